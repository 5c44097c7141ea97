/* What the two FMI 3.0 C hosts share (fmi3_loop_host.c, the co-simulation loop; fmi3_se_host.c, the Scheduled
   Execution scheduler): loading a binary and its fmi3 functions, the plan's instances, clocks, connections and
   printed outputs, the look-ups on them, and a co-simulation FMU's Event Mode and step. Each host is one .c file
   built with one compiler call, so this is a header of static inline functions (inline: a host that leaves one
   unused gets no -Wunused-function), found beside the .c by #include "...". Portable: dlopen on POSIX, LoadLibrary
   on Windows (the loop host runs under wine in the platform tests). No state of its own. */
#ifndef FMI3_HOST_COMMON_H
#define FMI3_HOST_COMMON_H

#if defined(_WIN32)
#include <windows.h>
#define LIB_OPEN(path) ((void*)LoadLibraryA(path))
#define LIB_SYMBOL(lib, name) ((void*)GetProcAddress((HMODULE)(lib), name))
#define LIB_CLOSE(lib) FreeLibrary((HMODULE)(lib))
#define LIB_ERROR() "LoadLibrary failed"
#else
#include <dlfcn.h>
#define LIB_OPEN(path) dlopen(path, RTLD_NOW | RTLD_LOCAL)
#define LIB_SYMBOL(lib, name) dlsym(lib, name)
#define LIB_CLOSE(lib) dlclose(lib)
#define LIB_ERROR() dlerror()
#endif
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"

#define MAX_FMUS 8
#define MAX_LINKS 512
#define MAX_CLOCKS 16
#define MAX_CLOCKED 512
#define MAX_DEPS 256
#define MAX_OUT 64
#define MAX_PARAMS 256

/* A periodic input clock (interval and shift in ticks); the last three fields are the Scheduled Execution host's. */
typedef struct {
  fmi3ValueReference vr;
  long interval, shift;
  unsigned declared; /* the FMU's priority attribute */
  int level;         /* the host's: smaller runs first */
  long ran_at;       /* the tick of its last activation (-1: none) */
} Clock;

/* An FMU instance of the plan and its fmi3 functions; scheduled, the dependencies, instantiate_se and activate are
   the Scheduled Execution host's (load() looks those two functions up only when asked). */
typedef struct {
  char name[64], token[128];
  int scheduled; /* Scheduled Execution (S) or co-simulation (F) */
  void* lib;
  fmi3Instance c;
  int n_clocks, n_clocked, n_deps, in_event, event_asked;
  Clock clocks[MAX_CLOCKS];
  fmi3ValueReference clocked_vr[MAX_CLOCKED], clocked_by[MAX_CLOCKED];
  fmi3ValueReference dep_consumer[MAX_DEPS], dep_producer[MAX_DEPS];
  fmi3InstantiateCoSimulationTYPE* instantiate;
  fmi3InstantiateScheduledExecutionTYPE* instantiate_se;
  fmi3EnterInitializationModeTYPE* enter_init;
  fmi3ExitInitializationModeTYPE* exit_init;
  fmi3EnterEventModeTYPE* enter_event;
  fmi3EnterStepModeTYPE* enter_step;
  fmi3SetClockTYPE* set_clock;
  fmi3UpdateDiscreteStatesTYPE* update;
  fmi3ActivateModelPartitionTYPE* activate;
  fmi3SetFloat64TYPE* set_float64;
  fmi3SetInt32TYPE* set_int32;
  fmi3SetBooleanTYPE* set_boolean;
  fmi3SetStringTYPE* set_string;
  fmi3GetFloat64TYPE* get_float64;
  fmi3GetInt32TYPE* get_int32;
  fmi3GetBooleanTYPE* get_boolean;
  fmi3DoStepTYPE* do_step;
  fmi3TerminateTYPE* terminate;
  fmi3FreeInstanceTYPE* free_instance;
} Fmu;

