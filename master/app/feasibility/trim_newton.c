/* Newton's method on the trim residual (plant_fmu/trim.py's newton, step for step), over CasADi's generated residual
 * and Jacobian (trim_residual, compiled with this file) and the LAPACK dgesv numpy's linalg.solve calls (its address
 * given); and the feasibility check's trims along a path (trajectory_check.py's _trim, halving and all): the same
 * operations on the same values, so the same bits, without Python between the steps. */
#include <math.h>
#include <string.h>

typedef long long casadi_int;
int trim_residual(const double **arg, double **res, casadi_int *iw, double *w, int mem);
int trim_residual_value(const double **arg, double **res, casadi_int *iw, double *w, int mem);
typedef void (*tl_gesv)(long long *n, long long *nrhs, double *a, long long *lda, long long *ipiv, double *b,
                        long long *ldb, long long *info);

enum { TL_MAX_N = 16, TL_MAX_NZ = TL_MAX_N * TL_MAX_N };
/* A step this small is most likely the last: the next iterate's residual is then evaluated alone first (a quarter of the
 * residual-and-Jacobian's operations), the Jacobian only when it has not converged after all. Which evaluation comes
 * first changes no value (the same expressions), only the cost: along a path 0.12 s apart the last steps measured below
 * 2.2e-4, the earlier ones above 1.8e-4. */
#define TL_LAST_STEP 1e-3

/* 0: r finite and max|r| <= tol (*worst set); 1: not converged; -1: a value not finite. */
static int converged(const double *r, int n, double tol, double *worst)
{
    *worst = 0.0;
    for (int i = 0; i < n; i++) {
        if (!isfinite(r[i]))
            return -1;
        if (fabs(r[i]) > *worst)
            *worst = fabs(r[i]);
    }
    return *worst <= tol ? 0 : 1;
}

/* z (n, in and out), ref, p; dense: the column-major position of each Jacobian nonzero; iw, w: the residual's work
 * (either function's). 1: converged (z the point, *residual, *iterations); 0: not (a value not finite, a singular
 * Jacobian, max_iter). */
__attribute__((visibility("default")))
int tl_trim_newton(double *z, const double *ref, const double *p, int n, const long long *dense, int nnz, double tol,
                   int max_iter, tl_gesv gesv, casadi_int *iw, double *w, double *residual, int *iterations)
{
    double r[TL_MAX_N], nz[TL_MAX_NZ], a[TL_MAX_NZ], b[TL_MAX_N], worst;
    long long ipiv[TL_MAX_N], nn = n, one = 1, info = 0;
    int last = 0, state;
    if (n > TL_MAX_N || nnz > TL_MAX_NZ)
        return 0;
    for (int it = 1; it <= max_iter; it++) {
        const double *arg[3] = {z, ref, p};
        double *res[2] = {r, nz};
        if (last) {
            if (trim_residual_value(arg, res, iw, w, 0) || (state = converged(r, n, tol, &worst)) < 0)
                return 0;
            if (state == 0) {
                *residual = worst;
                *iterations = it;
                return 1;
            }
        }
        if (trim_residual(arg, res, iw, w, 0))
            return 0;
        if (!last) {
            if ((state = converged(r, n, tol, &worst)) < 0)
                return 0;
            if (state == 0) {
                *residual = worst;
                *iterations = it;
                return 1;
            }
        }
        memset(a, 0, sizeof(double) * (size_t)(n * n));
        for (int k = 0; k < nnz; k++)
            a[dense[k]] = nz[k];
        memcpy(b, r, sizeof(double) * (size_t)n);
        gesv(&nn, &one, a, &nn, ipiv, b, &nn, &info);
        if (info != 0)
            return 0;
        double step = 0.0;
        for (int i = 0; i < n; i++) {
            z[i] = z[i] - b[i];
            step = fabs(b[i]) > step ? fabs(b[i]) : step;
        }
        last = step < TL_LAST_STEP;
    }
    return 0;
}

enum { TL_REF = 11, TL_MAX_DEPTH = 8 };

typedef struct {
    const double *p;
    int n, n_angles, nnz, max_iter;
    const long long *dense;
    double tol;
    tl_gesv gesv;
    casadi_int *iw;
    double *w;
} tl_trim_context;

