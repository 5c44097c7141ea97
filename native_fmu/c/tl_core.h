/* The core of the FMI layers: what FMI 2.0 and FMI 3.0 share, written once (tl_core.c), as the Reference-FMUs'
   cosimulation.c is for their two API files. The instance's life cycle (its resources folder included), logging,
   refusal, the variable access loops over the generated tables, the step, Event Mode, the clocks, Scheduled Execution
   and state snapshots. Each version's file (tl_fmi2.c, tl_fmi3.c) maps its standard's functions onto these: its
   state-mask table says in which phases a call is allowed, its binding (TlBinding) how its standard logs and
   allocates. Every function here returns a TlStatus, which a layer returns as its standard's status by a cast. */
#ifndef TL_CORE_H
#define TL_CORE_H

#include <stddef.h>

#include "tl_fmu.h"

/* ---- what each version's file provides ---------------------------------------------------------------------- */
typedef enum { TL_TYPE_REAL, TL_TYPE_INTEGER, TL_TYPE_BOOLEAN, TL_TYPE_STRING, TL_N_TYPES } TlType;

typedef struct {
  char message_escape;  /* doubled in every message: '%' (FMI 2.0 loggers may format it), '#' (FMI 3.0's escape) */
  int phase_after_error; /* TL_ERRORED (FMI 2.0: get, reset, terminate and free remain) or TL_TERMINATED (FMI 3.0) */
  const char* type_name[TL_N_TYPES]; /* in messages: Real or Float64, Integer or Int32, Boolean, String */
  void (*log)(const TlHost* host, const char* instance, TlStatus status, const char* category, const char* message);
  void* (*allocate)(const TlHost* host, size_t size); /* zeroed memory, or NULL */
  void (*release)(const TlHost* host, void* memory);
} TlBinding;

TL_INTERNAL extern const TlBinding tl_binding; /* defined by tl_fmi2.c or tl_fmi3.c */

/* The standard's value types under the core's names. */
#if TL_FMI_VERSION == 3
typedef fmi3ValueReference TlValueReference;
typedef fmi3Int32 TlInteger;
typedef fmi3Boolean TlBoolean;
typedef fmi3IntervalQualifier TlIntervalQualifier;
typedef fmi3UInt64 TlUInt64;
#else
typedef fmi2ValueReference TlValueReference;
typedef fmi2Integer TlInteger;
typedef fmi2Boolean TlBoolean;
#endif

/* ---- phases and refusal --------------------------------------------------------------------------------------- */
#define TL_IN(phase) (1u << (phase))
/* Every phase but the one after a fatal error: the calls that stay allowed until the instance is freed. */
#define TL_ANY_BUT_FATAL                                                                                             \
  (TL_IN(TL_INSTANTIATED) | TL_IN(TL_INITIALIZATION) | TL_IN(TL_EVENT) | TL_IN(TL_STEPPING) | TL_IN(TL_TERMINATED) | \
   TL_IN(TL_ERRORED) | TL_IN(TL_ACTIVATION))

/* The first statement of an API function: c, the instance, and call, the function's name; or the call refused (NULL
   instance, or its phase not in MASK_<function> of the version's state-mask table). TL_API_STATUS: the version's status. */
