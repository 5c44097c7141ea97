/* The engine's tick loop in C: the plan the Python engine builds, run N ticks per call.

   The semantics are those of master/engine/execution.py (docs/master.md, "Semantics"): at tick k an
   instance of period n steps when k % n == 0, in the plan's order; before it steps, every group of its
   connected inputs is gathered from the source's latest outputs (or from d ticks back through the delay
   line) and set with the FMU's own fmi2Set<type>; then fmi2DoStep(t_k, n T) and fmi2Get<type> of its
   outputs. At the end of a tick every instance's outputs enter its delay line. An FMI 3.0 FMU the kernel
   calls through its fmi3 functions; one with clocks goes through Event Mode at the ticks that need one
   (tl_clocks below), and a Scheduled Execution one has its due partitions activated in rank order instead. Instances the kernel cannot call directly (an FMU in a worker process or on another
   machine) are stepped by a callback into Python; manipulators (faults) are callbacks too, before the inputs are set and after the outputs
   are read. Every step can be recorded (its outputs copied into the instance's record rows) for the
   observers, which read the records after the call. The caller owns every array; the kernel keeps no
   state of its own beyond the plan. */
#ifndef TL_LOOP_H
#define TL_LOOP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "tl_draw.h"

#define TL_TYPES 3 /* Real (double), Integer (int), Boolean (int, as fmi2Boolean) */

typedef int (*tl_do_step_fn)(void *component, double t, double h, int no_set_prior);
typedef int (*tl_set_fn)(void *component, const unsigned int *vrs, size_t n, const void *values);
typedef int (*tl_get_fn)(void *component, const unsigned int *vrs, size_t n, void *values);
/* FMI 3.0 (an FMU without clocks): the value arrays' length is passed too; fmi3Boolean is a C bool */
typedef int (*tl_do_step3_fn)(void *instance, double t, double h, bool no_set_prior, bool *event_needed,
                              bool *terminate, bool *early_return, double *last_time);
typedef int (*tl_set3_fn)(void *instance, const unsigned int *vrs, size_t n, const void *values, size_t n_values);
typedef int (*tl_get3_fn)(void *instance, const unsigned int *vrs, size_t n, void *values, size_t n_values);
/* FMI 3.0 Event Mode, for an FMU with clocks */
typedef int (*tl_mode3_fn)(void *instance); /* fmi3EnterEventMode, fmi3EnterStepMode */
typedef int (*tl_set_clock3_fn)(void *instance, const unsigned int *vrs, size_t n, const bool *values);
typedef int (*tl_update3_fn)(void *instance, bool *need_update, bool *terminate, bool *nominals_changed,
                             bool *values_changed, bool *next_event_defined, double *next_event_time);
/* FMI 3.0 Scheduled Execution: fmi3ActivateModelPartition */
typedef int (*tl_activate3_fn)(void *instance, unsigned int clock, double t);
/* Python callbacks: return 0 when done; any other value stops the run (the Python side keeps the reason). */
typedef int (*tl_step_callback)(int instance, double t, double h);
typedef int (*tl_hook_callback)(int instance, int side, double t); /* side 0: inputs about to be set, 1: outputs read */

typedef struct {
    int source;                 /* instance index */
    int type;                   /* 0 Real, 1 Integer, 2 Boolean */
    int delay;                  /* ticks */
    int n;
    const int64_t *src_index;   /* n indices into the source's outputs of this type */
    const unsigned int *dst_vrs;
    void *values;               /* n values the set reads (double or int) */
} tl_group;

/* A fault the loop applies itself, at its instance's inputs (side 0, after the gather) or outputs (side 1, after the
   gets): override, bias, scale, ramp, clamp, hold (functions of time and value), noise (of time, value and seed),
   delay and stale (the value n ticks before), jitter (0..n ticks before, drawn), dropout (the sample before the
   fault, held; its flag is an override to false). */
enum { TL_OVERRIDE, TL_BIAS, TL_SCALE, TL_RAMP, TL_CLAMP, TL_HOLD, TL_NOISE, TL_DELAY, TL_JITTER, TL_DROPOUT };

