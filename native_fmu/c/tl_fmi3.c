/* The FMI 3.0 co-simulation API, written once for every tiltload native FMU, beside the FMI 2.0 one (tl_fmi2.c).

   The same hooks (tl_fmu.h), tables and start values (tl_core.c) as FMI 2.0. What differs is the interface:
   value references unique across types (0 time, then the clocks, then each type from its base; describe3.py),
   Float64/Int32/Boolean/String, the state machine (Instantiated, Initialization Mode, Event Mode, Step Mode,
   Terminated; any fmi3Error leads to Terminated, fmi3Fatal makes the instance unusable), fmi3Discard for a
   refused step (state kept), the log callback without printf semantics ('#' is its escape character).

   Clocked builds (TL_N_CLOCK > 0) have Event Mode and periodic input clocks. The importer enters Event Mode,
   activates the due clocks (fmi3SetClock), sets inputs, reads the clocked outputs, calls
   fmi3UpdateDiscreteStates and returns to Step Mode. The model's partition (tl_model_event) runs lazily: at
   the first Get in Event Mode, or in UpdateDiscreteStates, so inputs set after fmi3SetClock are seen. An input
   or clock set after a Get makes it run again, from the model state the event began with. Clocked variables
   are accessible only while their clock is active (and at initialization). Every fmi3 function is exported;
   those of model exchange and scheduled execution refuse with a reason. */
#include "tl_platform.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tl_core.h"
#include "tl_fmu.h"

#define TL_HAS_EVENT_MODE (TL_N_CLOCK > 0)

/* Format, escape '#' (the FMI 3.0 escape character of messages) and hand to the host's callback. Errors and
   discards are always logged (FMI 3.0.3 clarifies that errors may be logged with logging off). */
static void log_to(const TlHost* host, int logging_on, fmi2Status status, const char* format, va_list args) {
  char text[1024], escaped[2048];
  size_t i, j = 0;
  if (host == NULL || host->log_message == NULL) return;
  if (status < fmi2Discard && !logging_on) return;
  vsnprintf(text, sizeof text, format, args);
  for (i = 0; text[i] != '\0' && j + 2 < sizeof escaped; ++i) {
    if (text[i] == '#') escaped[j++] = '#';
    escaped[j++] = text[i];
  }
  escaped[j] = '\0';
  host->log_message(host->environment, (fmi3Status)status,
                    status >= fmi2Error ? "logStatusError" : status == fmi2Discard ? "logStatusDiscard" : "logEvents", escaped);
}

void tl_log(const TlInstance* c, fmi2Status status, const char* format, ...) {
  va_list args;
  if (c == NULL) return;
  va_start(args, format);
  log_to(&c->host, c->logging_on, status, format, args);
  va_end(args);
}

