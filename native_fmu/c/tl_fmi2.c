/* The FMI 2.0 co-simulation API of every tiltload native FMU: each function mapped onto the core (tl_core.c).

   Compiled per FMU with that FMU's generated tl_model.h / tl_model_tables.c and its model hooks (tl_fmu.h). What is
   FMI 2.0's own is here: the state-mask table (in which phases each call is allowed), how the standard logs and
   allocates (tl_binding), and the status functions. An error puts the instance in an error phase
   (get, reset, terminate and free remain), a discarded step keeps its state, a fatal error makes it unusable. */
#include "tl_platform.h"

#include <string.h>

#include "tl_core.h"

#define TL_API_STATUS fmi2Status
TL_STATIC_ASSERT(fmi2OK == (int)TL_OK && fmi2Warning == (int)TL_WARNING && fmi2Discard == (int)TL_DISCARD &&
                     fmi2Error == (int)TL_ERROR && fmi2Fatal == (int)TL_FATAL,
                 "a TlStatus is returned as the fmi2Status of the same value");

/* ---- the state-mask table: the phases in which each call is allowed --------------------------------------------- */
#define TL_FMI2_VARIABLES_SET (TL_IN(TL_INSTANTIATED) | TL_IN(TL_INITIALIZATION) | TL_IN(TL_STEPPING))
#define MASK_fmi2SetDebugLogging TL_ANY_BUT_FATAL
#define MASK_fmi2SetupExperiment TL_IN(TL_INSTANTIATED)
#define MASK_fmi2EnterInitializationMode TL_IN(TL_INSTANTIATED)
#define MASK_fmi2ExitInitializationMode TL_IN(TL_INITIALIZATION)
#define MASK_fmi2Terminate (TL_IN(TL_INITIALIZATION) | TL_IN(TL_STEPPING) | TL_IN(TL_ERRORED))
#define MASK_fmi2Reset TL_ANY_BUT_FATAL
#define MASK_fmi2GetReal TL_ANY_BUT_FATAL
#define MASK_fmi2GetInteger TL_ANY_BUT_FATAL
#define MASK_fmi2GetBoolean TL_ANY_BUT_FATAL
#define MASK_fmi2GetString TL_ANY_BUT_FATAL
#define MASK_fmi2SetReal TL_FMI2_VARIABLES_SET
#define MASK_fmi2SetInteger TL_FMI2_VARIABLES_SET
#define MASK_fmi2SetBoolean TL_FMI2_VARIABLES_SET
#define MASK_fmi2SetString TL_FMI2_VARIABLES_SET
#define MASK_fmi2DoStep TL_IN(TL_STEPPING)
#define MASK_fmi2CancelStep TL_IN(TL_STEPPING)
#define MASK_fmi2GetStatus TL_ANY_BUT_FATAL
#define MASK_fmi2GetRealStatus TL_ANY_BUT_FATAL
#define MASK_fmi2GetIntegerStatus TL_ANY_BUT_FATAL
#define MASK_fmi2GetBooleanStatus TL_ANY_BUT_FATAL
#define MASK_fmi2GetStringStatus TL_ANY_BUT_FATAL
#define MASK_fmi2GetFMUstate TL_ANY_BUT_FATAL
#define MASK_fmi2SetFMUstate TL_ANY_BUT_FATAL
#define MASK_fmi2FreeFMUstate TL_ANY_BUT_FATAL
#define MASK_fmi2SerializedFMUstateSize TL_ANY_BUT_FATAL
#define MASK_fmi2SerializeFMUstate TL_ANY_BUT_FATAL
#define MASK_fmi2DeSerializeFMUstate TL_ANY_BUT_FATAL

/* ---- the binding: how FMI 2.0 logs and allocates -------------------------------------------------------------------- */
static void host_log(const TlHost* host, const char* instance, TlStatus status, const char* category, const char* message) {
  if (host != NULL && host->logger != NULL) host->logger(host->componentEnvironment, instance, (fmi2Status)status, category, message);
}

static void* allocate(const TlHost* host, size_t size) {
  void* memory = host->allocateMemory(1, size);
  if (memory != NULL) memset(memory, 0, size);
  return memory;
}

static void release(const TlHost* host, void* memory) { host->freeMemory(memory); }

const TlBinding tl_binding = {'%', TL_ERRORED, {"Real", "Integer", "Boolean", "String"}, host_log, allocate, release};

