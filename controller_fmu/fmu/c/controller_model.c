/* The controller FMU's hooks: each doStep(t_k, T_c) reads the reference and the sensor inputs at
   t_k, runs the estimator (none, LKF or ZSE), then u = sat(u_tr - K chi) with the feedforward
   (3.18) and the integral states, and holds u over the tick. As controller_fmu/reference/runtime.py, the
   Python reference the tests compare it with; the designs are embedded (controller_data.h). One source
   for both vehicles: controller_dims.h gives the state size, the first and last measurement, and
   whether this build has the LKF and the mixed design (the UAV alone has neither).
   Delay-aware designs (loop_delay_ticks d): the command computed now reaches the plant d ticks later (a Jacobi
   master adds one tick per connection, docs/ports.md); the gain then also acts on the d commands still on their way,
   and the estimator propagates with the command that drove the plant over the interval it was measured in.
   The clocked FMI 3.0 variant (TL_N_CLOCK > 0) runs the same tick in the Event Mode of each control_clock tick
   (tl_model_event); its steps only advance time. The Scheduled Execution variant (TL_SCHEDULED) runs it in the law's
   partition, from the samples the correction partitions latched (tl_model_partition). */
#include "tl_platform.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "controller_data.h"
#include "tl_feedforward_call.h"
#include "tl_fmu.h"
#include "tl_law.h"

#define NX TL_NX
#define NNU TL_NNU

TL_STATIC_ASSERT(TL_REAL_tau_L - TL_REAL_f_R == 3, "the four commands are contiguous");
TL_STATIC_ASSERT(TL_MAX_DELAY == TL_LAW_MAX_DELAY, "the law shifts as many commands in flight as the state keeps");
TL_STATIC_ASSERT(NNU == NX + 3, "the estimate is the state and three disturbance forces");
TL_STATIC_ASSERT(TL_REAL_est_d_z - TL_REAL_est_x == NNU - 1, "the estimate is contiguous");
TL_STATIC_ASSERT(TL_REAL_est_d_z_lo - TL_REAL_est_x_lo == NNU - 1 && TL_REAL_est_d_z_hi - TL_REAL_est_x_hi == NNU - 1, "bounds");
TL_STATIC_ASSERT(TL_REAL_psi_dot_ref - TL_REAL_x_ref == 10, "the 11 references are contiguous");
TL_STATIC_ASSERT(TL_REAL_exact_alpha_L_dot - TL_REAL_exact_x == NX - 1, "the exact state inputs are contiguous");
#if TL_HAS_LKF
TL_STATIC_ASSERT(TL_REAL_lkf_alpha_L - TL_REAL_lkf_x == TL_NY_LKF - 1, "the LKF's q inputs are contiguous");
#endif
TL_STATIC_ASSERT(TL_LAST_MEAS - TL_FIRST_MEAS == TL_NY_ZSE - 1, "the ZSE's measurements are contiguous, in pi order");

static const char* const controllers[] = {"dlqr", "mixed"};
static const char* const estimators[] = {"none", "lkf", "zse"};
static const char* const reductions[] = {"combastel", "girard", "pca"};

static TlZseModel zse_model(const TlInstance* c) {
  TlZseModel m = {tl_A_nu, tl_B_nu, tl_H_zse, tl_zse_c_w, tl_zse_Gw, tl_zse_sigma, tl_zse_s, tl_zse_hull_w, tl_zse_Sw,
                  4, TL_RW, TL_R_MAX, c->s.model.reduction};
  return m;
}

#if TL_HAS_LKF
static const TlLkfModel lkf_model = {tl_A_nu, tl_B_nu, tl_H_lkf, tl_Pw, tl_Pv, 4};
#endif

static int choose(const char* value, const char* const* names, int n) {
  int i;
  for (i = 0; i < n; ++i)
    if (strcmp(value, names[i]) == 0) return i;
  return -1;
}

