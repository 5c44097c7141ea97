/* The FMI 3.0 co-simulation API of every tiltload native FMU: each function mapped onto the core (tl_core.c), beside
   the FMI 2.0 one (tl_fmi2.c). The same hooks (tl_fmu.h), tables and start values as FMI 2.0.

   What is FMI 3.0's own is here: the state-mask table, how the standard logs and allocates (tl_binding; '#' is its
   escape character), the checks of its arguments (array sizes, Event Mode asked for or not, the instantiation kind),
   and which of its functions a tiltload FMU refuses with a reason (model exchange, structural parameters, ...).
   Value references are unique across types (0 time, then the clocks, then each type from its base; describe_fmi3.py).
   Any error leads to Terminated, a fatal error makes the instance unusable; a refused step (fmi3Discard) keeps the
   state. Event Mode, the clocks and Scheduled Execution are the core's (tl_core.h says how they behave). The
   co-simulation builds refuse fmi3InstantiateScheduledExecution, and the Scheduled Execution builds
   fmi3InstantiateCoSimulation. */
#include "tl_platform.h"

#include <stdlib.h>
#include <string.h>

#include "tl_core.h"

#define TL_HAS_EVENT_MODE TL_EVENT_PARTITION
#define TL_API_STATUS fmi3Status
TL_STATIC_ASSERT(fmi3OK == (int)TL_OK && fmi3Warning == (int)TL_WARNING && fmi3Discard == (int)TL_DISCARD &&
                     fmi3Error == (int)TL_ERROR && fmi3Fatal == (int)TL_FATAL,
                 "a TlStatus is returned as the fmi3Status of the same value");

/* ---- the state-mask table: the phases in which each call is allowed --------------------------------------------- */
#define TL_FMI3_VARIABLES_SET \
  (TL_IN(TL_INSTANTIATED) | TL_IN(TL_INITIALIZATION) | TL_IN(TL_EVENT) | TL_IN(TL_STEPPING) | TL_IN(TL_ACTIVATION))
#define TL_FMI3_CLOCK_QUERY (TL_IN(TL_INITIALIZATION) | TL_IN(TL_EVENT) | TL_IN(TL_ACTIVATION))
#define MASK_fmi3SetDebugLogging TL_ANY_BUT_FATAL
#define MASK_fmi3EnterInitializationMode TL_IN(TL_INSTANTIATED)
#define MASK_fmi3ExitInitializationMode TL_IN(TL_INITIALIZATION)
#define MASK_fmi3EnterEventMode TL_IN(TL_STEPPING)
#define MASK_fmi3Terminate (TL_IN(TL_EVENT) | TL_IN(TL_STEPPING) | TL_IN(TL_ACTIVATION))
#define MASK_fmi3ActivateModelPartition TL_IN(TL_ACTIVATION)
#define MASK_fmi3Reset TL_ANY_BUT_FATAL
#define MASK_fmi3GetFloat64 TL_ANY_BUT_FATAL
#define MASK_fmi3GetInt32 TL_ANY_BUT_FATAL
#define MASK_fmi3GetBoolean TL_ANY_BUT_FATAL
#define MASK_fmi3GetString TL_ANY_BUT_FATAL
#define MASK_fmi3GetBinary TL_ANY_BUT_FATAL
#define MASK_fmi3SetFloat64 TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetInt32 TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetBoolean TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetString TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetBinary TL_FMI3_VARIABLES_SET
#define MASK_fmi3GetFloat32 TL_ANY_BUT_FATAL /* the types no tiltload FMU has */
#define MASK_fmi3GetInt8 TL_ANY_BUT_FATAL
#define MASK_fmi3GetUInt8 TL_ANY_BUT_FATAL
#define MASK_fmi3GetInt16 TL_ANY_BUT_FATAL
#define MASK_fmi3GetUInt16 TL_ANY_BUT_FATAL
#define MASK_fmi3GetUInt32 TL_ANY_BUT_FATAL
#define MASK_fmi3GetInt64 TL_ANY_BUT_FATAL
#define MASK_fmi3GetUInt64 TL_ANY_BUT_FATAL
#define MASK_fmi3SetFloat32 TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetInt8 TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetUInt8 TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetInt16 TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetUInt16 TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetUInt32 TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetInt64 TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetUInt64 TL_FMI3_VARIABLES_SET
#define MASK_fmi3SetClock TL_IN(TL_EVENT)
#define MASK_fmi3GetClock TL_IN(TL_EVENT)
#define MASK_fmi3GetIntervalDecimal TL_FMI3_CLOCK_QUERY
#define MASK_fmi3GetIntervalFraction TL_FMI3_CLOCK_QUERY
#define MASK_fmi3GetShiftDecimal TL_FMI3_CLOCK_QUERY
#define MASK_fmi3GetShiftFraction TL_FMI3_CLOCK_QUERY
#define MASK_fmi3UpdateDiscreteStates TL_IN(TL_EVENT)
#define MASK_fmi3EnterStepMode TL_IN(TL_EVENT)
#define MASK_fmi3DoStep TL_IN(TL_STEPPING)
#define MASK_fmi3GetOutputDerivatives TL_ANY_BUT_FATAL
#define MASK_fmi3GetFMUState TL_ANY_BUT_FATAL
#define MASK_fmi3SetFMUState TL_ANY_BUT_FATAL
#define MASK_fmi3FreeFMUState TL_ANY_BUT_FATAL
#define MASK_fmi3SerializedFMUStateSize TL_ANY_BUT_FATAL
#define MASK_fmi3SerializeFMUState TL_ANY_BUT_FATAL
#define MASK_fmi3DeserializeFMUState TL_ANY_BUT_FATAL

