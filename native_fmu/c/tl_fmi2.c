/* The FMI 2.0 co-simulation API, written once for every tiltload native FMU.

   Compiled per FMU with that FMU's generated tl_model.h / tl_model_tables.c and its model
   hooks (tl_fmu.h). The layer checks every call against the FMI 2.0 state machine and the
   variables' causality, refuses non-finite Reals, and turns the hooks' results into statuses:
   fmi2Error puts the instance in an error state (get, reset, terminate and free remain),
   fmi2Discard refuses one step and keeps the state, fmi2Fatal marks the instance unusable. */
#include "tl_platform.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "tl_core.h"
#include "tl_fmu.h"

#define TL_SERIAL_SIZE tl_serial_size()

/* Format, escape '%' (hosts may treat the message as a printf format) and hand to the host's logger. */
static void log_to(const fmi2CallbackFunctions* host, const char* name, fmi2Boolean logging_on, fmi2Status status,
                   const char* format, va_list args) {
  char text[1024], escaped[2048];
  size_t i, j = 0;
  if (host == NULL || host->logger == NULL) return;
  if (status < fmi2Discard && !logging_on) return;
  vsnprintf(text, sizeof text, format, args);
  for (i = 0; text[i] != '\0' && j + 2 < sizeof escaped; ++i) {
    if (text[i] == '%') escaped[j++] = '%';
    escaped[j++] = text[i];
  }
  escaped[j] = '\0';
  host->logger(host->componentEnvironment, name, status,
               status >= fmi2Error ? "logStatusError" : status == fmi2Discard ? "logStatusDiscard" : "logEvents", escaped);
}

void tl_log(const TlInstance* c, fmi2Status status, const char* format, ...) {
  va_list args;
  if (c == NULL) return;
  va_start(args, format);
  log_to(&c->host, c->name, c->logging_on, status, format, args);
  va_end(args);
}

