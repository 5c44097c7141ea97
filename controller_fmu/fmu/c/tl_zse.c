/* Multirate zonotopic state estimator: see tl_zse.h. Each step mirrors controller_fmu/reference/zse.py
   operation for operation, so the two agree to rounding; tests check it. */
#include "tl_platform.h"
#include "tl_zse.h"

#include <math.h>
#include <string.h>

#include "tl_linalg.h"

#define N TL_ZSE_N
#define LD TL_ZSE_LD
#define NY TL_NY_ZSE
#define RESYNC_EVERY 64

/* The one heavy product: dst rows = src rows times Mt (LD x LD, rows of M^T padded with zeros), i.e.
   dst_i = M g_i: 1725 x 23 x 24 multiply-adds a step with the load. Each output entry is the sum over k in
   order, whatever the vector width, so every copy below gives the same results to the bit. The accumulators
   must stay in registers (GCC/Clang vector extensions): with 128-bit registers (SSE2, NEON) one row at a time
   in LD / 2 two-wide accumulators; with AVX2 (TL_WIDE, picked at run time) two rows at a time in 2 x LD / 4
   four-wide ones. (Four-wide accumulators on SSE2 spill to the stack: 4.5x slower, docs/platforms.md.) */
#if defined(__GNUC__)
typedef double v4d __attribute__((vector_size(32), aligned(8)));
typedef double v2d __attribute__((vector_size(16), aligned(8)));
#define TL_VECTORS (LD / 4)
TL_STATIC_ASSERT(LD / 2 <= 14, "a row's two-wide accumulators fit the 16 SSE2 registers");

static void transform_rows_base(int rows, double (*src)[LD], const double* Mt, double (*dst)[LD], double* norms) {
  int i, j, k;
  const v2d zero = {0.0, 0.0};
  for (i = 0; i < rows; ++i) {
    v2d a[LD / 2];
    for (j = 0; j < LD / 2; ++j) a[j] = zero;
    for (k = 0; k < N; ++k) {
      const double g = src[i][k];
      const v2d* m = (const v2d*)(Mt + k * LD);
      for (j = 0; j < LD / 2; ++j) a[j] += g * m[j];
    }
    {
      v2d* d = (v2d*)dst[i];
      for (j = 0; j < LD / 2; ++j) d[j] = a[j];
    }
    if (norms) { /* row_norms2's sums from the registers: its four-wide lanes are the halves lo, hi here */
      v2d lo = a[0] * a[0], hi = a[1] * a[1];
      for (j = 1; j < TL_VECTORS; ++j) {
        lo += a[2 * j] * a[2 * j];
        hi += a[2 * j + 1] * a[2 * j + 1];
      }
      norms[i] = (lo[0] + lo[1]) + (hi[0] + hi[1]);
    }
  }
}

#if TL_HAVE_WIDE
/* One row pair: the 2 x TL_VECTORS accumulators stay in the 16 AVX registers across the N multiply-adds
   (the constant-trip inner loops unroll at -O3). */
TL_WIDE static void transform_rows_wide(int rows, double (*src)[LD], const double* Mt, double (*dst)[LD], double* norms) {
  int i, j, k;
  const v4d zero = {0.0, 0.0, 0.0, 0.0};
  for (i = 0; i < rows; i += 2) {
    const int pair = i + 1 < rows;
    v4d a[TL_VECTORS], b[TL_VECTORS];
    for (j = 0; j < TL_VECTORS; ++j) a[j] = b[j] = zero;
    for (k = 0; k < N; ++k) {
      const double ga = src[i][k], gb = pair ? src[i + 1][k] : 0.0;
      const v4d* m = (const v4d*)(Mt + k * LD);
      for (j = 0; j < TL_VECTORS; ++j) {
        const v4d mj = m[j];
        a[j] += ga * mj;
        b[j] += gb * mj;
      }
    }
    {
      v4d* da = (v4d*)dst[i];
      for (j = 0; j < TL_VECTORS; ++j) da[j] = a[j];
    }
    if (pair) {
      v4d* db = (v4d*)dst[i + 1];
      for (j = 0; j < TL_VECTORS; ++j) db[j] = b[j];
    }
    if (norms) { /* row_norms2's sums, from the registers */
      v4d na = a[0] * a[0], nb = b[0] * b[0];
      for (j = 1; j < TL_VECTORS; ++j) {
        na += a[j] * a[j];
        nb += b[j] * b[j];
      }
      norms[i] = (na[0] + na[1]) + (na[2] + na[3]);
      if (pair) norms[i + 1] = (nb[0] + nb[1]) + (nb[2] + nb[3]);
    }
  }
}
#endif

