/* The scenario FMU's hooks: the reference of the chosen trajectory, the thesis's three gusts and the wind,
   sampled at t_k in doStep(t_k, h) and held over the step (docs/ports.md, Timing). The thesis trajectories, the
   shapes and the gust are CasADi-generated (tl_scenario_gen.c); the waypoints' quintics and the wind are
   scenario_waypoints.c and scenario_wind.c; durations, starts and capacities come from scenario_table.h. */
#include "tl_platform.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "scenario_table.h"
#include "scenario_waypoints.h"
#include "scenario_wind.h"
#include "tl_fmu.h"
#include "tl_scenario_gen.h"
#include "tl_scenario_gen_sizes.h"

#define WAYPOINTS 4 /* trajectory codes: 0-3 the thesis's, 4 waypoints, 5-8 the shapes */
#define FIRST_SHAPE 5
#define LAST_SHAPE 8

TL_STATIC_ASSERT(TL_REAL_az_ref - TL_REAL_x_ref == 8, "position, velocity, acceleration references are contiguous");
TL_STATIC_ASSERT(TL_REAL_psi_dot_ref - TL_REAL_psi_ref == 1, "yaw and its rate");
TL_STATIC_ASSERT(TL_REAL_d_z - TL_REAL_d_x == 2 && TL_REAL_z_start - TL_REAL_x_start == 2, "three axes");
TL_STATIC_ASSERT(TL_REAL_gust_z_at - TL_REAL_gust_x_at == 2, "three gust onsets");
TL_STATIC_ASSERT(TL_REAL_steady_wind_z - TL_REAL_steady_wind_x == 2 && TL_REAL_wind_vz - TL_REAL_wind_vx == 2 &&
                   TL_REAL_turbulence_w - TL_REAL_turbulence_u == 2,
               "wind vectors");
TL_STATIC_ASSERT(TL_REAL_dryden_sigma_w - TL_REAL_dryden_sigma_u == 2 && TL_REAL_dryden_L_w - TL_REAL_dryden_L_u == 2,
               "Dryden intensities and scale lengths");
TL_STATIC_ASSERT(TL_REAL_shape_duration - TL_REAL_shape_center_x == TL_N_SHAPE_PARAMETERS - 1, "shape parameters are one vector");
TL_STATIC_ASSERT(TL_REAL_wind_profile_z_0 - TL_REAL_wind_profile_t_0 == 3 * TL_MAX_PROFILE, "profile blocks are contiguous");
TL_STATIC_ASSERT(TL_TRAJECTORY_1_SZ_IW <= 8 && TL_TRAJECTORY_2_SZ_IW <= 8 && TL_TRAJECTORY_3_SZ_IW <= 8 && TL_GUST_SZ_IW <= 8 &&
                   TL_SHAPE_LEMNISCATE_SZ_IW <= 8 && TL_SHAPE_LISSAJOUS_SZ_IW <= 8 && TL_SHAPE_STEP_SZ_IW <= 8 &&
                   TL_SHAPE_RAMP_SZ_IW <= 8,
               "integer work fits");
TL_STATIC_ASSERT(TL_TRAJECTORY_2_SZ_ARG <= 8 && TL_GUST_SZ_ARG <= 8 && TL_SHAPE_STEP_SZ_ARG <= 8, "arguments fit");
TL_STATIC_ASSERT(TL_N_TRAJECTORIES == 4, "hover and three generated thesis trajectories");

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

static const double* wp_block(const TlInstance* c, int block) { return c->s.model.knot[block]; }

static const double* profile_block(const TlInstance* c, int block) {
  return &c->s.real[TL_REAL_wind_profile_t_0 + block * TL_MAX_PROFILE];
}

/* position, velocity, acceleration (9), yaw and yaw rate of the reference at t */
static int reference(const TlInstance* c, double t, double out[11]) {
  static const Generated thesis[] = {tl_trajectory_1, tl_trajectory_2, tl_trajectory_3};
  static const Generated shape[] = {tl_shape_lemniscate, tl_shape_lissajous, tl_shape_step, tl_shape_ramp};
  int trajectory = c->s.integer[TL_INTEGER_trajectory], n = c->s.model.knots, k;
  const double* in[2];
  in[0] = &t;
  in[1] = &c->s.real[TL_REAL_shape_center_x];
  memset(out, 0, 11 * sizeof(double));
  if (trajectory == 0) return 0;
  if (trajectory == WAYPOINTS) {
    for (k = 0; k < 4; ++k) {
      double axis[3];
      tl_waypoints_axis(n, wp_block(c, 0), wp_block(c, 1 + 3 * k), wp_block(c, 2 + 3 * k), wp_block(c, 3 + 3 * k), t, axis);
      if (k < 3) out[k] = axis[0], out[3 + k] = axis[1], out[6 + k] = axis[2];
      else out[9] = axis[0], out[10] = axis[1];
    }
    return 0;
  }
  if (trajectory >= FIRST_SHAPE) return call(shape[trajectory - FIRST_SHAPE], in, 2, out);
  return call(thesis[trajectory - 1], in, 1, out);
}

