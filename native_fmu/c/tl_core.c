/* The core of the FMI layers (tl_core.h): one definition of what FMI 2.0 and FMI 3.0 share, so that an FMI 2.0 and an
   FMI 3.0 build of a model behave alike. What differs between the versions comes in through tl_binding. */
#include "tl_platform.h"

#include "tl_core.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* ---- logging ---------------------------------------------------------------------------------------------------- */
/* Format, escape the version's escape character (so hosts show the message as it is) and hand it to the host. */
static void emit(const TlHost* host, const char* instance, int logging_on, TlStatus status, const char* format, va_list args) {
  char text[1024], escaped[2048];
  size_t i, j = 0;
  if (status < TL_DISCARD && !logging_on) return; /* errors and discards always (FMI 3.0.3 allows errors with logging off) */
  vsnprintf(text, sizeof text, format, args);
  for (i = 0; text[i] != '\0' && j + 2 < sizeof escaped; ++i) {
    if (text[i] == tl_binding.message_escape) escaped[j++] = text[i];
    escaped[j++] = text[i];
  }
  escaped[j] = '\0';
  tl_binding.log(host, instance, status,
                 status >= TL_ERROR ? "logStatusError" : status == TL_DISCARD ? "logStatusDiscard" : "logEvents", escaped);
}

void tl_log(const TlInstance* c, TlStatus status, const char* format, ...) {
  va_list args;
  if (c == NULL) return;
  va_start(args, format);
  emit(&c->host, c->name, c->logging_on, status, format, args);
  va_end(args);
}

void tl_log_host(const TlHost* host, const char* instance, const char* format, ...) {
  va_list args;
  va_start(args, format);
  emit(host, instance, 1, TL_ERROR, format, args);
  va_end(args);
}

/* ---- phases and refusal ------------------------------------------------------------------------------------------- */
static const char* phase_name(int phase) {
  switch (phase) {
    case TL_INSTANTIATED: return "instantiated";
    case TL_INITIALIZATION: return "initialization mode";
    case TL_STEPPING: return "step mode";
    case TL_EVENT: return "event mode";
    case TL_ACTIVATION: return "clock activation mode";
    case TL_TERMINATED: return "terminated";
    case TL_BROKEN: return "fatal error";
    default: return "error";
  }
}

TlStatus tl_settle(TlInstance* c, TlStatus status) {
  if (status == TL_FATAL) c->s.phase = TL_BROKEN;
  else if (status == TL_ERROR) c->s.phase = tl_binding.phase_after_error;
  return status;
}

TlStatus tl_enter(TlInstance* c, const char* call, unsigned allowed) {
  if (c == NULL) return TL_ERROR;
  if (allowed & TL_IN(c->s.phase)) return TL_OK;
  tl_log(c, TL_ERROR, "%s is not allowed in %s", call, phase_name(c->s.phase));
  return c->s.phase == TL_BROKEN ? TL_ERROR : tl_settle(c, TL_ERROR);
}

TlStatus tl_fail(TlInstance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  emit(&c->host, c->name, c->logging_on, TL_ERROR, format, args);
  va_end(args);
  return tl_settle(c, TL_ERROR);
}

TlStatus tl_unsupported(TlInstance* c, const char* call, const char* why) {
  if (c == NULL || c->s.phase == TL_BROKEN) return TL_ERROR;
  return tl_fail(c, "%s is not supported by %s: %s", call, TL_MODEL_IDENTIFIER, why);
}

/* ---- life cycle ----------------------------------------------------------------------------------------------------- */
int tl_may_instantiate(const TlHost* host, const char* call, const char* name, const char* what, const char* token) {
  if (name == NULL || strspn(name, " \t\r\n") == strlen(name)) {
    tl_log_host(host, "?", "%s: the instance name is empty", call);
    return 0;
  }
  if (token == NULL || strcmp(token, TL_GUID) != 0) {
    tl_log_host(host, name, "%s: %s: %s %s does not match this binary's %s (modelDescription.xml from another build?)", call,
                name, what, token ? token : "(null)", TL_GUID);
    return 0;
  }
  return 1;
}

/* ---- resources: the importer's location as a native folder path --------------------------------------------------- */
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