#if TL_HAVE_WIDE
/* Three rows at a time: 3 x TL_VECTORS accumulators, each loaded block of Mt used three times, in AVX-512VL's 32
   registers (the two-row copy above is bound by its loads: each block loaded once per row, 16 registers); the
   rows left over (at most two) go to that copy. Same sums in the same order. */
TL_WIDE32 static void transform_rows_wide32(int rows, double (*src)[LD], const double* Mt, double (*dst)[LD],
                                            double* norms) {
  int i, j, k;
  const v4d zero = {0.0, 0.0, 0.0, 0.0};
  for (i = 0; i + 3 <= rows; i += 3) {
    v4d a[TL_VECTORS], b[TL_VECTORS], c[TL_VECTORS];
    for (j = 0; j < TL_VECTORS; ++j) a[j] = b[j] = c[j] = zero;
    for (k = 0; k < N; ++k) {
      const double ga = src[i][k], gb = src[i + 1][k], gc = src[i + 2][k];
      const v4d* m = (const v4d*)(Mt + k * LD);
      for (j = 0; j < TL_VECTORS; ++j) {
        const v4d mj = m[j];
        a[j] += ga * mj;
        b[j] += gb * mj;
        c[j] += gc * mj;
      }
    }
    for (j = 0; j < TL_VECTORS; ++j) {
      ((v4d*)dst[i])[j] = a[j];
      ((v4d*)dst[i + 1])[j] = b[j];
      ((v4d*)dst[i + 2])[j] = c[j];
    }
    if (norms) { /* row_norms2's sums, from the registers */
      v4d na = a[0] * a[0], nb = b[0] * b[0], nc = c[0] * c[0];
      for (j = 1; j < TL_VECTORS; ++j) {
        na += a[j] * a[j];
        nb += b[j] * b[j];
        nc += c[j] * c[j];
      }
      norms[i] = (na[0] + na[1]) + (na[2] + na[3]);
      norms[i + 1] = (nb[0] + nb[1]) + (nb[2] + nb[3]);
      norms[i + 2] = (nc[0] + nc[1]) + (nc[2] + nc[3]);
    }
  }
  if (i < rows) transform_rows_wide(rows - i, src + i, Mt, dst + i, norms ? norms + i : NULL);
}
#endif

/* dst = src M^T; norms (if not NULL): the squared 2-norm of each dst row, as row_norms2 sums it (the Combastel and
   PCA scores, taken while the row is in registers instead of in a second pass over the generators). */
static void transform_rows(int rows, double (*src)[LD], const double* Mt, double (*dst)[LD], double* norms) {
#if TL_HAVE_WIDE
  if (tl_wide32()) {
    transform_rows_wide32(rows, src, Mt, dst, norms);
    return;
  }
  if (tl_wide()) {
    transform_rows_wide(rows, src, Mt, dst, norms);
    return;
  }
#endif
  transform_rows_base(rows, src, Mt, dst, norms);
}
#else
static void row_norms2(int rows, double (*G)[LD], double* out);

