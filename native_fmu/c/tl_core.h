/* The core of the FMI layers: what FMI 2.0 and FMI 3.0 share, written once (tl_core.c). The instance's life cycle,
   logging, refusal, the variable access loops over the generated tables, Event Mode and state snapshots. Each
   version's file (tl_fmi2.c, tl_fmi3.c) maps its standard's functions onto these: its state-mask table says in which
   phases a call is allowed, its binding (TlBinding) how its standard logs and allocates. Every function here returns
   a TlStatus, which a layer returns as its standard's status by a cast. */
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
/* A new instance owning resources (a native folder path from tl_binding.allocate, or NULL), or NULL with resources
   released. The caller sets what its version adds, then loads the start values (tl_reset). */
TL_INTERNAL TlInstance* tl_instantiate(const TlHost* host, const char* name, int logging_on, char* resources);
TL_INTERNAL void tl_free_instance(TlInstance* c);
/* Start values into the variables, time 0, phase instantiated, then the model's reset hook. */
TL_INTERNAL void tl_reset(TlInstance* c);
/* The experiment's start time and, if defined, its stop time (a later step is refused). */
TL_INTERNAL TlStatus tl_set_experiment(TlInstance* c, const char* call, double start, int stop_defined, double stop);
/* The model initialized (its hook checks the parameters) and the instance in next_phase, or the error. */
TL_INTERNAL TlStatus tl_exit_initialization(TlInstance* c, int next_phase);
TL_INTERNAL void tl_terminate(TlInstance* c);
/* One communication step from t to t + h: the model's step, and the clock advanced unless it failed. */
TL_INTERNAL TlStatus tl_do_step(TlInstance* c, const char* call, double t, double h);

/* ---- Event Mode (clocked builds) ------------------------------------------------------------------------------ */
/* A new super-dense instant of Event Mode: the partition will run (again) before outputs are read. */
TL_INTERNAL void tl_begin_event(TlInstance* c);
/* This instant's partition, if inputs or clocks changed since it last ran (from the model state the event began in). */
TL_INTERNAL TlStatus tl_run_event(TlInstance* c);

/* ---- Scheduled Execution (TL_SCHEDULED builds) ---------------------------------------------------------------------- */
/* Activate clock k's model partition at t: t on the clock's grid, after its previous activation; then the model's
   partition, and the activation recorded. */
TL_INTERNAL TlStatus tl_activate(TlInstance* c, const char* call, int k, double t);

/* ---- variables ------------------------------------------------------------------------------------------------ */
/* Get or set n variables of one type by value reference: values is the standard's array of that type (double,
   TlInteger, TlBoolean, const char*). A set checks every value before it writes any: a refused call changes nothing. */
TL_INTERNAL TlStatus tl_get(TlInstance* c, const char* call, TlType type, const TlValueReference vr[], size_t n, void* values);
TL_INTERNAL TlStatus tl_set(TlInstance* c, const char* call, TlType type, const TlValueReference vr[], size_t n, const void* values);

/* ---- state snapshots: a TlState copy; serialized as magic, format, the build's GUID, then the TlState bytes ---- */
TL_INTERNAL TlStatus tl_get_state(TlInstance* c, const char* call, void** state);
TL_INTERNAL TlStatus tl_set_state(TlInstance* c, const char* call, const void* state);
TL_INTERNAL void tl_free_state(TlInstance* c, void** state);
TL_INTERNAL TlStatus tl_serialized_size(TlInstance* c, const char* call, size_t* size);
TL_INTERNAL TlStatus tl_serialize(TlInstance* c, const char* call, const void* state, unsigned char bytes[], size_t size);
TL_INTERNAL TlStatus tl_deserialize(TlInstance* c, const char* call, const unsigned char bytes[], size_t size, void** state);

#endif