typedef struct {
    int instance, side, action, type;
    void *array;                /* the group's values or the instance's outputs */
    int index;
    double value, high;         /* the fault's value; clamp: [value, high] */
    double start, end;          /* end: +inf without an end */
    int fault;                  /* the fault's place in the schedule */
    int reports;                /* this target's transitions are the fault's start and end events */
    int holding;                /* hold, dropout: the value taken at the fault's first active tick */
    double held;
    int n_entropy;              /* noise, jitter: numpy's uint32 words of [seed, fault], the tick's added per draw */
    uint32_t entropy[TL_ENTROPY_WORDS];
    /* delay, jitter, dropout: the target's true values, one per application (fault active or not), in a ring */
    double *history;
    int64_t history_capacity;   /* the longest lag + 1 */
    int64_t history_count;      /* values recorded, at most the capacity */
    int64_t history_next;       /* the slot the next value goes to */
} tl_fault;

/* A clocked FMU's inputs of one kind within one of its groups: they reach the FMU when the standard allows it
   (continuous ones at every step, discrete ones in Event Mode, clocked ones after their clock's fmi3SetClock). */
enum { TL_CONTINUOUS = -1, TL_DISCRETE = -2 }; /* a part's kind; 0.. : the index of its clock */

typedef struct {
    int group;                  /* the instance's group the values come from */
    int kind;
    int n;
    const unsigned int *vrs;
    const int64_t *index;       /* n indices into the group's values */
    int whole;                  /* the index is 0..n - 1: the whole group */
    void *buffer;               /* n values as the FMU takes them (fmi3Float64, fmi3Int32, fmi3Boolean) */
    void *applied;              /* discrete: the values last set; a change makes the step an event */
    int has_applied;            /* 0: none set yet (the next step is an event) */
} tl_part;

/* Outputs read in one call: those of no clock after every step; a clock's in the Event Mode where it ticks (before
   fmi3UpdateDiscreteStates deactivates it), their values held in the buffer until it ticks again. */
typedef struct {
    int type;
    int clock;                  /* -1: not clocked */
    int n;
    const unsigned int *vrs;
    const int64_t *index;       /* n indices into the instance's outputs of this type */
    int whole;                  /* the index is 0..n - 1: every output of the type */
    void *buffer;               /* n values as the FMU gives them */
} tl_read;

/* A clocked FMI 3.0 FMU (periodic input clocks): its schedule, its staging and what it carries between steps. At a
   step where a clock is due, the FMU asked for an event, its next event time is reached or a discrete input
   changed: fmi3EnterEventMode (the first step uses the Event Mode after initialization), the continuous and discrete
   inputs, fmi3SetClock(the due clocks), their clocked inputs, their clocked outputs, fmi3UpdateDiscreteStates
   until no further update (at most max_iterations calls), fmi3EnterStepMode. Then the continuous inputs (only those
   at a step without event), fmi3DoStep, the outputs of no clock, and the held clocked ones into the outputs. */
typedef struct {
    tl_mode3_fn enter_event_mode, enter_step_mode;
    tl_set_clock3_fn set_clock;
    tl_update3_fn update_discrete_states;
    int n_clocks;
    const unsigned int *clock_vrs;
    const int64_t *interval, *shift; /* ticks: clock j is due at tick k when k >= shift and (k - shift) % interval == 0 */
    int n_parts;
    tl_part *parts;
    int n_reads;
    tl_read *reads;             /* those of no clock, then clock 0's, 1's, ... */
    const int *read_first;      /* n_clocks + 2: clock j's reads are [read_first[j + 1], read_first[j + 2]) (j = -1: none) */
    int max_iterations;
    /* between steps (handed in by the caller before a call, read back after it) */
    int in_event;               /* in the Event Mode that follows initialization */
    int event_asked;            /* the last fmi3DoStep set eventHandlingNeeded */
    int next_event_defined;
    double next_event;          /* the last fmi3UpdateDiscreteStates' nextEventTime */
    /* room for one tick's due clocks (n_clocks each) */
    int *due;
    unsigned int *due_vrs;
    bool *due_on;               /* all true */
    /* the clock ticks of the last call, in order: clock index and tick */
    int64_t activation_capacity, activations;
    int32_t *activation_clock;
    int64_t *activation_tick;
    /* A Scheduled Execution FMU (activate set): no Event Mode and no fmi3DoStep. At a step: the inputs of no clock,
       then for each due clock in rank order its clocked inputs, fmi3ActivateModelPartition(clock, t), its clocked
       outputs; then the outputs of no clock and the held clocked ones, as above. One partition runs at a time. */
    tl_activate3_fn activate;
    const int *order;           /* the n_clocks clocks by rank (priority, then declaration): a due set's order is this
                                   one with the clocks not due left out */
    const int *lock_depth;      /* the locks the importer's lock callbacks count as held (NULL: not checked) */
} tl_clocks;