static void transform_rows(int rows, double (*src)[LD], const double* Mt, double (*dst)[LD], double* norms) {
  int i, j, k;
  for (i = 0; i < rows; ++i) {
    double acc[LD];
    for (j = 0; j < LD; ++j) acc[j] = 0.0;
    for (k = 0; k < N; ++k)
      for (j = 0; j < LD; ++j) acc[j] += src[i][k] * Mt[k * LD + j];
    for (j = 0; j < LD; ++j) dst[i][j] = acc[j];
  }
  if (norms) row_norms2(rows, dst, norms);
}
#endif

#if defined(__GNUC__)
typedef long long v4i __attribute__((vector_size(32), aligned(8)));

/* |x| by clearing the sign bits (a macro: a function returning a vector would change the ABI warning-wise). */
#define TL_MAGNITUDE ((v4i){0x7fffffffffffffffLL, 0x7fffffffffffffffLL, 0x7fffffffffffffffLL, 0x7fffffffffffffffLL})
#define vabs(x) ((v4d)((v4i)(x) & TL_MAGNITUDE))

/* hull = column sums of |G| (rs(G), Thm 4.1) and the squared 2-norm of every row (the Combastel and PCA
   scores): one body, inlined into a baseline and an AVX2 copy (these accumulators fit either register file). */
static inline __attribute__((always_inline)) void row_abs_sums_body(int rows, double (*G)[LD], double* hull) {
  v4d acc[TL_VECTORS];
  int i, j;
  for (j = 0; j < TL_VECTORS; ++j) acc[j] = (v4d){0.0, 0.0, 0.0, 0.0};
  for (i = 0; i < rows; ++i) {
    const v4d* g = (const v4d*)G[i];
    for (j = 0; j < TL_VECTORS; ++j) acc[j] += vabs(g[j]);
  }
  for (j = 0; j < N; ++j) hull[j] = acc[j / 4][j % 4];
}

static inline __attribute__((always_inline)) void row_norms2_body(int rows, double (*G)[LD], double* out) {
  int i, j;
  for (i = 0; i < rows; ++i) {
    const v4d* g = (const v4d*)G[i];
    v4d acc = g[0] * g[0];
    for (j = 1; j < TL_VECTORS; ++j) acc += g[j] * g[j];
    out[i] = (acc[0] + acc[1]) + (acc[2] + acc[3]);
  }
}

#if TL_HAVE_WIDE
TL_WIDE static void row_abs_sums_wide(int rows, double (*G)[LD], double* hull) { row_abs_sums_body(rows, G, hull); }
TL_WIDE static void row_norms2_wide(int rows, double (*G)[LD], double* out) { row_norms2_body(rows, G, out); }
#endif

static void row_abs_sums(int rows, double (*G)[LD], double* hull) {
#if TL_HAVE_WIDE
  if (tl_wide()) {
    row_abs_sums_wide(rows, G, hull);
    return;
  }
#endif
  row_abs_sums_body(rows, G, hull);
}

static void row_norms2(int rows, double (*G)[LD], double* out) {
#if TL_HAVE_WIDE
  if (tl_wide()) {
    row_norms2_wide(rows, G, out);
    return;
  }
#endif
  row_norms2_body(rows, G, out);
}

/* S (N x N) += sign * R^T R over the rows of R: per entry the same sum in row order at either width. The upper
   triangle only, mirrored (R[i][j] R[i][k] and R[i][k] R[i][j] are the same product, summed in the same order):
   a row j's sums from its diagonal's piece on, held in registers over the rows (one j at a time two-wide, two
   at a time four-wide); a zero R[i][j] adds zeros, which change no sum. */
static inline __attribute__((always_inline)) void add_sums(int j, int from, const double* D, double sign, double* S) {
  int k;
  for (k = from; k < N; ++k) {
    S[j * N + k] += sign * D[k];
    if (k != j) S[k * N + j] += sign * D[k];
  }
}

