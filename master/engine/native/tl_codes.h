/* The codes the tick loop shares with its Python side, declared once: each table below is an X-macro that this header
   turns into a C enum and that codes.py reads into a Python IntEnum (so keep the format it parses: one
   `X(TL_NAME, value)` entry to a line, an optional comment after it, values unique within a table). */
#ifndef TL_CODES_H
#define TL_CODES_H

/* The lengths of the plan's fixed arrays. */
#define TL_DIMENSIONS(X) \
    X(TL_TYPES, 3)              /* value types: the per-type arrays of an instance */ \
    X(TL_ENTROPY_WORDS, 16)     /* a noise or jitter fault's own seed words (seed, place) at most; the tick's are added per draw */ \
    X(TL_PROFILE_OCTAVE_BITS, 4) /* a profile histogram has 2^4 buckets per octave of nanoseconds (6 % wide) */ \
    X(TL_PROFILE_BUCKETS, 640)  /* 40 octaves: 1 ns to 18 min */

/* A value's type, the index of the per-type arrays (as the engine's TYPES). */
#define TL_VALUE_TYPES(X) \
    X(TL_REAL, 0)               /* double */ \
    X(TL_INTEGER, 1)            /* int */ \
    X(TL_BOOLEAN, 2)            /* int in the plan's arrays (fmi2Boolean); a C bool for FMI 3.0 */

/* Where a fault or the hook callback acts on an instance's step. */
#define TL_SIDES(X) \
    X(TL_INPUTS, 0)             /* after the gather, before the inputs are set */ \
    X(TL_OUTPUTS, 1)            /* after the outputs are read */

/* What tl_plan.profile times into tl_instance.seconds (and, with the histograms given, every step and tick). */
#define TL_PROFILES(X) \
    X(TL_PROFILE_OFF, 0) \
    X(TL_PROFILE_WALL, 1)       /* wall time */ \
    X(TL_PROFILE_CPU, 2)        /* this thread's CPU time (which other processes' load does not inflate) */

/* The faults the loop applies itself (tl_fault.action): override, bias, scale, ramp, clamp, hold (functions of time
   and value), noise (of time, value and seed), delay and stale (the value n ticks before), jitter (0..n ticks before,
   drawn), dropout (the sample before the fault, held; its flag is an override to false). */
#define TL_FAULT_ACTIONS(X) \
    X(TL_OVERRIDE, 0) \
    X(TL_BIAS, 1) \
    X(TL_SCALE, 2) \
    X(TL_RAMP, 3) \
    X(TL_CLAMP, 4) \
    X(TL_HOLD, 5) \
    X(TL_NOISE, 6) \
    X(TL_DELAY, 7)              /* delay and stale alike */ \
    X(TL_JITTER, 8) \
    X(TL_DROPOUT, 9)

/* A clocked FMU's input part's kind (tl_part.kind); 0.. is the index of its clock. */
#define TL_PART_KINDS(X) \
    X(TL_CONTINUOUS, -1)        /* set at every step */ \
    X(TL_DISCRETE, -2)          /* set in Event Mode; a change makes the step an event */

/* Why the last call of tl_run stopped early (tl_plan.error_kind), with what the plan's other error fields say. */
#define TL_ERROR_KINDS(X) \
    X(TL_ERROR_NONE, 0) \
    X(TL_ERROR_DO_STEP, 1)                  /* fmi2DoStep or fmi3DoStep failed */ \
    X(TL_ERROR_SET, 2)                      /* a group's set (error_group, error_type) */ \
    X(TL_ERROR_GET, 3)                      /* a get of the outputs (error_type) */ \
    X(TL_ERROR_STEP_CALLBACK, 4)            /* the Python step callback (it keeps the reason) */ \
    X(TL_ERROR_HOOK_CALLBACK, 5)            /* the Python hook callback (it keeps the reason) */ \
    X(TL_ERROR_TERMINATED_IN_STEP, 6)       /* terminateSimulation from fmi3DoStep */ \
    X(TL_ERROR_ENTER_EVENT_MODE, 7)         /* a clocked FMU's fmi3EnterEventMode */ \
    X(TL_ERROR_SET_CLOCK, 8)                /* fmi3SetClock */ \
    X(TL_ERROR_UPDATE_DISCRETE_STATES, 9)   /* fmi3UpdateDiscreteStates */ \
    X(TL_ERROR_ENTER_STEP_MODE, 10)         /* fmi3EnterStepMode */ \
    X(TL_ERROR_TERMINATED_IN_EVENT, 11)     /* terminateSimulation from fmi3UpdateDiscreteStates */ \
    X(TL_ERROR_UNSETTLED, 12)               /* discrete states unsettled after max_iterations updates */ \
    X(TL_ERROR_GET_CLOCKED, 13)             /* a get of a clock's outputs (error_group: the clock) */ \
    X(TL_ERROR_ACTIVATE, 14)                /* fmi3ActivateModelPartition (error_group: the clock) */ \
    X(TL_ERROR_LOCKS_HELD, 15)              /* a partition returned holding locks (error_group: the clock, error_status: how many) */ \
    X(TL_ERROR_LINK, 16)                    /* a shared-memory link (error_status: its failure, error_group: a corruption) */

/* How an isolated FMU's shared-memory link failed (tl_link.h). */
#define TL_LINK_FAILURES(X) \
    X(TL_LINK_ENDED, 1)         /* its host process ended (its pipe hung up) before it answered */ \
    X(TL_LINK_TIMEOUT, 2)       /* no answer within the watchdog's time */ \
    X(TL_LINK_CORRUPT, 3)       /* an answer that is none (error_group says what was wrong) */ \
    X(TL_LINK_INTERRUPTED, 4)   /* a signal arrived while waiting (Ctrl-C): Python raises it once the loop returns */

/* What was wrong with a corrupt reply. */
#define TL_LINK_CORRUPTIONS(X) \
    X(TL_CORRUPT_SEQUENCE, 1)   /* a sequence number that was not asked for */ \
    X(TL_CORRUPT_LENGTH, 2)     /* outputs of another length than the model's */ \
    X(TL_CORRUPT_CALL, 3)       /* an unknown call or status, or a group or type out of range */ \
    X(TL_CORRUPT_TIME, 4)       /* a last successful time outside the step, or a host time that is no duration */

#define TL_ENUMERATOR(name, value) name = value,
enum tl_dimension { TL_DIMENSIONS(TL_ENUMERATOR) };
enum tl_value_type { TL_VALUE_TYPES(TL_ENUMERATOR) };
enum tl_side { TL_SIDES(TL_ENUMERATOR) };
enum tl_profile { TL_PROFILES(TL_ENUMERATOR) };
enum tl_fault_action { TL_FAULT_ACTIONS(TL_ENUMERATOR) };
enum tl_part_kind { TL_PART_KINDS(TL_ENUMERATOR) };
enum tl_error_kind { TL_ERROR_KINDS(TL_ENUMERATOR) };
enum tl_link_failure { TL_LINK_FAILURES(TL_ENUMERATOR) };
enum tl_link_corruption { TL_LINK_CORRUPTIONS(TL_ENUMERATOR) };

#endif
