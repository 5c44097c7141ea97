/* A minimal FMI 2.0 host in C, with no Python anywhere in the process: it loads the plant FMU's
   binary with dlopen, hovers at the trim for STOP seconds in 12 ms steps under a state feedback
   read from LAW (the open-loop plant is unstable: round-off alone grows x83 per second), snapshots
   and restores the state half-way (the replay must match bit for bit) and frees everything.

   usage: fmu_host BINARY GUID STOP LAW
   LAW is text: the value references of x and f_R, the trim state (20), the trim input (4) and a
   gain K (4 x 24, row-major) acting on [x - x_trim; integrals of the x, y, z, psi errors].
   Exit 0 when every call succeeded, the state stayed finite, the load drifted <= 1e-9 m and
   the replay matched. */
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
  (void)env;
  fprintf(stderr, "[%s] %s (%d, %s)\n", name, message, (int)status, category);
}

typedef struct {
  unsigned vr_x, vr_u;
  double trim_x[20], trim_u[4], K[4][24], integral[4];
} Law;

static int read_law(const char* path, Law* law) {
  FILE* f = fopen(path, "r");
  int i, j, ok = f != NULL;
  ok = ok && fscanf(f, "%u %u", &law->vr_x, &law->vr_u) == 2;
  for (i = 0; ok && i < 20; ++i) ok = fscanf(f, "%lf", &law->trim_x[i]) == 1;
  for (i = 0; ok && i < 4; ++i) ok = fscanf(f, "%lf", &law->trim_u[i]) == 1;
  for (i = 0; ok && i < 4; ++i)
    for (j = 0; ok && j < 24; ++j) ok = fscanf(f, "%lf", &law->K[i][j]) == 1;
  if (f) fclose(f);
  memset(law->integral, 0, sizeof law->integral);
  return ok;
}

/* u = u_trim - K chi; the integrals of the x, y, z, psi errors advance after use (as the controller FMU does). */
static void control(Law* law, const double x[20], double h, double u[4]) {
  static const int regulated[4] = {0, 1, 2, 5};
  double chi[24];
  int i, j;
  for (i = 0; i < 20; ++i) chi[i] = x[i] - law->trim_x[i];
  for (i = 0; i < 4; ++i) chi[20 + i] = law->integral[i];
  for (i = 0; i < 4; ++i) {
    u[i] = law->trim_u[i];
    for (j = 0; j < 24; ++j) u[i] -= law->K[i][j] * chi[j];
  }
  for (i = 0; i < 4; ++i) law->integral[i] += h * chi[regulated[i]];
}

#define LOAD(name) fmi2##name##TYPE* name = (fmi2##name##TYPE*)dlsym(lib, "fmi2" #name)

int main(int argc, char** argv) {
  void* lib;
  fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
  fmi2Component c;
  fmi2ValueReference vr_state[20], vr_input[4];
  fmi2Real state[20], u[4], start[3], now[3], replay[3], drift = 0.0;
  Law law, law_at_snapshot;
  fmi2FMUstate snapshot = NULL;
  double stop, t = 0.0, h = 0.012;
  long k, n, half;
  int i, failed = 0;
  if (argc != 5 || !read_law(argv[4], &law)) {
    fprintf(stderr, "usage: %s BINARY GUID STOP LAW (a readable law file)\n", argv[0]);
    return 2;
  }
  for (i = 0; i < 20; ++i) vr_state[i] = law.vr_x + (unsigned)i;
  for (i = 0; i < 4; ++i) vr_input[i] = law.vr_u + (unsigned)i;
  law_at_snapshot = law;
  stop = atof(argv[3]);
  lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
  if (lib == NULL) {
    fprintf(stderr, "dlopen: %s\n", dlerror());
    return 1;
  }
  {
    LOAD(Instantiate); LOAD(SetupExperiment); LOAD(EnterInitializationMode); LOAD(ExitInitializationMode);
    LOAD(GetReal); LOAD(DoStep); LOAD(Terminate); LOAD(FreeInstance); LOAD(GetFMUstate); LOAD(SetFMUstate);
    LOAD(FreeFMUstate); LOAD(SetReal);
    if (!Instantiate || !SetupExperiment || !EnterInitializationMode || !ExitInitializationMode || !GetReal || !DoStep ||
        !Terminate || !FreeInstance || !GetFMUstate || !SetFMUstate || !FreeFMUstate || !SetReal) {
      fprintf(stderr, "missing fmi2 symbol\n");
      return 1;
    }
    c = Instantiate("plant", fmi2CoSimulation, argv[2], "file:///nowhere", &callbacks, fmi2False, fmi2False);
    if (c == NULL) return 1;
    failed |= SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK;
    failed |= EnterInitializationMode(c) != fmi2OK;
    failed |= ExitInitializationMode(c) != fmi2OK;
    failed |= GetReal(c, vr_state, 20, state) != fmi2OK;
    memcpy(start, state, sizeof start);
    n = lround(stop / h);
    half = n / 2;
    for (k = 0; k < n && !failed; ++k) {
      if (k == half) {
        failed |= GetFMUstate(c, &snapshot) != fmi2OK;
        law_at_snapshot = law;
      }
      t = k * h;
      control(&law, state, h, u);
      failed |= SetReal(c, vr_input, 4, u) != fmi2OK;
      failed |= DoStep(c, t, h, fmi2True) != fmi2OK;
      failed |= GetReal(c, vr_state, 20, state) != fmi2OK;
      for (i = 0; i < 20; ++i) failed |= !isfinite(state[i]);
      for (i = 0; i < 3; ++i)
        if (fabs(state[i] - start[i]) > drift) drift = fabs(state[i] - start[i]);
    }
    memcpy(now, state, sizeof now);
    /* replay the second half from the snapshot: it must give the same numbers to the bit */
    failed |= SetFMUstate(c, snapshot) != fmi2OK;
    law = law_at_snapshot;
    failed |= GetReal(c, vr_state, 20, state) != fmi2OK;
    for (k = half; k < n && !failed; ++k) {
      control(&law, state, h, u);
      failed |= SetReal(c, vr_input, 4, u) != fmi2OK;
      failed |= DoStep(c, k * h, h, fmi2True) != fmi2OK;
      failed |= GetReal(c, vr_state, 20, state) != fmi2OK;
    }
    memcpy(replay, state, sizeof replay);
    failed |= memcmp(replay, now, sizeof now) != 0;
    failed |= FreeFMUstate(c, &snapshot) != fmi2OK;
    failed |= Terminate(c) != fmi2OK;
    FreeInstance(c);
  }
  dlclose(lib);
  printf("steps %ld drift %.3e failed %d\n", n, drift, failed);
  return failed || !(drift <= 1e-9) ? 1 : 0;
}