static void add_gram_base(int rows, double (*R)[LD], double sign, double* S) {
  int i, j, c;
  for (j = 0; j < N; ++j) {
    const int c0 = j / 2;
    v2d d[LD / 2];
    double out[LD];
    for (c = c0; c < LD / 2; ++c) d[c] = (v2d){0.0, 0.0};
    for (i = 0; i < rows; ++i) {
      const double rj = R[i][j];
      const v2d* r = (const v2d*)R[i];
      for (c = c0; c < LD / 2; ++c) d[c] += rj * r[c];
    }
    for (c = c0; c < LD / 2; ++c) ((v2d*)out)[c] = d[c];
    add_sums(j, j, out, sign, S);
  }
}

#if TL_HAVE_WIDE
TL_WIDE static void add_gram_wide(int rows, double (*R)[LD], double sign, double* S) {
  int i, j, c;
  for (j = 0; j < N; j += 2) {
    const int c0 = j / 4, pair = j + 1 < N;
    v4d a[TL_VECTORS], b[TL_VECTORS];
    double out_a[LD], out_b[LD];
    for (c = c0; c < TL_VECTORS; ++c) a[c] = b[c] = (v4d){0.0, 0.0, 0.0, 0.0};
    for (i = 0; i < rows; ++i) {
      const double ra = R[i][j], rb = pair ? R[i][j + 1] : 0.0;
      const v4d* r = (const v4d*)R[i];
      for (c = c0; c < TL_VECTORS; ++c) {
        const v4d rc = r[c];
        a[c] += ra * rc;
        b[c] += rb * rc;
      }
    }
    for (c = c0; c < TL_VECTORS; ++c) {
      ((v4d*)out_a)[c] = a[c];
      ((v4d*)out_b)[c] = b[c];
    }
    add_sums(j, j, out_a, sign, S);
    if (pair) add_sums(j + 1, j + 1, out_b, sign, S);
  }
}
#endif

static void add_gram(int rows, double (*R)[LD], double sign, double* S) {
#if TL_HAVE_WIDE
  if (tl_wide()) {
    add_gram_wide(rows, R, sign, S);
    return;
  }
#endif
  add_gram_base(rows, R, sign, S);
}
#else
static void row_abs_sums(int rows, double (*G)[LD], double* hull) {
  int i, j;
  for (j = 0; j < N; ++j) hull[j] = 0.0;
  for (i = 0; i < rows; ++i)
    for (j = 0; j < N; ++j) hull[j] += fabs(G[i][j]);
}

static void row_norms2(int rows, double (*G)[LD], double* out) {
  int i, j;
  for (i = 0; i < rows; ++i) {
    out[i] = 0.0;
    for (j = 0; j < N; ++j) out[i] += G[i][j] * G[i][j];
  }
}

static void add_gram(int rows, double (*R)[LD], double sign, double* S) {
  int i, j, k;
  for (i = 0; i < rows; ++i)
    for (j = 0; j < N; ++j)
      for (k = 0; k < N; ++k) S[j * N + k] += sign * R[i][j] * R[i][k];
}
#endif

/* S = G^T G over the rows. */
static void gram(int rows, double (*G)[LD], double* S) {
  memset(S, 0, sizeof(double) * N * N);
  add_gram(rows, G, 1.0, S);
}

/* Girard's score ||g||_1 - ||g||_inf: small for generators close to an axis-aligned segment. */
static double girard_score(const double* g) {
  double s = 0.0, big = 0.0;
  int j;
  for (j = 0; j < N; ++j) {
    s += fabs(g[j]);
    if (fabs(g[j]) > big) big = fabs(g[j]);
  }
  return s - big;
}

/* Indices of the k smallest scores, ascending by index (ties: the lower index goes first): a max-heap of k
   (score, index) pairs, one pass over the rows given (rows[0..n_rows) ascending and without a NaN score, or
   0..n_rows if rows is NULL). */
