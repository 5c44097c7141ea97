/* The CasADi-generated feedforward u_tr(x_tr, qdd, p) (3.18) called with stack buffers; included by each FMU that
   compiles it (after its generated tl_feedforward_gen headers), so the sizes are that build's. */
#ifndef TL_FEEDFORWARD_CALL_H
#define TL_FEEDFORWARD_CALL_H

#include "tl_feedforward_gen.h"
#include "tl_feedforward_gen_sizes.h"

static int tl_feedforward_eval(const double* x_tr, const double* qdd, const double* params, double* u_tr) {
  const double* arg[TL_FEEDFORWARD_SZ_ARG + 1];
  double* res[TL_FEEDFORWARD_SZ_RES + 1];
  casadi_int iw[TL_FEEDFORWARD_SZ_IW];
  double w[TL_FEEDFORWARD_SZ_W];
  arg[0] = x_tr;
  arg[1] = qdd;
  arg[2] = params;
  res[0] = u_tr;
  return tl_feedforward(arg, res, iw, w, 0);
}

#endif