/* The path part of a file URI: file:///C:/a%20b/resources (RFC 8089), file:/C:/..., file://localhost/...,
   file://C:/... (a common slip), a UNC host on Windows, or a bare path as some importers pass one. *p moves to the
   path, *host_name to a UNC host (or NULL). 0 when the C library cannot open it (another scheme; a host off Windows). */
static int uri_path(const char** p, const char** host_name, size_t* host_len) {
  if (same_letters(*p, "file:", 5)) {
    *p += 5;
    if ((*p)[0] == '/' && (*p)[1] == '/') { /* an authority: empty, localhost, a drive by mistake, or a host */
      const char* end;
      *p += 2;
      end = *p + strcspn(*p, "/\\");
      if (!is_drive(*p)) { /* file://C:/dir: the drive is the path's start */
        if (end - *p != 0 && !((size_t)(end - *p) == 9 && same_letters(*p, "localhost", 9))) {
          *host_name = *p;
          *host_len = (size_t)(end - *p);
        }
        *p = end;
      }
    }
  } else {
    const char* q = *p;
    size_t k = 0; /* another scheme (http:, ...) is nothing the C library opens; a drive letter is no scheme */
    while ((q[k] >= 'a' && q[k] <= 'z') || (q[k] >= 'A' && q[k] <= 'Z') || (k > 0 && ((q[k] >= '0' && q[k] <= '9') ||
                                                                                     q[k] == '+' || q[k] == '-' || q[k] == '.')))
      ++k;
    if (k > 1 && q[k] == ':') return 0;
  }
#if defined(_WIN32)
  if ((*p)[0] == '/' && is_drive(*p + 1)) ++*p; /* /C:/dir -> C:/dir */
  return 1;
#else
  return *host_name == NULL; /* file://server/share: only Windows opens it */
#endif
}

/* A URI's path with percent-escapes decoded (backslashes taken as separators on Windows) into out; its length. */
static size_t decode_uri_path(char* out, const char* p, const char* host_name, size_t host_len, char separator) {
  size_t i, j = 0;
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
  return j;
}

/* The resources folder as a path the C library opens, ending in a separator; NULL when there is none. A native path
   (FMI 3.0: "absolute file path with a trailing file separator") is kept as given, the separator added if left off. */
static char* resource_folder(const TlHost* host, const char* location, int is_uri) {
#if defined(_WIN32)
  const char separator = '\\';
#else
  const char separator = '/';
#endif
  const char *p = location, *host_name = NULL;
  size_t host_len = 0, j;
  char* out;
  if (location == NULL || location[0] == '\0') return NULL;
  if (is_uri && !uri_path(&p, &host_name, &host_len)) return NULL;
  out = (char*)tl_binding.allocate(host, strlen(p) + host_len + 4);
  if (out == NULL) return NULL;
  if (is_uri) {
    j = decode_uri_path(out, p, host_name, host_len, separator);
  } else {
    j = strlen(p);
    memcpy(out, p, j);
    if (out[j - 1] != '/' && out[j - 1] != '\\') out[j++] = separator;
  }
  out[j] = '\0';
  return out;
}

TlInstance* tl_create(const TlHost* host, const char* call, const char* name, int logging_on, int event_mode_used,
                      const char* location, int is_uri) {
  const size_t n = strlen(name) + 1;
  char* resources = resource_folder(host, location, is_uri);
  TlInstance* c = (TlInstance*)tl_binding.allocate(host, sizeof(TlInstance));
  if (c != NULL) c->name = (char*)tl_binding.allocate(host, n);
  if (c == NULL || c->name == NULL) {
    if (c != NULL) tl_binding.release(host, c);
    if (resources != NULL) tl_binding.release(host, resources);
    return NULL;
  }
  memcpy(c->name, name, n);
  c->host = *host;
  c->logging_on = logging_on != 0;
  c->resources = resources;
  c->event_mode_used = event_mode_used != 0;
  if (is_uri && location != NULL && location[0] != '\0' && c->resources == NULL)
    tl_log(c, TL_WARNING, "%s: the resource location %s is not a file this platform opens; ignored", call, location);
  else
    tl_log(c, TL_OK, "%s: resources in %s", call, c->resources ? c->resources : "(none given)");
  tl_reset(c);
  return c;
}

void tl_free_instance(TlInstance* c) {
  TlHost host;
  if (c == NULL) return;
  host = c->host;
  if (c->resources != NULL) tl_binding.release(&host, c->resources);
  tl_binding.release(&host, c->name);
  tl_binding.release(&host, c);
}

