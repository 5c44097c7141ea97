/* Multirate zonotopic state estimator (thesis Alg. 4.4) in the fast form of controller_fmu/reference/zse.py:
   prediction (4.25), all strips of a step as one Kalman-like update with R = diag(sigma^2) (the
   Frobenius-optimal strips of Thm 4.6 in sequence), one pass over the generators, then order
   reduction (Combastel, Girard or PCA) to r_max generators.

   The estimator's state is a plain struct (a state snapshot copies it); the model is constant data
   passed with every call. Generators are rows of TL_ZSE_LD doubles (the last padding entry is 0). A step reads the
   generators of G[cur] and writes only those of G[1 - cur], then flips cur: the clocked controller relies on it to
   rerun a step from its scalars alone (controller_model.h). */
#ifndef TL_ZSE_H
#define TL_ZSE_H

#include "tl_platform.h"

#include "controller_dims.h"

#define TL_ZSE_N TL_NNU
#define TL_ZSE_LD ((TL_NNU + 3) / 4 * 4)
#define TL_ZSE_CAP (TL_R_MAX + TL_RW + TL_NY_ZSE)

enum { TL_REDUCE_COMBASTEL = 0, TL_REDUCE_GIRARD = 1, TL_REDUCE_PCA = 2 };

typedef struct {
  const double* A;      /* n x n */
  const double* B;      /* n x nu */
  const double* H;      /* ny x n */
  const double* c_w;    /* n: centre of W */
  const double* Gw;     /* rw x n: generators of W as rows */
  const double* sigma;  /* ny: strip half-widths, rs(G_v) */
  const double* s;      /* ny: -c_v */
  const double* hull_w; /* n: rs(G_w) */
  const double* Sw;     /* n x n: G_w G_w^T */
  int nu;               /* inputs */
  int rw;               /* generators of W */
  int r_max;            /* order limit, <= TL_R_MAX */
  int reduction;        /* TL_REDUCE_* */
} TlZseModel;

typedef struct {
  int r, cur, steps;
  double c[TL_ZSE_N];
  double S[TL_ZSE_N * TL_ZSE_N]; /* G G^T, updated in closed form and resynchronized every 64 steps */
  double hull[TL_ZSE_N];         /* rs(G): half-widths of the interval hull */
  double G[2][TL_ZSE_CAP][TL_ZSE_LD];
  double select_below; /* the reduction looks for its generators among scores at most this first (0: among all) */
} TlZse;

typedef struct {
  int used;                           /* strips applied */
  int n_nonfinite, n_inconsistent;    /* measurement entries skipped, and why */
  int nonfinite[TL_NY_ZSE], inconsistent[TL_NY_ZSE];
} TlZseReport;

/* Set X0 (r0 generators as rows of n) and apply the initial update with y0 if given (NULL: none). */
TL_INTERNAL int tl_zse_initialize(TlZse* z, const TlZseModel* m, const double* c0, const double* G0, int r0, const double* y0,
                      const int* available, TlZseReport* report);
/* One period: predict with du (the previous input's deviation), update with the available entries of y. */
TL_INTERNAL int tl_zse_step(TlZse* z, const TlZseModel* m, const double* du, const double* y, const int* available, TlZseReport* report);
/* Frobenius norm of G, sqrt(trace S). */
TL_INTERNAL double tl_zse_frobenius(const TlZse* z);
/* Generator row i of the current set (n entries, stride TL_ZSE_LD). */
TL_INTERNAL const double* tl_zse_generator(const TlZse* z, int i);
/* sizeof(TlZse), for hosts that allocate it (tests through ctypes). */
TL_INTERNAL unsigned long tl_zse_size(void);

#endif