/* Estimate, disturbance and bounds as outputs. */
static void publish_estimate(TlInstance* c, const double* half) {
  TlModelState* m = &c->s.model;
  double* r = c->s.real;
  double centre[NNU];
  int i;
  memcpy(centre, m->estimate, sizeof m->estimate); /* not a ternary per entry: gcc -O3 warns it reads past estimate */
  memcpy(centre + NX, m->disturbance, sizeof m->disturbance);
  for (i = 0; i < NNU; ++i) {
    r[TL_REAL_est_x + i] = centre[i];
    r[TL_REAL_est_x_lo + i] = centre[i] - (half ? half[i] : 0.0);
    r[TL_REAL_est_x_hi + i] = centre[i] + (half ? half[i] : 0.0);
  }
}

void tl_model_reset(TlInstance* c) {
  memset(&c->s.model, 0, sizeof c->s.model);
  tl_model_outputs(c);
}

/* Before the first tick: the trim inputs and the trim as the estimate. */
TlStatus tl_model_outputs(TlInstance* c) {
  TlModelState* m = &c->s.model;
  memcpy(c->s.real + TL_REAL_f_R, tl_trim_u, sizeof(double) * 4);
  memcpy(m->estimate, tl_trim_x, sizeof m->estimate);
  memset(m->disturbance, 0, sizeof m->disturbance);
  publish_estimate(c, NULL);
  return TL_OK;
}

TlStatus tl_model_initialize(TlInstance* c) {
  TlModelState* m = &c->s.model;
  const double* r = c->s.real;
  int i;
  m->controller = choose(c->s.string[TL_STRING_controller], controllers, 2);
  m->estimator = choose(c->s.string[TL_STRING_estimator], estimators, 3);
  m->reduction = choose(c->s.string[TL_STRING_zse_reduction], reductions, 3);
  if (m->controller < 0 || (m->controller == 1 && !TL_HAS_MIXED)) {
    tl_log(c, TL_ERROR, "invalid controller parameters: unknown controller '%s' (available: %s)",
           c->s.string[TL_STRING_controller], TL_HAS_MIXED ? "dlqr, mixed" : "dlqr");
    return TL_ERROR;
  }
  if (m->estimator < 0 || (m->estimator == 1 && !TL_HAS_LKF)) {
    tl_log(c, TL_ERROR, "invalid controller parameters: unknown estimator '%s' (available: %s)",
           c->s.string[TL_STRING_estimator], TL_HAS_LKF ? "none, lkf, zse" : "none, zse");
    return TL_ERROR;
  }
  if (m->reduction < 0) {
    tl_log(c, TL_ERROR, "invalid controller parameters: unknown zse_reduction '%s' (available: combastel, girard, pca)",
           c->s.string[TL_STRING_zse_reduction]);
    return TL_ERROR;
  }
  if (fabs(r[TL_REAL_Tc] - TL_TC) > 1e-12) {
    tl_log(c, TL_ERROR, "invalid controller parameters: Tc = %g s, but the embedded designs are for %g s (rebuild to change it)",
           r[TL_REAL_Tc], TL_TC);
    return TL_ERROR;
  }
  if (!(r[TL_REAL_f_min] < r[TL_REAL_f_max] && r[TL_REAL_tau_max] > 0.0)) {
    tl_log(c, TL_ERROR, "invalid controller parameters: actuator limits need f_min < f_max and tau_max > 0, got %g, %g, %g",
           r[TL_REAL_f_min], r[TL_REAL_f_max], r[TL_REAL_tau_max]);
    return TL_ERROR;
  }
  if (c->s.integer[TL_INTEGER_loop_delay_ticks] < 0 || c->s.integer[TL_INTEGER_loop_delay_ticks] > TL_MAX_DELAY) {
    tl_log(c, TL_ERROR, "invalid controller parameters: loop_delay_ticks = %d, the designs are made for 0 to %d ticks",
           (int)c->s.integer[TL_INTEGER_loop_delay_ticks], TL_MAX_DELAY);
    return TL_ERROR;
  }
  m->delay = (int)c->s.integer[TL_INTEGER_loop_delay_ticks];
  m->k = 0;
  memset(m->integral, 0, sizeof m->integral);
  for (i = 0; i <= TL_MAX_DELAY; ++i) memcpy(m->u_sent[i], tl_trim_u, sizeof m->u_sent[i]);
  memset(m->du_sent, 0, sizeof m->du_sent);
  return tl_model_outputs(c);
}

