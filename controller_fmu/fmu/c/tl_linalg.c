/* Small dense linear algebra (see tl_linalg.h). */
#include "tl_platform.h"
#include "tl_linalg.h"

#include <math.h>
#include <string.h>

#if defined(__GNUC__)
#define TL_ALWAYS_INLINE __attribute__((always_inline))
#else
#define TL_ALWAYS_INLINE
#endif

#if defined(__GNUC__)
typedef double v4d __attribute__((vector_size(32), aligned(8)));
typedef double v2d __attribute__((vector_size(16), aligned(8)));

/* Rows of up to 24 columns: B padded to 24 columns once, each row of C accumulated in registers over l (a
   store per row, not per multiply-add): twelve two-wide ones (SSE2, NEON), or with AVX2 six four-wide ones.
   Every entry is the same sum in the same order at either width. */
static void pad24(int k, int m, const double* B, double (*Bp)[24]) {
  int j, l;
  for (l = 0; l < k; ++l) {
    for (j = 0; j < m; ++j) Bp[l][j] = B[l * m + j];
    for (; j < 24; ++j) Bp[l][j] = 0.0;
  }
}

static void matmul_narrow_base(int n, int k, int m, const double* A, const double* B, double* C) {
  double Bp[TL_LINALG_MAX][24];
  int i, j, l;
  pad24(k, m, B, Bp);
  for (i = 0; i < n; ++i) {
    v2d c[12];
    double row[24];
    for (j = 0; j < 12; ++j) c[j] = (v2d){0.0, 0.0};
    for (l = 0; l < k; ++l) {
      const double a = A[i * k + l];
      const v2d* b = (const v2d*)Bp[l];
      for (j = 0; j < 12; ++j) c[j] += a * b[j];
    }
    for (j = 0; j < 12; ++j) ((v2d*)row)[j] = c[j];
    for (j = 0; j < m; ++j) C[i * m + j] = row[j];
  }
}

#if TL_HAVE_WIDE
TL_WIDE static void matmul_narrow_wide(int n, int k, int m, const double* A, const double* B, double* C) {
  double Bp[TL_LINALG_MAX][24];
  int i, j, l;
  pad24(k, m, B, Bp);
  for (i = 0; i < n; ++i) {
    const v4d zero = {0.0, 0.0, 0.0, 0.0};
    v4d c0 = zero, c1 = zero, c2 = zero, c3 = zero, c4 = zero, c5 = zero;
    double row[24];
    for (l = 0; l < k; ++l) {
      const double a = A[i * k + l];
      const v4d* b = (const v4d*)Bp[l];
      c0 += a * b[0]; c1 += a * b[1]; c2 += a * b[2]; c3 += a * b[3]; c4 += a * b[4]; c5 += a * b[5];
    }
    ((v4d*)row)[0] = c0; ((v4d*)row)[1] = c1; ((v4d*)row)[2] = c2;
    ((v4d*)row)[3] = c3; ((v4d*)row)[4] = c4; ((v4d*)row)[5] = c5;
    for (j = 0; j < m; ++j) C[i * m + j] = row[j];
  }
}
#endif
#endif

/* Any width: an axpy per row of A. */
static void matmul_wide(int n, int k, int m, const double* A, const double* B, double* C) {
  int i, j, l;
  for (i = 0; i < n; ++i) {
    double* c = C + (long)i * m;
    for (j = 0; j < m; ++j) c[j] = 0.0;
    for (l = 0; l < k; ++l) {
      const double a = A[(long)i * k + l];
      const double* b = B + (long)l * m;
      for (j = 0; j < m; ++j) c[j] += a * b[j];
    }
  }
}

void tl_matmul(int n, int k, int m, const double* A, const double* B, double* C) {
#if defined(__GNUC__)
  if (m <= 24 && k <= TL_LINALG_MAX) {
#if TL_HAVE_WIDE
    if (tl_wide()) {
      matmul_narrow_wide(n, k, m, A, B, C);
      return;
    }
#endif
    matmul_narrow_base(n, k, m, A, B, C);
    return;
  }
#endif
  matmul_wide(n, k, m, A, B, C);
}

/* As a transpose and tl_matmul: its axpy inner loop vectorizes, a dot-product loop would not
   (strict IEEE order forbids reassociating the sum). */
void tl_matmul_bt(int n, int k, int m, const double* A, const double* B, double* C) {
  double Bt[TL_LINALG_MAX * TL_LINALG_MAX];
  int i, j;
  if (k * m > TL_LINALG_MAX * TL_LINALG_MAX) { /* not used at these sizes: the plain loop */
    for (i = 0; i < n; ++i)
      for (j = 0; j < m; ++j) {
        double s = 0.0;
        int l;
        for (l = 0; l < k; ++l) s += A[(long)i * k + l] * B[(long)j * k + l];
        C[(long)i * m + j] = s;
      }
    return;
  }
  for (j = 0; j < m; ++j)
    for (i = 0; i < k; ++i) Bt[i * m + j] = B[j * k + i];
  tl_matmul(n, k, m, A, Bt, C);
}