/* Before an instance exists (fmi2Instantiate refusing): log through the callbacks given. */
static void log_host(const fmi2CallbackFunctions* host, const char* name, const char* format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static void log_host(const fmi2CallbackFunctions* host, const char* name, const char* format, ...) {
  va_list args;
  va_start(args, format);
  log_to(host, name, fmi2True, fmi2Error, format, args);
  va_end(args);
}

/* The result of a call: an error or fatal status moves the instance into its error phases. */
static fmi2Status settle(TlInstance* c, fmi2Status status) {
  if (status == fmi2Fatal) c->s.phase = TL_BROKEN;
  else if (status == fmi2Error) c->s.phase = TL_ERRORED;
  return status;
}

static fmi2Status refuse(TlInstance* c, const char* call) {
  tl_log(c, fmi2Error, "%s is not allowed in %s", call, tl_phase_name(c->s.phase));
  return c->s.phase == TL_BROKEN ? fmi2Error : settle(c, fmi2Error);
}

#define ALLOWED(call, mask)                                         \
  do {                                                              \
    if (c == NULL) return fmi2Error;                                \
    if (!(((unsigned)1 << c->s.phase) & (mask))) return refuse(c, call); \
  } while (0)
#define IN(p) ((unsigned)1 << (p))
#define ANY_BUT_FATAL (IN(TL_INSTANTIATED) | IN(TL_INITIALIZATION) | IN(TL_STEPPING) | IN(TL_TERMINATED) | IN(TL_ERRORED))

/* The fmuResourceLocation URI as a path the C library opens: file:///C:/a%20b/resources (RFC 8089),
   file:/C:/..., file://localhost/..., file://C:/... (a common slip), a UNC host on Windows, or a bare
   path as some importers pass one; percent-escapes decoded, backslashes taken as separators on Windows.
   Always ends in a separator. NULL when there is no such location (then a model has no resources). */
static int hex_digit(char c) {
  return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
}

static int is_drive(const char* p) {
  return ((p[0] >= 'A' && p[0] <= 'Z') || (p[0] >= 'a' && p[0] <= 'z')) && (p[1] == ':' || p[1] == '|') &&
         (p[2] == '/' || p[2] == '\\' || p[2] == '\0');
}

static int same_letters(const char* a, const char* b, size_t n) {
  size_t i;
  for (i = 0; i < n; ++i) {
    char x = a[i] >= 'A' && a[i] <= 'Z' ? (char)(a[i] - 'A' + 'a') : a[i];
    if (x != b[i]) return 0;
  }
  return 1;
}

static char* resource_path(const fmi2CallbackFunctions* host, const char* uri) {
#if defined(_WIN32)
  const char separator = '\\';
#else
  const char separator = '/';
#endif
  const char *p = uri, *host_name = NULL;
  size_t host_len = 0, n, i, j = 0;
  char* out;
  if (uri == NULL || uri[0] == '\0') return NULL;
  if (same_letters(p, "file:", 5)) {
    p += 5;
    if (p[0] == '/' && p[1] == '/') { /* an authority: empty, localhost, a drive by mistake, or a host */
      const char* end;
      p += 2;
      end = p + strcspn(p, "/\\");
      if (is_drive(p)) {
        /* file://C:/dir: the drive is the path's start */
      } else {
        if (end - p != 0 && !((size_t)(end - p) == 9 && same_letters(p, "localhost", 9))) {
          host_name = p;
          host_len = (size_t)(end - p);
        }
        p = end;
      }
    }
  } else {
    size_t k = 0; /* another scheme (http:, ...) is nothing the C library opens; a drive letter is no scheme */
    while ((p[k] >= 'a' && p[k] <= 'z') || (p[k] >= 'A' && p[k] <= 'Z') || (k > 0 && ((p[k] >= '0' && p[k] <= '9') ||
                                                                                     p[k] == '+' || p[k] == '-' || p[k] == '.')))
      ++k;
    if (k > 1 && p[k] == ':') return NULL;
  }
#if defined(_WIN32)
  if (p[0] == '/' && is_drive(p + 1)) ++p; /* /C:/dir -> C:/dir */
#else
  if (host_name != NULL) return NULL; /* file://server/share: only Windows opens it */
#endif
  n = strlen(p) + host_len + 4;
  out = (char*)host->allocateMemory(n, 1);
  if (out == NULL) return NULL;
  if (host_name != NULL) {
    out[j++] = separator;
    out[j++] = separator;
    memcpy(out + j, host_name, host_len);
    j += host_len;
  }
  for (i = 0; p[i] != '\0'; ++i) {
    char c = p[i];
    if (c == '%' && hex_digit(p[i + 1]) >= 0 && hex_digit(p[i + 2]) >= 0) {
      c = (char)(hex_digit(p[i + 1]) * 16 + hex_digit(p[i + 2]));
      i += 2;
    } else if (c == '?' || c == '#') {
      break; /* a query or fragment is not part of the path */
    }
#if defined(_WIN32)
    if (c == '/' || c == '\\') c = separator;
    if (c == '|' && j == 1) c = ':'; /* file:///C|/dir, the old form of a drive */
#endif
    out[j++] = c;
  }
  if (j == 0 || out[j - 1] != separator) out[j++] = separator;
  out[j] = '\0';
  return out;
}

/* ---- information and life cycle ------------------------------------------------------- */
const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component instance, fmi2Boolean on, size_t n, const fmi2String categories[]) {
  TlInstance* c = (TlInstance*)instance;
  (void)n; (void)categories;
  ALLOWED("fmi2SetDebugLogging", ANY_BUT_FATAL);
  c->logging_on = on;
  return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions* host, fmi2Boolean visible, fmi2Boolean logging_on) {
  TlInstance* c;
  size_t n;
  (void)visible;
  if (host == NULL || host->allocateMemory == NULL || host->freeMemory == NULL) return NULL;
  if (name == NULL || name[0] == '\0') {
    log_host(host, "?", "fmi2Instantiate: the instance name is empty");
    return NULL;
  }
  if (type != fmi2CoSimulation) {
    log_host(host, name, "fmi2Instantiate: %s is a co-simulation FMU only", TL_MODEL_IDENTIFIER);
    return NULL;
  }
  if (guid == NULL || strcmp(guid, TL_GUID) != 0) {
    log_host(host, name, "fmi2Instantiate: GUID %s does not match this binary's %s (modelDescription.xml from another build?)",
             guid ? guid : "(null)", TL_GUID);
    return NULL;
  }
  c = (TlInstance*)host->allocateMemory(1, sizeof(TlInstance));
  if (c == NULL) return NULL;
  memset(c, 0, sizeof *c);
  n = strlen(name) + 1;
  c->name = (char*)host->allocateMemory(n, 1);
  if (c->name == NULL) {
    host->freeMemory(c);
    return NULL;
  }
  memcpy(c->name, name, n);
  c->host = *host;
  c->logging_on = logging_on;
  c->resources = resource_path(host, resources);
  if (resources != NULL && resources[0] != '\0' && c->resources == NULL)
    tl_log(c, fmi2Warning, "fmi2Instantiate: the resource location %s is not a file this platform opens; ignored", resources);
  else
    tl_log(c, fmi2OK, "fmi2Instantiate: resources in %s", c->resources ? c->resources : "(none given)");
  tl_load_start_values(c);
  return c;
}

