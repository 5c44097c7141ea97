/* Linearized Kalman filter (thesis Alg. 4.1) on the disturbance-augmented model, Joseph-form
   covariance update, as controller_fmu/reference/lkf.py. The filter's state is a plain struct. */
#ifndef TL_LKF_H
#define TL_LKF_H

#include "tl_platform.h"

#include "controller_dims.h"

typedef struct {
  const double *A, *B, *H, *Pw, *Pv; /* n x n, n x nu, ny x n, n x n, ny x ny */
  int nu;
} TlLkfModel;

typedef struct {
  double nu[TL_NNU];
  double P[TL_NNU * TL_NNU];
} TlLkf;

TL_INTERNAL void tl_lkf_initialize(TlLkf* f, const double* nu0, const double* P0);
/* Predict with du, correct with the finite, available entries of dy; the skipped entries are
   returned in skipped (n_skipped of them). 0 ok, -1 the innovation covariance is singular. */
TL_INTERNAL int tl_lkf_step(TlLkf* f, const TlLkfModel* m, const double* du, const double* dy, const int* available, int* skipped,
                int* n_skipped);
TL_INTERNAL unsigned long tl_lkf_size(void);

#endif