static void wind(TlInstance* c, double t, double w[3]) {
  double* r = c->s.real;
  double uvw[3] = {0.0, 0.0, 0.0}, profile[3];
  int i, j;
  if (c->s.integer[TL_INTEGER_dryden] > 0) tl_dryden_output(&c->s.model.dryden, c->s.model.turbulence, uvw);
  tl_wind_profile(c->s.integer[TL_INTEGER_wind_profile_count], profile_block(c, 0), profile_block(c, 1), profile_block(c, 2),
                  profile_block(c, 3), t, profile);
  for (i = 0; i < 3; ++i) {
    w[i] = r[TL_REAL_steady_wind_x + i] + profile[i];
    for (j = 0; j < 3; ++j) w[i] += c->s.model.axes[j][i] * uvw[j];
    r[TL_REAL_turbulence_u + i] = uvw[i];
    r[TL_REAL_wind_vx + i] = w[i];
  }
}

static TlStatus evaluate(TlInstance* c, double t) {
  double* r = c->s.real;
  double out[11], w[3], speed, drag;
  int i;
  const double* in[4];
  if (reference(c, t, out)) {
    tl_log(c, TL_ERROR, "trajectory %d evaluation failed at t=%.6g s", c->s.integer[TL_INTEGER_trajectory], t);
    return TL_ERROR;
  }
  memcpy(r + TL_REAL_x_ref, out, 9 * sizeof(double));
  r[TL_REAL_psi_ref] = out[9];
  r[TL_REAL_psi_dot_ref] = out[10];
  wind(c, t, w);
  speed = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  drag = 0.5 * r[TL_REAL_air_density] * r[TL_REAL_drag_area] * speed;
  in[0] = &t;
  for (i = 0; i < 3; ++i) {
    in[1] = &c->s.model.onset[i];
    in[2] = &r[TL_REAL_gust_magnitude];
    in[3] = &r[TL_REAL_gust_tau];
    r[TL_REAL_d_x + i] = 0.0;
    if (c->s.boolean[TL_BOOLEAN_gusts] && call(tl_gust, in, 4, &r[TL_REAL_d_x + i])) return TL_ERROR;
    r[TL_REAL_d_x + i] += drag * w[i];
  }
  return TL_OK;
}

static int known(int trajectory) { return trajectory >= 0 && trajectory <= LAST_SHAPE; }

/* Duration, start and gust onsets of the chosen trajectory (0 hover: the defaults of trajectory 0), the turbulence's
   parameters. */
static void set_up(TlInstance* c) {
  double* r = c->s.real;
  int trajectory = c->s.integer[TL_INTEGER_trajectory], n = c->s.model.knots, i;
  double duration = tl_duration[0], start[11] = {0.0};
  if (trajectory >= 0 && trajectory < TL_N_TRAJECTORIES) {
    duration = tl_duration[trajectory];
    memcpy(start, tl_start[trajectory], 3 * sizeof(double));
  } else if (known(trajectory)) {
    duration = trajectory == WAYPOINTS ? (n >= 2 && n <= TL_MAX_WAYPOINTS ? wp_block(c, 0)[n - 1] : 0.0) : r[TL_REAL_shape_duration];
    if (trajectory != WAYPOINTS || (n >= 2 && n <= TL_MAX_WAYPOINTS)) (void)reference(c, 0.0, start);
  }
  r[TL_REAL_duration] = duration;
  for (i = 0; i < 3; ++i) {
    r[TL_REAL_x_start + i] = start[i];
    c->s.model.onset[i] = r[TL_REAL_gust_x_at + i] * duration;
  }
  if (c->s.integer[TL_INTEGER_dryden] >= 1 && c->s.integer[TL_INTEGER_dryden] <= 3) {
    tl_dryden_parameters(c->s.integer[TL_INTEGER_dryden], r[TL_REAL_dryden_altitude], r[TL_REAL_dryden_airspeed],
                         &r[TL_REAL_steady_wind_x], &c->s.model.dryden);
  } else {
    memset(&c->s.model.dryden, 0, sizeof c->s.model.dryden);
  }
  tl_wind_axes(&r[TL_REAL_steady_wind_x], c->s.model.axes);
  for (i = 0; i < 3; ++i) {
    r[TL_REAL_dryden_sigma_u + i] = c->s.model.dryden.sigma[i];
    r[TL_REAL_dryden_L_u + i] = c->s.model.dryden.length[i];
  }
  r[TL_REAL_dryden_V] = c->s.model.dryden.airspeed;
}

