/* A minimal FMI 2.0 host in C for long scenario runs (no Python in the process): loads the scenario FMU's
   binary with dlopen, sets parameters, steps it to STOP in steps of H and writes the chosen Real outputs after
   every step to standard output as raw native doubles.

   usage: wind_host BINARY GUID STOP H SETTING... OUTPUT...
   SETTING is rVR=VALUE (a Real) or iVR=VALUE (an Integer), OUTPUT is oVR; VR a value reference.
   Exit 0 when every call succeeded. */
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define MAX_OUTPUTS 16

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
  (void)env;
  fprintf(stderr, "[%s] %s (%d, %s)\n", name, message, (int)status, category);
}

#define LOAD(name) fmi2##name##TYPE* name = (fmi2##name##TYPE*)dlsym(lib, "fmi2" #name)

int main(int argc, char** argv) {
  void* lib;
  fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
  fmi2Component c;
  fmi2ValueReference outputs[MAX_OUTPUTS];
  fmi2Real values[MAX_OUTPUTS];
  double stop, h;
  long k, n;
  int i, n_out = 0, failed = 0;
  if (argc < 5) {
    fprintf(stderr, "usage: %s BINARY GUID STOP H [rVR=VALUE | iVR=VALUE | oVR]...\n", argv[0]);
    return 2;
  }
  stop = atof(argv[3]);
  h = atof(argv[4]);
  lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
  if (lib == NULL) {
    fprintf(stderr, "dlopen: %s\n", dlerror());
    return 1;
  }
  {
    LOAD(Instantiate); LOAD(SetupExperiment); LOAD(EnterInitializationMode); LOAD(ExitInitializationMode);
    LOAD(GetReal); LOAD(SetReal); LOAD(SetInteger); LOAD(DoStep); LOAD(Terminate); LOAD(FreeInstance);
    if (!Instantiate || !SetupExperiment || !EnterInitializationMode || !ExitInitializationMode || !GetReal || !SetReal ||
        !SetInteger || !DoStep || !Terminate || !FreeInstance) {
      fprintf(stderr, "missing fmi2 symbol\n");
      return 1;
    }
    c = Instantiate("scenario", fmi2CoSimulation, argv[2], "file:///nowhere", &callbacks, fmi2False, fmi2False);
    if (c == NULL) return 1;
    failed |= SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK;
    failed |= EnterInitializationMode(c) != fmi2OK;
    for (i = 5; i < argc && !failed; ++i) {
      fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i] + 1, NULL, 10);
      const char* eq = strchr(argv[i], '=');
      if (argv[i][0] == 'o' && n_out < MAX_OUTPUTS) {
        outputs[n_out++] = vr;
      } else if (argv[i][0] == 'r' && eq) {
        fmi2Real v = atof(eq + 1);
        failed |= SetReal(c, &vr, 1, &v) != fmi2OK;
      } else if (argv[i][0] == 'i' && eq) {
        fmi2Integer v = atoi(eq + 1);
        failed |= SetInteger(c, &vr, 1, &v) != fmi2OK;
      } else {
        fprintf(stderr, "bad argument %s\n", argv[i]);
        return 2;
      }
    }
    failed |= ExitInitializationMode(c) != fmi2OK;
    n = lround(stop / h);
    for (k = 0; k < n && !failed; ++k) {
      failed |= DoStep(c, k * h, h, fmi2True) != fmi2OK;
      failed |= GetReal(c, outputs, (size_t)n_out, values) != fmi2OK;
      failed |= fwrite(values, sizeof(fmi2Real), (size_t)n_out, stdout) != (size_t)n_out;
    }
    failed |= Terminate(c) != fmi2OK;
    FreeInstance(c);
  }
  dlclose(lib);
  return failed ? 1 : 0;
}
