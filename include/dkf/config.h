/*
 * dkf/config.h - compile-time limits and switches of the dkf core.
 *
 * Every option is #ifndef-guarded: define it on the command line, or put
 * your own values in a header and build with -DDKF_CONFIG_FILE='"my.h"'
 * (that file is included first, so it wins over every default below).
 * The consistency checks at the end turn a bad combination into a
 * compile error instead of a runtime surprise.
 */
#ifndef DKF_CONFIG_H
#define DKF_CONFIG_H

#ifdef DKF_CONFIG_FILE
#include DKF_CONFIG_FILE
#endif
/* The options the library was built with, when it was built by CMake (the
 * generated header; the source tree's copy is empty): a value above that
 * disagrees with them is an #error there. */
#include "dkf/build_config.h"

#include <float.h>
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The real type. 0: double (host default). 1: float (Cortex-M4F has a
 * single-precision FPU only, so firmware builds want this). */
#ifndef DKF_USE_FLOAT
#define DKF_USE_FLOAT 0
#endif

/* Largest number of rows or columns any matrix passed to dkf may have.
 * Bounds the small fixed-size arrays some routines keep on the stack
 * (DKF_MAX_DIM reals or indices, never a square of it). */
#ifndef DKF_MAX_DIM
#define DKF_MAX_DIM 48
#endif

/* 1: measurement updates use the Joseph form, evaluated as written
 *    P+ = (I - K H) P (I - K H)^T + K R K^T   (A = I - K H formed),
 * symmetric, positive semi-definite up to rounding and accurate when the
 * data pin the state (P+ << P);
 * 0: the cheaper short form P+ = P - K H P (loses |P| eps absolutely).
 * Either way a P+ that is not PSD within 4 n eps tr(P) is refused
 * (DKF_ERR_NOT_SPD; docs/decisions.md item 17). */
#ifndef DKF_JOSEPH
#define DKF_JOSEPH 1
#endif

/* DKF_SYMMETRISE is gone (docs/decisions.md item 19): every covariance a
 * filter stores is symmetric by construction (upper triangle formed and
 * mirrored), and the two sums that are symmetrised, (P + P^T)/2, always
 * are. Defining it 1 is accepted (what the library does); 0 is refused. */

/* 1: check argument preconditions that a correct program never violates
 * (NULL pointers, aliasing). 0 compiles them out for a lean firmware
 * build. Validation that protects filter state (dimensions, non-finite
 * data, SPD, rank) is never compiled out. */
#ifndef DKF_DEBUG_CHECKS
#define DKF_DEBUG_CHECKS 1
#endif

/* (n, m) sizes that get a Kalman step (dkf_kf_predict / dkf_kf_update)
 * compiled for exactly that state and measurement dimension, as an X-macro
 * list: X(n, m) per size. Other sizes run the generic step; results are
 * bit-identical either way, only speed and code size differ
 * (docs/results/bench.md, docs/results/footprint.md). Sizes above DKF_MAX_DIM are
 * ignored. The default covers constant-velocity / -acceleration tracking
 * in 2-D and 3-D and the benchmark's sizes, except in builds optimised for
 * size (-Os, __OPTIMIZE_SIZE__), where it is empty: each size costs
 * several KiB of Cortex-M4 flash. To choose, e.g. only n = 4, m = 2:
 *   #define DKF_KF_FIXED_SIZES(X) X(4, 2)
 * and `#define DKF_KF_FIXED_SIZES(X)` (empty) for none. */
#ifndef DKF_KF_FIXED_SIZES
#if defined(__OPTIMIZE_SIZE__)
#define DKF_KF_FIXED_SIZES(X)
#else
#define DKF_KF_FIXED_SIZES(X) X(4, 2) X(6, 3) X(8, 4) X(12, 6)
#endif
#endif

/* (n, m, p) sizes whose Difference-KF step (dkf_diffkf_step) is also
 * compiled with literal sizes (src/diffkf.c: the same operations in the
 * same order, so the same bits; seed 000 Example 1 by default, ~38 KB of
 * code per size at -O2 on x86-64, with DKF_PEEL_LOOPS: the step, and the
 * two phases of dkf_diffkf_gain / dkf_diffkf_update_z). Empty under -Os
 * (firmware), like DKF_KF_FIXED_SIZES; define it empty for none. */
#ifndef DKF_DIFFKF_FIXED_SIZES
#if defined(__OPTIMIZE_SIZE__)
#define DKF_DIFFKF_FIXED_SIZES(X)
#else
#define DKF_DIFFKF_FIXED_SIZES(X) X(4, 2, 2)
#endif
#endif