/* ---- the binding: how FMI 3.0 logs and allocates -------------------------------------------------------------------- */
static void host_log(const TlHost* host, const char* instance, TlStatus status, const char* category, const char* message) {
  (void)instance; /* an FMI 3.0 message names no instance: the environment says which */
  if (host != NULL && host->log_message != NULL) host->log_message(host->environment, (fmi3Status)status, category, message);
}

static void* allocate(const TlHost* host, size_t size) {
  (void)host;
  return calloc(1, size);
}

static void release(const TlHost* host, void* memory) {
  (void)host;
  free(memory);
}

const TlBinding tl_binding = {'#', TL_TERMINATED, {"Float64", "Int32", "Boolean", "String"}, host_log, allocate, release};

/* ---- information and life cycle ------------------------------------------------------------------------------------ */
const char* fmi3GetVersion(void) { return fmi3Version; }

static TlHost host_of(fmi3InstanceEnvironment environment, fmi3LogMessageCallback log_message) {
  TlHost host;
  memset(&host, 0, sizeof host);
  host.environment = environment;
  host.log_message = log_message;
  return host;
}

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean on, size_t n, const fmi3String categories[]) {
  TL_ENTER(fmi3SetDebugLogging);
  (void)n; (void)categories;
  tl_set_logging(c, on);
  return fmi3OK;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
                                         fmi3Boolean logging_on, fmi3Boolean event_mode_used, fmi3Boolean early_return_allowed,
                                         const fmi3ValueReference required_intermediate[], size_t n_required_intermediate,
                                         fmi3InstanceEnvironment environment, fmi3LogMessageCallback log_message,
                                         fmi3IntermediateUpdateCallback intermediate_update) {
  const char* const call = "fmi3InstantiateCoSimulation";
  TlHost host = host_of(environment, log_message);
  (void)visible; (void)early_return_allowed; (void)required_intermediate; (void)intermediate_update;
  if (!tl_may_instantiate(&host, call, name, "instantiation token", token)) return NULL;
  if (TL_SCHEDULED) {
    tl_log_host(&host, name, "%s: %s: %s is a Scheduled Execution FMU only (fmi3InstantiateScheduledExecution)", call, name,
                TL_MODEL_IDENTIFIER);
    return NULL;
  }
  if (event_mode_used && !TL_HAS_EVENT_MODE) {
    tl_log_host(&host, name, "%s: %s: %s has no Event Mode (hasEventMode=\"false\"): eventModeUsed must be false", call, name,
                TL_MODEL_IDENTIFIER);
    return NULL;
  }
  if (!event_mode_used && TL_HAS_EVENT_MODE) {
    tl_log_host(&host, name, "%s: %s: %s has clocks, which need Event Mode: eventModeUsed must be true (or use the plain "
                "variant without clocks)", call, name, TL_MODEL_IDENTIFIER);
    return NULL;
  }
  if (n_required_intermediate > 0) {
    tl_log_host(&host, name, "%s: %s: %s provides no intermediate update (requiredIntermediateVariables must be empty)", call,
                name, TL_MODEL_IDENTIFIER);
    return NULL;
  }
  return tl_create(&host, call, name, logging_on, event_mode_used, resources, 0);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
                                          fmi3Boolean logging_on, fmi3InstanceEnvironment environment,
                                          fmi3LogMessageCallback log_message) {
  TlHost host = host_of(environment, log_message);
  (void)token; (void)resources; (void)visible; (void)logging_on;
  tl_log_host(&host, name ? name : "?", "fmi3InstantiateModelExchange: %s: %s is a co-simulation FMU only", name ? name : "?", TL_MODEL_IDENTIFIER);
  return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
                                               fmi3Boolean logging_on, fmi3InstanceEnvironment environment,
                                               fmi3LogMessageCallback log_message, fmi3ClockUpdateCallback clock_update,
                                               fmi3LockPreemptionCallback lock, fmi3UnlockPreemptionCallback unlock) {
  const char* const call = "fmi3InstantiateScheduledExecution";
  TlHost host = host_of(environment, log_message);
  (void)visible; (void)clock_update; /* no output or countdown clocks: nothing to signal */
  if (!TL_SCHEDULED) {
    tl_log_host(&host, name ? name : "?", "%s: %s: %s is a co-simulation FMU only", call, name ? name : "?", TL_MODEL_IDENTIFIER);
    return NULL;
  }
  if (!tl_may_instantiate(&host, call, name, "instantiation token", token)) return NULL;
  host.lock_preemption = lock;
  host.unlock_preemption = unlock;
  return tl_create(&host, call, name, logging_on, 0, resources, 0);
}

