/* Small dense linear algebra for the controller FMU's estimators: row-major, sizes known to the
   caller, no allocation. Written for clarity first; the one hot product lives in tl_zse.c. */
#ifndef TL_LINALG_H
#define TL_LINALG_H

#include "tl_platform.h"

/* The hot kernels (tl_matmul, tl_zse.c's products) are written per vector width: a baseline copy for 128-bit
   registers (any x86-64: SSE2; aarch64: NEON) and, on x86-64 with GCC or clang, an AVX2 copy (TL_WIDE) called
   when the CPU and the OS have AVX2 (libgcc's CPUID check: on Linux and in a Windows DLL alike, where there is
   no ifunc). Contraction is off (tl_platform.h) and each entry is the same sum in the same order in either copy,
   so the results do not depend on the copy; -DTL_PORTABLE_FP (via $TILTLOAD_CFLAGS) builds the baseline only. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(TL_PORTABLE_FP)
#define TL_HAVE_WIDE 1
#define TL_WIDE __attribute__((target("avx2")))
static inline int tl_wide(void) {
  __builtin_cpu_init(); /* idempotent; needed before constructors have run */
  return __builtin_cpu_supports("avx2") != 0;
}
/* The same four-wide operations with AVX-512VL's 32 vector registers (not its eight-wide ones: on AMD Zen 4 those
   run as two halves and measured slower): more accumulators per loaded operand, for the ZSE's one heavy product.
   libgcc's check includes the OS's saving of the registers. */
#define TL_WIDE32 __attribute__((target("avx512f,avx512vl")))
static inline int tl_wide32(void) {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") != 0 && __builtin_cpu_supports("avx512vl") != 0;
}
#else
#define TL_HAVE_WIDE 0
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
