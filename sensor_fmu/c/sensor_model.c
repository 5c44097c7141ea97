/* The sensor FMU's hooks: the measurement model pi(x) (4.22, or (A.3) for the UAV alone;
   CasADi-generated) and q sampled on each group's period with counter-based noise (tl_noise.h). A sample taken in doStep(t_k) uses
   the state set before the call and is held until the group's next sample (docs/ports.md, Timing).
   The clocked FMI 3.0 variant (TL_N_CLOCK > 0, one clock per group) takes the same sample in the Event Mode at t_k
   when the group's clock is active (tl_model_event), and its steps only move the exact channel. */
#include "tl_platform.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "sensor_groups.h"
#include "tl_fmu.h"
#include "tl_noise.h"
#include "tl_pi_gen.h"
#include "tl_pi_gen_sizes.h"

#define NX TL_SENSOR_NX
#define STATE(c) ((c)->s.real + TL_REAL_x)
#define EXACT(c) ((c)->s.real + TL_REAL_exact_x)

TL_STATIC_ASSERT(TL_REAL_alpha_L_dot - TL_REAL_x == NX - 1, "the state inputs are contiguous");
TL_STATIC_ASSERT(TL_REAL_exact_alpha_L_dot - TL_REAL_exact_x == NX - 1, "the exact channel is contiguous");
TL_STATIC_ASSERT(TL_N_GROUPS <= TL_SENSOR_MAX_GROUPS && TL_N_PARAMS <= TL_SENSOR_MAX_PARAMS, "model state fits");
TL_STATIC_ASSERT(TL_PI_SZ_ARG == 2 && TL_PI_SZ_RES == 1, "pi(x, p) -> y");

static int evaluate_pi(TlInstance* c, double y[TL_SENSOR_NY]) {
  const double* arg[TL_PI_SZ_ARG + 1];
  double* res[TL_PI_SZ_RES + 1];
  casadi_int iw[TL_PI_SZ_IW];
  double w[TL_PI_SZ_W];
  arg[0] = STATE(c);
  arg[1] = c->s.model.params;
  res[0] = y;
  return tl_pi(arg, res, iw, w, 0);
}

/* Each group's held samples from the current state, with noise for sample k when noisy; a group samples when due. */
static TlStatus sample(TlInstance* c, long k, int noisy, const int due[TL_N_GROUPS]) {
  double y[TL_SENSOR_NY];
  int g, j;
  if (evaluate_pi(c, y)) {
    tl_log(c, TL_ERROR, "measurement model evaluation failed at t=%.6g s", c->s.time);
    return TL_ERROR;
  }
  memcpy(EXACT(c), STATE(c), NX * sizeof(double));
  for (g = 0; g < TL_N_GROUPS; ++g) {
    const TlSensorGroup* grp = &tl_sensor_groups[g];
    int fresh = !noisy || due[g];
    c->s.boolean[grp->flag] = noisy && fresh ? 1 : 0;
    if (!fresh) continue;
    for (j = 0; j < grp->n; ++j) {
      double truth = grp->from_pi ? y[grp->index[j]] : STATE(c)[grp->index[j]];
      double bound = c->s.real[grp->bound + (grp->n_bounds > 1 ? j : 0)], noise = 0.0;
      if (noisy) {
        int gaussian = c->s.model.gaussian[g];
        noise = tl_noise((uint64_t)c->s.integer[TL_INTEGER_seed], (uint64_t)g, (uint64_t)k, (uint64_t)j, gaussian) *
                (gaussian ? bound / 3.0 : bound);
      }
      c->s.real[grp->out + j] = truth + noise;
    }
  }
  return TL_OK;
}