/* ---- information and life cycle -------------------------------------------------------------------------------------- */
const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component instance, fmi2Boolean on, size_t n, const fmi2String categories[]) {
  TL_ENTER(fmi2SetDebugLogging);
  (void)n; (void)categories;
  tl_set_logging(c, on);
  return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions* host, fmi2Boolean visible, fmi2Boolean logging_on) {
  (void)visible;
  if (host == NULL || host->allocateMemory == NULL || host->freeMemory == NULL) return NULL;
  if (!tl_may_instantiate(host, "fmi2Instantiate", name, "GUID", guid)) return NULL;
  if (type != fmi2CoSimulation) {
    tl_log_host(host, name, "fmi2Instantiate: %s is a co-simulation FMU only", TL_MODEL_IDENTIFIER);
    return NULL;
  }
  return tl_create(host, "fmi2Instantiate", name, logging_on, 0, resources, 1);
}

void fmi2FreeInstance(fmi2Component instance) { tl_free_instance((TlInstance*)instance); }

fmi2Status fmi2SetupExperiment(fmi2Component instance, fmi2Boolean tolerance_defined, fmi2Real tolerance,
                               fmi2Real start_time, fmi2Boolean stop_time_defined, fmi2Real stop_time) {
  TL_ENTER(fmi2SetupExperiment);
  (void)tolerance_defined; (void)tolerance; (void)stop_time_defined; (void)stop_time; /* FMI 2.0 builds step past it */
  return (fmi2Status)tl_set_experiment(c, call, start_time, 0, 0.0);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component instance) {
  TL_ENTER(fmi2EnterInitializationMode);
  tl_enter_initialization(c);
  return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component instance) {
  TL_ENTER(fmi2ExitInitializationMode);
  return (fmi2Status)tl_exit_initialization(c, TL_STEPPING);
}

fmi2Status fmi2Terminate(fmi2Component instance) {
  TL_ENTER(fmi2Terminate);
  tl_terminate(c);
  return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component instance) {
  TL_ENTER(fmi2Reset);
  tl_reset(c);
  return fmi2OK;
}

/* ---- variables ------------------------------------------------------------------------------------------------------ */
fmi2Status fmi2GetReal(fmi2Component instance, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
  TL_ENTER(fmi2GetReal);
  return (fmi2Status)tl_get(c, call, TL_TYPE_REAL, vr, n, value);
}

fmi2Status fmi2GetInteger(fmi2Component instance, const fmi2ValueReference vr[], size_t n, fmi2Integer value[]) {
  TL_ENTER(fmi2GetInteger);
  return (fmi2Status)tl_get(c, call, TL_TYPE_INTEGER, vr, n, value);
}

fmi2Status fmi2GetBoolean(fmi2Component instance, const fmi2ValueReference vr[], size_t n, fmi2Boolean value[]) {
  TL_ENTER(fmi2GetBoolean);
  return (fmi2Status)tl_get(c, call, TL_TYPE_BOOLEAN, vr, n, value);
}

fmi2Status fmi2GetString(fmi2Component instance, const fmi2ValueReference vr[], size_t n, fmi2String value[]) {
  TL_ENTER(fmi2GetString);
  return (fmi2Status)tl_get(c, call, TL_TYPE_STRING, vr, n, value);
}

fmi2Status fmi2SetReal(fmi2Component instance, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
  TL_ENTER(fmi2SetReal);
  return (fmi2Status)tl_set(c, call, TL_TYPE_REAL, vr, n, value);
}

fmi2Status fmi2SetInteger(fmi2Component instance, const fmi2ValueReference vr[], size_t n, const fmi2Integer value[]) {
  TL_ENTER(fmi2SetInteger);
  return (fmi2Status)tl_set(c, call, TL_TYPE_INTEGER, vr, n, value);
}

fmi2Status fmi2SetBoolean(fmi2Component instance, const fmi2ValueReference vr[], size_t n, const fmi2Boolean value[]) {
  TL_ENTER(fmi2SetBoolean);
  return (fmi2Status)tl_set(c, call, TL_TYPE_BOOLEAN, vr, n, value);
}

fmi2Status fmi2SetString(fmi2Component instance, const fmi2ValueReference vr[], size_t n, const fmi2String value[]) {
  TL_ENTER(fmi2SetString);
  return (fmi2Status)tl_set(c, call, TL_TYPE_STRING, vr, n, value);
}

