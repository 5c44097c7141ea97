/* A small FMI 2.0 co-simulation master in portable C99: LoadLibrary on Windows, dlopen elsewhere, no
   other POSIX call. It loads the FMU binaries named in a plan, instantiates them with their resource
   URIs, sets parameters, steps them in plan order on a fixed tick (Gauss-Seidel, as tiltload's master
   and tests/support/hosts/loop_host.c: before an instance steps, its inputs are set from the current outputs of
   their sources) and prints Real outputs with %.17g, so two platforms' runs can be compared to the bit.

   usage: portable_host PLAN
   PLAN is text, one item a line (# starts a comment):
     F name binary guid [uri]      an FMU instance (stepping order = file order); uri: its resources
                                   location (default: none, a NULL pointer is passed)
     G                             load the following binaries into the global symbol scope (RTLD_GLOBAL)
     L                             turn the FMUs' logging on (fmi2Instantiate loggingOn and SetDebugLogging)
     P name R|I|B|S vr value       a parameter or input before initialization (S: the rest of the line)
     C src R|B vr dst vr           a connection from src's output to dst's input
     T tick ticks                  the tick (s) and how many ticks to run
     O name vr                     a Real to print
     E every                       print the O values every `every` ticks (default 0: at the end only)
     M plant ref ctrl vr ref_vr    ISE of one regulated variable, sampled as tiltload's Metrics observer
                                   does: when ctrl steps, (plant's vr - ref's ref_vr)^2 * tick, the plant's
                                   value being its output before it steps in that tick
   Output lines: "v t name vr value" (O values), "ise name vr value", "time name seconds" (wall time in
   fmi2DoStep per instance), "ticks n failed f". Exit 0 when every call succeeded and every printed value
   is finite. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#if defined(_WIN32)
#include <windows.h>
typedef HMODULE Library;
static Library open_library(const char* path, int global) {
  (void)global; /* a DLL's exports are always per module */
  return LoadLibraryA(path);
}
static void* symbol(Library lib, const char* name) {
  FARPROC f = GetProcAddress(lib, name);
  void* p;
  memcpy(&p, &f, sizeof p);
  return p;
}
static void close_library(Library lib) { FreeLibrary(lib); }
static const char* library_error(void) {
  static char text[64];
  sprintf(text, "error %lu", (unsigned long)GetLastError());
  return text;
}
static double now(void) {
  LARGE_INTEGER t, f;
  QueryPerformanceCounter(&t);
  QueryPerformanceFrequency(&f);
  return (double)t.QuadPart / (double)f.QuadPart;
}
#else
#include <dlfcn.h>
#include <time.h>
typedef void* Library;
static Library open_library(const char* path, int global) { return dlopen(path, RTLD_NOW | (global ? RTLD_GLOBAL : RTLD_LOCAL)); }
static void* symbol(Library lib, const char* name) { return dlsym(lib, name); }
static void close_library(Library lib) { dlclose(lib); }
static const char* library_error(void) { return dlerror(); }
static double now(void) { return (double)clock() / CLOCKS_PER_SEC; } /* processor time: the host is single-threaded */
#endif

#define MAX_FMUS 16
#define MAX_LINKS 1024
#define MAX_OUT 1024
#define MAX_ISE 16

typedef struct {
  char name[64];
  Library lib;
  fmi2Component c;
  double busy; /* s spent in fmi2DoStep */
  fmi2InstantiateTYPE* instantiate;
  fmi2SetDebugLoggingTYPE* set_debug_logging;
  fmi2SetupExperimentTYPE* setup;
  fmi2EnterInitializationModeTYPE* enter;
  fmi2ExitInitializationModeTYPE* exit_init;
  fmi2SetRealTYPE* set_real;
  fmi2SetIntegerTYPE* set_integer;
  fmi2SetBooleanTYPE* set_boolean;
  fmi2SetStringTYPE* set_string;
  fmi2GetRealTYPE* get_real;
  fmi2GetBooleanTYPE* get_boolean;
  fmi2DoStepTYPE* do_step;
  fmi2TerminateTYPE* terminate;
  fmi2FreeInstanceTYPE* free_instance;
} Fmu;

typedef struct {
  int src, dst;
  char type;
  fmi2ValueReference src_vr, dst_vr;
} Link;

typedef struct {
  int plant, ref, ctrl;
  fmi2ValueReference vr, ref_vr;
  double held, sum; /* the plant's output at the start of the tick; the sum so far */
} Ise;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
  (void)env;
  fprintf(stderr, "[%s] %s: %s (status %d)\n", name, category ? category : "?", message, (int)status);
}

static int find(const Fmu* fmus, int n, const char* name) {
  int i;
  for (i = 0; i < n; ++i)
    if (strcmp(fmus[i].name, name) == 0) return i;
  fprintf(stderr, "unknown instance %s\n", name);
  exit(2);
}