void fmi2FreeInstance(fmi2Component instance) {
  TlInstance* c = (TlInstance*)instance;
  fmi2CallbackFreeMemory release;
  if (c == NULL) return;
  release = c->host.freeMemory;
  if (c->resources != NULL) release(c->resources);
  release(c->name);
  release(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component instance, fmi2Boolean tolerance_defined, fmi2Real tolerance,
                               fmi2Real start_time, fmi2Boolean stop_time_defined, fmi2Real stop_time) {
  TlInstance* c = (TlInstance*)instance;
  (void)tolerance_defined; (void)tolerance; (void)stop_time_defined; (void)stop_time;
  ALLOWED("fmi2SetupExperiment", IN(TL_INSTANTIATED));
  if (!isfinite(start_time)) {
    tl_log(c, fmi2Error, "fmi2SetupExperiment: start time %g is not finite", start_time);
    return settle(c, fmi2Error);
  }
  c->s.time = c->s.start_time = start_time;
  return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component instance) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2EnterInitializationMode", IN(TL_INSTANTIATED));
  c->s.phase = TL_INITIALIZATION;
  return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component instance) {
  TlInstance* c = (TlInstance*)instance;
  fmi2Status status;
  ALLOWED("fmi2ExitInitializationMode", IN(TL_INITIALIZATION));
  status = tl_model_initialize(c);
  if (status <= fmi2Warning) c->s.phase = TL_STEPPING;
  return settle(c, status == fmi2Discard ? fmi2Error : status);
}

fmi2Status fmi2Terminate(fmi2Component instance) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2Terminate", IN(TL_INITIALIZATION) | IN(TL_STEPPING) | IN(TL_ERRORED));
  if (c->s.phase != TL_ERRORED) c->s.phase = TL_TERMINATED;
  return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component instance) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2Reset", ANY_BUT_FATAL);
  tl_load_start_values(c);
  return fmi2OK;
}

/* ---- variables -------------------------------------------------------------------------- */
static int bad_reference(TlInstance* c, const char* call, fmi2ValueReference vr, int count) {
  if (count > 0 && vr < (fmi2ValueReference)count) return 0;
  tl_log(c, fmi2Error, "%s: value reference %u does not exist (%d variables of this type)", call, vr, count);
  return 1;
}

static fmi2Status outputs_for_get(TlInstance* c) {
  return c->s.phase == TL_INITIALIZATION ? tl_model_outputs(c) : fmi2OK;
}

#define GETTER_PHASES ANY_BUT_FATAL