/* What the estimator reads at a tick: the co-simulation variants their inputs, the Scheduled Execution variant what its
   correction partitions latched. The same numbers either way, so the same arithmetic follows. */
typedef struct {
  const double* meas;   /* the ZSE's measurements, pi order (TL_NY_ZSE) */
  const int* group_new; /* per ZSE group: its sample is new at this tick */
  const double* q;      /* the LKF's measured q (TL_NY_LKF) */
} Samples;

/* Runs the chosen estimator for this tick; fills half-widths of the bounds. 0 ok, -1 numerical failure. */
static int estimate(TlInstance* c, const Samples* in, double* half, int* skipped) {
  TlModelState* m = &c->s.model;
  const double* r = c->s.real;
  double du[4], nu[NNU];
  int i;
  *skipped = 0;
  for (i = 0; i < 4; ++i) du[i] = m->u_sent[m->delay][i] - tl_trim_u[i]; /* drove the plant over the measured tick */
  if (m->estimator == 0) {
    memcpy(m->estimate, r + TL_REAL_exact_x, sizeof m->estimate);
    memset(half, 0, sizeof(double) * NNU);
    return 0;
  }
#if TL_HAS_LKF
  if (m->estimator == 1) {
    if (m->k == 0) { /* Sec. 5.3: the initial state is known, at rest at the start position */
      memset(nu, 0, sizeof nu);
      for (i = 0; i < 3; ++i) nu[i] = r[TL_REAL_x_0 + i] - tl_trim_x[i];
      tl_lkf_initialize(&m->lkf, nu, tl_P0);
    } else {
      double dy[TL_NY_LKF];
      int skip[TL_NY_LKF];
      for (i = 0; i < TL_NY_LKF; ++i) dy[i] = in->q[i] - tl_trim_x[i];
      if (tl_lkf_step(&m->lkf, &lkf_model, du, dy, NULL, skip, skipped)) return -1;
    }
    memcpy(nu, m->lkf.nu, sizeof nu);
    for (i = 0; i < NNU; ++i) {
      const double p = m->lkf.P[i * NNU + i];
      half[i] = 3.0 * sqrt(p > 0.0 ? p : 0.0);
    }
  } else
#endif
  {
    TlZseModel model = zse_model(c);
    TlZseReport report;
    int available[TL_NY_ZSE], g, j;
    memset(available, 0, sizeof available);
    for (g = 0; g < TL_N_ZSE_GROUPS; ++g)
      for (j = 0; j < tl_zse_groups[g].n; ++j) available[tl_zse_groups[g].index[j]] = in->group_new[g] != 0;
    if (m->k == 0) { /* Sec. 5.4: a box around the reference start, then the initial update with y_0 */
      double c0[NNU];
      memset(c0, 0, sizeof c0);
      for (i = 0; i < 3; ++i) c0[i] = m->reference_start[i] - tl_trim_x[i];
      if (tl_zse_initialize(&m->zse, &model, c0, tl_zse_G0, TL_R0, in->meas, available, &report)) return -1;
    } else if (tl_zse_step(&m->zse, &model, du, in->meas, available, &report)) {
      return -1;
    }
    *skipped = report.n_nonfinite + report.n_inconsistent;
    memcpy(nu, m->zse.c, sizeof nu);
    memcpy(half, m->zse.hull, sizeof(double) * NNU);
    c->s.real[TL_REAL_zse_G_frobenius] = tl_zse_frobenius(&m->zse);
    c->s.real[TL_REAL_zse_generators] = m->zse.r;
  }
  for (i = 0; i < NX; ++i) m->estimate[i] = tl_trim_x[i] + nu[i];
  for (i = 0; i < 3; ++i) m->disturbance[i] = nu[NX + i];
  return 0;
}