void tl_reset(TlInstance* c) {
  int i;
  for (i = 0; i < TL_N_REAL; ++i) c->s.real[i] = tl_real_start[i];
  for (i = 0; i < TL_N_INTEGER; ++i) c->s.integer[i] = tl_integer_start[i];
  for (i = 0; i < TL_N_BOOLEAN; ++i) c->s.boolean[i] = tl_boolean_start[i] ? 1 : 0;
#if TL_N_STRING > 0 /* GCC at -O0 warns about the copy into the placeholder array of an FMU without Strings */
  for (i = 0; i < TL_N_STRING; ++i) {
    strncpy(c->s.string[i], tl_string_start[i], TL_STRING_LEN - 1);
    c->s.string[i][TL_STRING_LEN - 1] = '\0';
  }
#endif
  c->s.time = c->s.start_time = 0.0;
  c->s.stop_time = INFINITY;
  c->s.phase = TL_INSTANTIATED;
  c->s.stop_requested = 0;
  memset(c->s.clock_active, 0, sizeof c->s.clock_active);
  c->s.event_dirty = c->s.event_ran = 0;
  c->s.next_event_time = -1.0;
#if TL_SCHEDULED
  for (i = 0; i < TL_CAP_CLOCK; ++i) c->s.activation[i] = -1;
#endif
  tl_model_reset(c);
}

void tl_set_logging(TlInstance* c, int on) { c->logging_on = on != 0; }

void tl_enter_initialization(TlInstance* c) { c->s.phase = TL_INITIALIZATION; }

TlStatus tl_set_experiment(TlInstance* c, const char* call, double start, int stop_defined, double stop) {
  if (!isfinite(start)) return tl_fail(c, "%s: start time %g is not finite", call, start);
  if (stop_defined && !(stop >= start)) return tl_fail(c, "%s: stop time %g s is before the start time %g s", call, stop, start);
  c->s.time = c->s.start_time = start;
  c->s.stop_time = stop_defined ? stop : INFINITY;
  return TL_OK;
}

TlStatus tl_exit_initialization(TlInstance* c, int next_phase) {
  const TlStatus status = tl_model_initialize(c);
  if (status <= TL_WARNING) c->s.phase = next_phase;
  return tl_settle(c, status == TL_DISCARD ? TL_ERROR : status);
}

void tl_terminate(TlInstance* c) {
  if (c->s.phase != TL_ERRORED) c->s.phase = TL_TERMINATED;
}

TlStatus tl_do_step(TlInstance* c, const char* call, double t, double h) {
  double end;
  TlStatus status;
  if (!(isfinite(h) && h > 0.0)) return tl_fail(c, "%s: communication step %g s must be positive and finite", call, h);
  if (!isfinite(t) || fabs(t - c->s.time) > 1e-6 * h)
    return tl_fail(c, "%s: called at t=%.9g s but the FMU is at t=%.9g s (steps must follow each other)", call, t, c->s.time);
  end = t + h;
  if (end > c->s.stop_time + 1e-9 * h)
    return tl_fail(c, "%s: the step to t=%.9g s goes beyond the stop time %.9g s", call, end, c->s.stop_time);
  status = tl_model_step(c, t, h);
  if (status <= TL_WARNING) c->s.time = end;
  return tl_settle(c, status);
}

/* ---- Event Mode ------------------------------------------------------------------------------------------------------ */
void tl_begin_event(TlInstance* c) {
  c->s.event_dirty = 1;
  c->s.event_ran = 0;
}

#if TL_EVENT_PARTITION
/* The model state but its unsaved region into pre_event (restore 0), or back (restore 1). */
static void event_copy(TlInstance* c, int restore) {
  unsigned char* model = (unsigned char*)&c->s.model;
  const size_t head = TL_MODEL_EVENT_UNSAVED_OFFSET, skip = TL_MODEL_EVENT_UNSAVED_SIZE;
  const size_t tail = sizeof(TlModelState) - head - skip;
  if (restore) {
    memcpy(model, c->s.pre_event, head);
    memcpy(model + head + skip, c->s.pre_event + head, tail);
  } else {
    memcpy(c->s.pre_event, model, head);
    memcpy(c->s.pre_event + head, model + head + skip, tail);
  }
}
#endif