void fmi3FreeInstance(fmi3Instance instance) { tl_free_instance((TlInstance*)instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean tolerance_defined, fmi3Float64 tolerance,
                                       fmi3Float64 start_time, fmi3Boolean stop_time_defined, fmi3Float64 stop_time) {
  TlStatus status;
  TL_ENTER(fmi3EnterInitializationMode);
  (void)tolerance_defined; (void)tolerance;
  status = tl_set_experiment(c, call, start_time, stop_time_defined, stop_time);
  if (status == TL_OK) tl_enter_initialization(c);
  return (fmi3Status)status;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
  TlStatus status;
  TL_ENTER(fmi3ExitInitializationMode);
  status = tl_exit_initialization(c, TL_SCHEDULED ? TL_ACTIVATION : c->event_mode_used ? TL_EVENT : TL_STEPPING);
  if (status <= TL_WARNING) tl_begin_event(c);
  return (fmi3Status)status;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
  TL_ENTER(fmi3EnterEventMode);
  return (fmi3Status)tl_enter_event_mode(c, call);
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
  TL_ENTER(fmi3Terminate);
  tl_terminate(c);
  return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
  TL_ENTER(fmi3Reset);
  tl_reset(c);
  return fmi3OK;
}

/* ---- variables ------------------------------------------------------------------------------------------------------- */
/* The types a tiltload FMU has: FMI 3.0's check of the array sizes, then the core's access. */
#define ACCESS(function, verb, type, qualifier, ctype)                                                                    \
  fmi3Status function(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, qualifier ctype value[], size_t n_values) { \
    TL_ENTER(function);                                                                                                   \
    if (n_values != n)                                                                                                    \
      return (fmi3Status)tl_fail(c, "%s: %lu values for %lu scalar variables", call, (unsigned long)n_values, (unsigned long)n); \
    return (fmi3Status)tl_##verb(c, call, type, vr, n, value);                                                            \
  }
#define NOTHING
ACCESS(fmi3GetFloat64, get, TL_TYPE_REAL, NOTHING, fmi3Float64)
ACCESS(fmi3GetInt32, get, TL_TYPE_INTEGER, NOTHING, fmi3Int32)
ACCESS(fmi3GetBoolean, get, TL_TYPE_BOOLEAN, NOTHING, fmi3Boolean)
ACCESS(fmi3GetString, get, TL_TYPE_STRING, NOTHING, fmi3String)
ACCESS(fmi3SetFloat64, set, TL_TYPE_REAL, const, fmi3Float64)
ACCESS(fmi3SetInt32, set, TL_TYPE_INTEGER, const, fmi3Int32)
ACCESS(fmi3SetBoolean, set, TL_TYPE_BOOLEAN, const, fmi3Boolean)
ACCESS(fmi3SetString, set, TL_TYPE_STRING, const, fmi3String)

/* The types no tiltload FMU has: an empty call is fine, any value reference is unknown. */
#define NO_SUCH_TYPE(function, qualifier, ctype)                                                                          \
  fmi3Status function(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, qualifier ctype value[], size_t n_values) { \
    TL_ENTER(function);                                                                                                   \
    (void)value; (void)n_values;                                                                                          \
    return (fmi3Status)tl_no_variables(c, call, vr, n, "variable of this type");                                          \
  }
NO_SUCH_TYPE(fmi3GetFloat32, NOTHING, fmi3Float32)
NO_SUCH_TYPE(fmi3GetInt8, NOTHING, fmi3Int8)
NO_SUCH_TYPE(fmi3GetUInt8, NOTHING, fmi3UInt8)
NO_SUCH_TYPE(fmi3GetInt16, NOTHING, fmi3Int16)
NO_SUCH_TYPE(fmi3GetUInt16, NOTHING, fmi3UInt16)
NO_SUCH_TYPE(fmi3GetUInt32, NOTHING, fmi3UInt32)
NO_SUCH_TYPE(fmi3GetInt64, NOTHING, fmi3Int64)
NO_SUCH_TYPE(fmi3GetUInt64, NOTHING, fmi3UInt64)
NO_SUCH_TYPE(fmi3SetFloat32, const, fmi3Float32)
NO_SUCH_TYPE(fmi3SetInt8, const, fmi3Int8)
NO_SUCH_TYPE(fmi3SetUInt8, const, fmi3UInt8)
NO_SUCH_TYPE(fmi3SetInt16, const, fmi3Int16)
NO_SUCH_TYPE(fmi3SetUInt16, const, fmi3UInt16)
NO_SUCH_TYPE(fmi3SetUInt32, const, fmi3UInt32)
NO_SUCH_TYPE(fmi3SetInt64, const, fmi3Int64)
NO_SUCH_TYPE(fmi3SetUInt64, const, fmi3UInt64)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, size_t sizes[], fmi3Binary value[],
                         size_t n_values) {
  TL_ENTER(fmi3GetBinary);
  (void)sizes; (void)value; (void)n_values;
  return (fmi3Status)tl_no_variables(c, call, vr, n, "Binary variable");
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const size_t sizes[],
                         const fmi3Binary value[], size_t n_values) {
  TL_ENTER(fmi3SetBinary);
  (void)sizes; (void)value; (void)n_values;
  return (fmi3Status)tl_no_variables(c, call, vr, n, "Binary variable");
}

