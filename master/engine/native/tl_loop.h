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

#include "tl_codes.h"
#include "tl_draw.h"

typedef int (*tl_do_step_fn)(void *component, double t, double h, int no_set_prior);
/* fmi2GetBooleanStatus and fmi2GetRealStatus: what an FMI 2.0 FMU says after a doStep that returned fmi2Discard */
typedef int (*tl_boolean_status_fn)(void *component, int kind, int *value);
typedef int (*tl_real_status_fn)(void *component, int kind, double *value);
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
typedef int (*tl_step_callback)(int instance, double t, double h); /* 0 done, 1 failed, 2 the FMU ended the run */
typedef int (*tl_hook_callback)(int instance, int side, double t); /* side: tl_side */

/* Each struct below is declared by a table of its fields, F(type, name) or A(type, name, length) for an array, so that
   tl_layout.c exports the offset and size of every field (kernel.py's ctypes structures are checked against them when
   the library is loaded): a field added here and not there, or there and not here, fails at once. */
#define TL_FIELD(type, name) type name;
#define TL_ARRAY(type, name, length) type name[length];

#define TL_GROUP_FIELDS(F, A) \
    F(int, source)                  /* instance index */ \
    F(int, type)                    /* tl_value_type: the target's, of the values */ \
    F(int, source_type)             /* the source outputs' type: type, or TL_INTEGER into a TL_REAL group (converted) */ \
    F(int, delay)                   /* ticks */ \
    F(int, n) \
    F(const int64_t *, src_index)   /* n indices into the source's outputs of source_type */ \
    F(const unsigned int *, dst_vrs) \
    F(void *, values)               /* n values the set reads (double or int) */
typedef struct { TL_GROUP_FIELDS(TL_FIELD, TL_ARRAY) } tl_group;

/* A fault the loop applies itself (tl_codes.h's TL_FAULT_ACTIONS), at its instance's inputs (after the gather) or
   outputs (after the gets). */
#define TL_FAULT_FIELDS(F, A) \
    F(int, instance) \
    F(int, side)                    /* tl_side */ \
    F(int, action)                  /* tl_fault_action */ \
    F(int, type)                    /* tl_value_type */ \
    F(void *, array)                /* the group's values or the instance's outputs */ \
    F(int, index) \
    F(double, value)                /* the fault's value; clamp: [value, high] */ \
    F(double, high) \
    F(double, start) \
    F(double, end)                  /* +inf without an end */ \
    F(int, fault)                   /* the fault's place in the schedule */ \
    F(int, reports)                 /* this target's transitions are the fault's start and end events */ \
    F(int, holding)                 /* hold, dropout: the value taken at the fault's first active tick */ \
    F(double, held) \
    F(int, n_entropy)               /* noise, jitter: numpy's uint32 words of [seed, fault], the tick's added per draw */ \
    A(uint32_t, entropy, TL_ENTROPY_WORDS) \
    /* delay, jitter, dropout: the target's true values, one per application (fault active or not), in a ring */ \
    F(double *, history) \
    F(int64_t, history_capacity)    /* the longest lag + 1 */ \
    F(int64_t, history_count)       /* values recorded, at most the capacity */ \
    F(int64_t, history_next)        /* the slot the next value goes to */
typedef struct { TL_FAULT_FIELDS(TL_FIELD, TL_ARRAY) } tl_fault;

/* A clocked FMU's inputs of one kind (tl_part_kind, or the index of their clock) within one of its groups: they reach
   the FMU when the standard allows it (continuous ones at every step, discrete ones in Event Mode, clocked ones after
   their clock's fmi3SetClock). */
#define TL_PART_FIELDS(F, A) \
    F(int, group)                   /* the instance's group the values come from */ \
    F(int, kind) \
    F(int, n) \
    F(const unsigned int *, vrs) \
    F(const int64_t *, index)       /* n indices into the group's values */ \
    F(int, whole)                   /* the index is 0..n - 1: the whole group */ \
    F(void *, buffer)               /* n values as the FMU takes them (fmi3Float64, fmi3Int32, fmi3Boolean) */ \
    F(void *, applied)              /* discrete: the values last set; a change makes the step an event */ \
    F(int, has_applied)             /* 0: none set yet (the next step is an event) */
