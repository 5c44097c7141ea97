/* The contract between the generic FMI layers (tl_fmi2.c, tl_fmi3.c; shared code in tl_core.c) and one model.

   The layer owns the instance: life cycle, status, logging, get/set by value reference with
   causality checks, state snapshots. A model provides its state struct (TlModelState, in the
   header named by tl_model.h) and four hooks (five with clocks). Everything a snapshot must restore lives in
   TlState, a plain struct with no pointers, so fmi2GetFMUstate is one copy. The same hooks compile
   under either layer: the generated tl_model.h says which (TL_FMI_VERSION). */
#ifndef TL_FMU_H
#define TL_FMU_H

#include "tl_platform.h"

#include "tl_model.h"

#ifndef TL_FMI_VERSION
#define TL_FMI_VERSION 2
#endif

#if TL_FMI_VERSION == 3
#include "fmi3Functions.h"
/* The hooks speak the FMI 2.0 status and Boolean names; FMI 3.0 keeps their values (fmi3OK = 0 ... fmi3Fatal = 4),
   so an FMI 3.0 build defines them here instead of including the FMI 2.0 headers. */
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
#define fmi2True 1
#define fmi2False 0
typedef struct {
  fmi3InstanceEnvironment environment;
  fmi3LogMessageCallback log_message;
} TlHost;
#else
#include "fmi2Functions.h"
typedef fmi2CallbackFunctions TlHost;
#endif

#ifndef TL_STRING_LEN /* the model may set it (FmuDefinition.string_length, in tl_model.h) */
#define TL_STRING_LEN 64 /* longest String value + 1 */
#endif

/* Co-simulation states. FMI 2.0: TL_ERRORED follows fmi2Error, TL_BROKEN follows fmi2Fatal. FMI 3.0: TL_EVENT is
   Event Mode, TL_STEPPING Step Mode; fmi3Error leads to TL_TERMINATED, fmi3Fatal to TL_BROKEN. */
enum { TL_INSTANTIATED, TL_INITIALIZATION, TL_STEPPING, TL_TERMINATED, TL_BROKEN, TL_ERRORED, TL_EVENT };

typedef struct {
  int phase;
  double time;
  double start_time;
  double stop_time;   /* FMI 3.0: a step beyond it is an error (infinite: none given) */
  int stop_requested; /* set by a model that refuses all further steps: fmi2Terminated reads it */
  fmi2Real real[TL_CAP_REAL];
  fmi2Integer integer[TL_CAP_INTEGER];
  fmi2Boolean boolean[TL_CAP_BOOLEAN];
  char string[TL_CAP_STRING][TL_STRING_LEN];
  TlModelState model;
  /* FMI 3.0 Event Mode (clocked builds; the FMI 2.0 layer leaves these zero) */
  int clock_active[TL_CAP_CLOCK]; /* set by fmi3SetClock, cleared by fmi3UpdateDiscreteStates */
  int event_dirty;                /* inputs or clocks changed since this event's partition ran (or it has not run) */
  int event_ran;                  /* the partition ran in this Event Mode: a rerun starts again from pre_event */
  double next_event_time;         /* a time event the model asks for (< 0: none): DoStep reports it as an event */
#if TL_N_CLOCK > 0
  TlModelState pre_event; /* the model state when this Event Mode began */
#endif
} TlState;

typedef struct TlInstance {
  TlState s;
  TlHost host;
  char* name;
  char* resources; /* the resources folder as a native path ending in a separator, or NULL (no file URI given) */
  fmi2Boolean logging_on;
  int event_mode_used; /* FMI 3.0: the importer runs Event Mode (clocked FMUs require it) */
} TlInstance;

/* Log a formatted message through the host's logger (errors and discards always; others when
   logging is on). The message is formatted here: hosts print it as it is. Each layer implements it. */
TL_INTERNAL void tl_log(const TlInstance* c, fmi2Status status, const char* format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Model hooks. */
TL_INTERNAL void tl_model_reset(TlInstance* c);                          /* start values are loaded: set the model state */
TL_INTERNAL fmi2Status tl_model_outputs(TlInstance* c);                  /* outputs from parameters and inputs (initialization mode) */
TL_INTERNAL fmi2Status tl_model_initialize(TlInstance* c);               /* exitInitializationMode: check parameters, set outputs */
TL_INTERNAL fmi2Status tl_model_step(TlInstance* c, double t, double h); /* advance [t, t + h); the layer advances the clock on OK */
#if TL_N_CLOCK > 0
/* Event Mode at time t with the clocks c->s.clock_active (any of them, or none): run their partitions from the
   inputs set, write the clocked outputs and the discrete ones. May run again in the same event, from the model
   state the event began with (the layer restores it), when inputs or clocks change after an output was read. */
TL_INTERNAL fmi2Status tl_model_event(TlInstance* c, double t);
#endif

#endif