/* ---- clocks: periodic, with constant intervals and no shift ---------------------------------------------------------- */
fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Clock value[]) {
  TL_ENTER(fmi3SetClock);
  return (fmi3Status)tl_set_clocks(c, call, vr, n, value);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3Clock value[]) {
  TL_ENTER(fmi3GetClock);
  return (fmi3Status)tl_get_clocks(c, call, vr, n, value);
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3Float64 interval[],
                                  fmi3IntervalQualifier qualifier[]) {
  TL_ENTER(fmi3GetIntervalDecimal);
  return (fmi3Status)tl_clock_grid(c, call, vr, n, interval != NULL && qualifier != NULL, 0, interval, NULL, NULL, qualifier);
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3UInt64 counter[],
                                   fmi3UInt64 resolution[], fmi3IntervalQualifier qualifier[]) {
  TL_ENTER(fmi3GetIntervalFraction);
  return (fmi3Status)tl_clock_grid(c, call, vr, n, counter != NULL && resolution != NULL && qualifier != NULL, 0, NULL, counter,
                                   resolution, qualifier);
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3Float64 shift[]) {
  TL_ENTER(fmi3GetShiftDecimal);
  return (fmi3Status)tl_clock_grid(c, call, vr, n, shift != NULL, 1, shift, NULL, NULL, NULL);
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3UInt64 counter[],
                                fmi3UInt64 resolution[]) {
  TL_ENTER(fmi3GetShiftFraction);
  return (fmi3Status)tl_clock_grid(c, call, vr, n, counter != NULL && resolution != NULL, 1, NULL, counter, resolution, NULL);
}