void tl_model_reset(TlInstance* c) {
  memset(&c->s.model, 0, sizeof c->s.model);
  tl_model_outputs(c);
}

TlStatus tl_model_outputs(TlInstance* c) {
  int trajectory = c->s.integer[TL_INTEGER_trajectory], n = c->s.model.knots;
  set_up(c);
  if (!known(trajectory) || (trajectory == WAYPOINTS && (n < 2 || n > TL_MAX_WAYPOINTS))) return TL_OK; /* refused at initialization */
  if (c->s.integer[TL_INTEGER_wind_profile_count] < 0 || c->s.integer[TL_INTEGER_wind_profile_count] > TL_MAX_PROFILE) return TL_OK;
  return evaluate(c, c->s.time);
}

#define REFUSE(...)                                               \
  do {                                                            \
    tl_log(c, TL_ERROR, "invalid scenario parameters: " __VA_ARGS__); \
    return TL_ERROR;                                             \
  } while (0)

/* Times increasing and every value finite in `blocks` consecutive blocks of `stride` entries, n used. */
static int bad_table(const double* table, int blocks, int stride, int n, int* row) {
  int b, i;
  for (i = 0; i < n; ++i) {
    *row = i;
    for (b = 0; b < blocks; ++b)
      if (!isfinite(table[b * stride + i])) return 1;
    if (i > 0 && !(table[i] > table[i - 1])) return 2;
  }
  return 0;
}

/* The knot file named by waypoints_file: as given when absolute, else in the FMU's resources folder. */
static TlStatus load_knots(TlInstance* c) {
  const char* name = c->s.string[TL_STRING_waypoints_file];
  char path[TL_STRING_LEN + 4096], why[TL_STRING_LEN + 200];
  int absolute = name[0] == '/' || name[0] == '\\' || (name[0] != '\0' && name[1] == ':');
  if (name[0] == '\0') REFUSE("trajectory 4 needs waypoints_file: the knot file of the mission (docs/test_bench.md)");
  if (!absolute && c->resources == NULL) REFUSE("waypoints_file %s is relative and the FMU was given no resources folder", name);
  if (!absolute && strlen(c->resources) >= sizeof path - TL_STRING_LEN) REFUSE("the resources folder's path is too long");
  snprintf(path, sizeof path, "%s%s", absolute ? "" : c->resources, name);
  if (tl_waypoints_load(path, c->s.model.knot, &c->s.model.knots, why, sizeof why)) REFUSE("waypoints_file %s", why);
  return TL_OK;
}

static TlStatus check_reference(TlInstance* c) {
  const double* r = c->s.real;
  int trajectory = c->s.integer[TL_INTEGER_trajectory], n, i, row;
  if (!known(trajectory)) REFUSE("trajectory must be 0 to %d, got %d", LAST_SHAPE, trajectory);
  c->s.model.knots = 0;
  if (trajectory != WAYPOINTS && c->s.string[TL_STRING_waypoints_file][0] != '\0')
    REFUSE("waypoints_file is trajectory 4's; trajectory is %d", trajectory);
  if (trajectory == WAYPOINTS) {
    if (load_knots(c) != TL_OK) return TL_ERROR;
    n = c->s.model.knots;
    if (n < 2) REFUSE("waypoints_file %s has %d knots; a mission has 2 to %d", c->s.string[TL_STRING_waypoints_file], n, TL_MAX_WAYPOINTS);
    switch (bad_table(wp_block(c, 0), TL_KNOT_COLUMNS, TL_MAX_WAYPOINTS, n, &row)) {
      case 1: REFUSE("knot %d of waypoints_file has a value that is not finite", row);
      case 2: REFUSE("knot %d of waypoints_file: t = %g is not after the previous knot's t = %g", row, wp_block(c, 0)[row],
                     wp_block(c, 0)[row - 1]);
      default: break;
    }
  }
  if (trajectory >= FIRST_SHAPE) {
    for (i = 0; i < TL_N_SHAPE_PARAMETERS; ++i)
      if (!isfinite(r[TL_REAL_shape_center_x + i])) REFUSE("%s is not finite", tl_real_name[TL_REAL_shape_center_x + i]);
    if (!(r[TL_REAL_shape_period] > 0.0)) REFUSE("shape_period must be > 0, got %g", r[TL_REAL_shape_period]);
    if (!(r[TL_REAL_shape_duration] > 0.0)) REFUSE("shape_duration must be > 0, got %g", r[TL_REAL_shape_duration]);
    if (!(r[TL_REAL_shape_rise] >= 0.0)) REFUSE("shape_rise must be >= 0, got %g", r[TL_REAL_shape_rise]);
  }
  return TL_OK;
}