static void heap_select(const int* rows, int n_rows, const double* scores, int k, int* chosen) {
  int heap[TL_ZSE_CAP], size = 0, i, t;
#define LESS(a, b) (scores[a] < scores[b] || (scores[a] == scores[b] && (a) < (b)))
  for (t = 0; t < n_rows; ++t) {
    const int row = rows ? rows[t] : t;
    int pos;
    if (size < k) {
      pos = size++;
      while (pos > 0 && LESS(heap[(pos - 1) / 2], row)) {
        heap[pos] = heap[(pos - 1) / 2];
        pos = (pos - 1) / 2;
      }
      heap[pos] = row;
    } else if (LESS(row, heap[0])) {
      int child;
      pos = 0;
      for (;;) { /* sift the new element down from the root */
        child = 2 * pos + 1;
        if (child >= size) break;
        if (child + 1 < size && LESS(heap[child], heap[child + 1])) ++child;
        if (!LESS(row, heap[child])) break;
        heap[pos] = heap[child];
        pos = child;
      }
      heap[pos] = row;
    }
  }
  if (rows != NULL && size == k && k > 0) { /* rows ascend and have no NaN score (smallest's promise): LESS orders them
                                               totally, so the k chosen are the rows not after the heap's root, kept in
                                               the rows' order, without sorting */
    const int kth = heap[0];
    int m = 0;
    for (t = 0; t < n_rows && m < k; ++t) {
      chosen[m] = rows[t];
      m += !LESS(kth, rows[t]);
    }
    return;
  }
#undef LESS
  for (i = 0; i < k; ++i) chosen[i] = heap[i];
  for (i = 1; i < k; ++i) { /* insertion sort by index */
    int v = chosen[i], j = i;
    while (j > 0 && chosen[j - 1] > v) {
      chosen[j] = chosen[j - 1];
      --j;
    }
    chosen[j] = v;
  }
}

/* The k smallest of r scores (heap_select's answer over all), looked for first among the scores at most *below,
   from the previous tick (a set changes little in one tick). The k smallest of all are among those candidates
   whenever there are k of them, so the answer never depends on *below, only the time does; with fewer (or a NaN
   score: no candidate, ordered as the heap alone orders it), all r. *below becomes this tick's k-th smallest
   score times SELECT_MARGIN. */
#define SELECT_MARGIN 1.25
static void smallest(int r, const double* scores, int k, int* chosen, double* below) {
  int candidates[TL_ZSE_CAP], n = 0, nan = 0, i;
  const double limit = *below;
  double kth = 0.0;
  for (i = 0; i < r; ++i) {
    candidates[n] = i;
    n += scores[i] <= limit;
    nan |= scores[i] != scores[i];
  }
  if (n >= k && !nan) heap_select(candidates, n, scores, k, chosen);
  else heap_select(NULL, r, scores, k, chosen);
  for (i = 0; i < k; ++i)
    if (scores[chosen[i]] > kth) kth = scores[chosen[i]];
  *below = SELECT_MARGIN * kth;
}

/* S += sign * diag(w)^T diag(w) as add_gram sums it over the rows w_j e_j: each off-diagonal sum is +0 (products
   of a zero, finite w), each diagonal one w_j^2, added once to its entry (n^2 operations, not n^3). */
static void add_gram_diagonal(const double* w, double sign, double* S) {
  int j;
  for (j = 0; j < N * N; ++j) S[j] += sign * 0.0;
  for (j = 0; j < N; ++j) S[j * N + j] += sign * (0.0 + w[j] * w[j]);
}

/* Reduce buf[:r] to buf[:r_max] keeping the kept rows in place (as zonotope.reduce_in_place does);
   S is updated with the removed and added generators. scores: the Combastel and PCA scores (squared 2-norms of
   the rows) when the caller has them, else NULL. */