/* A connection, with the source output's latest value (read by the host when the source computed it). */
typedef struct {
  int src, dst;
  char type;
  fmi3ValueReference src_vr, dst_vr;
  double real;
  fmi3Int32 integer;
  fmi3Boolean boolean;
} Link;

/* The printed outputs (O lines): instance, value reference, the value a clocked one had at its clock's last tick. */
typedef struct {
  int n, fmu[MAX_OUT];
  fmi3ValueReference vr[MAX_OUT];
  fmi3Float64 held[MAX_OUT];
} Outputs;

static inline void log_message(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
  (void)category;
  if (status >= fmi3Warning) fprintf(stderr, "[%s] %s\n", (const char*)env, message);
}

static inline int find(const Fmu* fmus, int n, const char* name) {
  int i;
  for (i = 0; i < n; ++i)
    if (strcmp(fmus[i].name, name) == 0) return i;
  fprintf(stderr, "unknown instance %s\n", name);
  exit(2);
}

/* The clock of a variable of f (its value reference), or 0 when it is not clocked. */
static inline fmi3ValueReference clock_of(const Fmu* f, fmi3ValueReference vr) {
  int i;
  for (i = 0; i < f->n_clocked; ++i)
    if (f->clocked_vr[i] == vr) return f->clocked_by[i];
  return 0;
}

/* Whether the clock (a value reference) is due, due[j] telling it for f's j-th clock. */
static inline int is_due(const Fmu* f, fmi3ValueReference clock, const int* due) {
  int j;
  for (j = 0; j < f->n_clocks; ++j)
    if (f->clocks[j].vr == clock) return due[j];
  return 0;
}

/* A periodic clock ticks at shift, shift + interval, ... (in ticks). */
static inline int due_at(const Clock* k, long tick) { return tick >= k->shift && (tick - k->shift) % k->interval == 0; }

/* Which of f's clocks are due at tick (due[j] for its j-th), and whether f needs Event Mode then: a clock due, the
   Event Mode that follows initialization, or eventHandlingNeeded at its last step. */
static inline int needs_event_mode(const Fmu* f, long tick, int* due) {
  int j, any = 0;
  for (j = 0; j < f->n_clocks; ++j) {
    due[j] = due_at(&f->clocks[j], tick);
    any |= due[j];
  }
  return f->n_clocks && (any || f->in_event || f->event_asked);
}

/* In Event Mode: the due clocks set active (fmi3SetClock). */
static inline int set_due_clocks(Fmu* f, const int* due) {
  fmi3ValueReference vrs[MAX_CLOCKS];
  fmi3Clock on[MAX_CLOCKS];
  int j, n = 0;
  for (j = 0; j < f->n_clocks; ++j)
    if (due[j]) {
      vrs[n] = f->clocks[j].vr;
      on[n++] = fmi3ClockActive;
    }
  return n ? f->set_clock(f->c, vrs, (size_t)n, on) != fmi3OK : 0;
}

/* The end of Event Mode: fmi3UpdateDiscreteStates until no further update (none after a failure: failed, the Event
   Mode's calls so far; at most 100 rounds), then fmi3EnterStepMode. */
static inline int leave_event_mode(Fmu* f, int failed) {
  fmi3Boolean need = fmi3True, terminate = fmi3False, nominals, values, next_defined;
  fmi3Float64 next_time;
  int rounds = 0;
  while (need && !failed && rounds++ < 100)
    failed |= f->update(f->c, &need, &terminate, &nominals, &values, &next_defined, &next_time) != fmi3OK;
  failed |= need || terminate;
  failed |= f->enter_step(f->c) != fmi3OK;
  f->in_event = 0;
  return failed;
}

/* fmi3DoStep(t, h): a request to terminate or an early return fails the run; eventHandlingNeeded asks for Event Mode
   at the next tick. */
static inline int step_fmu(Fmu* f, double t, double h) {
  fmi3Boolean event_needed, terminate, early;
  fmi3Float64 last;
  int failed = f->do_step(f->c, t, h, fmi3True, &event_needed, &terminate, &early, &last) != fmi3OK;
  failed |= terminate || early;
  f->event_asked = event_needed;
  return failed;
}

