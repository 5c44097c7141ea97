/* The plant FMU's hooks: parameter checks, actuator saturation and fixed-step RK4 on the
   CasADi-generated model (tl_plant_gen.c). All values live in the layer's variable array, laid
   out by the variable table so that states, inputs and parameters are the model's vectors.
   One source for both vehicles (with the load, and the UAV alone): plant_layout.h says where
   this one's parameters are and which checks they get. */
#include "tl_platform.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "tl_fmu.h"
#include "tl_plant_gen.h"
#include "tl_plant_gen_sizes.h"
#include "plant_layout.h"

#define NX TL_PLANT_NX
#define TL_PI 3.14159265358979323846
#define STATE(c) ((c)->s.real + TL_REAL_x)
#define STATE0(c) ((c)->s.real + TL_REAL_x_0)
#define OUTPUTS(c) ((c)->s.real + TL_REAL_x_B)
#define APPLIED(c) ((c)->s.real + TL_REAL_f_R_applied)
#define INPUTS(c) ((c)->s.real + TL_REAL_f_R)
#define DISTURBANCE(c) ((c)->s.real + TL_REAL_d_x)
#define PARAMS(c) ((c)->s.real + TL_PLANT_FIRST_PARAM)

TL_STATIC_ASSERT(TL_REAL_alpha_L_dot - TL_REAL_x == NX - 1, "states are contiguous, in the model's order");
TL_STATIC_ASSERT(TL_REAL_alpha_L_dot_0 - TL_REAL_x_0 == NX - 1, "initial states are contiguous");
TL_STATIC_ASSERT(TL_REAL_L_z - TL_REAL_x_B == TL_PLANT_NY - 1, "diagnostic outputs are contiguous");
TL_STATIC_ASSERT(TL_PLANT_LAST_PARAM - TL_PLANT_FIRST_PARAM == TL_PLANT_NP - 1, "Table 5.1 parameters are contiguous");
TL_STATIC_ASSERT(TL_REAL_tau_L_applied - TL_REAL_f_R_applied == 3 && TL_REAL_tau_L - TL_REAL_f_R == 3, "four actuators");
TL_STATIC_ASSERT(TL_REAL_d_z - TL_REAL_d_x == 2, "three disturbance components");

static TlStatus evaluate_outputs(TlInstance* c) {
  const double* arg[TL_PLANT_OUT_SZ_ARG + 1];
  double* res[TL_PLANT_OUT_SZ_RES + 1];
  casadi_int iw[TL_PLANT_OUT_SZ_IW];
  double w[TL_PLANT_OUT_SZ_W];
  arg[0] = STATE(c);
  arg[1] = PARAMS(c);
  res[0] = OUTPUTS(c);
  return tl_plant_out(arg, res, iw, w, 0) ? TL_ERROR : TL_OK;
}