/* Look a symbol up into a function pointer of any type (ISO C has no cast from void* to a function pointer). */
#define BIND(f, field, name) (memcpy_symbol(&(f)->field, sizeof (f)->field, symbol((f)->lib, name)) == NULL)
static void* memcpy_symbol(void* field, size_t size, void* p) {
  if (p != NULL) memcpy(field, &p, size);
  return p;
}

static int load(Fmu* f, const char* binary, int global) {
  f->lib = open_library(binary, global);
  if (f->lib == NULL) {
    fprintf(stderr, "cannot load %s: %s\n", binary, library_error());
    return 1;
  }
  if (BIND(f, instantiate, "fmi2Instantiate") || BIND(f, set_debug_logging, "fmi2SetDebugLogging") ||
      BIND(f, setup, "fmi2SetupExperiment") || BIND(f, enter, "fmi2EnterInitializationMode") ||
      BIND(f, exit_init, "fmi2ExitInitializationMode") || BIND(f, set_real, "fmi2SetReal") ||
      BIND(f, set_integer, "fmi2SetInteger") || BIND(f, set_boolean, "fmi2SetBoolean") ||
      BIND(f, set_string, "fmi2SetString") || BIND(f, get_real, "fmi2GetReal") || BIND(f, get_boolean, "fmi2GetBoolean") ||
      BIND(f, do_step, "fmi2DoStep") || BIND(f, terminate, "fmi2Terminate") || BIND(f, free_instance, "fmi2FreeInstance")) {
    fprintf(stderr, "%s: an fmi2 function is not exported\n", binary);
    return 1;
  }
  return 0;
}

static int print_outputs(Fmu* fmus, const int* out_fmu, const fmi2ValueReference* out_vr, int n_out, double t) {
  int i, failed = 0;
  for (i = 0; i < n_out; ++i) {
    fmi2Real v = 0.0;
    Fmu* f = &fmus[out_fmu[i]];
    failed |= f->get_real(f->c, &out_vr[i], 1, &v) != fmi2OK;
    failed |= !isfinite(v);
    printf("v %.17g %s %u %.17g\n", t, f->name, (unsigned)out_vr[i], v);
  }
  return failed;
}