static TlStatus check_wind(TlInstance* c) {
  const double* r = c->s.real;
  int dryden = c->s.integer[TL_INTEGER_dryden], n = c->s.integer[TL_INTEGER_wind_profile_count], i, row;
  for (i = 0; i < 3; ++i)
    if (!isfinite(r[TL_REAL_steady_wind_x + i])) REFUSE("%s is not finite", tl_real_name[TL_REAL_steady_wind_x + i]);
  if (dryden < 0 || dryden > 3) REFUSE("dryden must be 0 (none), 1 light, 2 moderate or 3 severe, got %d", dryden);
  if (dryden > 0 && !(r[TL_REAL_dryden_altitude] >= TL_DRYDEN_MIN_ALTITUDE && r[TL_REAL_dryden_altitude] <= TL_DRYDEN_MAX_ALTITUDE))
    REFUSE("dryden_altitude must be %.4g to %.4g m (MIL-F-8785C low altitude), got %g", TL_DRYDEN_MIN_ALTITUDE,
           TL_DRYDEN_MAX_ALTITUDE, r[TL_REAL_dryden_altitude]);
  if (!(r[TL_REAL_dryden_airspeed] >= 0.0 && isfinite(r[TL_REAL_dryden_airspeed])))
    REFUSE("dryden_airspeed must be >= 0, got %g", r[TL_REAL_dryden_airspeed]);
  if (!(r[TL_REAL_drag_area] >= 0.0 && isfinite(r[TL_REAL_drag_area]))) REFUSE("drag_area must be >= 0, got %g", r[TL_REAL_drag_area]);
  if (!(r[TL_REAL_air_density] >= 0.0 && isfinite(r[TL_REAL_air_density])))
    REFUSE("air_density must be >= 0, got %g", r[TL_REAL_air_density]);
  if (c->s.integer[TL_INTEGER_seed] < 0) REFUSE("seed must be >= 0, got %d", c->s.integer[TL_INTEGER_seed]);
  if (n < 0 || n > TL_MAX_PROFILE) REFUSE("wind_profile_count must be 0 to %d, got %d", TL_MAX_PROFILE, n);
  switch (bad_table(profile_block(c, 0), 4, TL_MAX_PROFILE, n, &row)) {
    case 1: REFUSE("wind profile row %d has a value that is not finite", row);
    case 2: REFUSE("wind_profile_t_%d is not after wind_profile_t_%d", row, row - 1);
    default: break;
  }
  return TL_OK;
}

TlStatus tl_model_initialize(TlInstance* c) {
  const double* r = c->s.real;
  int i;
  for (i = 0; i < TL_N_REAL; ++i) /* used or not (a table's spare rows), a parameter that is not a number is a mistake */
    if (tl_real_settable[i] == 1 && !isfinite(r[i])) REFUSE("%s = %g is not finite", tl_real_name[i], r[i]);
  if (check_reference(c) != TL_OK || check_wind(c) != TL_OK) return TL_ERROR;
  if (!(r[TL_REAL_gust_tau] >= 0.0)) REFUSE("gust_tau must be >= 0, got %g", r[TL_REAL_gust_tau]);
  for (i = 0; i < 3; ++i) {
    if (!(r[TL_REAL_gust_x_at + i] >= 0.0))
      REFUSE("gust onsets must be non-negative fractions, got %s = %g", tl_real_name[TL_REAL_gust_x_at + i], r[TL_REAL_gust_x_at + i]);
  }
  set_up(c);
  memset(c->s.model.turbulence, 0, sizeof c->s.model.turbulence);
  memset(&c->s.model.step, 0, sizeof c->s.model.step);
  c->s.model.sample = 0;
  if (c->s.integer[TL_INTEGER_dryden] > 0)
    tl_dryden_start(&c->s.model.dryden, (uint64_t)c->s.integer[TL_INTEGER_seed], c->s.model.turbulence);
  return tl_model_outputs(c);
}

TlStatus tl_model_step(TlInstance* c, double t, double h) {
  TlStatus status = evaluate(c, t); /* the sample at t_k, from the filters' state at t_k */
  if (status == TL_OK && c->s.integer[TL_INTEGER_dryden] > 0) {
    c->s.model.sample += 1;
    tl_dryden_step(&c->s.model.dryden, (uint64_t)c->s.integer[TL_INTEGER_seed], c->s.model.sample, h, &c->s.model.step,
                   c->s.model.turbulence);
  }
  return status;
}