static double clamp(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

/* Table 5.2: the plant applies what the actuators can deliver. */
static void saturate(TlInstance* c) {
  const double *u = INPUTS(c), *r = c->s.real;
  double* a = APPLIED(c);
  a[0] = clamp(u[0], r[TL_REAL_f_min], r[TL_REAL_f_max]);
  a[1] = clamp(u[1], r[TL_REAL_f_min], r[TL_REAL_f_max]);
  a[2] = clamp(u[2], -r[TL_REAL_tau_max], r[TL_REAL_tau_max]);
  a[3] = clamp(u[3], -r[TL_REAL_tau_max], r[TL_REAL_tau_max]);
}

/* Eigenvalues of a symmetric 3x3 matrix (xx yy zz xy xz yz), ascending: the trigonometric
   closed form (Smith, CACM 1961). */
static void sym3_eigenvalues(const double* m, double e[3]) {
  double xx = m[0], yy = m[1], zz = m[2], xy = m[3], xz = m[4], yz = m[5];
  double off = xy * xy + xz * xz + yz * yz, q = (xx + yy + zz) / 3.0, p, r, phi, a, b, d;
  if (off == 0.0) {
    double t;
    e[0] = xx; e[1] = yy; e[2] = zz;
    if (e[0] > e[1]) { t = e[0]; e[0] = e[1]; e[1] = t; }
    if (e[1] > e[2]) { t = e[1]; e[1] = e[2]; e[2] = t; }
    if (e[0] > e[1]) { t = e[0]; e[0] = e[1]; e[1] = t; }
    return;
  }
  p = sqrt(((xx - q) * (xx - q) + (yy - q) * (yy - q) + (zz - q) * (zz - q) + 2.0 * off) / 6.0);
  a = (xx - q) / p; b = (yy - q) / p; d = (zz - q) / p;
  r = (a * (b * d - (yz / p) * (yz / p)) - (xy / p) * ((xy / p) * d - (yz / p) * (xz / p)) +
       (xz / p) * ((xy / p) * (yz / p) - b * (xz / p))) / 2.0;
  phi = r <= -1.0 ? TL_PI / 3.0 : r >= 1.0 ? 0.0 : acos(r) / 3.0;
  e[2] = q + 2.0 * p * cos(phi);
  e[0] = q + 2.0 * p * cos(phi + 2.0 * TL_PI / 3.0);
  e[1] = 3.0 * q - e[0] - e[2];
}

/* One line naming the first parameter that does not describe a physical plant (as the
   Python model's parameters.validate words it), or 0 if all are fine. */
static int check_parameters(TlInstance* c, char* why, size_t n) {
  static const int positive[] = {TL_PLANT_POSITIVE};
  static const int non_negative[] = {TL_PLANT_NON_NEGATIVE};
  static const int inertia[] = {TL_PLANT_INERTIA};
  static const char* const inertia_name[] = {TL_PLANT_INERTIA_NAMES};
  const double* r = c->s.real;
  size_t i;
  int k;
  for (i = 0; i < sizeof positive / sizeof *positive; ++i)
    if (!(r[positive[i]] > 0.0))
      return snprintf(why, n, "parameter %s must be positive, got %g", tl_real_name[positive[i]], r[positive[i]]);
  for (i = 0; i < sizeof non_negative / sizeof *non_negative; ++i)
    if (!(r[non_negative[i]] >= 0.0))
      return snprintf(why, n, "parameter %s must be non-negative, got %g", tl_real_name[non_negative[i]], r[non_negative[i]]);
  for (k = TL_REAL_lambda_R; k <= TL_REAL_lambda_L; ++k)
    if (r[k] != 1.0 && r[k] != -1.0) return snprintf(why, n, "parameter %s must be +1 or -1, got %g", tl_real_name[k], r[k]);
  if (!(fabs(r[TL_REAL_beta]) < TL_PI / 2.0))
    return snprintf(why, n, "parameter beta must lie in (-pi/2, pi/2) rad, got %g", r[TL_REAL_beta]);
  for (i = 0; i < TL_PLANT_N_INERTIA; ++i) {
    double e[3];
    sym3_eigenvalues(r + inertia[i], e);
    if (!(e[0] > 0.0))
      return snprintf(why, n, "inertia %s must be positive definite (smallest eigenvalue %.3g)", inertia_name[i], e[0]);
    if (e[0] + e[1] < e[2] * (1.0 - 1e-9))
      return snprintf(why, n, "inertia %s violates the triangle inequality of principal moments", inertia_name[i]);
  }
  if (!(0.0 <= r[TL_REAL_f_min] && r[TL_REAL_f_min] < r[TL_REAL_f_max] && r[TL_REAL_tau_max] > 0.0))
    return snprintf(why, n, "actuator limits need 0 <= f_min < f_max and tau_max > 0, got f_min=%g, f_max=%g, tau_max=%g",
                    r[TL_REAL_f_min], r[TL_REAL_f_max], r[TL_REAL_tau_max]);
  if (!(r[TL_REAL_integrator_step] > 0.0))
    return snprintf(why, n, "integrator_step must be a positive finite time, got %g", r[TL_REAL_integrator_step]);
  return 0;
}

void tl_model_reset(TlInstance* c) {
  memset(&c->s.model, 0, sizeof c->s.model);
  tl_model_outputs(c);
}

TlStatus tl_model_outputs(TlInstance* c) {
  memcpy(STATE(c), STATE0(c), NX * sizeof(double));
  saturate(c);
  return evaluate_outputs(c);
}

TlStatus tl_model_initialize(TlInstance* c) {
  char why[256];
  if (check_parameters(c, why, sizeof why)) {
    tl_log(c, TL_ERROR, "invalid plant parameters: %s", why);
    return TL_ERROR;
  }
  if (tl_model_outputs(c) != TL_OK) {
    tl_log(c, TL_ERROR, "plant output evaluation failed at the initial state");
    return TL_ERROR;
  }
  return TL_OK;
}

TlStatus tl_model_step(TlInstance* c, double t, double h) {
  TlModelState* m = &c->s.model;
  double step = c->s.real[TL_REAL_integrator_step], sub, cur[NX], next[NX], stuck[2];
  const double* arg[TL_PLANT_RK4_STUCK_SZ_ARG + 1];
  double* res[TL_PLANT_RK4_STUCK_SZ_RES + 1];
  casadi_int iw[TL_PLANT_RK4_STUCK_SZ_IW > TL_PLANT_RK4_SZ_IW ? TL_PLANT_RK4_STUCK_SZ_IW : TL_PLANT_RK4_SZ_IW];
  double w[TL_PLANT_RK4_STUCK_SZ_W > TL_PLANT_RK4_SZ_W ? TL_PLANT_RK4_STUCK_SZ_W : TL_PLANT_RK4_SZ_W];
  int any_stuck;
  long n, k;
  int i;
  if (m->stopped) {
    tl_log(c, TL_DISCARD, "plant stopped at t=%.6g s after an earlier error; no further steps", m->stopped_at);
    return TL_DISCARD;
  }
  if (h <= step * (1.0 + 1e-9)) {
    n = 1;
    sub = h;
  } else {
    n = lround(h / step);
    if (fabs((double)n * step - h) > 1e-6 * h) {
      tl_log(c, TL_ERROR, "communication step %.9g s is not a whole multiple of integrator_step %.9g s", h, step);
      return TL_ERROR;
    }
    sub = h / (double)n;
  }
  saturate(c);
  memcpy(cur, STATE(c), sizeof cur);
  {
    /* a servo stuck at its angle: the joint's rate is stopped when it sticks (an impulse along the
       servo's own generalized force), then the RK4 holds its acceleration at zero */
    double newly[2], stuck_cur[NX];
    const double* sarg[TL_PLANT_STICK_SZ_ARG + 1];
    double* sres[TL_PLANT_STICK_SZ_RES + 1];
    casadi_int siw[TL_PLANT_STICK_SZ_IW];
    double sw[TL_PLANT_STICK_SZ_W];
    stuck[0] = c->s.boolean[TL_BOOLEAN_servo_R_stuck] ? 1.0 : 0.0;
    stuck[1] = c->s.boolean[TL_BOOLEAN_servo_L_stuck] ? 1.0 : 0.0;
    newly[0] = stuck[0] && !m->stuck[0];
    newly[1] = stuck[1] && !m->stuck[1];
    if (newly[0] || newly[1]) {
      sarg[0] = cur;
      sarg[1] = PARAMS(c);
      sarg[2] = newly;
      sres[0] = stuck_cur;
      if (tl_plant_stick(sarg, sres, siw, sw, 0)) {
        tl_log(c, TL_ERROR, "plant model evaluation failed when a servo stuck at t=%.6g s", t);
        return TL_ERROR;
      }
      memcpy(cur, stuck_cur, sizeof cur);
    }
  }
  arg[1] = APPLIED(c);
  arg[2] = DISTURBANCE(c);
  arg[3] = PARAMS(c);
  arg[4] = &sub;
  arg[5] = stuck;
  res[0] = next;
  any_stuck = stuck[0] != 0.0 || stuck[1] != 0.0; /* the free model is cheaper: used whenever it can be */
  for (k = 1; k <= n; ++k) {
    arg[0] = cur;
    if (any_stuck ? tl_plant_rk4_stuck(arg, res, iw, w, 0) : tl_plant_rk4(arg, res, iw, w, 0)) {
      tl_log(c, TL_ERROR, "plant model evaluation failed at t=%.6g s", t);
      return TL_ERROR;
    }
    for (i = 0; i < NX; ++i) {
      if (!isfinite(next[i])) {
        m->stopped = 1;
        m->stopped_at = t;
        c->s.stop_requested = 1;
        tl_log(c, TL_DISCARD,
               "state diverged (non-finite) in substep %ld of the step from t=%.6g s; the state is kept at its last value "
               "and the plant stops", k, t);
        return TL_DISCARD;
      }
    }
    memcpy(cur, next, sizeof cur);
  }
  memcpy(STATE(c), cur, sizeof cur);
  m->stuck[0] = stuck[0] != 0.0;
  m->stuck[1] = stuck[1] != 0.0;
  return evaluate_outputs(c) == TL_OK ? TL_OK : TL_ERROR;
}