/* trajectory_check._trim: the trim at ref from the trim z_prev at ref_prev, halving the way when Newton strays. */
static int trim_at(const tl_trim_context *c, double *z_out, const double *z_prev, const double *ref_prev, const double *ref,
                   int depth)
{
    double z[TL_MAX_N], residual, middle[TL_REF], z_mid[TL_MAX_N];
    int iterations;
    memcpy(z, z_prev, sizeof(double) * (size_t)c->n);
    if (tl_trim_newton(z, ref, c->p, c->n, c->dense, c->nnz, c->tol, c->max_iter, c->gesv, c->iw, c->w, &residual,
                       &iterations)) {
        double far = 0.0;
        for (int i = 0; i < c->n_angles; i++)
            if (fabs(z[i] - z_prev[i]) > far)
                far = fabs(z[i] - z_prev[i]);
        if (far < 0.3) {
            memcpy(z_out, z, sizeof(double) * (size_t)c->n);
            return 1;
        }
    }
    if (depth >= TL_MAX_DEPTH)
        return 0;
    for (int j = 0; j < TL_REF; j++)
        middle[j] = 0.5 * (ref_prev[j] + ref[j]);
    if (!trim_at(c, z_mid, z_prev, ref_prev, middle, depth + 1))
        return 0;
    return trim_at(c, z_out, z_mid, middle, ref, depth + 1);
}

/* The trims at each of the count references (rows of TL_REF), each from the one before (z, previous: the start's, then
 * the last found); trims: count rows of n. Returns how many were found (fewer than count: none at the next). */
__attribute__((visibility("default")))
int tl_trim_path(const double *z0, const double *previous0, const double *refs, int count, const double *p, int n,
                 int n_angles, const long long *dense, int nnz, double tol, int max_iter, tl_gesv gesv, casadi_int *iw,
                 double *w, double *trims)
{
    tl_trim_context c = {p, n, n_angles, nnz, max_iter, dense, tol, gesv, iw, w};
    const double *z = z0, *previous = previous0;
    if (n > TL_MAX_N)
        return 0;
    for (int k = 0; k < count; k++) {
        if (!trim_at(&c, trims + (size_t)k * (size_t)n, z, previous, refs + (size_t)k * TL_REF, 0))
            return k;
        z = trims + (size_t)k * (size_t)n;
        previous = refs + (size_t)k * TL_REF;
    }
    return count;
}

typedef int (*tl_casadi_function)(const double **arg, double **res, casadi_int *iw, double *w, int mem);

enum { TL_MAX_NX = 64 };

/* The feedforward (3.18) along the reference, one row at a time as CasADi's map does: at each row of refs (count rows of
 * TL_REF, stride apart: the load's position, psi, their rates, the load's acceleration) the state hover_x (nx = 2 nq)
 * with the load's position, psi and their rates put in (the entries trim_residual.along_reference names) and every
 * other rate 0, and qdd the load's acceleration alone, with the parameters p; out: count rows of nu. The feedforward comes in two parts (trim_residual.feedforward_parts):
 * fixed (x, p) -> values, what the rows leave unchanged, once into values; rest (x, qdd, p, values) -> u at each row.
 * 0: done; else the functions' code (-1: a state larger than TL_MAX_NX). */
__attribute__((visibility("default")))
int tl_feedforward_along(tl_casadi_function fixed, tl_casadi_function rest, const double *hover_x, int nq, const double *refs,
                         int stride, const double *p, double *values, double *out, int nu, int count, casadi_int *iw,
                         double *w)
{
    double x[TL_MAX_NX], qdd[TL_MAX_NX / 2];
    int status;
    if (2 * nq > TL_MAX_NX || nq < 6 || stride < TL_REF)
        return -1;
    memcpy(x, hover_x, sizeof(double) * (size_t)nq);
    memset(x + nq, 0, sizeof(double) * (size_t)nq);
    memset(qdd, 0, sizeof(double) * (size_t)nq);
    {
        const double *arg[2] = {x, p};
        double *res[1] = {values};
        if ((status = fixed(arg, res, iw, w, 0)))
            return status;
    }
    for (int k = 0; k < count; k++) {
        const double *ref = refs + (size_t)k * (size_t)stride;
        memcpy(x, ref, 3 * sizeof(double));
        x[5] = ref[3];
        memcpy(x + nq, ref + 4, 3 * sizeof(double));
        x[nq + 5] = ref[7];
        memcpy(qdd, ref + 8, 3 * sizeof(double));
        const double *arg[4] = {x, qdd, p, values};
        double *res[1] = {out + (size_t)k * (size_t)nu};
        if ((status = rest(arg, res, iw, w, 0)))
            return status;
    }
    return 0;
}