#define SYM(f, field, name) ((f)->field = (void*)LIB_SYMBOL((f)->lib, name)) == NULL

/* Open the binary and look up the fmi3 functions the hosts call (with scheduled_execution, the two of Scheduled
   Execution too: every FMU the SE host loads must have them). */
static inline int load(Fmu* f, const char* binary, bool scheduled_execution) {
  f->lib = LIB_OPEN(binary);
  if (f->lib == NULL) {
    fprintf(stderr, "loading %s: %s\n", binary, LIB_ERROR());
    return 1;
  }
  if (SYM(f, instantiate, "fmi3InstantiateCoSimulation") || SYM(f, enter_init, "fmi3EnterInitializationMode") ||
      SYM(f, exit_init, "fmi3ExitInitializationMode") || SYM(f, enter_event, "fmi3EnterEventMode") ||
      SYM(f, enter_step, "fmi3EnterStepMode") || SYM(f, set_clock, "fmi3SetClock") ||
      SYM(f, update, "fmi3UpdateDiscreteStates") || SYM(f, set_float64, "fmi3SetFloat64") ||
      SYM(f, set_int32, "fmi3SetInt32") || SYM(f, set_boolean, "fmi3SetBoolean") || SYM(f, set_string, "fmi3SetString") ||
      SYM(f, get_float64, "fmi3GetFloat64") || SYM(f, get_int32, "fmi3GetInt32") || SYM(f, get_boolean, "fmi3GetBoolean") ||
      SYM(f, do_step, "fmi3DoStep") || SYM(f, terminate, "fmi3Terminate") || SYM(f, free_instance, "fmi3FreeInstance") ||
      (scheduled_execution && (SYM(f, instantiate_se, "fmi3InstantiateScheduledExecution") ||
                               SYM(f, activate, "fmi3ActivateModelPartition")))) {
    fprintf(stderr, "%s: missing fmi3 symbol\n", f->name);
    return 1;
  }
  return 0;
}

/* Set one parameter line "P name R|I|B|S vr value" (in Initialization Mode). */
static inline int set_parameter(Fmu* fmus, int n_fmus, const char* line) {
  char name[64], type;
  unsigned a;
  const char* value = line;
  int spaces = 0;
  Fmu* f;
  fmi3ValueReference vr;
  if (sscanf(line, "P %63s %c %u", name, &type, &a) != 3) return 1;
  f = &fmus[find(fmus, n_fmus, name)];
  vr = a;
  while (*value && spaces < 4) spaces += *value++ == ' ';
  if (type == 'R') {
    fmi3Float64 v = strtod(value, NULL);
    return f->set_float64(f->c, &vr, 1, &v, 1) != fmi3OK;
  }
  if (type == 'I') {
    fmi3Int32 v = (fmi3Int32)strtol(value, NULL, 10);
    return f->set_int32(f->c, &vr, 1, &v, 1) != fmi3OK;
  }
  if (type == 'B') {
    fmi3Boolean v = atoi(value) != 0;
    return f->set_boolean(f->c, &vr, 1, &v, 1) != fmi3OK;
  }
  {
    fmi3String v = value;
    return f->set_string(f->c, &vr, 1, &v, 1) != fmi3OK;
  }
}

/* Print the outputs of instance fi after tick k ("k name vr value", C99 hex float): a clocked one as held, the
   others read now. */
static inline int print_outputs(const Outputs* o, Fmu* f, int fi, long k) {
  int j, failed = 0;
  for (j = 0; j < o->n; ++j)
    if (o->fmu[j] == fi) {
      fmi3Float64 v = o->held[j];
      if (clock_of(f, o->vr[j]) == 0) failed |= f->get_float64(f->c, &o->vr[j], 1, &v, 1) != fmi3OK;
      printf("%ld %s %u %a\n", k, f->name, o->vr[j], v);
    }
  return failed;
}

#endif