typedef struct { TL_PART_FIELDS(TL_FIELD, TL_ARRAY) } tl_part;

/* Outputs read in one call: those of no clock after every step; a clock's in the Event Mode where it ticks (before
   fmi3UpdateDiscreteStates deactivates it), their values held in the buffer until it ticks again. */
#define TL_READ_FIELDS(F, A) \
    F(int, type)                    /* tl_value_type */ \
    F(int, clock)                   /* -1: not clocked */ \
    F(int, n) \
    F(const unsigned int *, vrs) \
    F(const int64_t *, index)       /* n indices into the instance's outputs of this type */ \
    F(int, whole)                   /* the index is 0..n - 1: every output of the type */ \
    F(void *, buffer)               /* n values as the FMU gives them */
typedef struct { TL_READ_FIELDS(TL_FIELD, TL_ARRAY) } tl_read;

/* A clocked FMI 3.0 FMU (periodic input clocks): its schedule, its staging and what it carries between steps. At a
   step where a clock is due, the FMU asked for an event, its next event time is reached or a discrete input
   changed: fmi3EnterEventMode (the first step uses the Event Mode after initialization), the continuous and discrete
   inputs, fmi3SetClock(the due clocks), their clocked inputs, their clocked outputs, fmi3UpdateDiscreteStates
   until no further update (at most max_iterations calls), fmi3EnterStepMode. Then the continuous inputs (only those
   at a step without event), fmi3DoStep, the outputs of no clock, and the held clocked ones into the outputs.
   A Scheduled Execution FMU (activate set): no Event Mode and no fmi3DoStep. At a step: the inputs of no clock,
   then for each due clock in rank order its clocked inputs, fmi3ActivateModelPartition(clock, t), its clocked
   outputs; then the outputs of no clock and the held clocked ones, as above. One partition runs at a time. */
#define TL_CLOCKS_FIELDS(F, A) \
    F(tl_mode3_fn, enter_event_mode) \
    F(tl_mode3_fn, enter_step_mode) \
    F(tl_set_clock3_fn, set_clock) \
    F(tl_update3_fn, update_discrete_states) \
    F(int, n_clocks) \
    F(const unsigned int *, clock_vrs) \
    F(const int64_t *, interval)    /* ticks: clock j is due at tick k when k >= shift and (k - shift) % interval == 0 */ \
    F(const int64_t *, shift) \
    F(int, n_parts) \
    F(tl_part *, parts) \
    F(int, n_reads) \
    F(tl_read *, reads)             /* those of no clock, then clock 0's, 1's, ... */ \
    F(const int *, read_first)      /* n_clocks + 2: clock j's reads are [read_first[j + 1], read_first[j + 2]) (j = -1: none) */ \
    F(int, max_iterations) \
    /* between steps (handed in by the caller before a call, read back after it) */ \
    F(int, in_event)                /* in the Event Mode that follows initialization */ \
    F(int, event_asked)             /* the last fmi3DoStep set eventHandlingNeeded */ \
    F(int, next_event_defined) \
    F(double, next_event)           /* the last fmi3UpdateDiscreteStates' nextEventTime */ \
    /* room for one tick's due clocks (n_clocks each) */ \
    F(int *, due) \
    F(unsigned int *, due_vrs) \
    F(bool *, due_on)               /* all true */ \
    /* the clock ticks of the last call, in order: clock index and tick */ \
    F(int64_t, activation_capacity) \
    F(int64_t, activations) \
    F(int32_t *, activation_clock) \
    F(int64_t *, activation_tick) \
    /* Scheduled Execution */ \
    F(tl_activate3_fn, activate) \
    F(const int *, order)           /* the n_clocks clocks by rank (priority, then declaration): a due set's order is this one \
                                       with the clocks not due left out */ \
    F(const int *, lock_depth)      /* the locks the importer's lock callbacks count as held (NULL: not checked) */
typedef struct { TL_CLOCKS_FIELDS(TL_FIELD, TL_ARRAY) } tl_clocks;