/* The first run keeps the model state it starts from (one copy per event), so that a later change runs it again from there. */
TlStatus tl_run_event(TlInstance* c) {
#if TL_EVENT_PARTITION
  TlStatus status;
  if (!c->s.event_dirty) return TL_OK;
  event_copy(c, c->s.event_ran); /* ran already: inputs or clocks changed, so run again from the event's start */
  status = tl_model_event(c, c->s.time);
  c->s.event_ran = 1;
  c->s.event_dirty = 0;
  return status;
#else
  (void)c;
  return TL_OK;
#endif
}

#if TL_FMI_VERSION == 3
TlStatus tl_enter_event_mode(TlInstance* c, const char* call) {
  if (!c->event_mode_used) return tl_fail(c, "%s: the instance was created with eventModeUsed = false", call);
  c->s.phase = TL_EVENT;
  tl_begin_event(c);
  return TL_OK;
}

TlStatus tl_update_discrete_states(TlInstance* c, int* terminate, int* next_defined, double* next_time) {
  const TlStatus status = tl_run_event(c);
  if (status > TL_WARNING) return tl_settle(c, status == TL_DISCARD ? TL_ERROR : status);
  memset(c->s.clock_active, 0, sizeof c->s.clock_active); /* the clocks' ticks are over: a new super-dense instant */
  c->s.event_ran = 0;
  *terminate = c->s.stop_requested;
  *next_defined = c->s.next_event_time >= 0.0;
  *next_time = c->s.next_event_time >= 0.0 ? c->s.next_event_time : 0.0;
  return status;
}

TlStatus tl_enter_step_mode(TlInstance* c) {
  const TlStatus status = tl_run_event(c); /* an event left without fmi3UpdateDiscreteStates still runs its partition */
  if (status > TL_WARNING) return tl_settle(c, status == TL_DISCARD ? TL_ERROR : status);
  memset(c->s.clock_active, 0, sizeof c->s.clock_active);
  c->s.phase = TL_STEPPING;
  return status;
}

/* a time event the model asked for, reached by this step: the importer enters Event Mode at the step's end */
int tl_event_needed(const TlInstance* c, double h) {
  return c->event_mode_used && c->s.next_event_time >= 0.0 && c->s.time >= c->s.next_event_time - 1e-9 * h;
}

/* The clock index of vr, or -1 with a log line. */
static int clock_index(TlInstance* c, const char* call, TlValueReference vr) {
  const long k = (long)vr - TL_VR_CLOCK0, n = TL_N_CLOCK;
  if (k >= 0 && k < n) return (int)k;
  tl_log(c, TL_ERROR, "%s: value reference %u is not a clock of %s (it has %d)", call, vr, TL_MODEL_IDENTIFIER, TL_N_CLOCK);
  return -1;
}

/* Every value reference a clock (the arrays given): TL_OK, or the error settled. */
static TlStatus all_clocks(TlInstance* c, const char* call, const TlValueReference vr[], size_t n, int arrays_given) {
  size_t i;
  if (n && (vr == NULL || !arrays_given)) return tl_fail(c, "%s: no value references or values given", call);
  for (i = 0; i < n; ++i)
    if (clock_index(c, call, vr[i]) < 0) return tl_settle(c, TL_ERROR);
  return TL_OK;
}

TlStatus tl_set_clocks(TlInstance* c, const char* call, const TlValueReference vr[], size_t n, const TlBoolean value[]) {
  size_t i;
  if (all_clocks(c, call, vr, n, value != NULL) != TL_OK) return TL_ERROR;
#if TL_EVENT_PARTITION
  for (i = 0; i < n; ++i)
    if (!value[i] && c->s.clock_active[vr[i] - TL_VR_CLOCK0])
      return tl_fail(c, "%s: %s cannot be deactivated (canBeDeactivated is false)", call, tl_clock_name[vr[i] - TL_VR_CLOCK0]);
  for (i = 0; i < n; ++i) {
    const unsigned k = vr[i] - TL_VR_CLOCK0;
    if (value[i] && !c->s.clock_active[k]) {
      c->s.clock_active[k] = 1;
      c->s.event_dirty = 1;
    }
  }
#else
  (void)i;
#endif
  return TL_OK;
}