/* 1: the register-blocked products (matrix products and the Kalman step)
 * use the vector extension of GCC and Clang on targets with 16-byte SIMD
 * registers and IEEE vector arithmetic (x86-64 SSE2, AArch64; not 32-bit
 * ARM NEON, which flushes subnormals), which makes their vectorisation
 * independent of the compiler's auto-vectoriser heuristics; elsewhere, and
 * with 0, plain C99. Results are bit-identical either way: every lane is
 * the scalar operation, in the same order (a ctest compares the two). */
#ifndef DKF_SIMD
#define DKF_SIMD 1
#endif

/* 1: under GCC, the files with the dense kernels and the Kalman and DKF
 * steps (kernels.c, kf.c, diffkf.c and their AVX instances) are compiled
 * with complete peeling of small constant-trip loops (-fpeel-loops, which
 * -O3 has and -O2 does not; src/peel.h): 20-30 % fewer instructions per
 * step at the fixed sizes, for about 1.5x their code at -O2. 0 leaves
 * GCC's -O2 choice. Never under -Os; no effect with other compilers. The
 * results are the same bits either way. */
#ifndef DKF_PEEL_LOOPS
#define DKF_PEEL_LOOPS 1
#endif

/* Relative step of the forward-difference Jacobians of a nonlinear model
 * without Jacobian callbacks (dkf/nl_model.h): component v of the point
 * moves by DKF_NL_FD_STEP * max(1, |v|). Double: 1e-5, seed 001's eq. 44.
 * Float: 3e-4 ~ sqrt(FLT_EPSILON), which balances the truncation error
 * (~ step) against the rounding error (~ eps / step); 1e-5 in float would
 * leave ~1 % of rounding error in every derivative. */
#ifndef DKF_NL_FD_STEP
#if DKF_USE_FLOAT
#define DKF_NL_FD_STEP 3e-4f
#else
#define DKF_NL_FD_STEP 1e-5
#endif
#endif

/* Sweeps of the one-sided Jacobi SVD before it reports
 * DKF_ERR_NO_CONVERGENCE. Jacobi converges quadratically; 6-10 sweeps are
 * typical for the sizes dkf meets. */
#ifndef DKF_SVD_MAX_SWEEPS
#define DKF_SVD_MAX_SWEEPS 60
#endif

#if DKF_USE_FLOAT
typedef float dkf_real_t;
#define DKF_REAL_EPSILON FLT_EPSILON
#define DKF_REAL_MAX FLT_MAX
#define DKF_REAL_MIN FLT_MIN
#define DKF_R(x) (x##f)
#define DKF_SQRT sqrtf
#define DKF_FABS fabsf
#define DKF_HYPOT hypotf
#else
typedef double dkf_real_t;
#define DKF_REAL_EPSILON DBL_EPSILON
#define DKF_REAL_MAX DBL_MAX
#define DKF_REAL_MIN DBL_MIN
#define DKF_R(x) (x)
#define DKF_SQRT sqrt
#define DKF_FABS fabs
#define DKF_HYPOT hypot
#endif

/* ---- consistency checks ------------------------------------------------ */
#define DKF_STATIC_ASSERT(cond, msg) \
    typedef char dkf_static_assert_##msg[(cond) ? 1 : -1]

#if DKF_MAX_DIM < 1 || DKF_MAX_DIM > 4096
#error "DKF_MAX_DIM must lie in [1, 4096]"
#endif
#if DKF_USE_FLOAT != 0 && DKF_USE_FLOAT != 1
#error "DKF_USE_FLOAT must be 0 or 1"
#endif
#if DKF_SIMD != 0 && DKF_SIMD != 1
#error "DKF_SIMD must be 0 or 1"
#endif
#if DKF_JOSEPH != 0 && DKF_JOSEPH != 1
#error "DKF_JOSEPH must be 0 or 1"
#endif
#if defined(DKF_SYMMETRISE) && DKF_SYMMETRISE != 1
#error "DKF_SYMMETRISE must be 1 if defined: the switch was removed (docs/decisions.md item 19)"
#endif
#if DKF_SVD_MAX_SWEEPS < 1
#error "DKF_SVD_MAX_SWEEPS must be at least 1"
#endif
/* size_t must hold DKF_MAX_DIM^2 elements for index arithmetic. */
DKF_STATIC_ASSERT(sizeof(size_t) >= 4, size_t_at_least_32_bits);

#ifdef __cplusplus
}
#endif

#endif /* DKF_CONFIG_H */