/* LU with partial pivoting, then back substitution: elementwise row operations only (no sum is reordered by the
   vector width), in one body compiled in a baseline and, on x86-64, an AVX2 copy. */
static inline TL_ALWAYS_INLINE int solve_body(int n, int m, double* A, double* B) {
  int i, j, col, pivot;
  for (col = 0; col < n; ++col) {
    double best = fabs(A[col * n + col]);
    pivot = col;
    for (i = col + 1; i < n; ++i)
      if (fabs(A[i * n + col]) > best) {
        best = fabs(A[i * n + col]);
        pivot = i;
      }
    if (!(best > 0.0)) return -1;
    if (pivot != col) {
      for (j = 0; j < n; ++j) {
        double t = A[col * n + j];
        A[col * n + j] = A[pivot * n + j];
        A[pivot * n + j] = t;
      }
      for (j = 0; j < m; ++j) {
        double t = B[col * m + j];
        B[col * m + j] = B[pivot * m + j];
        B[pivot * m + j] = t;
      }
    }
    for (i = col + 1; i < n; ++i) {
      double f = A[i * n + col] / A[col * n + col];
      if (f == 0.0) continue;
      for (j = col; j < n; ++j) A[i * n + j] -= f * A[col * n + j];
      for (j = 0; j < m; ++j) B[i * m + j] -= f * B[col * m + j];
    }
  }
  for (i = n - 1; i >= 0; --i) { /* row i less A[i][l] times the solved rows l > i, in that order: axpys that vectorize */
    double* b = B + i * m;
    int l;
    for (l = i + 1; l < n; ++l) {
      const double a = A[i * n + l];
      const double* x = B + l * m;
      for (j = 0; j < m; ++j) b[j] -= a * x[j];
    }
    for (j = 0; j < m; ++j) b[j] /= A[i * n + i];
  }
  return 0;
}

#if TL_HAVE_WIDE
TL_WIDE static int solve_wide(int n, int m, double* A, double* B) { return solve_body(n, m, A, B); }
#endif

int tl_solve(int n, int m, double* A, double* B) {
#if TL_HAVE_WIDE
  if (tl_wide()) return solve_wide(n, m, A, B);
#endif
  return solve_body(n, m, A, B);
}

void tl_eigh(int n, double* A, double* w, double* V) {
  int i, j, p, q, sweep;
  for (i = 0; i < n; ++i)
    for (j = 0; j < n; ++j) V[i * n + j] = i == j ? 1.0 : 0.0;
  for (sweep = 0; sweep < 100; ++sweep) {
    double off = 0.0, scale = 0.0;
    for (p = 0; p < n; ++p)
      for (q = 0; q < n; ++q) {
        if (p != q) off += A[p * n + q] * A[p * n + q];
        else scale += A[p * n + q] * A[p * n + q];
      }
    if (off <= 1e-30 * scale) break;
    for (p = 0; p < n - 1; ++p) {
      for (q = p + 1; q < n; ++q) {
        double apq = A[p * n + q], theta, t, cs, sn;
        if (apq == 0.0) continue;
        theta = (A[q * n + q] - A[p * n + p]) / (2.0 * apq);
        t = (theta >= 0.0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
        cs = 1.0 / sqrt(t * t + 1.0);
        sn = t * cs;
        for (i = 0; i < n; ++i) { /* A <- A J (columns p, q) */
          double aip = A[i * n + p], aiq = A[i * n + q];
          A[i * n + p] = cs * aip - sn * aiq;
          A[i * n + q] = sn * aip + cs * aiq;
        }
        for (i = 0; i < n; ++i) { /* A <- J^T A (rows p, q) */
          double api = A[p * n + i], aqi = A[q * n + i];
          A[p * n + i] = cs * api - sn * aqi;
          A[q * n + i] = sn * api + cs * aqi;
        }
        for (i = 0; i < n; ++i) {
          double vip = V[i * n + p], viq = V[i * n + q];
          V[i * n + p] = cs * vip - sn * viq;
          V[i * n + q] = sn * vip + cs * viq;
        }
      }
    }
  }
  for (i = 0; i < n; ++i) w[i] = A[i * n + i];
  for (i = 1; i < n; ++i) { /* insertion sort, ascending, columns of V along */
    for (j = i; j > 0 && w[j - 1] > w[j]; --j) {
      double t = w[j];
      w[j] = w[j - 1];
      w[j - 1] = t;
      for (p = 0; p < n; ++p) {
        t = V[p * n + j];
        V[p * n + j] = V[p * n + j - 1];
        V[p * n + j - 1] = t;
      }
    }
  }
}

void tl_symmetrize(int n, double* S) {
  int i, j;
  for (i = 0; i < n; ++i)
    for (j = i + 1; j < n; ++j) {
      double m = 0.5 * (S[i * n + j] + S[j * n + i]);
      S[i * n + j] = S[j * n + i] = m;
    }
}
