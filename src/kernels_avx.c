/*
 * src/kernels_avx.c - the large-model kernels (kernels_wide.h) compiled for
 * AVX, on x86-64 under GCC (DKF__AVX, kernels.h); kernels.c calls them when
 * the CPU has AVX. Every function of this file is AVX code (the target
 * pragma comes before any definition), so the library itself is built for
 * the baseline ISA and no -march is needed. The register blocks are 2 rows
 * x 4 vectors of 32 bytes (16 double or 32 float columns): 8 sums, 4 loads
 * and 2 broadcasts in the 16 AVX registers. Each lane is an IEEE product
 * or sum in the scalar code's order, and no FMA is enabled, so the results
 * are the baseline instance's bit for bit (test_kernels_wide).
 */
#include "peel.h" /* first: before any definition */

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#pragma GCC target("avx")
#endif

#include "kernels.h"

#if DKF__AVX
#include <stddef.h>
#include <string.h>

#include "kernels_inline.h"

typedef dkf_real_t kw_vec_t __attribute__((vector_size(32)));
#define KW_VL (32 / sizeof(dkf_real_t))

DKF__INLINE kw_vec_t kw_load(const dkf_real_t *p)
{
    kw_vec_t v;
    memcpy(&v, p, sizeof v);
    return v;
}

DKF__INLINE void kw_store(dkf_real_t *p, kw_vec_t v)
{
    memcpy(p, &v, sizeof v);
}

/* nn_2xv (kernels_inline.h) on 4 vectors of 32 bytes per row. */
DKF__INLINE void nn_2xw_avx(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                            const dkf_real_t *restrict a0, const dkf_real_t *restrict a1,
                            size_t sa, const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    kw_vec_t b0 = kw_load(b), b1 = kw_load(b + KW_VL), b2 = kw_load(b + 2 * KW_VL),
             b3 = kw_load(b + 3 * KW_VL);
    dkf_real_t x0 = a0[0], x1 = a1[0];
    kw_vec_t s00 = b0 * x0, s01 = b1 * x0, s02 = b2 * x0, s03 = b3 * x0;
    kw_vec_t s10 = b0 * x1, s11 = b1 * x1, s12 = b2 * x1, s13 = b3 * x1;
    size_t l;
    for (l = 1; l < k; ++l) {
        const dkf_real_t *bl = b + l * ldb;
        x0 = a0[l * sa], x1 = a1[l * sa];
        b0 = kw_load(bl), b1 = kw_load(bl + KW_VL);
        b2 = kw_load(bl + 2 * KW_VL), b3 = kw_load(bl + 3 * KW_VL);
        s00 += b0 * x0, s10 += b0 * x1, s01 += b1 * x0, s11 += b1 * x1;
        s02 += b2 * x0, s12 += b2 * x1, s03 += b3 * x0, s13 += b3 * x1;
    }
    kw_store(c0, s00), kw_store(c0 + KW_VL, s01);
    kw_store(c0 + 2 * KW_VL, s02), kw_store(c0 + 3 * KW_VL, s03);
    kw_store(c1, s10), kw_store(c1 + KW_VL, s11);
    kw_store(c1 + 2 * KW_VL, s12), kw_store(c1 + 3 * KW_VL, s13);
}

/* solve_2xv (kernels_inline.h) on 4 vectors of 32 bytes per row. */
DKF__INLINE void solve_2xw_avx(dkf_real_t *bh, dkf_real_t *bg, const dkf_real_t *x, ptrdiff_t xs,
                               const dkf_real_t *a, const dkf_real_t *b, ptrdiff_t cs, size_t k,
                               dkf_real_t dh, dkf_real_t c, dkf_real_t dg)
{
    kw_vec_t t0 = kw_load(bh), t1 = kw_load(bh + KW_VL), t2 = kw_load(bh + 2 * KW_VL),
             t3 = kw_load(bh + 3 * KW_VL);
    kw_vec_t u0 = kw_load(bg), u1 = kw_load(bg + KW_VL), u2 = kw_load(bg + 2 * KW_VL),
             u3 = kw_load(bg + 3 * KW_VL);
    size_t q;
    for (q = 0; q < k; ++q, x += xs, a += cs, b += cs) {
        const kw_vec_t x0 = kw_load(x), x1 = kw_load(x + KW_VL), x2 = kw_load(x + 2 * KW_VL),
                       x3 = kw_load(x + 3 * KW_VL);
        t0 -= *a * x0, u0 -= *b * x0, t1 -= *a * x1, u1 -= *b * x1;
        t2 -= *a * x2, u2 -= *b * x2, t3 -= *a * x3, u3 -= *b * x3;
    }
    t0 *= dh, t1 *= dh, t2 *= dh, t3 *= dh;
    u0 -= c * t0, u1 -= c * t1, u2 -= c * t2, u3 -= c * t3;
    u0 *= dg, u1 *= dg, u2 *= dg, u3 *= dg;
    kw_store(bh, t0), kw_store(bh + KW_VL, t1);
    kw_store(bh + 2 * KW_VL, t2), kw_store(bh + 3 * KW_VL, t3);
    kw_store(bg, u0), kw_store(bg + KW_VL, u1);
    kw_store(bg + 2 * KW_VL, u2), kw_store(bg + 3 * KW_VL, u3);
}

#define KW(name) name##_avx
#define KW_W (4 * KW_VL)
#define KW_NN nn_2xw_avx
#define KW_SOLVE solve_2xw_avx
#include "kernels_wide.h"

#else
typedef int dkf__kernels_avx_unused; /* ISO C: a translation unit is not empty */
#endif