static void log_host(const TlHost* host, const char* format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static void log_host(const TlHost* host, const char* format, ...) {
  va_list args;
  va_start(args, format);
  log_to(host, 1, fmi2Error, format, args);
  va_end(args);
}

/* The result of a call: fmi3Error ends in Terminated, fmi3Fatal makes the instance unusable. */
static fmi3Status settle(TlInstance* c, fmi2Status status) {
  if (status == fmi2Fatal) c->s.phase = TL_BROKEN;
  else if (status == fmi2Error) c->s.phase = TL_TERMINATED;
  return (fmi3Status)status;
}

static fmi3Status refuse(TlInstance* c, const char* call) {
  tl_log(c, fmi2Error, "%s is not allowed in %s", call, tl_phase_name(c->s.phase));
  return c->s.phase == TL_BROKEN ? fmi3Error : settle(c, fmi2Error);
}

static fmi3Status fail(TlInstance* c, const char* format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static fmi3Status fail(TlInstance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  log_to(&c->host, c->logging_on, fmi2Error, format, args);
  va_end(args);
  return settle(c, fmi2Error);
}

#define IN(p) ((unsigned)1 << (p))
#define ALLOWED(call, mask)                                                \
  do {                                                                     \
    if (c == NULL) return fmi3Error;                                       \
    if (!(((unsigned)1 << c->s.phase) & (mask))) return refuse(c, call);   \
  } while (0)
#define ANY_BUT_FATAL (IN(TL_INSTANTIATED) | IN(TL_INITIALIZATION) | IN(TL_EVENT) | IN(TL_STEPPING) | IN(TL_TERMINATED))
#define SETTER_PHASES (IN(TL_INSTANTIATED) | IN(TL_INITIALIZATION) | IN(TL_EVENT) | IN(TL_STEPPING))

/* ---- Event Mode: the partition of the active clocks ------------------------------------------------------ */
static void begin_instant(TlInstance* c) { c->s.event_ran = 0; }

/* The partition, if inputs or clocks changed since it last ran in this instant. Its first run keeps the model state
   it starts from (one copy per event), so that a later change runs it again from there. */
static fmi2Status run_event(TlInstance* c) {
#if TL_HAS_EVENT_MODE
  fmi2Status status;
  if (!c->s.event_dirty) return fmi2OK;
  if (c->s.event_ran) c->s.model = c->s.pre_event; /* inputs or clocks changed: run again from the event's start */
  else c->s.pre_event = c->s.model;
  status = tl_model_event(c, c->s.time);
  c->s.event_ran = 1;
  c->s.event_dirty = 0;
  return status;
#else
  (void)c;
  return fmi2OK;
#endif
}

/* ---- information and life cycle ------------------------------------------------------------------------ */
const char* fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean on, size_t n, const fmi3String categories[]) {
  TlInstance* c = (TlInstance*)instance;
  (void)n; (void)categories;
  ALLOWED("fmi3SetDebugLogging", ANY_BUT_FATAL);
  c->logging_on = on ? fmi2True : fmi2False;
  return fmi3OK;
}

/* FMI 3.0 gives the resources folder as a native path already (2_3: "absolute file path with a trailing file
   separator"); kept as given, with the separator added if an importer left it off. NULL for none. */
static char* resource_path(const char* path) {
#if defined(_WIN32)
  const char separator = '\\';
#else
  const char separator = '/';
#endif
  size_t n;
  char* out;
  if (path == NULL || path[0] == '\0') return NULL;
  n = strlen(path);
  out = (char*)malloc(n + 2);
  if (out == NULL) return NULL;
  memcpy(out, path, n);
  if (out[n - 1] != '/' && out[n - 1] != '\\') out[n++] = separator;
  out[n] = '\0';
  return out;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
                                         fmi3Boolean logging_on, fmi3Boolean event_mode_used, fmi3Boolean early_return_allowed,
                                         const fmi3ValueReference required_intermediate[], size_t n_required_intermediate,
                                         fmi3InstanceEnvironment environment, fmi3LogMessageCallback log_message,
                                         fmi3IntermediateUpdateCallback intermediate_update) {
  TlHost host;
  TlInstance* c;
  size_t n;
  (void)visible; (void)early_return_allowed; (void)required_intermediate; (void)intermediate_update;
  host.environment = environment;
  host.log_message = log_message;
  if (name == NULL || strspn(name, " \t\r\n") == strlen(name)) {
    log_host(&host, "fmi3InstantiateCoSimulation: the instance name is empty");
    return NULL;
  }
  if (token == NULL || strcmp(token, TL_GUID) != 0) {
    log_host(&host, "fmi3InstantiateCoSimulation: %s: instantiation token %s does not match this binary's %s "
             "(modelDescription.xml from another build?)", name, token ? token : "(null)", TL_GUID);
    return NULL;
  }
  if (event_mode_used && !TL_HAS_EVENT_MODE) {
    log_host(&host, "fmi3InstantiateCoSimulation: %s: %s has no Event Mode (hasEventMode=\"false\"): eventModeUsed must be "
             "false", name, TL_MODEL_IDENTIFIER);
    return NULL;
  }
  if (!event_mode_used && TL_N_CLOCK > 0) {
    log_host(&host, "fmi3InstantiateCoSimulation: %s: %s has clocks, which need Event Mode: eventModeUsed must be true "
             "(or use the plain variant without clocks)", name, TL_MODEL_IDENTIFIER);
    return NULL;
  }
  if (n_required_intermediate > 0) {
    log_host(&host, "fmi3InstantiateCoSimulation: %s: %s provides no intermediate update (requiredIntermediateVariables "
             "must be empty)", name, TL_MODEL_IDENTIFIER);
    return NULL;
  }
  c = (TlInstance*)calloc(1, sizeof(TlInstance));
  if (c == NULL) return NULL;
  n = strlen(name) + 1;
  c->name = (char*)malloc(n);
  if (c->name == NULL) {
    free(c);
    return NULL;
  }
  memcpy(c->name, name, n);
  c->host = host;
  c->logging_on = logging_on ? fmi2True : fmi2False;
  c->event_mode_used = event_mode_used ? 1 : 0;
  c->resources = resource_path(resources);
  tl_log(c, fmi2OK, "fmi3InstantiateCoSimulation: resources in %s", c->resources ? c->resources : "(none given)");
  tl_load_start_values(c);
  return c;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
                                          fmi3Boolean logging_on, fmi3InstanceEnvironment environment,
                                          fmi3LogMessageCallback log_message) {
  TlHost host;
  (void)token; (void)resources; (void)visible; (void)logging_on;
  host.environment = environment;
  host.log_message = log_message;
  log_host(&host, "fmi3InstantiateModelExchange: %s: %s is a co-simulation FMU only", name ? name : "?", TL_MODEL_IDENTIFIER);
  return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
                                               fmi3Boolean logging_on, fmi3InstanceEnvironment environment,
                                               fmi3LogMessageCallback log_message, fmi3ClockUpdateCallback clock_update,
                                               fmi3LockPreemptionCallback lock, fmi3UnlockPreemptionCallback unlock) {
  TlHost host;
  (void)token; (void)resources; (void)visible; (void)logging_on; (void)clock_update; (void)lock; (void)unlock;
  host.environment = environment;
  host.log_message = log_message;
  log_host(&host, "fmi3InstantiateScheduledExecution: %s: %s is a co-simulation FMU only", name ? name : "?",
           TL_MODEL_IDENTIFIER);
  return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
  TlInstance* c = (TlInstance*)instance;
  if (c == NULL) return;
  free(c->resources);
  free(c->name);
  free(c);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean tolerance_defined, fmi3Float64 tolerance,
                                       fmi3Float64 start_time, fmi3Boolean stop_time_defined, fmi3Float64 stop_time) {
  TlInstance* c = (TlInstance*)instance;
  (void)tolerance_defined; (void)tolerance;
  ALLOWED("fmi3EnterInitializationMode", IN(TL_INSTANTIATED));
  if (!isfinite(start_time)) return fail(c, "fmi3EnterInitializationMode: start time %g is not finite", start_time);
  if (stop_time_defined && !(stop_time >= start_time))
    return fail(c, "fmi3EnterInitializationMode: stop time %g s is before the start time %g s", stop_time, start_time);
  c->s.time = c->s.start_time = start_time;
  c->s.stop_time = stop_time_defined ? stop_time : INFINITY;
  c->s.phase = TL_INITIALIZATION;
  return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
  TlInstance* c = (TlInstance*)instance;
  fmi2Status status;
  ALLOWED("fmi3ExitInitializationMode", IN(TL_INITIALIZATION));
  status = tl_model_initialize(c);
  if (status <= fmi2Warning) {
    c->s.phase = c->event_mode_used ? TL_EVENT : TL_STEPPING; /* the initial event at the start time, clocks inactive */
    c->s.event_dirty = 1;
    begin_instant(c);
  }
  return settle(c, status == fmi2Discard ? fmi2Error : status);
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi3EnterEventMode", IN(TL_STEPPING));
  if (!c->event_mode_used) return fail(c, "fmi3EnterEventMode: the instance was created with eventModeUsed = false");
  c->s.phase = TL_EVENT;
  c->s.event_dirty = 1;
  begin_instant(c);
  return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi3Terminate", IN(TL_EVENT) | IN(TL_STEPPING));
  c->s.phase = TL_TERMINATED;
  return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi3Reset", ANY_BUT_FATAL);
  tl_load_start_values(c);
  return fmi3OK;
}

/* ---- variables ------------------------------------------------------------------------------------------- */
/* The index of vr among the variables of one type (base: its first value reference), or -1 with a log line. */
static int index_of(TlInstance* c, const char* call, fmi3ValueReference vr, unsigned base, int count, const char* type) {
  if (vr >= base && vr - base < (unsigned)count) return (int)(vr - base);
  tl_log(c, fmi2Error, "%s: value reference %u is not a %s variable of %s", call, vr, type, TL_MODEL_IDENTIFIER);
  return -1;
}

/* May a variable with this clock (-1: none) be read or written now? Logs why not. */
static int clock_allows(TlInstance* c, const char* call, const char* name, int clock) {
  if (clock < 0 || c->s.phase == TL_INSTANTIATED || c->s.phase == TL_INITIALIZATION || c->s.phase == TL_TERMINATED) return 1;
#if TL_HAS_EVENT_MODE
  if (c->s.phase == TL_EVENT && c->s.clock_active[clock]) return 1;
  tl_log(c, fmi2Error, "%s: %s is clocked by %s, which is not active (%s)", call, name, tl_clock_name[clock],
         c->s.phase == TL_EVENT ? "activate it with fmi3SetClock first" : "clocked variables are accessible in Event Mode only");
#else
  (void)call; (void)name;
#endif
  return 0;
}

/* A Set: may this variable be written now (causality, clock, discrete inputs in Event Mode only)? */
static int may_write(TlInstance* c, const char* call, unsigned char settable, const char* name, int clock, int discrete) {
  if (!tl_may_set(c, call, settable, name) || !clock_allows(c, call, name, clock)) return 0;
  if (settable == 2 && discrete && clock < 0 && c->event_mode_used && c->s.phase == TL_STEPPING) {
    tl_log(c, fmi2Error, "%s: %s is a discrete input: with Event Mode it changes in Event Mode only", call, name);
    return 0;
  }
  return 1;
}

/* Before a Get: outputs computed for initialization, or this event's partition. */
static fmi2Status prepare_get(TlInstance* c) {
  if (c->s.phase == TL_INITIALIZATION) return tl_model_outputs(c);
  if (c->s.phase == TL_EVENT) return run_event(c);
  return fmi2OK;
}

static fmi3Status check_counts(TlInstance* c, const char* call, size_t n, const void* vr, size_t n_values, const void* values) {
  if (n && (vr == NULL || values == NULL)) return fail(c, "%s: no value references or values given", call);
  if (n_values != n) return fail(c, "%s: %lu values for %lu scalar variables", call, (unsigned long)n_values, (unsigned long)n);
  return fmi3OK;
}

#define GET_PROLOGUE(call)                                                 \
  TlInstance* c = (TlInstance*)instance;                                   \
  size_t i;                                                                \
  ALLOWED(call, ANY_BUT_FATAL);                                            \
  if (check_counts(c, call, n, vr, n_values, value) != fmi3OK) return fmi3Error; \
  if (prepare_get(c) > fmi2Warning) return settle(c, fmi2Error)

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3Float64 value[], size_t n_values) {
  GET_PROLOGUE("fmi3GetFloat64");
  for (i = 0; i < n; ++i) {
    int k;
    if (vr[i] == TL_VR_TIME) {
      value[i] = c->s.time;
      continue;
    }
    k = index_of(c, "fmi3GetFloat64", vr[i], TL_VR_REAL0, TL_N_REAL, "Float64");
    if (k < 0 || !clock_allows(c, "fmi3GetFloat64", tl_real_name[k], tl_real_clock[k])) return settle(c, fmi2Error);
    value[i] = c->s.real[k];
  }
  return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3Int32 value[], size_t n_values) {
  GET_PROLOGUE("fmi3GetInt32");
  for (i = 0; i < n; ++i) {
    int k = index_of(c, "fmi3GetInt32", vr[i], TL_VR_INTEGER0, TL_N_INTEGER, "Int32");
    if (k < 0 || !clock_allows(c, "fmi3GetInt32", tl_integer_name[k], tl_integer_clock[k])) return settle(c, fmi2Error);
    value[i] = (fmi3Int32)c->s.integer[k];
  }
  return fmi3OK;
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3Boolean value[], size_t n_values) {
  GET_PROLOGUE("fmi3GetBoolean");
  for (i = 0; i < n; ++i) {
    int k = index_of(c, "fmi3GetBoolean", vr[i], TL_VR_BOOLEAN0, TL_N_BOOLEAN, "Boolean");
    if (k < 0 || !clock_allows(c, "fmi3GetBoolean", tl_boolean_name[k], tl_boolean_clock[k])) return settle(c, fmi2Error);
    value[i] = c->s.boolean[k] ? fmi3True : fmi3False;
  }
  return fmi3OK;
}

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3String value[], size_t n_values) {
  GET_PROLOGUE("fmi3GetString");
  for (i = 0; i < n; ++i) {
    int k = index_of(c, "fmi3GetString", vr[i], TL_VR_STRING0, TL_N_STRING, "String");
    if (k < 0) return settle(c, fmi2Error);
    value[i] = c->s.string[k];
  }
  return fmi3OK;
}

