/* The formation FMU's hooks. doStep(t_k, h): the three UAVs' measured x, y, z, psi and rates at t_k give
   rho_S and its rate; the generated tl_formation (formation/kinematics.py: the cooperative dual task-space,
   backstepping (B.15) or TSID (B.16), exact Jacobians) gives the accelerations rho_S''. The references held
   over the tick are the integrated position and velocity and that acceleration (Sec. B.3.4); then the
   references, and the backstepping's e_C, advance to t_k + h (exactly, for an acceleration held over h). */
#include "tl_platform.h"

#include <math.h>
#include <string.h>

#include "tl_fmu.h"
#include "tl_formation_gen.h"
#include "tl_formation_gen_sizes.h"

#define AGENT_INPUTS (TL_REAL_zeta_x - TL_REAL_sigma_x)
#define AGENT_REFS (TL_REAL_zeta_x_ref - TL_REAL_sigma_x_ref)
TL_STATIC_ASSERT(AGENT_INPUTS == 8 && TL_REAL_tau_x - TL_REAL_zeta_x == 8, "8 measured values per UAV, UAV after UAV");
TL_STATIC_ASSERT(AGENT_REFS == 11 && TL_REAL_tau_x_ref - TL_REAL_zeta_x_ref == 11, "11 references per UAV, UAV after UAV");
TL_STATIC_ASSERT(TL_REAL_sigma_psi_dot - TL_REAL_sigma_x == 7, "x y z psi, then their rates");
TL_STATIC_ASSERT(TL_REAL_tau_az_disturbance - TL_REAL_sigma_ax_disturbance == 8, "3 disturbances per UAV");

static const char* const laws[] = {"backstepping", "tsid"};

void tl_model_reset(TlInstance* c) {
  memset(&c->s.model, 0, sizeof c->s.model);
  tl_model_outputs(c);
}

TlStatus tl_model_outputs(TlInstance* c) {
  (void)c; /* the references are computed by the first step */
  return TL_OK;
}

TlStatus tl_model_initialize(TlInstance* c) {
  TlModelState* m = &c->s.model;
  const char* name = c->s.string[TL_STRING_controller];
  memset(m, 0, sizeof *m);
  m->law = strcmp(name, laws[0]) == 0 ? 0 : strcmp(name, laws[1]) == 0 ? 1 : -1;
  if (m->law < 0) {
    tl_log(c, TL_ERROR, "invalid formation parameters: unknown controller '%s' (available: backstepping, tsid)", name);
    return TL_ERROR;
  }
  return TL_OK;
}

TlStatus tl_model_step(TlInstance* c, double t, double h) {
  TlModelState* m = &c->s.model;
  double* r = c->s.real;
  double rho[12], rho_dot[12], d_acc[12], rho_ddot[12], e_B[24], e_A[24], law = m->law, norm[3] = {0, 0, 0};
  const double* arg[TL_FORMATION_SZ_ARG + 1];
  double* res[TL_FORMATION_SZ_RES + 1];
  casadi_int iw[TL_FORMATION_SZ_IW];
  double w[TL_FORMATION_SZ_W];
  const int disturbed = t >= r[TL_REAL_disturbance_start] - 1e-9;
  int i, j;
  for (i = 0; i < 3; ++i) {
    const double* in = r + TL_REAL_sigma_x + AGENT_INPUTS * i;
    for (j = 0; j < 4; ++j) {
      rho[4 * i + j] = in[j];
      rho_dot[4 * i + j] = in[4 + j];
      d_acc[4 * i + j] = disturbed && j < 3 ? r[TL_REAL_sigma_ax_disturbance + 3 * i + j] : 0.0;
    }
  }
  if (!m->started) { /* the references start where the UAVs are */
    memcpy(m->rho_ref, rho, sizeof rho);
    memcpy(m->rho_dot_ref, rho_dot, sizeof rho_dot);
    m->started = 1;
  }
  arg[0] = rho;
  arg[1] = rho_dot;
  arg[2] = m->e_C;
  arg[3] = &t;
  arg[4] = &law;
  arg[5] = d_acc;
  res[0] = rho_ddot;
  res[1] = e_B;
  res[2] = e_A;
  if (tl_formation(arg, res, iw, w, 0)) {
    tl_log(c, TL_ERROR, "the formation law failed at t=%.6g s", t);
    return TL_ERROR;
  }
  for (i = 0; i < 12; ++i)
    if (!isfinite(rho_ddot[i])) {
      tl_log(c, TL_ERROR, "the formation law gave a non-finite acceleration at t=%.6g s (are the UAVs' states finite?)", t);
      return TL_ERROR;
    }
  for (i = 0; i < 3; ++i) {
    double* out = r + TL_REAL_sigma_x_ref + AGENT_REFS * i;
    for (j = 0; j < 3; ++j) {
      out[j] = m->rho_ref[4 * i + j];
      out[3 + j] = m->rho_dot_ref[4 * i + j];
      out[6 + j] = rho_ddot[4 * i + j];
    }
    out[9] = m->rho_ref[4 * i + 3];
    out[10] = m->rho_dot_ref[4 * i + 3];
  }
  for (i = 0; i < 24; ++i) norm[i / 8] += e_A[i] * e_A[i];
  r[TL_REAL_error_norm] = sqrt(norm[0] + norm[1] + norm[2]);
  r[TL_REAL_error_leader] = sqrt(norm[0]);
  r[TL_REAL_error_relative] = sqrt(norm[1]);
  r[TL_REAL_error_absolute] = sqrt(norm[2]);
  for (i = 0; i < 12; ++i) {
    m->rho_ref[i] += h * m->rho_dot_ref[i] + 0.5 * h * h * rho_ddot[i];
    m->rho_dot_ref[i] += h * rho_ddot[i];
  }
  for (i = 0; i < 24; ++i) m->e_C[i] += h * e_B[i];
  return TL_OK;
}
