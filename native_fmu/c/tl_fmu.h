/* The contract between the generic FMI 2.0 layer (tl_fmi2.c) and one model.

   The layer owns the instance: life cycle, status, logging, get/set by value reference with
   causality checks, state snapshots. A model provides its state struct (TlModelState, in the
   header named by tl_model.h) and four hooks. Everything a snapshot must restore lives in
   TlState, a plain struct with no pointers, so fmi2GetFMUstate is one copy. */
#ifndef TL_FMU_H
#define TL_FMU_H

#include "tl_platform.h"

#include "fmi2Functions.h"
#include "tl_model.h"

#define TL_STRING_LEN 64 /* longest String value + 1 */

/* FMI 2.0 co-simulation states; TL_ERRORED follows fmi2Error, TL_BROKEN follows fmi2Fatal. */
enum { TL_INSTANTIATED, TL_INITIALIZATION, TL_STEPPING, TL_TERMINATED, TL_BROKEN, TL_ERRORED };

typedef struct {
  int phase;
  double time;
  double start_time;
  int stop_requested; /* set by a model that refuses all further steps: fmi2Terminated reads it */
  fmi2Real real[TL_CAP_REAL];
  fmi2Integer integer[TL_CAP_INTEGER];
  fmi2Boolean boolean[TL_CAP_BOOLEAN];
  char string[TL_CAP_STRING][TL_STRING_LEN];
  TlModelState model;
} TlState;

typedef struct TlInstance {
  TlState s;
  fmi2CallbackFunctions host;
  char* name;
  char* resources; /* the resources folder as a native path ending in a separator, or NULL (no file URI given) */
  fmi2Boolean logging_on;
} TlInstance;

/* Log a formatted message through the host's logger (errors and discards always; others when
   logging is on). The message is formatted here: hosts print it as it is. */
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

#endif
