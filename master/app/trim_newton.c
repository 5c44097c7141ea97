/* Newton's method on the trim residual (plant_fmu/trim.py's newton, step for step), over CasADi's generated residual
 * and Jacobian (trim_residual, compiled with this file) and the LAPACK dgesv numpy's linalg.solve calls (its address
 * given): the same operations on the same values, so the same bits, without Python between the steps. */
#include <math.h>
#include <string.h>

typedef long long casadi_int;
int trim_residual(const double **arg, double **res, casadi_int *iw, double *w, int mem);
typedef void (*tl_gesv)(long long *n, long long *nrhs, double *a, long long *lda, long long *ipiv, double *b,
                        long long *ldb, long long *info);

enum { TL_MAX_N = 16, TL_MAX_NZ = TL_MAX_N * TL_MAX_N };

/* z (n, in and out), ref, p; dense: the column-major position of each Jacobian nonzero; iw, w: the residual's work.
 * 1: converged (z the point, *residual, *iterations); 0: not (a value not finite, a singular Jacobian, max_iter). */
__attribute__((visibility("default")))
int tl_trim_newton(double *z, const double *ref, const double *p, int n, const long long *dense, int nnz, double tol,
                   int max_iter, tl_gesv gesv, casadi_int *iw, double *w, double *residual, int *iterations)
{
    double r[TL_MAX_N], nz[TL_MAX_NZ], a[TL_MAX_NZ], b[TL_MAX_N];
    long long ipiv[TL_MAX_N], nn = n, one = 1, info = 0;
    if (n > TL_MAX_N || nnz > TL_MAX_NZ)
        return 0;
    for (int it = 1; it <= max_iter; it++) {
        const double *arg[3] = {z, ref, p};
        double *res[2] = {r, nz};
        if (trim_residual(arg, res, iw, w, 0))
            return 0;
        double worst = 0.0;
        for (int i = 0; i < n; i++) {
            if (!isfinite(r[i]))
                return 0;
            if (fabs(r[i]) > worst)
                worst = fabs(r[i]);
        }
        if (worst <= tol) {
            *residual = worst;
            *iterations = it;
            return 1;
        }
        memset(a, 0, sizeof(double) * (size_t)(n * n));
        for (int k = 0; k < nnz; k++)
            a[dense[k]] = nz[k];
        memcpy(b, r, sizeof(double) * (size_t)n);
        gesv(&nn, &one, a, &nn, ipiv, b, &nn, &info);
        if (info != 0)
            return 0;
        for (int i = 0; i < n; i++)
            z[i] = z[i] - b[i];
    }
    return 0;
}