TlStatus tl_get_clocks(TlInstance* c, const char* call, const TlValueReference vr[], size_t n, TlBoolean value[]) {
  size_t i;
  if (all_clocks(c, call, vr, n, value != NULL) != TL_OK) return TL_ERROR;
  for (i = 0; i < n; ++i) value[i] = c->s.clock_active[vr[i] - TL_VR_CLOCK0] ? 1 : 0;
  return TL_OK;
}

/* The clocks are periodic with constant intervals (those of modelDescription.xml) and no shift. */
TlStatus tl_clock_grid(TlInstance* c, const char* call, const TlValueReference vr[], size_t n, int arrays_given, int shift,
                       double decimal[], TlUInt64 counter[], TlUInt64 resolution[], TlIntervalQualifier qualifier[]) {
  size_t i;
  if (all_clocks(c, call, vr, n, arrays_given) != TL_OK) return TL_ERROR;
  for (i = 0; i < n; ++i) {
    const unsigned k = vr[i] - TL_VR_CLOCK0;
    if (decimal != NULL) decimal[i] = shift ? 0.0 : tl_clock_interval[k];
    if (counter != NULL) counter[i] = shift ? 0 : tl_clock_counter[k];
    if (resolution != NULL) resolution[i] = tl_clock_resolution[k];
    if (qualifier != NULL) qualifier[i] = fmi3IntervalUnchanged;
  }
  return TL_OK;
}
#endif

/* ---- Scheduled Execution ---------------------------------------------------------------------------------------------- */
#if TL_SCHEDULED
/* The activation of clock k at t in intervals from the start (exact decimal interval counter / resolution), or -1 when
   t is not on its grid. */
static long long grid_index(const TlInstance* c, int k, double t) {
  const double intervals = (t - c->s.start_time) * (double)tl_clock_resolution[k] / (double)tl_clock_counter[k];
  const double n = floor(intervals + 0.5);
  return isfinite(intervals) && n >= 0.0 && fabs(intervals - n) <= 1e-6 ? (long long)n : -1;
}

int tl_partition_done(const TlInstance* c, int k, double t) {
  const long long n = grid_index(c, k, t);
  return n < 0 || c->s.activation[k] >= n; /* a later activation (preempting this instant's partition) counts too */
}

void tl_lock_preemption(const TlInstance* c) {
  if (c->host.lock_preemption != NULL) c->host.lock_preemption();
}

void tl_unlock_preemption(const TlInstance* c) {
  if (c->host.unlock_preemption != NULL) c->host.unlock_preemption();
}

TlStatus tl_activate(TlInstance* c, const char* call, TlValueReference clock, double t) {
  const int k = clock_index(c, call, clock);
  long long n;
  TlStatus status;
  if (k < 0) return tl_settle(c, TL_ERROR);
  if (!isfinite(t) || t > c->s.stop_time + 1e-9 * tl_clock_interval[k])
    return tl_fail(c, "%s: %s activated at t=%.9g s, beyond the stop time %.9g s", call, tl_clock_name[k], t, c->s.stop_time);
  n = grid_index(c, k, t);
  if (n < 0)
    return tl_fail(c, "%s: t=%.9g s is not an activation time of %s (every %.9g s from %.9g s)", call, t, tl_clock_name[k],
                   tl_clock_interval[k], c->s.start_time);
  tl_lock_preemption(c); /* the activation record and the time are shared by every partition */
  if (c->running[k] != 0) { /* from a lock callback of its own run: it would run on its own half-written state */
    const double at = c->s.start_time + (double)(c->running[k] - 1) * tl_clock_interval[k];
    tl_unlock_preemption(c);
    return tl_fail(c, "%s: %s activated at t=%.9g s while its partition is still running for t=%.9g s (a partition "
                   "cannot preempt itself: activate it again after it returns)", call, tl_clock_name[k], t, at);
  }
  if (n <= c->s.activation[k]) {
    tl_unlock_preemption(c);
    return tl_fail(c, "%s: %s activated at t=%.9g s, but its last activation was at t=%.9g s (activation times must "
                   "increase)", call, tl_clock_name[k], t, c->s.start_time + (double)c->s.activation[k] * tl_clock_interval[k]);
  }
  c->partitions_running += 1;
  c->running[k] = n + 1;
  tl_unlock_preemption(c);
  status = tl_model_partition(c, k, t);
  tl_lock_preemption(c);
  c->partitions_running -= 1;
  c->running[k] = 0;
  if (status <= TL_WARNING) {
    c->s.activation[k] = n;
    if (t > c->s.time) c->s.time = t;
  }
  tl_unlock_preemption(c);
  return tl_settle(c, status == TL_DISCARD ? TL_ERROR : status); /* Scheduled Execution treats Discard as Error */
}
#endif

