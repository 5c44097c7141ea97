/* Linearized Kalman filter: see tl_lkf.h. */
#include "tl_platform.h"
#include "tl_lkf.h"

#include <math.h>
#include <string.h>

#include "tl_linalg.h"

#define N TL_NNU
#define NY TL_NY_LKF

void tl_lkf_initialize(TlLkf* f, const double* nu0, const double* P0) {
  memcpy(f->nu, nu0, sizeof f->nu);
  memcpy(f->P, P0, sizeof f->P);
}

int tl_lkf_step(TlLkf* f, const TlLkfModel* m, const double* du, const double* dy, const int* available, int* skipped,
                int* n_skipped) {
  double nu[N], AP[N * N], P[N * N];
  int ok[NY], n_ok = 0, i, j, k;
  for (i = 0; i < N; ++i) { /* nu = A nu + B du */
    double v = 0.0, b = 0.0;
    for (k = 0; k < N; ++k) v += m->A[i * N + k] * f->nu[k];
    for (k = 0; k < m->nu; ++k) b += m->B[i * m->nu + k] * du[k];
    nu[i] = v + b;
  }
  tl_matmul(N, N, N, m->A, f->P, AP); /* P = A P A^T + P_w */
  tl_matmul_bt(N, N, N, AP, m->A, P);
  for (i = 0; i < N * N; ++i) P[i] += m->Pw[i];
  *n_skipped = 0;
  for (i = 0; i < NY; ++i) {
    if (available && !available[i]) continue;
    if (!isfinite(dy[i])) skipped[(*n_skipped)++] = i;
    else ok[n_ok++] = i;
  }
  if (n_ok) {
    double H[NY * N], HP[NY * N], S[NY * NY], Nt[NY * N], Nk[N * NY], Pv[NY * NY], IKH[N * N], T1[N * N], NPv[N * NY];
    double innovation[NY];
    for (i = 0; i < n_ok; ++i) memcpy(H + i * N, m->H + ok[i] * N, sizeof(double) * N);
    for (i = 0; i < n_ok; ++i)
      for (j = 0; j < n_ok; ++j) Pv[i * n_ok + j] = m->Pv[ok[i] * NY + ok[j]];
    tl_matmul(n_ok, N, N, H, P, HP);          /* H P */
    tl_matmul_bt(n_ok, N, n_ok, HP, H, S);    /* H P H^T */
    for (i = 0; i < n_ok * n_ok; ++i) S[i] += Pv[i];
    memcpy(Nt, HP, sizeof(double) * n_ok * N);
    if (tl_solve(n_ok, N, S, Nt)) return -1;  /* N^T = S^-1 H P */
    for (k = 0; k < N; ++k)
      for (i = 0; i < n_ok; ++i) Nk[k * n_ok + i] = Nt[i * N + k];
    for (i = 0; i < n_ok; ++i) {
      double hnu = 0.0;
      for (k = 0; k < N; ++k) hnu += H[i * N + k] * nu[k];
      innovation[i] = dy[ok[i]] - hnu;
    }
    for (k = 0; k < N; ++k) {
      double v = 0.0;
      for (i = 0; i < n_ok; ++i) v += Nk[k * n_ok + i] * innovation[i];
      nu[k] += v;
    }
    tl_matmul(N, n_ok, N, Nk, H, IKH); /* I - N H */
    for (i = 0; i < N * N; ++i) IKH[i] = -IKH[i];
    for (i = 0; i < N; ++i) IKH[i * N + i] += 1.0;
    tl_matmul(N, N, N, IKH, P, T1); /* P = (I - N H) P (I - N H)^T + N P_v N^T */
    tl_matmul_bt(N, N, N, T1, IKH, P);
    tl_matmul(N, n_ok, n_ok, Nk, Pv, NPv);
    tl_matmul_bt(N, n_ok, N, NPv, Nk, T1);
    for (i = 0; i < N * N; ++i) P[i] += T1[i];
    tl_symmetrize(N, P);
  }
  memcpy(f->nu, nu, sizeof nu);
  memcpy(f->P, P, sizeof P);
  return 0;
}

unsigned long tl_lkf_size(void) { return (unsigned long)sizeof(TlLkf); }