#define CONSTANT_CLOCKS "its clocks are constant (intervalVariability=\"constant\"): nothing to set"

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Float64 interval[]) {
  (void)vr; (void)n; (void)interval;
  return (fmi3Status)tl_unsupported((TlInstance*)instance, "fmi3SetIntervalDecimal", CONSTANT_CLOCKS);
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 counter[],
                                   const fmi3UInt64 resolution[]) {
  (void)vr; (void)n; (void)counter; (void)resolution;
  return (fmi3Status)tl_unsupported((TlInstance*)instance, "fmi3SetIntervalFraction", CONSTANT_CLOCKS);
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Float64 shift[]) {
  (void)vr; (void)n; (void)shift;
  return (fmi3Status)tl_unsupported((TlInstance*)instance, "fmi3SetShiftDecimal", CONSTANT_CLOCKS);
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 counter[],
                                const fmi3UInt64 resolution[]) {
  (void)vr; (void)n; (void)counter; (void)resolution;
  return (fmi3Status)tl_unsupported((TlInstance*)instance, "fmi3SetShiftFraction", CONSTANT_CLOCKS);
}

/* ---- Event Mode and stepping ----------------------------------------------------------------------------------------- */
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean* need_update, fmi3Boolean* terminate,
                                    fmi3Boolean* nominals_changed, fmi3Boolean* values_changed, fmi3Boolean* next_defined,
                                    fmi3Float64* next_time) {
  TlStatus status;
  int terminating, defined;
  TL_ENTER(fmi3UpdateDiscreteStates);
  if (!need_update || !terminate || !nominals_changed || !values_changed || !next_defined || !next_time)
    return (fmi3Status)tl_fail(c, "%s: an output argument is NULL", call);
  status = tl_update_discrete_states(c, &terminating, &defined, next_time);
  if (status > TL_WARNING) return (fmi3Status)status;
  *need_update = fmi3False; /* the partitions have no iteration of their own */
  *terminate = terminating ? fmi3True : fmi3False;
  *nominals_changed = *values_changed = fmi3False;
  *next_defined = defined ? fmi3True : fmi3False;
  return (fmi3Status)status;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
  TL_ENTER(fmi3EnterStepMode);
  return (fmi3Status)tl_enter_step_mode(c);
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 t, fmi3Float64 h, fmi3Boolean no_set_prior, fmi3Boolean* event_needed,
                      fmi3Boolean* terminate, fmi3Boolean* early_return, fmi3Float64* last_time) {
  TlStatus status;
  TL_ENTER(fmi3DoStep);
  (void)no_set_prior;
  if (!event_needed || !terminate || !early_return || !last_time) return (fmi3Status)tl_fail(c, "%s: an output argument is NULL", call);
  status = tl_do_step(c, call, t, h);
  *early_return = fmi3False;
  *last_time = c->s.time;
  *terminate = c->s.stop_requested ? fmi3True : fmi3False;
  *event_needed = tl_event_needed(c, h) ? fmi3True : fmi3False;
  return (fmi3Status)status;
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Int32 order[],
                                    fmi3Float64 value[], size_t n_values) {
  TL_ENTER(fmi3GetOutputDerivatives);
  (void)vr; (void)n; (void)order; (void)value; (void)n_values;
  return (fmi3Status)tl_fail(c, "%s: %s provides no output derivatives (maxOutputDerivativeOrder=0)", call, TL_MODEL_IDENTIFIER);
}