/* ---- variables ------------------------------------------------------------------------------------------------------- */
/* The generated tables of one type (tl_model_tables.c) and where its value references begin. */
typedef struct {
  const char* const* name;
  const unsigned char* settable; /* 0 output, 1 parameter (fixed after initialization), 2 input or tunable */
  unsigned first_vr;
  int count;
#if TL_N_CLOCK > 0
  const int* clock;              /* -1: none */
  const unsigned char* discrete; /* changes in Event Mode only */
#endif
} TlTable;

#if TL_N_CLOCK > 0
#define TL_CLOCK_TABLES(type) , tl_##type##_clock, tl_##type##_discrete
#else
#define TL_CLOCK_TABLES(type)
#endif

static const TlTable tables[TL_N_TYPES] = {
    {tl_real_name, tl_real_settable, TL_VR_REAL0, TL_N_REAL TL_CLOCK_TABLES(real)},
    {tl_integer_name, tl_integer_settable, TL_VR_INTEGER0, TL_N_INTEGER TL_CLOCK_TABLES(integer)},
    {tl_boolean_name, tl_boolean_settable, TL_VR_BOOLEAN0, TL_N_BOOLEAN TL_CLOCK_TABLES(boolean)},
    {tl_string_name, tl_string_settable, TL_VR_STRING0, TL_N_STRING TL_CLOCK_TABLES(string)},
};

/* The index of vr among the variables of one type, or -1 with a log line. */
static int index_of(TlInstance* c, const char* call, TlType type, TlValueReference vr) {
  const TlTable* t = &tables[type];
  if (vr >= t->first_vr && vr - t->first_vr < (unsigned)t->count) return (int)(vr - t->first_vr);
  tl_log(c, TL_ERROR, "%s: value reference %u is not a %s variable of %s", call, (unsigned)vr, tl_binding.type_name[type],
         TL_MODEL_IDENTIFIER);
  return -1;
}

static int clock_of(TlType type, int k) {
#if TL_N_CLOCK > 0
  return tables[type].clock[k];
#else
  (void)type; (void)k;
  return -1;
#endif
}

/* May a variable with this clock (-1: none) be read or written now? Logs why not. */
static int clock_allows(TlInstance* c, const char* call, const char* name, int clock) {
  if (clock < 0 || c->s.phase == TL_INSTANTIATED || c->s.phase == TL_INITIALIZATION || c->s.phase == TL_TERMINATED) return 1;
  if (c->s.phase == TL_ACTIVATION) return 1; /* set before its partition's activation, read after it: the importer's order */
#if TL_N_CLOCK > 0
  if (c->s.phase == TL_EVENT && c->s.clock_active[clock]) return 1;
  tl_log(c, TL_ERROR, "%s: %s is clocked by %s, which is not active (%s)", call, name, tl_clock_name[clock],
         c->s.phase == TL_EVENT ? "activate it with fmi3SetClock first" : "clocked variables are accessible in Event Mode only");
#else
  (void)call; (void)name;
#endif
  return 0;
}

static int readable(TlInstance* c, const char* call, TlType type, TlValueReference vr) {
  const int k = index_of(c, call, type, vr);
  return k >= 0 && clock_allows(c, call, tables[type].name[k], clock_of(type, k)) ? k : -1;
}

/* May variable k be written now (causality, clock, discrete inputs in Event Mode only)? Logs why not. */
static int may_write(TlInstance* c, const char* call, TlType type, int k) {
  const TlTable* t = &tables[type];
  const unsigned char settable = t->settable[k];
  const int clock = clock_of(type, k);
  if (!(settable == 2 || (settable == 1 && (c->s.phase == TL_INSTANTIATED || c->s.phase == TL_INITIALIZATION)))) {
    tl_log(c, TL_ERROR, "%s: cannot set %s: it is %s", call, t->name[k],
           settable == 1 ? "a parameter, fixed after initialization" : "an output");
    return 0;
  }
  if (!clock_allows(c, call, t->name[k], clock)) return 0;
#if TL_N_CLOCK > 0
  if (settable == 2 && t->discrete[k] && clock < 0 && c->event_mode_used && c->s.phase == TL_STEPPING) {
    tl_log(c, TL_ERROR, "%s: %s is a discrete input: with Event Mode it changes in Event Mode only", call, t->name[k]);
    return 0;
  }
#endif
  return 1;
}

