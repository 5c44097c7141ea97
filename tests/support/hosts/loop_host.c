/* A minimal FMI 2.0 master in C for the tiltload loop, with no Python anywhere in the process: it
   loads every FMU binary named in a plan file, sets their parameters, and steps them in order on a
   fixed tick (Gauss-Seidel, as tiltload's master does: before an instance steps, its inputs are set
   from the current outputs of their sources). At the end it prints the recorded outputs.

   usage: loop_host PLAN
   PLAN is text, one item a line:
     F name binary guid           an FMU instance (stepping order = file order)
     P name R|I|B|S vr value      a parameter (S: the rest of the line)
     C src R|B vr dst vr          a connection from src's output to dst's input
     T tick ticks                 the tick (s) and how many to run
     O name vr                    a Real to print at the end
   Exit 0 when every call succeeded and every recorded value is finite. */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define MAX_FMUS 8
#define MAX_LINKS 512

typedef struct {
  char name[64];
  void* lib;
  fmi2Component c;
  fmi2InstantiateTYPE* instantiate;
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

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
  (void)env; (void)category;
  if (status >= fmi2Warning) fprintf(stderr, "[%s] %s\n", name, message);
}

static int find(Fmu* fmus, int n, const char* name) {
  int i;
  for (i = 0; i < n; ++i)
    if (strcmp(fmus[i].name, name) == 0) return i;
  fprintf(stderr, "unknown instance %s\n", name);
  exit(2);
}

#define SYM(f, field, name) ((f)->field = (void*)dlsym((f)->lib, name)) == NULL

int main(int argc, char** argv) {
  static Fmu fmus[MAX_FMUS];
  static Link links[MAX_LINKS];
  fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
  char line[4096], name[64], other[64], binary[2048], guid[128], type;
  int n_fmus = 0, n_links = 0, n_out = 0, out_fmu[64], failed = 0, i;
  fmi2ValueReference out_vr[64];
  double tick = 0.0;
  long ticks = 0, k;
  FILE* plan;
  if (argc != 2 || (plan = fopen(argv[1], "r")) == NULL) {
    fprintf(stderr, "usage: %s PLAN\n", argv[0]);
    return 2;
  }
  while (fgets(line, sizeof line, plan)) {
    unsigned a, b;
    line[strcspn(line, "\n")] = '\0';
    if (line[0] == 'F' && sscanf(line, "F %63s %2047s %127s", name, binary, guid) == 3) {
      Fmu* f = &fmus[n_fmus++];
      strcpy(f->name, name);
      f->lib = dlopen(binary, RTLD_NOW | RTLD_LOCAL);
      if (f->lib == NULL) {
        fprintf(stderr, "dlopen %s: %s\n", binary, dlerror());
        return 1;
      }
      if (SYM(f, instantiate, "fmi2Instantiate") || SYM(f, setup, "fmi2SetupExperiment") ||
          SYM(f, enter, "fmi2EnterInitializationMode") || SYM(f, exit_init, "fmi2ExitInitializationMode") ||
          SYM(f, set_real, "fmi2SetReal") || SYM(f, set_integer, "fmi2SetInteger") || SYM(f, set_boolean, "fmi2SetBoolean") ||
          SYM(f, set_string, "fmi2SetString") || SYM(f, get_real, "fmi2GetReal") || SYM(f, get_boolean, "fmi2GetBoolean") ||
          SYM(f, do_step, "fmi2DoStep") || SYM(f, terminate, "fmi2Terminate") || SYM(f, free_instance, "fmi2FreeInstance")) {
        fprintf(stderr, "%s: missing fmi2 symbol\n", name);
        return 1;
      }
      f->c = f->instantiate(name, fmi2CoSimulation, guid, "", &callbacks, fmi2False, fmi2False);
      if (f->c == NULL) return 1;
      failed |= f->setup(f->c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK;
      failed |= f->enter(f->c) != fmi2OK;
    } else if (line[0] == 'P' && sscanf(line, "P %63s %c %u", name, &type, &a) == 3) {
      Fmu* f = &fmus[find(fmus, n_fmus, name)];
      const char* value = line;
      int spaces = 0;
      fmi2ValueReference vr = a;
      while (*value && spaces < 4) spaces += *value++ == ' ';
      if (type == 'R') {
        fmi2Real v = atof(value);
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
      Link* l = &links[n_links++];
      l->src = find(fmus, n_fmus, name);
      l->dst = find(fmus, n_fmus, other);
      l->type = type;
      l->src_vr = a;
      l->dst_vr = b;
    } else if (line[0] == 'T') {
      if (sscanf(line, "T %lf %ld", &tick, &ticks) != 2) return 2;
    } else if (line[0] == 'O' && sscanf(line, "O %63s %u", name, &a) == 2) {
      out_fmu[n_out] = find(fmus, n_fmus, name);
      out_vr[n_out++] = a;
    }
  }
  fclose(plan);
  for (i = 0; i < n_fmus; ++i) failed |= fmus[i].exit_init(fmus[i].c) != fmi2OK;
  for (k = 0; k < ticks && !failed; ++k) {
    for (i = 0; i < n_fmus && !failed; ++i) {
      int j;
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
      failed |= fmus[i].do_step(fmus[i].c, k * tick, tick, fmi2True) != fmi2OK;
    }
  }
  for (i = 0; i < n_out; ++i) {
    fmi2Real v = NAN;
    failed |= fmus[out_fmu[i]].get_real(fmus[out_fmu[i]].c, &out_vr[i], 1, &v) != fmi2OK;
    failed |= !isfinite(v);
    printf("%s %u %.17g\n", fmus[out_fmu[i]].name, out_vr[i], v);
  }
  for (i = 0; i < n_fmus; ++i) {
    fmus[i].terminate(fmus[i].c);
    fmus[i].free_instance(fmus[i].c);
    dlclose(fmus[i].lib);
  }
  printf("ticks %ld failed %d\n", k, failed);
  return failed ? 1 : 0;
}
