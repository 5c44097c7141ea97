/* The hooks of a controller traced from Python (master/app/wrap/trace.py): at every step the CasADi-generated
   tl_traced_step(t, inputs, parameters, states) gives the command (f_R, f_L, tau_R, tau_L) and the next states, as
   the class's step did in Python at the same t. The layout tables (which variable is which argument) are generated
   beside it in traced_layout.h. */
#include "tl_platform.h"

#include <math.h>
#include <string.h>

#include "tl_fmu.h"
#include "tl_traced.h"
#include "tl_traced_sizes.h"
#include "traced_layout.h"

TL_STATIC_ASSERT(TL_TRACED_STEP_SZ_ARG == 4 && TL_TRACED_STEP_SZ_RES == 2, "step(t, u, p, s) -> (y, s_next)");
TL_STATIC_ASSERT(TL_TRACED_INIT_SZ_ARG == 1 && TL_TRACED_INIT_SZ_RES == 1, "init(p) -> s0");

void tl_model_reset(TlInstance* c) {
  memcpy(c->s.model.state, tl_traced_initial_state, sizeof c->s.model.state);
}

TlStatus tl_model_outputs(TlInstance* c) {
  (void)c; /* the command holds its start value (the hover trim) until the first step */
  return TL_OK;
}

TlStatus tl_model_initialize(TlInstance* c) {
  int i;
  for (i = 0; i < TL_TRACED_NP; ++i) {
    double v = c->s.real[tl_traced_parameter[i]];
    if (!(v == v) || v - v != 0.0) {
      tl_log(c, TL_ERROR, "parameter %s is not finite (%g)", tl_traced_parameter_name[i], v);
      return TL_ERROR;
    }
    if (tl_traced_parameter_fixed[i] && v != tl_traced_parameter_default[i]) {
      tl_log(c, TL_ERROR, "parameter %s is fixed at %g in this native FMU (the class's __init__ needs its number); "
             "wrap the class with pythonfmu to tune it", tl_traced_parameter_name[i], tl_traced_parameter_default[i]);
      return TL_ERROR;
    }
  }
  { /* the states start from __init__'s values for these parameters */
    double p[TL_TRACED_NP_ROOM];
    const double* arg[TL_TRACED_INIT_SZ_ARG + 1];
    double* res[TL_TRACED_INIT_SZ_RES + 1];
    casadi_int iw[TL_TRACED_INIT_SZ_IW];
    double w[TL_TRACED_INIT_SZ_W];
    for (i = 0; i < TL_TRACED_NP; ++i) p[i] = c->s.real[tl_traced_parameter[i]];
    arg[0] = p;
    res[0] = c->s.model.state;
    if (tl_traced_init(arg, res, iw, w, 0)) {
      tl_log(c, TL_ERROR, "the traced initial states failed");
      return TL_ERROR;
    }
  }
  return TL_OK;
}

TlStatus tl_model_step(TlInstance* c, double t, double h) {
  double u[TL_TRACED_NU_ROOM], p[TL_TRACED_NP_ROOM], y[4], next[TL_TRACED_NS_ROOM];
  const double* arg[TL_TRACED_STEP_SZ_ARG + 1];
  double* res[TL_TRACED_STEP_SZ_RES + 1];
  casadi_int iw[TL_TRACED_STEP_SZ_IW];
  double w[TL_TRACED_STEP_SZ_W];
  int i;
  (void)h;
  for (i = 0; i < TL_TRACED_NU; ++i)
    u[i] = tl_traced_input_is_boolean[i] ? (double)c->s.boolean[tl_traced_input[i]] : c->s.real[tl_traced_input[i]];
  for (i = 0; i < TL_TRACED_NP; ++i) p[i] = c->s.real[tl_traced_parameter[i]];
  arg[0] = &t;
  arg[1] = u;
  arg[2] = p;
  arg[3] = c->s.model.state;
  res[0] = y;
  res[1] = next;
  if (tl_traced_step(arg, res, iw, w, 0)) {
    tl_log(c, TL_ERROR, "the traced step failed at t=%.6g s", t);
    return TL_ERROR;
  }
  for (i = 0; i < 4; ++i) {
    if (!(y[i] == y[i]) || y[i] - y[i] != 0.0) {
      tl_log(c, TL_ERROR, "step returned a non-finite command at t=%.6g s: (%g, %g, %g, %g)", t, y[0], y[1], y[2], y[3]);
      return TL_ERROR;
    }
  }
  for (i = 0; i < 4; ++i) c->s.real[tl_traced_output[i]] = y[i];
  memcpy(c->s.model.state, next, sizeof c->s.model.state);
  return TL_OK;
}