/* Is value i refused for variable k (a non-finite Real, a String too long)? Logs why. */
static int value_refused(TlInstance* c, const char* call, TlType type, int k, const void* values, size_t i) {
  if (type == TL_TYPE_REAL) {
    const double v = ((const double*)values)[i];
    if (isfinite(v)) return 0;
    tl_log(c, TL_ERROR, "non-finite %s %s = %g at t=%.6g s; value refused", tl_real_settable[k] == 2 ? "input" : "parameter",
           tl_real_name[k], v, c->s.time);
    return 1;
  }
  if (type == TL_TYPE_STRING) {
    const char* v = ((const char* const*)values)[i];
    if (v != NULL && strlen(v) < TL_STRING_LEN) return 0;
    tl_log(c, TL_ERROR, "%s: %s must be a string of at most %d characters", call, tl_string_name[k], TL_STRING_LEN - 1);
    return 1;
  }
  return 0;
}

/* Before a Get: the outputs computed for initialization, or this event's partition. */
static TlStatus prepare_get(TlInstance* c) {
  if (c->s.phase == TL_INITIALIZATION) return tl_model_outputs(c);
  if (c->s.phase == TL_EVENT) return tl_run_event(c);
  return TL_OK;
}

TlStatus tl_get(TlInstance* c, const char* call, TlType type, const TlValueReference vr[], size_t n, void* values) {
  size_t i;
  if (n && (vr == NULL || values == NULL)) return tl_fail(c, "%s: no value references or values given", call);
  if (prepare_get(c) > TL_WARNING) return tl_settle(c, TL_ERROR);
  for (i = 0; i < n; ++i) {
    int k;
#ifdef TL_VR_TIME
    if (type == TL_TYPE_REAL && vr[i] == TL_VR_TIME) { /* FMI 3.0: the independent variable has a value reference */
      ((double*)values)[i] = c->s.time;
      continue;
    }
#endif
    k = readable(c, call, type, vr[i]);
    if (k < 0) return tl_settle(c, TL_ERROR);
    switch (type) {
      case TL_TYPE_REAL: ((double*)values)[i] = c->s.real[k]; break;
      case TL_TYPE_INTEGER: ((TlInteger*)values)[i] = (TlInteger)c->s.integer[k]; break;
      case TL_TYPE_BOOLEAN: ((TlBoolean*)values)[i] = c->s.boolean[k] ? 1 : 0; break;
      default: ((const char**)values)[i] = c->s.string[k]; break;
    }
  }
  return TL_OK;
}

TlStatus tl_set(TlInstance* c, const char* call, TlType type, const TlValueReference vr[], size_t n, const void* values) {
  size_t i;
  if (n && (vr == NULL || values == NULL)) return tl_fail(c, "%s: no value references or values given", call);
  for (i = 0; i < n; ++i) { /* check all first: a refused call changes nothing */
    const int k = index_of(c, call, type, vr[i]);
    if (k < 0 || !may_write(c, call, type, k) || value_refused(c, call, type, k, values, i)) return tl_settle(c, TL_ERROR);
  }
  for (i = 0; i < n; ++i) {
    const int k = (int)(vr[i] - tables[type].first_vr);
    switch (type) {
      case TL_TYPE_REAL: c->s.real[k] = ((const double*)values)[i]; break;
      case TL_TYPE_INTEGER: c->s.integer[k] = ((const TlInteger*)values)[i]; break;
      case TL_TYPE_BOOLEAN: c->s.boolean[k] = ((const TlBoolean*)values)[i] ? 1 : 0; break;
      default: {
        const char* v = ((const char* const*)values)[i];
        memset(c->s.string[k], 0, TL_STRING_LEN);
        memcpy(c->s.string[k], v, strlen(v));
      }
    }
  }
  if (n && c->s.phase == TL_EVENT) c->s.event_dirty = 1; /* an input set in Event Mode changes this event's partition */
  return TL_OK;
}