/* An isolated FMU stepped over shared memory (tl_link.h): the master's side of the link. */
#define TL_LINK_FIELDS(F, A) \
    F(unsigned char *, base)        /* the segment, mapped */ \
    F(int64_t, size)                /* its bytes (sealed: the host cannot shrink it) */ \
    F(const int64_t *, in_offset)   /* per group of the instance: where its values go */ \
    F(int64_t, out_offset)          /* the reply's header; the outputs after it */ \
    F(uint32_t, seq)                /* the last request's sequence number */ \
    F(int, hung_up_fd)              /* the host's reply pipe: readable or hung up while a step waits = the host ended */ \
    F(int, signal_fd)               /* Python's signal wakeup fd (-1: none): readable = a signal to handle, stop waiting */ \
    F(int64_t, timeout_ns)          /* the watchdog */ \
    F(int64_t, spin_ns)             /* the least spin before sleeping on the futex (tl_spin_budget) */ \
    F(int64_t, usual_wait_ns)       /* the usual wait for a reply (tl_spin_learn): the master's own, starts at 0 */ \
    F(int, n_clocks)                /* the FMU's clocks (a failure the host reports names one by its index) */
typedef struct { TL_LINK_FIELDS(TL_FIELD, TL_ARRAY) } tl_link;

#define TL_INSTANCE_FIELDS(F, A) \
    F(void *, component) \
    F(tl_do_step_fn, do_step) \
    A(tl_set_fn, set, TL_TYPES) \
    A(tl_get_fn, get, TL_TYPES) \
    F(tl_boolean_status_fn, boolean_status) /* FMI 2.0: asked after fmi2Discard whether the FMU ended the run (NULL: not) */ \
    F(tl_real_status_fn, real_status) \
    F(tl_do_step3_fn, do_step3)     /* fmi3: the FMI 3.0 functions instead (do_step, set and get unused) */ \
    A(tl_set3_fn, set3, TL_TYPES) \
    A(tl_get3_fn, get3, TL_TYPES) \
    F(int, every)                   /* period in ticks */ \
    F(int, continuous)              /* outputs of doStep(t, h) hold the value at t + h */ \
    F(int, by_callback)             /* stepped by the Python step callback (it sets inputs, steps, reads outputs) */ \
    F(int, fmi3)                    /* an FMI 3.0 FMU: called through do_step3, set3 and get3 (and clocks, if it has any) */ \
    F(bool *, booleans)             /* fmi3: room for its most Boolean values in one call (they are int in the arrays) */ \
    F(int, hook_inputs)             /* call the hook callback before the sets */ \
    F(int, hook_outputs)            /* and after the gets */ \
    A(int, n_out, TL_TYPES) \
    A(const unsigned int *, out_vrs, TL_TYPES) \
    A(void *, out, TL_TYPES)        /* the outputs, as the slave's value arrays */ \
    A(void *, history, TL_TYPES)    /* delay line: slots x n_out values per type (NULL without delays) */ \
    F(int, n_groups) \
    F(tl_group *, groups) \
    A(void *, record, TL_TYPES)     /* rows x n_out values per type, one row per recorded step */ \
    F(double, seconds)              /* time in this instance's FMI calls (with profile on) */ \
    /* with profile on and a histogram given: every step's time (its FMI calls, or its callback) */ \
    F(int64_t *, histogram)         /* TL_PROFILE_BUCKETS counts (NULL: none kept) */ \
    F(int64_t, fastest_ns)          /* the caller starts them at INT64_MAX and 0 */ \
    F(int64_t, slowest_ns) \
    F(int64_t, host_ns)             /* of those steps' time: its host's own in the FMU's calls (isolated on shared memory) */ \
    F(tl_clocks *, clocks)          /* fmi3 with clocks: its Event Mode plan (NULL: none) */ \
    F(tl_link *, link)              /* an isolated FMU the kernel steps over shared memory (NULL: none; by_callback 0) */
typedef struct { TL_INSTANCE_FIELDS(TL_FIELD, TL_ARRAY) } tl_instance;