static void reduce(double (*buf)[LD], int r, int r_max, int method, double* scores, double* S, double* below) {
  static const int n = N;
  double own[TL_ZSE_CAP], removed[2 * N + NY][LD], added[N][LD], widths[N];
  int drop[2 * N + NY], nbox = r - r_max + n, i, j, k, n_slots = 0, n_movers = 0, finite = 1;
  int slots[2 * N + NY], movers[N + NY], tail_dropped[N + NY + N];
  if (method == TL_REDUCE_GIRARD || scores == NULL) {
    scores = own;
    if (method == TL_REDUCE_GIRARD)
      for (i = 0; i < r; ++i) scores[i] = girard_score(buf[i]);
    else
      row_norms2(r, buf, scores); /* combastel, pca: the shortest (2-norm) generators go */
  }
  smallest(r, scores, nbox, drop, below);
  for (i = 0; i < nbox; ++i) memcpy(removed[i], buf[drop[i]], sizeof(double) * LD);
  memset(added, 0, sizeof added);
  if (method == TL_REDUCE_PCA) { /* a box in the principal axes of the whole set */
    double gtg[N * N], w[N], V[N * N];
    gram(r, buf, gtg);
    tl_eigh(n, gtg, w, V);
    for (j = 0; j < n; ++j) {
      double width = 0.0;
      for (i = 0; i < nbox; ++i) {
        double proj = 0.0;
        for (k = 0; k < n; ++k) proj += removed[i][k] * V[k * n + j];
        width += fabs(proj);
      }
      for (k = 0; k < n; ++k) added[j][k] = V[k * n + j] * width;
    }
  } else { /* an axis-aligned box */
    for (j = 0; j < n; ++j) {
      double width = 0.0;
      for (i = 0; i < nbox; ++i) width += fabs(removed[i][j]);
      added[j][j] = widths[j] = width;
      finite &= isfinite(width) != 0;
    }
  }
  for (i = 0; i < r - r_max; ++i) tail_dropped[i] = 0;
  for (i = 0; i < nbox; ++i) {
    if (drop[i] < r_max) slots[n_slots++] = drop[i];
    else tail_dropped[drop[i] - r_max] = 1;
  }
  for (i = 0; i < r - r_max; ++i)
    if (!tail_dropped[i]) movers[n_movers++] = r_max + i;
  for (i = 0; i < n_movers; ++i) memcpy(buf[slots[i]], buf[movers[i]], sizeof(double) * LD);
  for (i = n_movers; i < n_slots; ++i) memcpy(buf[slots[i]], added[i - n_movers], sizeof(double) * LD);
  add_gram(nbox, removed, -1.0, S); /* S += added^T added - removed^T removed */
  if (method != TL_REDUCE_PCA && finite) add_gram_diagonal(widths, 1.0, S);
  else add_gram(n, added, 1.0, S);
}