fmi2Status fmi2GetReal(fmi2Component instance, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi2GetReal", GETTER_PHASES);
  if (n && (vr == NULL || value == NULL)) return settle(c, fmi2Error);
  if (outputs_for_get(c) > fmi2Warning) return settle(c, fmi2Error);
  for (i = 0; i < n; ++i) {
    if (bad_reference(c, "fmi2GetReal", vr[i], TL_N_REAL)) return settle(c, fmi2Error);
    value[i] = c->s.real[vr[i]];
  }
  return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component instance, const fmi2ValueReference vr[], size_t n, fmi2Integer value[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi2GetInteger", GETTER_PHASES);
  if (n && (vr == NULL || value == NULL)) return settle(c, fmi2Error);
  for (i = 0; i < n; ++i) {
    if (bad_reference(c, "fmi2GetInteger", vr[i], TL_N_INTEGER)) return settle(c, fmi2Error);
    value[i] = c->s.integer[vr[i]];
  }
  return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component instance, const fmi2ValueReference vr[], size_t n, fmi2Boolean value[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi2GetBoolean", GETTER_PHASES);
  if (n && (vr == NULL || value == NULL)) return settle(c, fmi2Error);
  if (outputs_for_get(c) > fmi2Warning) return settle(c, fmi2Error);
  for (i = 0; i < n; ++i) {
    if (bad_reference(c, "fmi2GetBoolean", vr[i], TL_N_BOOLEAN)) return settle(c, fmi2Error);
    value[i] = c->s.boolean[vr[i]];
  }
  return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component instance, const fmi2ValueReference vr[], size_t n, fmi2String value[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi2GetString", GETTER_PHASES);
  if (n && (vr == NULL || value == NULL)) return settle(c, fmi2Error);
  for (i = 0; i < n; ++i) {
    if (bad_reference(c, "fmi2GetString", vr[i], TL_N_STRING)) return settle(c, fmi2Error);
    value[i] = c->s.string[vr[i]];
  }
  return fmi2OK;
}

#define SETTER_PHASES (IN(TL_INSTANTIATED) | IN(TL_INITIALIZATION) | IN(TL_STEPPING))

fmi2Status fmi2SetReal(fmi2Component instance, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi2SetReal", SETTER_PHASES);
  if (n && (vr == NULL || value == NULL)) return settle(c, fmi2Error);
  for (i = 0; i < n; ++i) { /* check all first: a refused call changes nothing */
    if (bad_reference(c, "fmi2SetReal", vr[i], TL_N_REAL)) return settle(c, fmi2Error);
    if (!tl_may_set(c, "fmi2SetReal", tl_real_settable[vr[i]], tl_real_name[vr[i]])) return settle(c, fmi2Error);
    if (tl_real_refused(c, (int)vr[i], value[i])) return settle(c, fmi2Error);
  }
  for (i = 0; i < n; ++i) c->s.real[vr[i]] = value[i];
  return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component instance, const fmi2ValueReference vr[], size_t n, const fmi2Integer value[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi2SetInteger", SETTER_PHASES);
  if (n && (vr == NULL || value == NULL)) return settle(c, fmi2Error);
  for (i = 0; i < n; ++i) {
    if (bad_reference(c, "fmi2SetInteger", vr[i], TL_N_INTEGER)) return settle(c, fmi2Error);
    if (!tl_may_set(c, "fmi2SetInteger", tl_integer_settable[vr[i]], tl_integer_name[vr[i]])) return settle(c, fmi2Error);
  }
  for (i = 0; i < n; ++i) c->s.integer[vr[i]] = value[i];
  return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component instance, const fmi2ValueReference vr[], size_t n, const fmi2Boolean value[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi2SetBoolean", SETTER_PHASES);
  if (n && (vr == NULL || value == NULL)) return settle(c, fmi2Error);
  for (i = 0; i < n; ++i) {
    if (bad_reference(c, "fmi2SetBoolean", vr[i], TL_N_BOOLEAN)) return settle(c, fmi2Error);
    if (!tl_may_set(c, "fmi2SetBoolean", tl_boolean_settable[vr[i]], tl_boolean_name[vr[i]])) return settle(c, fmi2Error);
  }
  for (i = 0; i < n; ++i) c->s.boolean[vr[i]] = value[i] ? fmi2True : fmi2False;
  return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component instance, const fmi2ValueReference vr[], size_t n, const fmi2String value[]) {
  TlInstance* c = (TlInstance*)instance;
  size_t i;
  ALLOWED("fmi2SetString", SETTER_PHASES);
  if (n && (vr == NULL || value == NULL)) return settle(c, fmi2Error);
  for (i = 0; i < n; ++i) {
    if (bad_reference(c, "fmi2SetString", vr[i], TL_N_STRING)) return settle(c, fmi2Error);
    if (!tl_may_set(c, "fmi2SetString", tl_string_settable[vr[i]], tl_string_name[vr[i]])) return settle(c, fmi2Error);
    if (tl_string_refused(c, "fmi2SetString", (int)vr[i], value[i])) return settle(c, fmi2Error);
  }
  for (i = 0; i < n; ++i) {
    memset(c->s.string[vr[i]], 0, TL_STRING_LEN);
    memcpy(c->s.string[vr[i]], value[i], strlen(value[i]));
  }
  return fmi2OK;
}

/* ---- stepping ----------------------------------------------------------------------------- */
fmi2Status fmi2DoStep(fmi2Component instance, fmi2Real t, fmi2Real h, fmi2Boolean no_set_prior) {
  TlInstance* c = (TlInstance*)instance;
  fmi2Status status;
  (void)no_set_prior;
  ALLOWED("fmi2DoStep", IN(TL_STEPPING));
  if (!(isfinite(h) && h > 0.0)) {
    tl_log(c, fmi2Error, "fmi2DoStep: communication step %g s must be positive and finite", h);
    return settle(c, fmi2Error);
  }
  if (!isfinite(t) || fabs(t - c->s.time) > 1e-6 * h) {
    tl_log(c, fmi2Error, "fmi2DoStep: called at t=%.9g s but the FMU is at t=%.9g s (steps must follow each other)", t, c->s.time);
    return settle(c, fmi2Error);
  }
  status = tl_model_step(c, t, h);
  if (status <= fmi2Warning) c->s.time = t + h;
  return settle(c, status);
}

fmi2Status fmi2CancelStep(fmi2Component instance) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2CancelStep", IN(TL_STEPPING));
  tl_log(c, fmi2Error, "fmi2CancelStep: steps are synchronous, there is nothing to cancel");
  return settle(c, fmi2Error);
}

fmi2Status fmi2GetStatus(fmi2Component instance, const fmi2StatusKind kind, fmi2Status* value) {
  TlInstance* c = (TlInstance*)instance;
  (void)kind; (void)value;
  ALLOWED("fmi2GetStatus", ANY_BUT_FATAL);
  return fmi2Discard; /* no asynchronous step is ever pending */
}

fmi2Status fmi2GetRealStatus(fmi2Component instance, const fmi2StatusKind kind, fmi2Real* value) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2GetRealStatus", ANY_BUT_FATAL);
  if (kind != fmi2LastSuccessfulTime || value == NULL) return fmi2Discard;
  *value = c->s.time;
  return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component instance, const fmi2StatusKind kind, fmi2Integer* value) {
  TlInstance* c = (TlInstance*)instance;
  (void)kind; (void)value;
  ALLOWED("fmi2GetIntegerStatus", ANY_BUT_FATAL);
  return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component instance, const fmi2StatusKind kind, fmi2Boolean* value) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2GetBooleanStatus", ANY_BUT_FATAL);
  if (kind != fmi2Terminated || value == NULL) return fmi2Discard;
  *value = c->s.stop_requested ? fmi2True : fmi2False; /* asked after a discarded step */
  return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component instance, const fmi2StatusKind kind, fmi2String* value) {
  TlInstance* c = (TlInstance*)instance;
  (void)kind; (void)value;
  ALLOWED("fmi2GetStringStatus", ANY_BUT_FATAL);
  return fmi2Discard;
}

static fmi2Status unsupported(TlInstance* c, const char* call) {
  if (c == NULL) return fmi2Error;
  tl_log(c, fmi2Error, "%s is not supported by %s", call, TL_MODEL_IDENTIFIER);
  return fmi2Error;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component instance, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) {
  (void)vr; (void)n; (void)order; (void)value;
  return unsupported((TlInstance*)instance, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component instance, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) {
  (void)vr; (void)n; (void)order; (void)value;
  return unsupported((TlInstance*)instance, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component instance, const fmi2ValueReference unknown[], size_t n_unknown,
                                        const fmi2ValueReference known[], size_t n_known, const fmi2Real dv_known[],
                                        fmi2Real dv_unknown[]) {
  (void)unknown; (void)n_unknown; (void)known; (void)n_known; (void)dv_known; (void)dv_unknown;
  return unsupported((TlInstance*)instance, "fmi2GetDirectionalDerivative");
}

/* ---- state snapshots ---------------------------------------------------------------------- */
fmi2Status fmi2GetFMUstate(fmi2Component instance, fmi2FMUstate* state) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2GetFMUstate", ANY_BUT_FATAL);
  if (state == NULL) return fmi2Error;
  if (*state == NULL) {
    *state = c->host.allocateMemory(1, sizeof(TlState));
    if (*state == NULL) {
      tl_log(c, fmi2Error, "fmi2GetFMUstate: out of memory");
      return fmi2Error;
    }
  }
  memcpy(*state, &c->s, sizeof(TlState));
  return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component instance, fmi2FMUstate state) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2SetFMUstate", ANY_BUT_FATAL);
  if (state == NULL) {
    tl_log(c, fmi2Error, "fmi2SetFMUstate: no state given");
    return fmi2Error;
  }
  memcpy(&c->s, state, sizeof(TlState));
  return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component instance, fmi2FMUstate* state) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2FreeFMUstate", ANY_BUT_FATAL);
  if (state == NULL) return fmi2OK;
  if (*state != NULL) c->host.freeMemory(*state);
  *state = NULL;
  return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component instance, fmi2FMUstate state, size_t* size) {
  TlInstance* c = (TlInstance*)instance;
  (void)state;
  ALLOWED("fmi2SerializedFMUstateSize", ANY_BUT_FATAL);
  if (size == NULL) return fmi2Error;
  *size = TL_SERIAL_SIZE;
  return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component instance, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2SerializeFMUstate", ANY_BUT_FATAL);
  if (state == NULL || bytes == NULL || size < TL_SERIAL_SIZE) {
    tl_log(c, fmi2Error, "fmi2SerializeFMUstate: needs a state and %lu bytes", (unsigned long)TL_SERIAL_SIZE);
    return fmi2Error;
  }
  tl_serialize((const TlState*)state, (unsigned char*)bytes);
  return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component instance, const fmi2Byte bytes[], size_t size, fmi2FMUstate* state) {
  TlInstance* c = (TlInstance*)instance;
  ALLOWED("fmi2DeSerializeFMUstate", ANY_BUT_FATAL);
  if (state == NULL || !tl_is_serial_of_this_build((const unsigned char*)bytes, size)) {
    tl_log(c, fmi2Error, "fmi2DeSerializeFMUstate: the bytes are not a state of this %s build", TL_MODEL_IDENTIFIER);
    return fmi2Error;
  }
  if (*state == NULL) *state = c->host.allocateMemory(1, sizeof(TlState));
  if (*state == NULL) return fmi2Error;
  tl_deserialize((const unsigned char*)bytes, (TlState*)*state);
  return fmi2OK;
}