/* ---- state snapshots ---------------------------------------------------------------------------------------------------- */
fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState* state) {
  TL_ENTER(fmi3GetFMUState);
  return (fmi3Status)tl_get_state(c, call, state);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState state) {
  TL_ENTER(fmi3SetFMUState);
  return (fmi3Status)tl_set_state(c, call, state);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState* state) {
  TL_ENTER(fmi3FreeFMUState);
  tl_free_state(c, state);
  return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState state, size_t* size) {
  TL_ENTER(fmi3SerializedFMUStateSize);
  (void)state;
  return (fmi3Status)tl_serialized_size(c, call, size);
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState state, fmi3Byte bytes[], size_t size) {
  TL_ENTER(fmi3SerializeFMUState);
  return (fmi3Status)tl_serialize(c, call, state, bytes, size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte bytes[], size_t size, fmi3FMUState* state) {
  TL_ENTER(fmi3DeserializeFMUState);
  return (fmi3Status)tl_deserialize(c, call, bytes, size, state);
}

/* ---- what a tiltload FMU does not provide: a reason, fmi3Error ---------------------------------------------------------- */
static fmi3Status unsupported(fmi3Instance instance, const char* call, const char* why) {
  return (fmi3Status)tl_unsupported((TlInstance*)instance, call, why);
}

#define CS_ONLY "it is a co-simulation FMU (no model exchange)"

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference vr, size_t* n) {
  (void)vr; (void)n;
  return unsupported(instance, "fmi3GetNumberOfVariableDependencies", "providesPerElementDependencies is false");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent, size_t element_dependent[],
                                       fmi3ValueReference independents[], size_t element_independent[],
                                       fmi3DependencyKind kinds[], size_t n) {
  (void)dependent; (void)element_dependent; (void)independents; (void)element_independent; (void)kinds; (void)n;
  return unsupported(instance, "fmi3GetVariableDependencies", "providesPerElementDependencies is false");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t n_unknowns,
                                        const fmi3ValueReference knowns[], size_t n_knowns, const fmi3Float64 seed[],
                                        size_t n_seed, fmi3Float64 sensitivity[], size_t n_sensitivity) {
  (void)unknowns; (void)n_unknowns; (void)knowns; (void)n_knowns; (void)seed; (void)n_seed; (void)sensitivity; (void)n_sensitivity;
  return unsupported(instance, "fmi3GetDirectionalDerivative", "providesDirectionalDerivatives is false");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t n_unknowns,
                                    const fmi3ValueReference knowns[], size_t n_knowns, const fmi3Float64 seed[], size_t n_seed,
                                    fmi3Float64 sensitivity[], size_t n_sensitivity) {
  (void)unknowns; (void)n_unknowns; (void)knowns; (void)n_knowns; (void)seed; (void)n_seed; (void)sensitivity; (void)n_sensitivity;
  return unsupported(instance, "fmi3GetAdjointDerivative", "providesAdjointDerivatives is false");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
  return unsupported(instance, "fmi3EnterConfigurationMode", "it has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
  return unsupported(instance, "fmi3ExitConfigurationMode", "it has no structural parameters");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
  return unsupported(instance, "fmi3EvaluateDiscreteStates", "providesEvaluateDiscreteStates is false");
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
  return unsupported(instance, "fmi3EnterContinuousTimeMode", CS_ONLY);
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean no_set_prior, fmi3Boolean* enter_event_mode,
                                       fmi3Boolean* terminate) {
  (void)no_set_prior; (void)enter_event_mode; (void)terminate;
  return unsupported(instance, "fmi3CompletedIntegratorStep", CS_ONLY);
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
  (void)time;
  return unsupported(instance, "fmi3SetTime", CS_ONLY);
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 states[], size_t n) {
  (void)states; (void)n;
  return unsupported(instance, "fmi3SetContinuousStates", CS_ONLY);
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[], size_t n) {
  (void)derivatives; (void)n;
  return unsupported(instance, "fmi3GetContinuousStateDerivatives", CS_ONLY);
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 indicators[], size_t n) {
  (void)indicators; (void)n;
  return unsupported(instance, "fmi3GetEventIndicators", CS_ONLY);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 states[], size_t n) {
  (void)states; (void)n;
  return unsupported(instance, "fmi3GetContinuousStates", CS_ONLY);
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t n) {
  (void)nominals; (void)n;
  return unsupported(instance, "fmi3GetNominalsOfContinuousStates", CS_ONLY);
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t* n) {
  (void)n;
  return unsupported(instance, "fmi3GetNumberOfEventIndicators", CS_ONLY);
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t* n) {
  (void)n;
  return unsupported(instance, "fmi3GetNumberOfContinuousStates", CS_ONLY);
}

#if TL_SCHEDULED
fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clock, fmi3Float64 time) {
  TL_ENTER(fmi3ActivateModelPartition);
  return (fmi3Status)tl_activate(c, call, clock, time);
}
#else
fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clock, fmi3Float64 time) {
  (void)clock; (void)time;
  return unsupported(instance, "fmi3ActivateModelPartition", "it is not a scheduled-execution FMU");
}
#endif