#define TL_PLAN_FIELDS(F, A) \
    F(int, n_instances) \
    F(tl_instance *, instances) \
    F(double, tick) \
    F(double, start_time)           /* s: tick k is at start_time + k * tick (0: as k * tick, bit for bit) */ \
    F(int64_t, ticks_done)          /* the next tick to run is ticks_done */ \
    F(int, slots)                   /* delay-line length: max delay + 1 (0: no delay line) */ \
    F(tl_step_callback, step_callback) \
    F(tl_hook_callback, hook_callback) \
    F(int, profile)                 /* tl_profile: time every step's FMI calls into tl_instance.seconds */ \
    F(int64_t *, tick_histogram)    /* with profile on: every tick's time (pacing's sleep not counted), as the steps' */ \
    F(int64_t, tick_ns)             /* their sum */ \
    F(int64_t, fastest_tick_ns) \
    F(int64_t, slowest_tick_ns) \
    /* records of the last call: which instance stepped, the time its outputs hold, its row */ \
    F(int64_t, record_capacity)     /* rows available per instance, and entries in the arrays below */ \
    F(int64_t, records)             /* steps recorded in this call */ \
    F(int32_t *, record_instance) \
    F(int64_t *, record_tick) \
    F(double *, record_time) \
    F(int64_t *, record_row) \
    F(int64_t *, rows)              /* per instance: rows recorded in this call */ \
    /* why the last call stopped early: tl_error_kind, and what tl_codes.h says of the fields after it */ \
    F(int, error_kind) \
    F(int, error_instance) \
    F(int, error_status) \
    F(int, error_group) \
    F(int, error_type) \
    F(double, error_time) \
    /* real-time pacing: every tick starts at start + k * tick / factor on CLOCK_MONOTONIC (factor <= 0: off) */ \
    F(double, realtime_factor) \
    F(int64_t, realtime_start_ns)   /* the monotonic time of tick 0 (set by the caller) */ \
    F(int64_t, realtime_first_tick) \
    /* value faults applied in the loop; their start and end events of the last call */ \
    F(int, n_faults) \
    F(tl_fault *, faults) \
    F(int8_t *, fault_on)           /* per fault of the schedule: active at the last tick it was looked at */ \
    F(int64_t, event_capacity) \
    F(int64_t, events) \
    F(int64_t *, event_record)      /* the event came before this record */ \
    F(int32_t *, event_fault) \
    F(int8_t *, event_start)        /* 1 start, 0 end */ \
    F(double *, event_time) \
    F(double *, lateness)           /* per tick run in this call: how late it started, s (NULL: not kept) */ \
    F(int8_t *, overrun)            /* per tick: 1 if it arrived after its deadline (the tick before overran its slot) */ \
    /* the run's edges (docs/master.md, "Signals at a run's edges") */ \
    F(double, stop_time)            /* > 0: a step that would pass it is shortened to end there (0: none is) */ \
    F(int, closing)                 /* set by tl_close while it takes the closing samples (no step is shortened) */ \
    F(int, ended_instance)          /* >= 0: this instance asked to end the run (FMI 2.0 fmi2Terminated, FMI 3.0 \
                                       terminateSimulation from doStep); its last outputs were recorded; -1: none */ \
    F(double, ended_time)           /* the time it ended the run at (the step callback sets it before returning 2) */ \
    F(int, ends_allowed)            /* 1: such a request ends the run; 0: it fails it (TL_ERROR_TERMINATED_IN_STEP, or \
                                       fmi2Discard's TL_ERROR_DO_STEP) */
typedef struct { TL_PLAN_FIELDS(TL_FIELD, TL_ARRAY) } tl_plan;

/* Run up to n ticks; stop early after an error (error_kind != TL_ERROR_NONE). Returns the ticks run. */
int64_t tl_run(tl_plan *plan, int64_t n);
/* The closing samples at time t (the run's end): every instance whose outputs belong to the start of its step (not
   continuous) is stepped once more at tick ticks_done, time t, in the system's order, and recorded at t; the others
   are not stepped (their last step's outputs already belong to t). Returns 0, or 1 after an error. */
int tl_close(tl_plan *plan, double t);
/* Send a yield request over an instance's link (the host goes back to its pipe; it answers there). Returns 0, or -1
   without a link. */
int tl_link_yield(tl_link *link);
/* Copy every instance's outputs into its delay-line slot for the entry j (the values after tick j - 1). */
void tl_store_history(tl_plan *plan, int64_t j);
int64_t tl_monotonic_ns(void);
/* Row i (0, 1, ...) of the layout of the structs above (tl_layout.c): a struct (field NULL, size its sizeof) or one of
   its fields (its C type, offset and size). Returns 0 past the last row. */
int tl_layout(int i, const char **structure, const char **field, const char **type, int64_t *offset, int64_t *size);

#endif