/* All strips of this step at once, then one pass over the generators: G+ = [T G_w, (T M) G, K Sigma]. */
static int update(TlZse* z, const TlZseModel* m, const double* M, const double* y, const int* available,
                  const double* predicted_hull, int with_noise, TlZseReport* rep) {
  int idx[NY], n_idx = 0, i, j, k, r, finite_T = 1;
  double innovation[NY], Hs[NY * N], K[N * NY], T[N * N], TM[N * N], TMt[LD * LD], scores[TL_ZSE_CAP];
  double* fused = NULL;
  double (*src)[LD] = z->G[z->cur], (*dst)[LD] = z->G[1 - z->cur];
  memset(rep, 0, sizeof *rep);
  for (i = 0; y != NULL && i < NY; ++i) {
    const double* h = m->H + i * N;
    double hc = 0.0, reach = 0.0;
    if (available && !available[i]) continue;
    if (!isfinite(y[i])) {
      rep->nonfinite[rep->n_nonfinite++] = i;
      continue;
    }
    for (k = 0; k < N; ++k) {
      hc += h[k] * z->c[k];
      reach += fabs(h[k]) * predicted_hull[k];
    }
    innovation[n_idx] = y[i] + m->s[i] - hc;
    if (fabs(innovation[n_idx]) > reach + m->sigma[i]) { /* the strip misses the predicted box: the model is violated */
      rep->inconsistent[rep->n_inconsistent++] = i;
      continue;
    }
    memcpy(Hs + n_idx * N, h, sizeof(double) * N);
    idx[n_idx++] = i;
  }
  rep->used = n_idx;
  if (n_idx) { /* K = S H^T (H S H^T + diag(sigma^2))^-1, T = I - K H, S+ = T S */
    double SH[N * NY], Mat[NY * NY], Kt[NY * N], St[N * N];
    tl_matmul_bt(N, N, n_idx, z->S, Hs, SH);
    tl_matmul(n_idx, N, n_idx, Hs, SH, Mat);
    for (i = 0; i < n_idx; ++i) Mat[i * n_idx + i] += m->sigma[idx[i]] * m->sigma[idx[i]];
    for (i = 0; i < n_idx; ++i)
      for (k = 0; k < N; ++k) Kt[i * N + k] = SH[k * n_idx + i];
    if (tl_solve(n_idx, N, Mat, Kt)) return -1;
    for (k = 0; k < N; ++k)
      for (i = 0; i < n_idx; ++i) K[k * n_idx + i] = Kt[i * N + k];
    for (k = 0; k < N; ++k) {
      double dc = 0.0;
      for (i = 0; i < n_idx; ++i) dc += K[k * n_idx + i] * innovation[i];
      z->c[k] += dc;
    }
    tl_matmul(N, n_idx, N, K, Hs, T);
    for (i = 0; i < N * N; ++i) T[i] = -T[i];
    for (i = 0; i < N; ++i) T[i * N + i] += 1.0;
    tl_matmul(N, N, N, T, M, TM);
    tl_matmul(N, N, N, T, z->S, St);
    memcpy(z->S, St, sizeof St);
    tl_symmetrize(N, z->S);
  } else {
    for (i = 0; i < N * N; ++i) T[i] = (i / N == i % N) ? 1.0 : 0.0;
    memcpy(TM, M, sizeof TM);
  }
  r = 0;
  memset(TMt, 0, sizeof TMt);
  if (with_noise && m->rw) { /* T G_w */
    double row[LD];
    for (k = 0; k < N; ++k)
      for (j = 0; j < N; ++j) TMt[k * LD + j] = T[j * N + k];
    for (i = 0; i < N * N; ++i) finite_T &= isfinite(T[i]) != 0;
    for (i = 0; i < m->rw; ++i, ++r) {
      const double* g = m->Gw + i * N;
      int nonzero = 0, at = 0;
      for (k = 0; k < N; ++k)
        if (g[k] != 0.0) {
          ++nonzero;
          at = k;
        }
      if (nonzero == 1 && finite_T && isfinite(g[at])) { /* g = w e_at (a diagonal G_w): T g is w T[:, at]; the zero
                                                           terms of the product add +-0, which turns a -0 into +0 and
                                                           nothing else, as 0.0 + does */
        for (j = 0; j < N; ++j) dst[r][j] = 0.0 + g[at] * T[j * N + at];
        for (j = N; j < LD; ++j) dst[r][j] = 0.0;
        continue;
      }
      memset(row, 0, sizeof row);
      memcpy(row, g, sizeof(double) * N);
      transform_rows(1, &row, TMt, &dst[r], NULL);
    }
  }
  for (k = 0; k < N; ++k)
    for (j = 0; j < N; ++j) TMt[k * LD + j] = TM[j * N + k];
  if (r + z->r + n_idx > m->r_max && m->reduction != TL_REDUCE_GIRARD) fused = scores; /* a reduction follows */
  transform_rows(z->r, src, TMt, dst + r, fused ? fused + r : NULL); /* (T M) G */
  if (fused) row_norms2(r, dst, fused);
  r += z->r;
  for (i = 0; i < n_idx; ++i, ++r) { /* the new generators sigma_i K[:, i] */
    for (k = 0; k < N; ++k) dst[r][k] = K[k * n_idx + i] * m->sigma[idx[i]];
    for (k = N; k < LD; ++k) dst[r][k] = 0.0;
  }
  z->cur = 1 - z->cur;
  if (r > m->r_max) {
    if (fused) row_norms2(n_idx, dst + r - n_idx, fused + r - n_idx);
    reduce(dst, r, m->r_max, m->reduction, fused, z->S, &z->select_below);
    r = m->r_max;
  }
  z->r = r;
  z->steps += 1;
  if (z->steps % RESYNC_EVERY == 0) gram(r, dst, z->S);
  row_abs_sums(r, dst, z->hull);
  return 0;
}

