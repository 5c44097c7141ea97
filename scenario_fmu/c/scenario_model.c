/* The scenario FMU's hooks: the reference of the chosen trajectory and the three gusts, sampled
   at t_k in doStep(t_k, h) and held over the step (docs/ports.md, Timing). The trajectories and the gust are
   CasADi-generated (tl_scenario_gen.c); durations and starts come from scenario_table.h. */
#include "tl_platform.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "scenario_table.h"
#include "tl_fmu.h"
#include "tl_scenario_gen.h"
#include "tl_scenario_gen_sizes.h"

TL_STATIC_ASSERT(TL_REAL_az_ref - TL_REAL_x_ref == 8, "position, velocity, acceleration references are contiguous");
TL_STATIC_ASSERT(TL_REAL_d_z - TL_REAL_d_x == 2 && TL_REAL_z_start - TL_REAL_x_start == 2, "three axes");
TL_STATIC_ASSERT(TL_REAL_gust_z_at - TL_REAL_gust_x_at == 2, "three gust onsets");
TL_STATIC_ASSERT(TL_TRAJECTORY_1_SZ_IW <= 8 && TL_TRAJECTORY_2_SZ_IW <= 8 && TL_TRAJECTORY_3_SZ_IW <= 8 && TL_GUST_SZ_IW <= 8,
               "integer work fits");
TL_STATIC_ASSERT(TL_TRAJECTORY_2_SZ_ARG <= 8 && TL_GUST_SZ_ARG <= 8, "arguments fit");
TL_STATIC_ASSERT(TL_N_TRAJECTORIES == 4, "hover and three generated trajectories");

typedef int (*Generated)(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem);

static int call(Generated f, const double* const* in, int n_in, double* out) {
  const double* arg[8];
  double* res[2];
  casadi_int iw[8];
  double w[TL_SCENARIO_MAX_W];
  int i;
  for (i = 0; i < n_in; ++i) arg[i] = in[i];
  res[0] = out;
  return f(arg, res, iw, w, 0);
}

static fmi2Status evaluate(TlInstance* c, double t) {
  double* r = c->s.real;
  int trajectory = c->s.integer[TL_INTEGER_trajectory], i;
  const double* in[4];
  in[0] = &t;
  if (trajectory == 0) {
    memset(r + TL_REAL_x_ref, 0, 9 * sizeof(double));
  } else if (call(trajectory == 1 ? tl_trajectory_1 : trajectory == 2 ? tl_trajectory_2 : tl_trajectory_3, in, 1,
                  r + TL_REAL_x_ref)) {
    tl_log(c, fmi2Error, "trajectory %d evaluation failed at t=%.6g s", trajectory, t);
    return fmi2Error;
  }
  for (i = 0; i < 3; ++i) {
    in[1] = &c->s.model.onset[i];
    in[2] = &r[TL_REAL_gust_magnitude];
    in[3] = &r[TL_REAL_gust_tau];
    r[TL_REAL_d_x + i] = 0.0;
    if (c->s.boolean[TL_BOOLEAN_gusts] && call(tl_gust, in, 4, &r[TL_REAL_d_x + i])) return fmi2Error;
  }
  return fmi2OK;
}

/* Duration, start and gust onsets of the chosen trajectory (0 hover: the defaults of trajectory 0). */
static void set_up(TlInstance* c) {
  int trajectory = c->s.integer[TL_INTEGER_trajectory], i;
  int known = trajectory >= 0 && trajectory < TL_N_TRAJECTORIES;
  double duration = tl_duration[known ? trajectory : 0];
  c->s.real[TL_REAL_duration] = duration;
  for (i = 0; i < 3; ++i) {
    c->s.real[TL_REAL_x_start + i] = tl_start[known ? trajectory : 0][i];
    c->s.model.onset[i] = c->s.real[TL_REAL_gust_x_at + i] * duration;
  }
}

void tl_model_reset(TlInstance* c) {
  memset(&c->s.model, 0, sizeof c->s.model);
  tl_model_outputs(c);
}

fmi2Status tl_model_outputs(TlInstance* c) {
  int trajectory = c->s.integer[TL_INTEGER_trajectory];
  set_up(c);
  if (trajectory < 0 || trajectory >= TL_N_TRAJECTORIES) return fmi2OK; /* refused at initialization */
  return evaluate(c, c->s.time);
}

fmi2Status tl_model_initialize(TlInstance* c) {
  const double* r = c->s.real;
  int trajectory = c->s.integer[TL_INTEGER_trajectory], i;
  if (trajectory < 0 || trajectory >= TL_N_TRAJECTORIES) {
    tl_log(c, fmi2Error, "invalid scenario parameters: trajectory must be 0, 1, 2 or 3, got %d", trajectory);
    return fmi2Error;
  }
  if (!(r[TL_REAL_gust_tau] >= 0.0)) {
    tl_log(c, fmi2Error, "invalid scenario parameters: gust_tau must be >= 0, got %g", r[TL_REAL_gust_tau]);
    return fmi2Error;
  }
  for (i = 0; i < 3; ++i) {
    if (!(r[TL_REAL_gust_x_at + i] >= 0.0)) {
      tl_log(c, fmi2Error, "invalid scenario parameters: gust onsets must be non-negative fractions, got %s = %g",
             tl_real_name[TL_REAL_gust_x_at + i], r[TL_REAL_gust_x_at + i]);
      return fmi2Error;
    }
  }
  return tl_model_outputs(c);
}

fmi2Status tl_model_step(TlInstance* c, double t, double h) {
  (void)h;
  return evaluate(c, t);
}