int main(int argc, char** argv) {
  static Fmu fmus[MAX_FMUS];
  static Link links[MAX_LINKS];
  static Ise ise[MAX_ISE];
  static int out_fmu[MAX_OUT];
  static fmi2ValueReference out_vr[MAX_OUT];
  static char line[8192];
  fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
  char name[64], other[64], binary[2048], guid[128], uri[2048], type;
  int n_fmus = 0, n_links = 0, n_out = 0, n_ise = 0, failed = 0, global = 0, logging = 0, i, j;
  double tick = 0.0;
  long ticks = 0, every = 0, k;
  FILE* plan;
  if (argc != 2 || (plan = fopen(argv[1], "r")) == NULL) {
    fprintf(stderr, "usage: %s PLAN\n", argv[0]);
    return 2;
  }
  while (fgets(line, sizeof line, plan)) {
    unsigned a, b;
    int fields;
    line[strcspn(line, "\r\n")] = '\0';
    if (line[0] == 'F' && (fields = sscanf(line, "F %63s %2047s %127s %2047s", name, binary, guid, uri)) >= 3) {
      Fmu* f;
      if (n_fmus == MAX_FMUS) return 2;
      f = &fmus[n_fmus++];
      strcpy(f->name, name);
      if (load(f, binary, global)) return 1;
      f->c = f->instantiate(name, fmi2CoSimulation, guid, fields == 4 ? uri : NULL, &callbacks, fmi2False,
                            logging ? fmi2True : fmi2False);
      if (f->c == NULL) {
        fprintf(stderr, "%s: fmi2Instantiate failed\n", name);
        return 1;
      }
      if (logging) failed |= f->set_debug_logging(f->c, fmi2True, 0, NULL) != fmi2OK;
      failed |= f->setup(f->c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK;
      failed |= f->enter(f->c) != fmi2OK;
    } else if (line[0] == 'G') {
      global = 1;
    } else if (line[0] == 'L') {
      logging = 1;
    } else if (line[0] == 'P' && sscanf(line, "P %63s %c %u", name, &type, &a) == 3) {
      Fmu* f = &fmus[find(fmus, n_fmus, name)];
      const char* value = line;
      int spaces = 0;
      fmi2ValueReference vr = a;
      while (*value && spaces < 4) spaces += *value++ == ' ';
      if (type == 'R') {
        fmi2Real v = strtod(value, NULL);
        failed |= f->set_real(f->c, &vr, 1, &v) != fmi2OK;
      } else if (type == 'I') {
        fmi2Integer v = atoi(value);
        failed |= f->set_integer(f->c, &vr, 1, &v) != fmi2OK;
      } else if (type == 'B') {
        fmi2Boolean v = atoi(value);
        failed |= f->set_boolean(f->c, &vr, 1, &v) != fmi2OK;
      } else {
        fmi2String v = value;
        failed |= f->set_string(f->c, &vr, 1, &v) != fmi2OK;
      }
    } else if (line[0] == 'C' && sscanf(line, "C %63s %c %u %63s %u", name, &type, &a, other, &b) == 5) {
      Link* l;
      if (n_links == MAX_LINKS) return 2;
      l = &links[n_links++];
      l->src = find(fmus, n_fmus, name);
      l->dst = find(fmus, n_fmus, other);
      l->type = type;
      l->src_vr = a;
      l->dst_vr = b;
    } else if (line[0] == 'T') {
      if (sscanf(line, "T %lf %ld", &tick, &ticks) != 2) return 2;
    } else if (line[0] == 'E') {
      if (sscanf(line, "E %ld", &every) != 1) return 2;
    } else if (line[0] == 'O' && sscanf(line, "O %63s %u", name, &a) == 2) {
      if (n_out == MAX_OUT) return 2;
      out_fmu[n_out] = find(fmus, n_fmus, name);
      out_vr[n_out++] = a;
    } else if (line[0] == 'M') {
      char ref[64], ctrl[64];
      Ise* m;
      if (n_ise == MAX_ISE || sscanf(line, "M %63s %63s %63s %u %u", name, ref, ctrl, &a, &b) != 5) return 2;
      m = &ise[n_ise++];
      m->plant = find(fmus, n_fmus, name);
      m->ref = find(fmus, n_fmus, ref);
      m->ctrl = find(fmus, n_fmus, ctrl);
      m->vr = a;
      m->ref_vr = b;
      m->sum = 0.0;
    } else if (line[0] != '\0' && line[0] != '#') {
      fprintf(stderr, "plan: cannot read '%s'\n", line);
      return 2;
    }
  }
  fclose(plan);
  for (i = 0; i < n_fmus; ++i) failed |= fmus[i].exit_init(fmus[i].c) != fmi2OK;
  for (j = 0; j < n_ise; ++j) failed |= fmus[ise[j].plant].get_real(fmus[ise[j].plant].c, &ise[j].vr, 1, &ise[j].held) != fmi2OK;
  if (every > 0 && !failed) failed |= print_outputs(fmus, out_fmu, out_vr, n_out, 0.0);
  for (k = 0; k < ticks && !failed; ++k) {
    const double t = (double)k * tick;
    for (i = 0; i < n_fmus && !failed; ++i) {
      double started;
      for (j = 0; j < n_links; ++j) {
        Link* l = &links[j];
        if (l->dst != i) continue;
        if (l->type == 'R') {
          fmi2Real v;
          failed |= fmus[l->src].get_real(fmus[l->src].c, &l->src_vr, 1, &v) != fmi2OK;
          failed |= fmus[i].set_real(fmus[i].c, &l->dst_vr, 1, &v) != fmi2OK;
        } else {
          fmi2Boolean v;
          failed |= fmus[l->src].get_boolean(fmus[l->src].c, &l->src_vr, 1, &v) != fmi2OK;
          failed |= fmus[i].set_boolean(fmus[i].c, &l->dst_vr, 1, &v) != fmi2OK;
        }
      }
      started = now();
      failed |= fmus[i].do_step(fmus[i].c, t, tick, fmi2True) != fmi2OK;
      fmus[i].busy += now() - started;
      for (j = 0; j < n_ise && !failed; ++j) {
        Ise* m = &ise[j];
        if (m->ctrl == i) {
          fmi2Real r;
          failed |= fmus[m->ref].get_real(fmus[m->ref].c, &m->ref_vr, 1, &r) != fmi2OK;
          m->sum += (m->held - r) * (m->held - r) * tick;
        }
        if (m->plant == i) failed |= fmus[i].get_real(fmus[i].c, &m->vr, 1, &m->held) != fmi2OK;
      }
    }
    if (!failed && ((every > 0 && (k + 1) % every == 0) || (every <= 0 && k + 1 == ticks)))
      failed |= print_outputs(fmus, out_fmu, out_vr, n_out, (double)(k + 1) * tick);
  }
  for (j = 0; j < n_ise; ++j) {
    printf("ise %s %u %.17g\n", fmus[ise[j].plant].name, (unsigned)ise[j].vr, ise[j].sum);
    failed |= !isfinite(ise[j].sum);
  }
  for (i = 0; i < n_fmus; ++i) {
    printf("time %s %.6f\n", fmus[i].name, fmus[i].busy);
    fmus[i].terminate(fmus[i].c);
    fmus[i].free_instance(fmus[i].c);
    close_library(fmus[i].lib);
  }
  printf("ticks %ld failed %d\n", k, failed);
  return failed ? 1 : 0;
}