int tl_zse_initialize(TlZse* z, const TlZseModel* m, const double* c0, const double* G0, int r0, const double* y0,
                      const int* available, TlZseReport* report) {
  double I[N * N];
  int i, k;
  if (r0 < 0 || r0 > TL_ZSE_CAP || m->r_max > TL_R_MAX || m->r_max < N) return -1;
  memset(z, 0, sizeof *z);
  z->r = 0;
  for (i = 0; i < r0; ++i) { /* zero generators carry nothing */
    int nonzero = 0;
    for (k = 0; k < N; ++k) nonzero |= G0[i * N + k] != 0.0;
    if (!nonzero) continue;
    memcpy(z->G[0][z->r], G0 + i * N, sizeof(double) * N);
    z->r += 1;
  }
  memcpy(z->c, c0, sizeof z->c);
  gram(z->r, z->G[0], z->S);
  row_abs_sums(z->r, z->G[0], z->hull);
  memset(report, 0, sizeof *report);
  if (y0 == NULL) return 0;
  for (i = 0; i < N * N; ++i) I[i] = (i / N == i % N) ? 1.0 : 0.0;
  {
    double hull[N];
    memcpy(hull, z->hull, sizeof hull);
    return update(z, m, I, y0, available, hull, 0, report);
  }
}

int tl_zse_step(TlZse* z, const TlZseModel* m, const double* du, const double* y, const int* available, TlZseReport* report) {
  double c[N], AS[N * N], hull[N];
  int i, k;
  for (i = 0; i < N; ++i) { /* c = A c + B du + c_w */
    double v = 0.0, b = 0.0;
    for (k = 0; k < N; ++k) v += m->A[i * N + k] * z->c[k];
    for (k = 0; k < m->nu; ++k) b += m->B[i * m->nu + k] * du[k];
    c[i] = v + b + m->c_w[i];
  }
  memcpy(z->c, c, sizeof c);
  tl_matmul(N, N, N, m->A, z->S, AS); /* S = A S A^T + S_w */
  tl_matmul_bt(N, N, N, AS, m->A, z->S);
  for (i = 0; i < N * N; ++i) z->S[i] += m->Sw[i];
  for (i = 0; i < N; ++i) { /* a box containing the predicted set's interval hull */
    double v = 0.0;
    for (k = 0; k < N; ++k) v += fabs(m->A[i * N + k]) * z->hull[k];
    hull[i] = v + m->hull_w[i];
  }
  return update(z, m, m->A, y, available, hull, 1, report);
}

double tl_zse_frobenius(const TlZse* z) {
  double t = 0.0;
  int i;
  for (i = 0; i < N; ++i) t += z->S[i * N + i];
  return sqrt(t > 0.0 ? t : 0.0);
}

const double* tl_zse_generator(const TlZse* z, int i) { return z->G[z->cur][i]; }

unsigned long tl_zse_size(void) { return (unsigned long)sizeof(TlZse); }