TlStatus tl_no_variables(TlInstance* c, const char* call, const TlValueReference vr[], size_t n, const char* what) {
  if (n == 0) return TL_OK;
  return tl_fail(c, "%s: value reference %u: %s has no %s", call, vr ? (unsigned)vr[0] : 0u, TL_MODEL_IDENTIFIER, what);
}

/* ---- state snapshots -------------------------------------------------------------------------------------------------- */
#define TL_STATE_MAGIC "TLSTATE1"
#define TL_GUID_LEN 40
#define TL_SERIAL_SIZE (8 + TL_GUID_LEN + sizeof(TlState))

static void guid_field(char field[TL_GUID_LEN]) {
  memset(field, 0, TL_GUID_LEN);
  memcpy(field, TL_GUID, strlen(TL_GUID) < TL_GUID_LEN ? strlen(TL_GUID) : TL_GUID_LEN);
}

static int is_serial_of_this_build(const unsigned char* bytes, size_t size) {
  char guid[TL_GUID_LEN];
  guid_field(guid);
  return bytes != NULL && size == TL_SERIAL_SIZE && memcmp(bytes, TL_STATE_MAGIC, 8) == 0 && memcmp(bytes + 8, guid, TL_GUID_LEN) == 0;
}

/* Scheduled Execution: the state functions apply to the whole FMU, never while a partition runs (or is preempted). */
static TlStatus partitions_idle(TlInstance* c, const char* call) {
  if (c->partitions_running == 0) return TL_OK;
  return tl_fail(c, "%s: %d model partition(s) active or preempted; the FMU state applies to all of them", call,
                 c->partitions_running);
}

TlStatus tl_get_state(TlInstance* c, const char* call, void** state) {
  if (partitions_idle(c, call) != TL_OK) return TL_ERROR;
  if (state == NULL) return tl_fail(c, "%s: no place for the state given", call);
  if (*state == NULL) {
    *state = tl_binding.allocate(&c->host, sizeof(TlState));
    if (*state == NULL) return tl_fail(c, "%s: out of memory", call);
  }
  memcpy(*state, &c->s, sizeof(TlState));
  return TL_OK;
}

TlStatus tl_set_state(TlInstance* c, const char* call, const void* state) {
  if (partitions_idle(c, call) != TL_OK) return TL_ERROR;
  if (state == NULL) return tl_fail(c, "%s: no state given", call);
  memcpy(&c->s, state, sizeof(TlState));
  return TL_OK;
}

void tl_free_state(TlInstance* c, void** state) {
  if (state == NULL) return;
  if (*state != NULL) tl_binding.release(&c->host, *state);
  *state = NULL;
}

TlStatus tl_serialized_size(TlInstance* c, const char* call, size_t* size) {
  if (size == NULL) return tl_fail(c, "%s: no place for the size given", call);
  *size = TL_SERIAL_SIZE;
  return TL_OK;
}

TlStatus tl_serialize(TlInstance* c, const char* call, const void* state, unsigned char bytes[], size_t size) {
  char guid[TL_GUID_LEN];
  if (state == NULL || bytes == NULL || size < TL_SERIAL_SIZE)
    return tl_fail(c, "%s: needs a state and %lu bytes", call, (unsigned long)TL_SERIAL_SIZE);
  guid_field(guid);
  memset(bytes, 0, TL_SERIAL_SIZE);
  memcpy(bytes, TL_STATE_MAGIC, 8);
  memcpy(bytes + 8, guid, TL_GUID_LEN);
  memcpy(bytes + 8 + TL_GUID_LEN, state, sizeof(TlState));
  return TL_OK;
}

TlStatus tl_deserialize(TlInstance* c, const char* call, const unsigned char bytes[], size_t size, void** state) {
  if (state == NULL || !is_serial_of_this_build(bytes, size))
    return tl_fail(c, "%s: the bytes are not a state of this %s build", call, TL_MODEL_IDENTIFIER);
  if (*state == NULL) *state = tl_binding.allocate(&c->host, sizeof(TlState));
  if (*state == NULL) return tl_fail(c, "%s: out of memory", call);
  memcpy(*state, bytes + 8 + TL_GUID_LEN, sizeof(TlState));
  return TL_OK;
}