/* One line naming the first parameter that cannot be sampled, or 0. */
static int check_parameters(TlInstance* c, char* why, size_t n) {
  const double step = c->s.real[TL_REAL_step];
  int g, j;
  if (!(step > 0.0)) return snprintf(why, n, "step must be a positive finite time, got %g", step);
  if (c->s.integer[TL_INTEGER_seed] < 0)
    return snprintf(why, n, "seed must be between 0 and 2147483647, got %d", c->s.integer[TL_INTEGER_seed]);
#if TL_HAS_ROD
  if (!(c->s.real[TL_REAL_l] > 0.0)) return snprintf(why, n, "l must be positive and finite, got %g", c->s.real[TL_REAL_l]);
#endif
  for (g = 0; g < TL_N_GROUPS; ++g) {
    const TlSensorGroup* grp = &tl_sensor_groups[g];
    double period, ticks;
    const char* pdf = c->s.string[grp->pdf];
#if TL_N_CLOCK > 0
    period = tl_clock_interval[grp->clock];
#else
    period = c->s.real[grp->period];
#endif
    if (!(period > 0.0)) return snprintf(why, n, "%s_period must be positive and finite, got %g", grp->name, period);
    ticks = floor(period / step + 0.5);
    if (ticks < 1.0 || fabs(ticks * step - period) > 1e-9 * (period > step ? period : step))
      return snprintf(why, n, "%s_period = %.9g s is not a whole multiple of the step %.9g s", grp->name, period, step);
    for (j = 0; j < grp->n_bounds; ++j)
      if (!(c->s.real[grp->bound + j] >= 0.0))
        return snprintf(why, n, "%s bound must be non-negative and finite, got %g", grp->name, c->s.real[grp->bound + j]);
    if (strcmp(pdf, "gaussian") != 0 && strcmp(pdf, "uniform") != 0)
      return snprintf(why, n, "%s_pdf must be one of gaussian, uniform, got '%s'", grp->name, pdf);
    c->s.model.ticks[g] = (long)ticks;
    c->s.model.gaussian[g] = strcmp(pdf, "gaussian") == 0;
  }
  return 0;
}

void tl_model_reset(TlInstance* c) {
  int g;
  memset(&c->s.model, 0, sizeof c->s.model);
  memcpy(c->s.model.params, tl_sensor_p0, sizeof tl_sensor_p0);
  for (g = 0; g < TL_N_GROUPS; ++g) c->s.model.ticks[g] = 1;
  tl_model_outputs(c);
}

/* Before the first sample every channel holds its noise-free value and no flag is raised. */
TlStatus tl_model_outputs(TlInstance* c) {
  int due[TL_N_GROUPS];
#if TL_HAS_ROD
  c->s.model.params[TL_L_INDEX] = c->s.real[TL_REAL_l];
#endif
  memset(due, 0, sizeof due);
  return sample(c, 0, 0, due);
}

TlStatus tl_model_initialize(TlInstance* c) {
  char why[256];
  if (check_parameters(c, why, sizeof why)) {
    tl_log(c, TL_ERROR, "invalid sensor parameters: %s", why);
    return TL_ERROR;
  }
  return tl_model_outputs(c);
}

#if TL_N_CLOCK > 0
/* The step moves the exact channel only: the groups sample at their clocks' ticks (tl_model_event). */
TlStatus tl_model_step(TlInstance* c, double t, double h) {
  (void)t; (void)h;
  memcpy(EXACT(c), STATE(c), NX * sizeof(double));
  return TL_OK;
}

/* Event Mode at t: the groups whose clocks are active sample (the same sample k as the plain variant's doStep(t));
   every flag says whether its group sampled now. A raised flag is lowered in the next tick's Event Mode, which the
   FMU asks for (a time event one step later) in case no clock ticks there. */
TlStatus tl_model_event(TlInstance* c, double t) {
  const double step = c->s.real[TL_REAL_step];
  int due[TL_N_GROUPS], g, any = 0;
  TlStatus status;
  for (g = 0; g < TL_N_GROUPS; ++g) {
    due[g] = c->s.clock_active[tl_sensor_groups[g].clock];
    any |= due[g];
  }
  status = sample(c, lround(t / step), 1, due);
  c->s.next_event_time = any ? t + step : -1.0;
  return status;
}
#else
TlStatus tl_model_step(TlInstance* c, double t, double h) {
  const double step = c->s.real[TL_REAL_step];
  int due[TL_N_GROUPS], g;
  long k;
  if (fabs(h - step) > 1e-9 * step) {
    tl_log(c, TL_ERROR, "communication step %.9g s differs from the suite's step %.9g s; step refused", h, step);
    return TL_ERROR;
  }
  if (c->s.integer[TL_INTEGER_seed] < 0) { /* tunable: may have changed since initialization */
    tl_log(c, TL_ERROR, "seed must be between 0 and 2147483647, got %d; step refused", c->s.integer[TL_INTEGER_seed]);
    return TL_ERROR;
  }
  k = lround(t / step);
  for (g = 0; g < TL_N_GROUPS; ++g) due[g] = k % c->s.model.ticks[g] == 0;
  return sample(c, k, 1, due);
}
#endif