#define SET_PROLOGUE(call)                                                 \
  TlInstance* c = (TlInstance*)instance;                                   \
  size_t i;                                                                \
  ALLOWED(call, SETTER_PHASES);                                            \
  if (check_counts(c, call, n, vr, n_values, value) != fmi3OK) return fmi3Error

/* An input set in Event Mode changes this event's partition. */
static void written(TlInstance* c, size_t n) {
  if (n && c->s.phase == TL_EVENT) c->s.event_dirty = 1;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Float64 value[],
                          size_t n_values) {
  SET_PROLOGUE("fmi3SetFloat64");
  for (i = 0; i < n; ++i) { /* check all first: a refused call changes nothing */
    int k = index_of(c, "fmi3SetFloat64", vr[i], TL_VR_REAL0, TL_N_REAL, "settable Float64");
    if (k < 0 || !may_write(c, "fmi3SetFloat64", tl_real_settable[k], tl_real_name[k], tl_real_clock[k], tl_real_discrete[k]) ||
        tl_real_refused(c, k, value[i]))
      return settle(c, fmi2Error);
  }
  for (i = 0; i < n; ++i) c->s.real[vr[i] - TL_VR_REAL0] = value[i];
  written(c, n);
  return fmi3OK;
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Int32 value[], size_t n_values) {
  SET_PROLOGUE("fmi3SetInt32");
  for (i = 0; i < n; ++i) {
    int k = index_of(c, "fmi3SetInt32", vr[i], TL_VR_INTEGER0, TL_N_INTEGER, "Int32");
    if (k < 0 || !may_write(c, "fmi3SetInt32", tl_integer_settable[k], tl_integer_name[k], tl_integer_clock[k],
                            tl_integer_discrete[k]))
      return settle(c, fmi2Error);
  }
  for (i = 0; i < n; ++i) c->s.integer[vr[i] - TL_VR_INTEGER0] = value[i];
  written(c, n);
  return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Boolean value[],
                          size_t n_values) {
  SET_PROLOGUE("fmi3SetBoolean");
  for (i = 0; i < n; ++i) {
    int k = index_of(c, "fmi3SetBoolean", vr[i], TL_VR_BOOLEAN0, TL_N_BOOLEAN, "Boolean");
    if (k < 0 || !may_write(c, "fmi3SetBoolean", tl_boolean_settable[k], tl_boolean_name[k], tl_boolean_clock[k],
                            tl_boolean_discrete[k]))
      return settle(c, fmi2Error);
  }
  for (i = 0; i < n; ++i) c->s.boolean[vr[i] - TL_VR_BOOLEAN0] = value[i] ? fmi2True : fmi2False;
  written(c, n);
  return fmi3OK;
}

fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3String value[], size_t n_values) {
  SET_PROLOGUE("fmi3SetString");
  for (i = 0; i < n; ++i) {
    int k = index_of(c, "fmi3SetString", vr[i], TL_VR_STRING0, TL_N_STRING, "String");
    if (k < 0 || !tl_may_set(c, "fmi3SetString", tl_string_settable[k], tl_string_name[k]) ||
        tl_string_refused(c, "fmi3SetString", k, value[i]))
      return settle(c, fmi2Error);
  }
  for (i = 0; i < n; ++i) {
    char* to = c->s.string[vr[i] - TL_VR_STRING0];
    memset(to, 0, TL_STRING_LEN);
    memcpy(to, value[i], strlen(value[i]));
  }
  written(c, n);
  return fmi3OK;
}

/* The types no tiltload FMU has: an empty call is fine, any value reference is unknown. */
#define NO_SUCH_TYPE(kind, ctype, qualifier)                                                                  \
  fmi3Status fmi3##kind(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, qualifier ctype value[], \
                        size_t n_values) {                                                                    \
    TlInstance* c = (TlInstance*)instance;                                                                    \
    (void)value; (void)n_values;                                                                              \
    ALLOWED("fmi3" #kind, ANY_BUT_FATAL);                                                                     \
    if (n == 0) return fmi3OK;                                                                                \
    return fail(c, "fmi3" #kind ": value reference %u: %s has no variable of this type", vr ? vr[0] : 0u,     \
                TL_MODEL_IDENTIFIER);                                                                         \
  }
#define NOTHING
NO_SUCH_TYPE(GetFloat32, fmi3Float32, NOTHING)
NO_SUCH_TYPE(GetInt8, fmi3Int8, NOTHING)
NO_SUCH_TYPE(GetUInt8, fmi3UInt8, NOTHING)
NO_SUCH_TYPE(GetInt16, fmi3Int16, NOTHING)
NO_SUCH_TYPE(GetUInt16, fmi3UInt16, NOTHING)
NO_SUCH_TYPE(GetUInt32, fmi3UInt32, NOTHING)
NO_SUCH_TYPE(GetInt64, fmi3Int64, NOTHING)
NO_SUCH_TYPE(GetUInt64, fmi3UInt64, NOTHING)
NO_SUCH_TYPE(SetFloat32, fmi3Float32, const)
NO_SUCH_TYPE(SetInt8, fmi3Int8, const)
NO_SUCH_TYPE(SetUInt8, fmi3UInt8, const)
NO_SUCH_TYPE(SetInt16, fmi3Int16, const)
NO_SUCH_TYPE(SetUInt16, fmi3UInt16, const)
NO_SUCH_TYPE(SetUInt32, fmi3UInt32, const)
NO_SUCH_TYPE(SetInt64, fmi3Int64, const)
NO_SUCH_TYPE(SetUInt64, fmi3UInt64, const)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, size_t sizes[], fmi3Binary value[],
                         size_t n_values) {
  TlInstance* c = (TlInstance*)instance;
  (void)sizes; (void)value; (void)n_values;
  ALLOWED("fmi3GetBinary", ANY_BUT_FATAL);
  if (n == 0) return fmi3OK;
  return fail(c, "fmi3GetBinary: value reference %u: %s has no Binary variable", vr ? vr[0] : 0u, TL_MODEL_IDENTIFIER);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const size_t sizes[],
                         const fmi3Binary value[], size_t n_values) {
  TlInstance* c = (TlInstance*)instance;
  (void)sizes; (void)value; (void)n_values;
  ALLOWED("fmi3SetBinary", SETTER_PHASES);
  if (n == 0) return fmi3OK;
  return fail(c, "fmi3SetBinary: value reference %u: %s has no Binary variable", vr ? vr[0] : 0u, TL_MODEL_IDENTIFIER);
}

