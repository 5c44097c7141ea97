/* Times one FMU's fmi2DoStep from C, with no Python in the process (benchmarks/fmu_arithmetic.py drives it).

   usage: fmu_arithmetic_host BINARY GUID STEP STEPS ROUNDS [VR ...]
   Instantiates the FMU with its start values, initializes it and takes a snapshot; then ROUNDS times: restore the
   snapshot and run STEPS doSteps of STEP seconds, timing each doStep alone (the restore is not timed). Prints two
   lines per round, "round ns_per_step" and "steps ns ns ..." (every step's own time: the caller can keep each
   step's least time over the rounds, which a shared machine disturbs far less than whole rounds), then
   "value VR x" for each Real VR asked for (after the last round), so the caller can check the run did the work
   it meant (the estimator used its strips, the plant stayed finite).
   ROUNDS 0 runs STEPS steps once untimed: for callgrind, whose instruction counts difference two step counts. */
#define _POSIX_C_SOURCE 199309L
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
  (void)env;
  fprintf(stderr, "[%s] %s (%d, %s)\n", name, message, (int)status, category);
}

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

#define LOAD(name) fmi2##name##TYPE* name = (fmi2##name##TYPE*)dlsym(lib, "fmi2" #name)

int main(int argc, char** argv) {
  fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
  fmi2FMUstate start = NULL;
  fmi2Component c;
  double h, t0, *each = NULL;
  long steps, rounds, r, k;
  int i, failed = 0;
  void* lib;
  if (argc < 6 || (h = atof(argv[3])) <= 0.0 || (steps = atol(argv[4])) < 1 || (rounds = atol(argv[5])) < 0) {
    fprintf(stderr, "usage: %s BINARY GUID STEP STEPS ROUNDS [VR ...] (STEP > 0, STEPS >= 1, ROUNDS >= 0)\n", argv[0]);
    return 2;
  }
  lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
  if (lib == NULL) {
    fprintf(stderr, "dlopen: %s\n", dlerror());
    return 1;
  }
  {
    LOAD(Instantiate); LOAD(SetupExperiment); LOAD(EnterInitializationMode); LOAD(ExitInitializationMode);
    LOAD(GetReal); LOAD(DoStep); LOAD(Terminate); LOAD(FreeInstance); LOAD(GetFMUstate); LOAD(SetFMUstate);
    LOAD(FreeFMUstate);
    if (!Instantiate || !SetupExperiment || !EnterInitializationMode || !ExitInitializationMode || !GetReal || !DoStep ||
        !Terminate || !FreeInstance || !GetFMUstate || !SetFMUstate || !FreeFMUstate) {
      fprintf(stderr, "missing fmi2 symbol in %s\n", argv[1]);
      return 1;
    }
    c = Instantiate("bench", fmi2CoSimulation, argv[2], "file:///nowhere", &callbacks, fmi2False, fmi2False);
    if (c == NULL) return 1;
    failed |= SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK;
    failed |= EnterInitializationMode(c) != fmi2OK;
    failed |= ExitInitializationMode(c) != fmi2OK;
    failed |= GetFMUstate(c, &start) != fmi2OK;
    if (rounds && (each = (double*)malloc(sizeof(double) * (size_t)steps)) == NULL) failed = 1;
    for (r = 0; r < (rounds ? rounds : 1) && !failed; ++r) {
      double total = 0.0;
      failed |= SetFMUstate(c, start) != fmi2OK;
      for (k = 0; k < steps && !failed; ++k) {
        if (rounds) t0 = now();
        failed |= DoStep(c, (double)k * h, h, fmi2True) != fmi2OK;
        if (rounds) total += each[k] = now() - t0;
      }
      if (rounds && !failed) {
        printf("round %.1f\nsteps", total / (double)steps * 1e9);
        for (k = 0; k < steps; ++k) printf(" %.0f", each[k] * 1e9);
        printf("\n");
      }
    }
    free(each);
    for (i = 6; i < argc && !failed; ++i) {
      fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i], NULL, 10);
      fmi2Real v;
      failed |= GetReal(c, &vr, 1, &v) != fmi2OK;
      printf("value %u %.17g\n", (unsigned)vr, v);
    }
    failed |= FreeFMUstate(c, &start) != fmi2OK;
    failed |= Terminate(c) != fmi2OK;
    FreeInstance(c);
  }
  dlclose(lib);
  return failed ? 1 : 0;
}
