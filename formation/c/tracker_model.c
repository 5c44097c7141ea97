/* The tracker FMU's hooks: each doStep(t_k, T) reads the UAV's state and its references at t_k and holds
   u = sat(u_tr - K chi) over the tick (the shared law, tl_law.c), K the D-stable H-infinity gain of
   Sec. B.3.3 and u_tr the feedforward L+ (M qdd + C qd + g) of the reference (CasADi-generated). */
#include "tl_platform.h"

#include <math.h>
#include <string.h>

#include "tl_feedforward_call.h"
#include "tl_fmu.h"
#include "tl_law.h"
#include "tracker_data.h"

TL_STATIC_ASSERT(TL_REAL_tau_L - TL_REAL_f_R == 3, "the four commands are contiguous");
TL_STATIC_ASSERT(TL_REAL_psi_dot_ref - TL_REAL_x_ref == 10, "the 11 references are contiguous");
TL_STATIC_ASSERT(TL_REAL_alpha_L_dot - TL_REAL_x == TL_NX - 1, "the measured state is contiguous");

static int feedforward(const double* x_tr, const double* qdd, double* u_tr) {
  return tl_feedforward_eval(x_tr, qdd, tl_params, u_tr);
}

void tl_model_reset(TlInstance* c) {
  memset(&c->s.model, 0, sizeof c->s.model);
  tl_model_outputs(c);
}

TlStatus tl_model_outputs(TlInstance* c) {
  memcpy(c->s.real + TL_REAL_f_R, tl_trim_u, sizeof(double) * 4);
  return TL_OK;
}

TlStatus tl_model_initialize(TlInstance* c) {
  const double* r = c->s.real;
  if (!(r[TL_REAL_f_min] < r[TL_REAL_f_max] && r[TL_REAL_tau_max] > 0.0)) {
    tl_log(c, TL_ERROR, "invalid tracker parameters: actuator limits need f_min < f_max and tau_max > 0, got %g, %g, %g",
           r[TL_REAL_f_min], r[TL_REAL_f_max], r[TL_REAL_tau_max]);
    return TL_ERROR;
  }
  memset(&c->s.model, 0, sizeof c->s.model);
  return tl_model_outputs(c);
}

TlStatus tl_model_step(TlInstance* c, double t, double h) {
  TlModelState* m = &c->s.model;
  TlLaw law;
  double u[4];
  int i;
  if (fabs(h - TL_TC) > 1e-9 * TL_TC) {
    tl_log(c, TL_ERROR, "communication step %.9g s is not the tracker's period %g s; step refused", h, TL_TC);
    return TL_ERROR;
  }
  law.nx = TL_NX;
  law.trim_x = tl_trim_x;
  law.K = tl_K;
  law.delay = 0;
  law.Tc = TL_TC;
  law.f_min = c->s.real[TL_REAL_f_min];
  law.f_max = c->s.real[TL_REAL_f_max];
  law.tau_max = c->s.real[TL_REAL_tau_max];
  law.feedforward = feedforward;
  if (tl_law_step(&law, c->s.real + TL_REAL_x_ref, c->s.real + TL_REAL_x, m->integral, m->du_sent, u)) {
    tl_log(c, TL_ERROR, "the feedforward failed numerically at t=%.6g s", t);
    return TL_ERROR;
  }
  for (i = 0; i < 4; ++i)
    if (!isfinite(u[i])) {
      tl_log(c, TL_ERROR, "the tracker produced a non-finite input at t=%.6g s (is the UAV's state finite?)", t);
      return TL_ERROR;
    }
  memcpy(c->s.real + TL_REAL_f_R, u, sizeof u);
  return TL_OK;
}