#define TL_ENTER(function)                                         \
  TlInstance* const c = (TlInstance*)instance;                     \
  const char* const call = #function;                             \
  do {                                                             \
    const TlStatus refused_ = tl_enter(c, call, MASK_##function); \
    (void)call;                                                    \
    if (refused_ != TL_OK) return (TL_API_STATUS)refused_;         \
  } while (0)

TL_INTERNAL TlStatus tl_enter(TlInstance* c, const char* call, unsigned allowed);
/* The phase a status leaves the instance in: an error or fatal status moves it to the version's error phases. */
TL_INTERNAL TlStatus tl_settle(TlInstance* c, TlStatus status);
/* Log an error and settle it: the refusal of a call with its reason. */
TL_INTERNAL TlStatus tl_fail(TlInstance* c, const char* format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
TL_INTERNAL TlStatus tl_unsupported(TlInstance* c, const char* call, const char* why);
/* An error before an instance exists (an instantiation refused): logged through the host's callbacks. */
TL_INTERNAL void tl_log_host(const TlHost* host, const char* instance, const char* format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* ---- life cycle ----------------------------------------------------------------------------------------------- */
/* Is there an instance name, and does the token (GUID, instantiation token) name this build? Logs why not. */
TL_INTERNAL int tl_may_instantiate(const TlHost* host, const char* call, const char* name, const char* what, const char* token);
/* A new instance with its start values loaded (tl_reset), or NULL. location is where the importer says the resources
   are: a file URI (is_uri: FMI 2.0's fmuResourceLocation) or a native path (FMI 3.0's resourcePath); the instance
   keeps it as a native folder path ending in a separator (c->resources), NULL for none or one it cannot open. */
TL_INTERNAL TlInstance* tl_create(const TlHost* host, const char* call, const char* name, int logging_on, int event_mode_used,
                                  const char* location, int is_uri);
TL_INTERNAL void tl_free_instance(TlInstance* c);
/* Start values into the variables, time 0, phase instantiated, then the model's reset hook. */
TL_INTERNAL void tl_reset(TlInstance* c);
TL_INTERNAL void tl_set_logging(TlInstance* c, int on);
TL_INTERNAL void tl_enter_initialization(TlInstance* c);
/* The experiment's start time and, if defined, its stop time (a later step is refused). */
TL_INTERNAL TlStatus tl_set_experiment(TlInstance* c, const char* call, double start, int stop_defined, double stop);
/* The model initialized (its hook checks the parameters) and the instance in next_phase, or the error. */
TL_INTERNAL TlStatus tl_exit_initialization(TlInstance* c, int next_phase);
TL_INTERNAL void tl_terminate(TlInstance* c);
/* One communication step from t to t + h: the model's step, and the clock advanced unless it failed. */
TL_INTERNAL TlStatus tl_do_step(TlInstance* c, const char* call, double t, double h);

/* ---- Event Mode and clocks (FMI 3.0 builds) -------------------------------------------------------------------
   Clocked builds (TL_N_CLOCK > 0) have Event Mode and periodic input clocks. The importer enters Event Mode,
   activates the due clocks (fmi3SetClock), sets inputs, reads the clocked outputs, calls fmi3UpdateDiscreteStates
   and returns to Step Mode. The model's partition (tl_model_event) runs lazily: at the first Get in Event Mode, or in
   UpdateDiscreteStates, so inputs set after fmi3SetClock are seen. An input or clock set after a Get makes it run
   again, from the model state the event began with. Clocked variables are accessible only while their clock is
   active (and at initialization). */
/* A new super-dense instant of Event Mode: the partition will run (again) before outputs are read. */
TL_INTERNAL void tl_begin_event(TlInstance* c);
/* This instant's partition, if inputs or clocks changed since it last ran (from the model state the event began in). */
TL_INTERNAL TlStatus tl_run_event(TlInstance* c);
#if TL_FMI_VERSION == 3
/* Step Mode to Event Mode (the instance must have been created with Event Mode used). */
TL_INTERNAL TlStatus tl_enter_event_mode(TlInstance* c, const char* call);
/* The end of an Event Mode instant: its partition run if due, the clocks' ticks over; what the importer is told. */
TL_INTERNAL TlStatus tl_update_discrete_states(TlInstance* c, int* terminate, int* next_defined, double* next_time);
/* Event Mode to Step Mode: a partition still due runs first. */
TL_INTERNAL TlStatus tl_enter_step_mode(TlInstance* c);
/* After a step of size h: has it reached the time event the model asked for? */
TL_INTERNAL int tl_event_needed(const TlInstance* c, double h);
/* Clocks by value reference (arrays_given: the importer's value arrays are not NULL). Activating a clock marks the
   instant's partition to run; an active clock cannot be deactivated. */
TL_INTERNAL TlStatus tl_set_clocks(TlInstance* c, const char* call, const TlValueReference vr[], size_t n, const TlBoolean value[]);
TL_INTERNAL TlStatus tl_get_clocks(TlInstance* c, const char* call, const TlValueReference vr[], size_t n, TlBoolean value[]);
/* The clocks' constant periodic grids: interval (or shift: 0) as a decimal and as counter / resolution; any of the
   arrays may be NULL (not asked for). qualifier: always unchanged. */
TL_INTERNAL TlStatus tl_clock_grid(TlInstance* c, const char* call, const TlValueReference vr[], size_t n, int arrays_given, int shift,
                                   double decimal[], TlUInt64 counter[], TlUInt64 resolution[],
                                   TlIntervalQualifier qualifier[]);
#endif

/* ---- Scheduled Execution (TL_SCHEDULED builds) ----------------------------------------------------------------------
   No co-simulation: after Initialization Mode the instance is in Clock Activation Mode, where the importer's scheduler
   activates each clock's partition at its activation times (on the clock's grid, increasing), setting a partition's
   inputs before and reading its outputs after. The partitions may preempt each other; the model locks around what
   they share through the importer's callbacks (tl_lock_preemption). */
/* Activate the model partition of the clock with value reference clock at t: t on the clock's grid, after its previous
   activation; then the model's partition, and the activation recorded. */
TL_INTERNAL TlStatus tl_activate(TlInstance* c, const char* call, TlValueReference clock, double t);

/* ---- variables ------------------------------------------------------------------------------------------------ */
/* Get or set n variables of one type by value reference: values is the standard's array of that type (double,
   TlInteger, TlBoolean, const char*). A set checks every value before it writes any: a refused call changes nothing. */
TL_INTERNAL TlStatus tl_get(TlInstance* c, const char* call, TlType type, const TlValueReference vr[], size_t n, void* values);
TL_INTERNAL TlStatus tl_set(TlInstance* c, const char* call, TlType type, const TlValueReference vr[], size_t n, const void* values);
/* A get or set of a type the model has no variable of (what: "variable of this type", "Binary variable"): an empty call
   is fine, any value reference is unknown. */
TL_INTERNAL TlStatus tl_no_variables(TlInstance* c, const char* call, const TlValueReference vr[], size_t n, const char* what);

/* ---- state snapshots: a TlState copy; serialized as magic, format, the build's GUID, then the TlState bytes ---- */
TL_INTERNAL TlStatus tl_get_state(TlInstance* c, const char* call, void** state);
TL_INTERNAL TlStatus tl_set_state(TlInstance* c, const char* call, const void* state);
TL_INTERNAL void tl_free_state(TlInstance* c, void** state);
TL_INTERNAL TlStatus tl_serialized_size(TlInstance* c, const char* call, size_t* size);
TL_INTERNAL TlStatus tl_serialize(TlInstance* c, const char* call, const void* state, unsigned char bytes[], size_t size);
TL_INTERNAL TlStatus tl_deserialize(TlInstance* c, const char* call, const unsigned char bytes[], size_t size, void** state);

#endif