/* ---- clocks ------------------------------------------------------------------------------------------------ */
static int clock_of(TlInstance* c, const char* call, fmi3ValueReference vr) {
  const long k = (long)vr - TL_VR_CLOCK0, n = TL_N_CLOCK;
  if (k >= 0 && k < n) return (int)k;
  tl_log(c, fmi2Error, "%s: value reference %u is not a clock of %s (it has %d)", call, vr, TL_MODEL_IDENTIFIER, TL_N_CLOCK);
  return -1;
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Clock value[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi3SetClock", IN(TL_EVENT));
  if (n && (vr == NULL || value == NULL)) return fail(c, "fmi3SetClock: no value references or values given");
  for (i = 0; i < n; ++i) {
    int k = clock_of(c, "fmi3SetClock", vr[i]);
    if (k < 0) return settle(c, fmi2Error);
#if TL_HAS_EVENT_MODE
    if (!value[i] && c->s.clock_active[k])
      return fail(c, "fmi3SetClock: %s cannot be deactivated (canBeDeactivated is false)", tl_clock_name[k]);
#endif
  }
#if TL_HAS_EVENT_MODE
  for (i = 0; i < n; ++i) {
    int k = (int)(vr[i] - TL_VR_CLOCK0);
    if (value[i] && !c->s.clock_active[k]) {
      c->s.clock_active[k] = 1;
      c->s.event_dirty = 1;
    }
  }
#endif
  return fmi3OK;
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3Clock value[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi3GetClock", IN(TL_EVENT));
  if (n && (vr == NULL || value == NULL)) return fail(c, "fmi3GetClock: no value references or values given");
  for (i = 0; i < n; ++i) {
    int k = clock_of(c, "fmi3GetClock", vr[i]);
    if (k < 0) return settle(c, fmi2Error);
    value[i] = c->s.clock_active[k] ? fmi3ClockActive : fmi3ClockInactive;
  }
  return fmi3OK;
}

#define CLOCK_QUERY_PHASES (IN(TL_INITIALIZATION) | IN(TL_EVENT))

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3Float64 interval[],
                                  fmi3IntervalQualifier qualifier[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi3GetIntervalDecimal", CLOCK_QUERY_PHASES);
  if (n && (vr == NULL || interval == NULL || qualifier == NULL)) return fail(c, "fmi3GetIntervalDecimal: missing arrays");
  for (i = 0; i < n; ++i) {
    int k = clock_of(c, "fmi3GetIntervalDecimal", vr[i]);
    if (k < 0) return settle(c, fmi2Error);
    interval[i] = tl_clock_interval[k];
    qualifier[i] = fmi3IntervalUnchanged; /* constant clocks: the interval of modelDescription.xml */
  }
  return fmi3OK;
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3UInt64 counter[],
                                   fmi3UInt64 resolution[], fmi3IntervalQualifier qualifier[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi3GetIntervalFraction", CLOCK_QUERY_PHASES);
  if (n && (vr == NULL || counter == NULL || resolution == NULL || qualifier == NULL))
    return fail(c, "fmi3GetIntervalFraction: missing arrays");
  for (i = 0; i < n; ++i) {
    int k = clock_of(c, "fmi3GetIntervalFraction", vr[i]);
    if (k < 0) return settle(c, fmi2Error);
    counter[i] = tl_clock_counter[k];
    resolution[i] = tl_clock_resolution[k];
    qualifier[i] = fmi3IntervalUnchanged;
  }
  return fmi3OK;
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3Float64 shift[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi3GetShiftDecimal", CLOCK_QUERY_PHASES);
  if (n && (vr == NULL || shift == NULL)) return fail(c, "fmi3GetShiftDecimal: missing arrays");
  for (i = 0; i < n; ++i) {
    if (clock_of(c, "fmi3GetShiftDecimal", vr[i]) < 0) return settle(c, fmi2Error);
    shift[i] = 0.0;
  }
  return fmi3OK;
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3UInt64 counter[],
                                fmi3UInt64 resolution[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi3GetShiftFraction", CLOCK_QUERY_PHASES);
  if (n && (vr == NULL || counter == NULL || resolution == NULL)) return fail(c, "fmi3GetShiftFraction: missing arrays");
  for (i = 0; i < n; ++i) {
    int k = clock_of(c, "fmi3GetShiftFraction", vr[i]);
    if (k < 0) return settle(c, fmi2Error);
    counter[i] = 0;
    resolution[i] = tl_clock_resolution[k];
  }
  return fmi3OK;
}

static fmi3Status constant_clock(TlInstance* c, const char* call) {
  if (c == NULL) return fmi3Error;
  return fail(c, "%s: the clocks of %s are constant (intervalVariability=\"constant\"): nothing to set", call, TL_MODEL_IDENTIFIER);
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Float64 interval[]) {
  (void)vr; (void)n; (void)interval;
  return constant_clock((TlInstance*)instance, "fmi3SetIntervalDecimal");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 counter[],
                                   const fmi3UInt64 resolution[]) {
  (void)vr; (void)n; (void)counter; (void)resolution;
  return constant_clock((TlInstance*)instance, "fmi3SetIntervalFraction");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Float64 shift[]) {
  (void)vr; (void)n; (void)shift;
  return constant_clock((TlInstance*)instance, "fmi3SetShiftDecimal");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 counter[],
                                const fmi3UInt64 resolution[]) {
  (void)vr; (void)n; (void)counter; (void)resolution;
  return constant_clock((TlInstance*)instance, "fmi3SetShiftFraction");
}

/* ---- Event Mode and stepping ------------------------------------------------------------------------------ */
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean* need_update, fmi3Boolean* terminate,
                                    fmi3Boolean* nominals_changed, fmi3Boolean* values_changed, fmi3Boolean* next_defined,
                                    fmi3Float64* next_time) {
  TlInstance* c = (TlInstance*)instance;
  fmi2Status status;
  ALLOWED("fmi3UpdateDiscreteStates", IN(TL_EVENT));
  if (!need_update || !terminate || !nominals_changed || !values_changed || !next_defined || !next_time)
    return fail(c, "fmi3UpdateDiscreteStates: an output argument is NULL");
  status = run_event(c);
  if (status > fmi2Warning) return settle(c, status == fmi2Discard ? fmi2Error : status);
  memset(c->s.clock_active, 0, sizeof c->s.clock_active); /* the clocks' ticks are over: a new super-dense instant */
  begin_instant(c);
  *need_update = fmi3False; /* the partitions have no iteration of their own */
  *terminate = c->s.stop_requested ? fmi3True : fmi3False;
  *nominals_changed = *values_changed = fmi3False;
  *next_defined = c->s.next_event_time >= 0.0 ? fmi3True : fmi3False;
  *next_time = c->s.next_event_time >= 0.0 ? c->s.next_event_time : 0.0;
  return (fmi3Status)status;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
  TlInstance* c = (TlInstance*)instance;
  fmi2Status status;
  ALLOWED("fmi3EnterStepMode", IN(TL_EVENT));
  status = run_event(c); /* an event left without fmi3UpdateDiscreteStates still runs its partition */
  if (status > fmi2Warning) return settle(c, status == fmi2Discard ? fmi2Error : status);
  memset(c->s.clock_active, 0, sizeof c->s.clock_active);
  c->s.phase = TL_STEPPING;
  return (fmi3Status)status;
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 t, fmi3Float64 h, fmi3Boolean no_set_prior, fmi3Boolean* event_needed,
                      fmi3Boolean* terminate, fmi3Boolean* early_return, fmi3Float64* last_time) {
  TlInstance* c = (TlInstance*)instance;
  fmi2Status status;
  double end;
  (void)no_set_prior;
  ALLOWED("fmi3DoStep", IN(TL_STEPPING));
  if (!event_needed || !terminate || !early_return || !last_time) return fail(c, "fmi3DoStep: an output argument is NULL");
  if (!(isfinite(h) && h > 0.0)) return fail(c, "fmi3DoStep: communication step %g s must be positive and finite", h);
  if (!isfinite(t) || fabs(t - c->s.time) > 1e-6 * h)
    return fail(c, "fmi3DoStep: called at t=%.9g s but the FMU is at t=%.9g s (steps must follow each other)", t, c->s.time);
  end = t + h;
  if (end > c->s.stop_time + 1e-9 * h)
    return fail(c, "fmi3DoStep: the step to t=%.9g s goes beyond the stop time %.9g s", end, c->s.stop_time);
  *early_return = fmi3False;
  status = tl_model_step(c, t, h);
  if (status <= fmi2Warning) c->s.time = end;
  *last_time = c->s.time;
  *terminate = c->s.stop_requested ? fmi3True : fmi3False;
  /* a time event the model asked for, reached by this step: the importer enters Event Mode at last_time */
  *event_needed = c->event_mode_used && c->s.next_event_time >= 0.0 && c->s.time >= c->s.next_event_time - 1e-9 * h;
  return settle(c, status);
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3Int32 order[],
                                    fmi3Float64 value[], size_t n_values) {
  TlInstance* c = (TlInstance*)instance;
  (void)vr; (void)n; (void)order; (void)value; (void)n_values;
  ALLOWED("fmi3GetOutputDerivatives", ANY_BUT_FATAL);
  return fail(c, "fmi3GetOutputDerivatives: %s provides no output derivatives (maxOutputDerivativeOrder=0)", TL_MODEL_IDENTIFIER);
}

/* ---- state snapshots ---------------------------------------------------------------------------------------- */
fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState* state) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi3GetFMUState", ANY_BUT_FATAL);
  if (state == NULL) return fail(c, "fmi3GetFMUState: no place for the state given");
  if (*state == NULL) {
    *state = malloc(sizeof(TlState));
    if (*state == NULL) return fail(c, "fmi3GetFMUState: out of memory");
  }
  memcpy(*state, &c->s, sizeof(TlState));
  return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState state) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi3SetFMUState", ANY_BUT_FATAL);
  if (state == NULL) return fail(c, "fmi3SetFMUState: no state given");
  memcpy(&c->s, state, sizeof(TlState));
  return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState* state) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi3FreeFMUState", ANY_BUT_FATAL);
  if (state == NULL) return fmi3OK;
  free(*state);
  *state = NULL;
  return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState state, size_t* size) {
  TlInstance* c = (TlInstance*)instance;
  (void)state;
  ALLOWED("fmi3SerializedFMUStateSize", ANY_BUT_FATAL);
  if (size == NULL) return fail(c, "fmi3SerializedFMUStateSize: no place for the size given");
  *size = tl_serial_size();
  return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState state, fmi3Byte bytes[], size_t size) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi3SerializeFMUState", ANY_BUT_FATAL);
  if (state == NULL || bytes == NULL || size < tl_serial_size())
    return fail(c, "fmi3SerializeFMUState: needs a state and %lu bytes", (unsigned long)tl_serial_size());
  tl_serialize((const TlState*)state, (unsigned char*)bytes);
  return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte bytes[], size_t size, fmi3FMUState* state) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi3DeserializeFMUState", ANY_BUT_FATAL);
  if (state == NULL || !tl_is_serial_of_this_build((const unsigned char*)bytes, size))
    return fail(c, "fmi3DeserializeFMUState: the bytes are not a state of this %s build", TL_MODEL_IDENTIFIER);
  if (*state == NULL) *state = malloc(sizeof(TlState));
  if (*state == NULL) return fail(c, "fmi3DeserializeFMUState: out of memory");
  tl_deserialize((const unsigned char*)bytes, (TlState*)*state);
  return fmi3OK;
}

/* ---- what a tiltload FMU does not provide: a reason, fmi3Error ------------------------------------------------ */
static fmi3Status unsupported(fmi3Instance instance, const char* call, const char* why) {
  TlInstance* c = (TlInstance*)instance;
  if (c == NULL) return fmi3Error;
  if (c->s.phase == TL_BROKEN) return fmi3Error;
  return fail(c, "%s is not supported by %s: %s", call, TL_MODEL_IDENTIFIER, why);
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

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clock, fmi3Float64 time) {
  (void)clock; (void)time;
  return unsupported(instance, "fmi3ActivateModelPartition", "it is not a scheduled-execution FMU");
}
