/* Small dense linear algebra for the controller FMU's estimators: row-major, sizes known to the
   caller, no allocation. Written for clarity first; the one hot product lives in tl_zse.c. */
#ifndef TL_LINALG_H
#define TL_LINALG_H

#include "tl_platform.h"

/* On x86-64 Linux with GCC, hot routines get a second, x86-64-v3 (AVX2) copy chosen at run time: the
   shipped binary stays portable. Contraction is off (tl_platform.h), so that copy does the same IEEE
   operations four wide and gives the default copy's results to the bit, as every other platform does;
   -DTL_PORTABLE_FP (via $TILTLOAD_CFLAGS) builds the default copy only. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__linux__) && !defined(TL_PORTABLE_FP)
#define TL_DISPATCH __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define TL_DISPATCH
#endif

#define TL_LINALG_MAX 32 /* the largest k and m tl_matmul_bt transposes on the stack */

/* C (n x m) = A (n x k) B (k x m). C may not alias A or B. */
TL_INTERNAL void tl_matmul(int n, int k, int m, const double* A, const double* B, double* C);
/* C (n x m) = A (n x k) B^T (B is m x k). */
TL_INTERNAL void tl_matmul_bt(int n, int k, int m, const double* A, const double* B, double* C);
/* Solve A X = B in place of B (A n x n, destroyed; B n x m) by LU with partial pivoting. 0 ok, -1 singular. */
TL_INTERNAL int tl_solve(int n, int m, double* A, double* B);
/* Eigenvalues (ascending) and eigenvectors (columns of V, row-major n x n) of the symmetric A (destroyed):
   cyclic Jacobi rotations until the off-diagonal part is negligible. */
TL_INTERNAL void tl_eigh(int n, double* A, double* eigenvalues, double* V);
/* S = (S + S^T) / 2 */
TL_INTERNAL void tl_symmetrize(int n, double* S);

#endif