typedef struct {
    void *component;
    tl_do_step_fn do_step;
    tl_set_fn set[TL_TYPES];
    tl_get_fn get[TL_TYPES];
    tl_do_step3_fn do_step3;    /* fmi3: the FMI 3.0 functions instead (do_step, set and get unused) */
    tl_set3_fn set3[TL_TYPES];
    tl_get3_fn get3[TL_TYPES];
    int every;                  /* period in ticks */
    int continuous;             /* outputs of doStep(t, h) hold the value at t + h */
    int by_callback;            /* stepped by the Python step callback (it sets inputs, steps, reads outputs) */
    int fmi3;                   /* an FMI 3.0 FMU: called through do_step3, set3 and get3 (and clocks, if it has any) */
    bool *booleans;             /* fmi3: room for its most Boolean values in one call (they are int in the arrays) */
    int hook_inputs, hook_outputs; /* call the hook callback before the sets / after the gets */
    int n_out[TL_TYPES];
    const unsigned int *out_vrs[TL_TYPES];
    void *out[TL_TYPES];        /* the outputs, as the slave's value arrays */
    void *history[TL_TYPES];    /* delay line: slots x n_out values per type (NULL without delays) */
    int n_groups;
    tl_group *groups;
    void *record[TL_TYPES];     /* rows x n_out values per type, one row per recorded step */
    double seconds;             /* time in this instance's FMI calls (with profile on) */
    tl_clocks *clocks;          /* fmi3 with clocks: its Event Mode plan (NULL: none) */
} tl_instance;

typedef struct {
    int n_instances;
    tl_instance *instances;
    double tick;
    int64_t ticks_done;         /* the next tick to run is ticks_done */
    int slots;                  /* delay-line length: max delay + 1 (0: no delay line) */
    tl_step_callback step_callback;
    tl_hook_callback hook_callback;
    int profile;                /* time every step's FMI calls into tl_instance.seconds: 1 wall time, 2 this thread's
                                   CPU time (which other processes' load does not inflate) */
    /* records of the last call: which instance stepped, the time its outputs hold, its row */
    int64_t record_capacity;    /* rows available per instance, and entries in the arrays below */
    int64_t records;            /* steps recorded in this call */
    int32_t *record_instance;
    int64_t *record_tick;
    double *record_time;
    int64_t *record_row;
    int64_t *rows;              /* per instance: rows recorded in this call */
    /* why the last call stopped early */
    /* 0 none, 1 doStep, 2 set, 3 get, 4 step callback, 5 hook callback, 6 terminateSimulation from fmi3DoStep;
       a clocked FMU's: 7 fmi3EnterEventMode, 8 fmi3SetClock, 9 fmi3UpdateDiscreteStates, 10 fmi3EnterStepMode,
       11 terminateSimulation from fmi3UpdateDiscreteStates, 12 discrete states unsettled after max_iterations
       updates, 13 get of a clock's outputs (error_group: the clock); a Scheduled Execution FMU's: 14
       fmi3ActivateModelPartition (error_group: the clock), 15 a partition returned with preemption locks held
       (error_group: the clock, error_status: how many) */
    int error_kind;
    int error_instance, error_status, error_group, error_type;
    double error_time;
    /* real-time pacing: every tick starts at start + k * tick / factor on CLOCK_MONOTONIC (factor <= 0: off) */
    double realtime_factor;
    int64_t realtime_start_ns;  /* the monotonic time of tick 0 (set by the caller) */
    int64_t realtime_first_tick;
    /* value faults applied in the loop; their start and end events of the last call */
    int n_faults;
    tl_fault *faults;
    int8_t *fault_on;           /* per fault of the schedule: active at the last tick it was looked at */
    int64_t event_capacity, events;
    int64_t *event_record;      /* the event came before this record */
    int32_t *event_fault;
    int8_t *event_start;        /* 1 start, 0 end */
    double *event_time;
    double *lateness;           /* per tick run in this call: how late it started, s (NULL: not kept) */
    int8_t *overrun;            /* per tick: 1 if it arrived after its deadline (the tick before overran its slot) */
} tl_plan;

/* Run up to n ticks; stop early after an error (error_kind != 0). Returns the ticks run. */
int64_t tl_run(tl_plan *plan, int64_t n);
/* Copy every instance's outputs into its delay-line slot for the entry j (the values after tick j - 1). */
void tl_store_history(tl_plan *plan, int64_t j);
int64_t tl_monotonic_ns(void);

#endif