/* ---- stepping and status ---------------------------------------------------------------------------------------------- */
fmi2Status fmi2DoStep(fmi2Component instance, fmi2Real t, fmi2Real h, fmi2Boolean no_set_prior) {
  TL_ENTER(fmi2DoStep);
  (void)no_set_prior;
  return (fmi2Status)tl_do_step(c, call, t, h);
}

fmi2Status fmi2CancelStep(fmi2Component instance) {
  TL_ENTER(fmi2CancelStep);
  return (fmi2Status)tl_fail(c, "fmi2CancelStep: steps are synchronous, there is nothing to cancel");
}

fmi2Status fmi2GetStatus(fmi2Component instance, const fmi2StatusKind kind, fmi2Status* value) {
  TL_ENTER(fmi2GetStatus);
  (void)kind; (void)value;
  return fmi2Discard; /* no asynchronous step is ever pending */
}

fmi2Status fmi2GetRealStatus(fmi2Component instance, const fmi2StatusKind kind, fmi2Real* value) {
  TL_ENTER(fmi2GetRealStatus);
  if (kind != fmi2LastSuccessfulTime || value == NULL) return fmi2Discard;
  *value = c->s.time;
  return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component instance, const fmi2StatusKind kind, fmi2Integer* value) {
  TL_ENTER(fmi2GetIntegerStatus);
  (void)kind; (void)value;
  return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component instance, const fmi2StatusKind kind, fmi2Boolean* value) {
  TL_ENTER(fmi2GetBooleanStatus);
  if (kind != fmi2Terminated || value == NULL) return fmi2Discard;
  *value = c->s.stop_requested ? fmi2True : fmi2False; /* asked after a discarded step */
  return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component instance, const fmi2StatusKind kind, fmi2String* value) {
  TL_ENTER(fmi2GetStringStatus);
  (void)kind; (void)value;
  return fmi2Discard;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component instance, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) {
  (void)vr; (void)n; (void)order; (void)value;
  return (fmi2Status)tl_unsupported((TlInstance*)instance, "fmi2SetRealInputDerivatives", "canInterpolateInputs is false");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component instance, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) {
  (void)vr; (void)n; (void)order; (void)value;
  return (fmi2Status)tl_unsupported((TlInstance*)instance, "fmi2GetRealOutputDerivatives", "maxOutputDerivativeOrder is 0");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component instance, const fmi2ValueReference unknown[], size_t n_unknown,
                                        const fmi2ValueReference known[], size_t n_known, const fmi2Real dv_known[],
                                        fmi2Real dv_unknown[]) {
  (void)unknown; (void)n_unknown; (void)known; (void)n_known; (void)dv_known; (void)dv_unknown;
  return (fmi2Status)tl_unsupported((TlInstance*)instance, "fmi2GetDirectionalDerivative",
                                    "providesDirectionalDerivative is false");
}

/* ---- state snapshots ---------------------------------------------------------------------------------------------------- */
fmi2Status fmi2GetFMUstate(fmi2Component instance, fmi2FMUstate* state) {
  TL_ENTER(fmi2GetFMUstate);
  return (fmi2Status)tl_get_state(c, call, state);
}

fmi2Status fmi2SetFMUstate(fmi2Component instance, fmi2FMUstate state) {
  TL_ENTER(fmi2SetFMUstate);
  return (fmi2Status)tl_set_state(c, call, state);
}

fmi2Status fmi2FreeFMUstate(fmi2Component instance, fmi2FMUstate* state) {
  TL_ENTER(fmi2FreeFMUstate);
  tl_free_state(c, state);
  return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component instance, fmi2FMUstate state, size_t* size) {
  TL_ENTER(fmi2SerializedFMUstateSize);
  (void)state;
  return (fmi2Status)tl_serialized_size(c, call, size);
}

fmi2Status fmi2SerializeFMUstate(fmi2Component instance, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
  TL_ENTER(fmi2SerializeFMUstate);
  return (fmi2Status)tl_serialize(c, call, state, (unsigned char*)bytes, size);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component instance, const fmi2Byte bytes[], size_t size, fmi2FMUstate* state) {
  TL_ENTER(fmi2DeSerializeFMUstate);
  return (fmi2Status)tl_deserialize(c, call, (const unsigned char*)bytes, size, state);
}
