/* The contract between the generic FMI layers and one model: the hooks a model provides, the state they work on.

   The core (tl_core.c) owns the instance: life cycle, status, logging, get/set by value reference with causality
   checks, state snapshots; each FMI version's file (tl_fmi2.c, tl_fmi3.c) maps its standard's functions onto it.
   A model provides its state struct (TlModelState, in the header named by tl_model.h) and four hooks (five with
   clocks). Everything a snapshot must restore lives in TlState, a plain struct with no pointers, so getting a
   state is one copy. The hooks speak TlStatus, which is neither version's: the same hooks compile under either
   layer, and the generated tl_model.h says which (TL_FMI_VERSION). */
#ifndef TL_FMU_H
#define TL_FMU_H

#include "tl_platform.h"

#include "tl_model.h"

#ifndef TL_FMI_VERSION
#define TL_FMI_VERSION 2
#endif
#ifndef TL_SCHEDULED /* FMI 3.0 Scheduled Execution (a model partition per clock); FMI 2.0 tables do not say */
#define TL_SCHEDULED 0
#endif
/* Event Mode's lazy partition: the co-simulation builds with clocks (a Scheduled Execution build runs partitions instead) */
#define TL_EVENT_PARTITION (TL_N_CLOCK > 0 && !TL_SCHEDULED)
/* A rerun of the partition in the same Event Mode restores the model state the event began with. A model may leave a
   region of its state out of that copy (in its header: TL_MODEL_EVENT_UNSAVED_OFFSET and _SIZE, in bytes), one its
   partition either leaves as it found it or writes before it reads: the controller's ZSE generator buffers, 680 kB
   (controller_model.h). */
#ifndef TL_MODEL_EVENT_UNSAVED_SIZE
#define TL_MODEL_EVENT_UNSAVED_OFFSET sizeof(TlModelState)
#define TL_MODEL_EVENT_UNSAVED_SIZE 0
#endif
#define TL_EVENT_SAVED (sizeof(TlModelState) - TL_MODEL_EVENT_UNSAVED_SIZE + 1) /* + 1: never an empty array */

/* The result of a hook or a call, in the order and with the values of fmi2Status and fmi3Status (each layer checks). */
typedef enum { TL_OK, TL_WARNING, TL_DISCARD, TL_ERROR, TL_FATAL } TlStatus;

/* The importer's callbacks, as its standard hands them over (only the core and the layers use them). */
#if TL_FMI_VERSION == 3
#include "fmi3Functions.h"
typedef struct {
  fmi3InstanceEnvironment environment;
  fmi3LogMessageCallback log_message;
  fmi3LockPreemptionCallback lock_preemption;     /* Scheduled Execution: around state partitions share (or NULL) */
  fmi3UnlockPreemptionCallback unlock_preemption;
} TlHost;
#else
#include "fmi2Functions.h"
typedef fmi2CallbackFunctions TlHost;
#endif

#ifndef TL_STRING_LEN /* the model may set it (FmuDefinition.string_length, in tl_model.h) */
#define TL_STRING_LEN 64 /* longest String value + 1 */
#endif

/* Co-simulation phases; each version reaches some of them (its state-mask table in its file says where each call is
   allowed). FMI 2.0: TL_ERRORED follows an error, TL_BROKEN a fatal error. FMI 3.0: TL_EVENT is Event Mode,
   TL_STEPPING Step Mode, TL_ACTIVATION Scheduled Execution's Clock Activation Mode; an error leads to TL_TERMINATED, a
   fatal error to TL_BROKEN. */
enum { TL_INSTANTIATED, TL_INITIALIZATION, TL_STEPPING, TL_TERMINATED, TL_BROKEN, TL_ERRORED, TL_EVENT, TL_ACTIVATION };

typedef struct {
  int phase;
  double time;
  double start_time;
  double stop_time;   /* FMI 3.0: a step beyond it is an error (infinite: none given) */
  int stop_requested; /* set by a model that refuses all further steps: the importer is told to terminate */
  double real[TL_CAP_REAL];
  int integer[TL_CAP_INTEGER];
  int boolean[TL_CAP_BOOLEAN]; /* 0 or 1 */
  char string[TL_CAP_STRING][TL_STRING_LEN];
  TlModelState model;
  /* FMI 3.0 Event Mode (clocked builds; the FMI 2.0 layer leaves these zero) */
  int clock_active[TL_CAP_CLOCK]; /* set by fmi3SetClock, cleared by fmi3UpdateDiscreteStates */
  int event_dirty;                /* inputs or clocks changed since this event's partition ran (or it has not run) */
  int event_ran;                  /* the partition ran in this Event Mode: a rerun starts again from pre_event */
  double next_event_time;         /* a time event the model asks for (< 0: none): DoStep reports it as an event */
#if TL_EVENT_PARTITION
  unsigned char pre_event[TL_EVENT_SAVED]; /* the model state when this Event Mode began, less its unsaved region */
#endif
#if TL_SCHEDULED
  long long activation[TL_CAP_CLOCK]; /* each partition's last activation, in its clock's intervals from the start (-1: none) */
#endif
} TlState;

typedef struct TlInstance {
  TlState s;
  TlHost host;
  char* name;
  char* resources; /* the resources folder as a native path ending in a separator, or NULL (no file URI given) */
  int logging_on;
  int event_mode_used; /* FMI 3.0: the importer runs Event Mode (clocked FMUs require it) */
  int partitions_running; /* Scheduled Execution: activations in progress (preempted ones too) */
#if TL_SCHEDULED
  long long running[TL_CAP_CLOCK]; /* each partition's activation in progress, in its clock's intervals plus 1 (0: none) */
#endif
} TlInstance;

/* Log a formatted message through the host's logger (errors and discards always; others when
   logging is on). The message is formatted here: hosts print it as it is. */
TL_INTERNAL void tl_log(const TlInstance* c, TlStatus status, const char* format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Model hooks. */
TL_INTERNAL void tl_model_reset(TlInstance* c);                        /* start values are loaded: set the model state */
TL_INTERNAL TlStatus tl_model_outputs(TlInstance* c);                  /* outputs from parameters and inputs (initialization mode) */
TL_INTERNAL TlStatus tl_model_initialize(TlInstance* c);               /* exitInitializationMode: check parameters, set outputs */
TL_INTERNAL TlStatus tl_model_step(TlInstance* c, double t, double h); /* advance [t, t + h); the layer advances the clock on OK */
#if TL_EVENT_PARTITION
/* Event Mode at time t with the clocks c->s.clock_active (any of them, or none): run their partitions from the
   inputs set, write the clocked outputs and the discrete ones. May run again in the same event, from the model
   state the event began with (the layer restores it), when inputs or clocks change after an output was read. */
TL_INTERNAL TlStatus tl_model_event(TlInstance* c, double t);
#endif
#if TL_SCHEDULED
/* Scheduled Execution: the model partition of clock k (TL_CLOCK_*) activated at t, inputs as set before. Partitions
   may preempt each other: state two partitions share is touched only between tl_lock_preemption and
   tl_unlock_preemption (the importer's callbacks). */
TL_INTERNAL TlStatus tl_model_partition(TlInstance* c, int k, double t);
TL_INTERNAL void tl_lock_preemption(const TlInstance* c);
TL_INTERNAL void tl_unlock_preemption(const TlInstance* c);
/* 1 if clock k has no activation due at t, or its partition ran at t (or later); else 0 (a partition that must
   precede another at the same instant has not run: the importer broke the declared priorities). */
TL_INTERNAL int tl_partition_done(const TlInstance* c, int k, double t);
#endif

#endif