static int feedforward(const double* x_tr, const double* qdd, double* u_tr) {
  return tl_feedforward_eval(x_tr, qdd, tl_params, u_tr);
}

/* The shared law (tl_law.c) with this build's gain for the chosen controller and loop delay. */
static int control(TlInstance* c, double* u) {
  TlModelState* m = &c->s.model;
  TlLaw law;
  law.nx = NX;
  law.trim_x = tl_trim_x;
  law.K = tl_gains[m->controller * (TL_MAX_DELAY + 1) + m->delay];
  law.delay = m->delay;
  law.Tc = TL_TC;
  law.f_min = c->s.real[TL_REAL_f_min];
  law.f_max = c->s.real[TL_REAL_f_max];
  law.tau_max = c->s.real[TL_REAL_tau_max];
  law.feedforward = feedforward;
  return tl_law_step(&law, c->s.real + TL_REAL_x_ref, m->estimate, m->integral, m->du_sent, u);
}

/* One controller tick at t: estimate from the samples of t, the law, the command held until the next tick. */
static TlStatus control_tick(TlInstance* c, double t, const Samples* in) {
  TlModelState* m = &c->s.model;
  double half[NNU], u[4];
  int skipped, i;
  if (m->k == 0) memcpy(m->reference_start, c->s.real + TL_REAL_x_ref, sizeof m->reference_start);
  if (estimate(c, in, half, &skipped) || control(c, u)) {
    tl_log(c, TL_ERROR, "the %s estimator or the control law failed numerically at t=%.6g s", estimators[m->estimator], t);
    return TL_ERROR;
  }
  for (i = 0; i < 4; ++i)
    if (!isfinite(u[i])) {
      tl_log(c, TL_ERROR, "the controller produced a non-finite input at t=%.6g s (estimator %s); step refused", t,
             estimators[m->estimator]);
      return TL_ERROR;
    }
  memmove(m->u_sent[1], m->u_sent[0], sizeof(double) * 4 * TL_MAX_DELAY);
  memcpy(m->u_sent[0], u, sizeof u);
  memcpy(c->s.real + TL_REAL_f_R, u, sizeof u);
  publish_estimate(c, half);
  c->s.integer[TL_INTEGER_skipped_measurements] = skipped;
  if (skipped) tl_log(c, TL_WARNING, "t=%.6g s: skipped %d measurement entries (non-finite or inconsistent)", t, skipped);
  m->k += 1;
  return TL_OK;
}

#if TL_SCHEDULED
/* Scheduled Execution. A correction partition latches its group's sample (and flag) for the law; the law's partition
   takes everything latched and runs the tick: the strips of all groups of an instant meet in one update, as in the
   co-simulation variants, so the result is theirs bit for bit. The law ranks below the corrections (the importer
   activates one instant's partitions by priority); one it finds missing at its instant is the importer's error. A
   correction of the next instant may preempt the law anywhere: it latches into the next instant's slot, and the
   slots are touched under the importer's lock. */
TlStatus tl_model_step(TlInstance* c, double t, double h) {
  (void)t; (void)h;
  tl_log(c, TL_ERROR, "%s is a Scheduled Execution FMU: no communication steps", TL_MODEL_IDENTIFIER);
  return TL_ERROR;
}

/* The slot of the law instant a partition activated at t belongs to: the first law activation at or after t. */
static int slot_of(const TlInstance* c, double t) {
  return (int)((long long)ceil((t - c->s.start_time) / TL_TC - 1e-6) & 1);
}

static TlStatus law_partition(TlInstance* c, double t) {
  TlModelState* m = &c->s.model;
  double meas[TL_NY_ZSE], q[TL_NY_LKF];
  int fresh[TL_N_ZSE_GROUPS], k;
  const int slot = slot_of(c, t);
  Samples in;
  for (k = 0; k < TL_N_CLOCK; ++k)
    if (k != TL_CLOCK_control_clock && !tl_partition_done(c, k, t)) {
      tl_log(c, TL_ERROR, "the law at t=%.9g s needs the %s correction of the same instant first (its priority is higher); "
             "activate it before control_clock", t, tl_clock_name[k]);
      return TL_ERROR;
    }
  tl_lock_preemption(c);
  memcpy(meas, m->latched_meas[slot], sizeof meas);
  memcpy(fresh, m->latched_new[slot], sizeof fresh);
  memcpy(q, m->latched_q[slot], sizeof q);
  memset(m->latched_new[slot], 0, sizeof fresh); /* a group not activated before that slot's next law brings nothing new */
  tl_unlock_preemption(c);
  in.meas = meas;
  in.group_new = fresh;
  in.q = q;
  return control_tick(c, t, &in);
}

TlStatus tl_model_partition(TlInstance* c, int k, double t) {
  TlModelState* m = &c->s.model;
  const double* r = c->s.real;
  const int slot = slot_of(c, t);
  int g, j;
  if (k == TL_CLOCK_control_clock) return law_partition(c, t);
  for (g = 0; g < TL_N_ZSE_GROUPS; ++g)
    if (tl_zse_groups[g].clock == k) {
      tl_lock_preemption(c);
      for (j = 0; j < tl_zse_groups[g].n; ++j) {
        const int i = tl_zse_groups[g].index[j];
        m->latched_meas[slot][i] = r[TL_FIRST_MEAS + i];
      }
      m->latched_new[slot][g] = c->s.boolean[tl_zse_groups[g].flag] != 0;
      tl_unlock_preemption(c);
      return TL_OK;
    }
#if TL_HAS_LKF
  if (k == TL_CLOCK_lkf_clock) {
    tl_lock_preemption(c);
    memcpy(m->latched_q[slot], r + TL_REAL_lkf_x, sizeof m->latched_q[slot]);
    tl_unlock_preemption(c);
  }
#endif
  return TL_OK;
}
#else
/* The co-simulation variants read the tick's samples from their inputs. */
static TlStatus tick_from_inputs(TlInstance* c, double t) {
  int flags[TL_N_ZSE_GROUPS], g;
  Samples in;
  for (g = 0; g < TL_N_ZSE_GROUPS; ++g) flags[g] = c->s.boolean[tl_zse_groups[g].flag] != 0;
  in.meas = c->s.real + TL_FIRST_MEAS;
  in.group_new = flags;
#if TL_HAS_LKF
  in.q = c->s.real + TL_REAL_lkf_x;
#else
  in.q = NULL;
#endif
  return control_tick(c, t, &in);
}
#endif

#if TL_SCHEDULED
#elif TL_N_CLOCK > 0
TlStatus tl_model_step(TlInstance* c, double t, double h) {
  (void)c; (void)t; (void)h;
  return TL_OK; /* the law runs at the control clock's ticks; the commands hold in between */
}

TlStatus tl_model_event(TlInstance* c, double t) {
  return c->s.clock_active[TL_CLOCK_control_clock] ? tick_from_inputs(c, t) : TL_OK;
}
#else
TlStatus tl_model_step(TlInstance* c, double t, double h) {
  if (fabs(h - TL_TC) > 1e-9 * TL_TC) {
    tl_log(c, TL_ERROR, "communication step %.9g s is not the controller period T_c = %g s; step refused", h, TL_TC);
    return TL_ERROR;
  }
  return tick_from_inputs(c, t);
}
#endif
