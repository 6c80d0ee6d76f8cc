/*
 * src/kernels_inline.h - bodies of the dense kernels a Kalman step runs on
 * (see kernels.h for their contracts), as forced-inline static functions.
 *
 * kernels.c instantiates each once with run-time sizes (dkf__mul_nn is
 * inl_mul_nn, ...); kf.c inlines them into steps compiled for fixed sizes,
 * where every trip count is a constant the compiler unrolls and vectorises
 * (DKF_KF_FIXED_SIZES in config.h). Not installed.
 */
#ifndef DKF_KERNELS_INLINE_H
#define DKF_KERNELS_INLINE_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "dkf/config.h"

/* Forced inlining where the compiler has a way to ask for it: the fixed-size
 * steps only pay off if the kernels are expanded with constant sizes, which
 * GCC's size heuristics would refuse for bodies this large. Not when
 * optimising for size (-Os): there the compiler keeps one copy of each. */
#if defined(__GNUC__) && !defined(__OPTIMIZE_SIZE__)
#define DKF__INLINE static inline __attribute__((always_inline))
#else
#define DKF__INLINE static inline
#endif

/* DKF_SIMD (config.h) uses the vector extension of GCC and Clang for the
 * register blocks, on targets with 16-byte SIMD registers whose vector
 * arithmetic is the scalar code's: SSE2 doing the scalar maths too
 * (__SSE2_MATH__: every x86-64; not x87) and AArch64. Not 32-bit ARM
 * NEON, which flushes subnormals to zero (its lanes would not compute what
 * the scalar VFP code computes). */
#if DKF_SIMD && (defined(__GNUC__) || defined(__clang__)) && \
    (defined(__SSE2_MATH__) || (defined(__aarch64__) && defined(__ARM_NEON)))
#define DKF__SIMD 1
#else
#define DKF__SIMD 0
#endif

/* Register blocks of C = A B (B row-major with row stride ldb). Each
 * block keeps its sums in registers across the whole l loop: a loaded B
 * element feeds one multiply-add per row of the block, and the sums are
 * independent chains (no add-latency bound). Along a row the 8 (4, 2)
 * sums use contiguous B elements: SIMD lanes. 2 x 8 (8 double or 4 float
 * SSE accumulators) is the widest block whose sums, B values and
 * broadcasts of A all stay in the 16 registers of x86-64 SSE. With
 * DKF__SIMD the blocks are written with vectors; in plain C they are
 * scalars, which GCC's basic-block vectoriser may or may not turn into
 * SIMD (its cost model decided differently for the same block in two
 * places of one Kalman step: docs/results/bench.md). Every sum runs over l = 0,
 * 1, ... in order from its first product, so each C(i,j) is bit-identical
 * to the textbook loop's whatever the block and with or without vectors.
 * The results go straight to c0 = &C(i,j), c1 = &C(i+1,j): a block stored
 * to a temporary array and copied on was turned into memcpy calls, and
 * the array kept the sums out of registers.
 * a0, a1 point at A(i,0), A(i+1,0), and A(i,l) is a0[l * sa]: sa = 1 for
 * a row-major A (A B), sa = r for a product A^T B whose A is stored k x r.
 * b points at B(0,j). */
#if DKF__SIMD
/* Vectors of DKF__VEC_BYTES bytes, DKF__VL reals (GCC/Clang vector
 * extension): 16, or 32 in the AVX instance of the Kalman step (kf_avx.c,
 * double only: the kernels take DKF__VL = 2 or 4). Each lane is an
 * ordinary IEEE product or sum, so a lane computes exactly what the
 * scalar code computes, in the same order, whatever the width. memcpy is
 * the unaligned load and store. */
#ifndef DKF__VEC_BYTES
#define DKF__VEC_BYTES 16
#endif
typedef dkf_real_t dkf__vec_t __attribute__((vector_size(DKF__VEC_BYTES)));
#if DKF_USE_FLOAT
typedef int32_t dkf__mask_t __attribute__((vector_size(DKF__VEC_BYTES))); /* of a v != w */
#else
typedef int64_t dkf__mask_t __attribute__((vector_size(DKF__VEC_BYTES)));
#endif
#define DKF__VL (DKF__VEC_BYTES / sizeof(dkf_real_t))

DKF__INLINE dkf__vec_t vload(const dkf_real_t *p)
{
    dkf__vec_t v;
    memcpy(&v, p, sizeof v);
    return v;
}

DKF__INLINE void vstore(dkf_real_t *p, dkf__vec_t v)
{
    memcpy(p, &v, sizeof v);
}

/* Rows c0, c1 of a 2 x (nv DKF__VL) block, nv = 1 to 4 (a constant
 * once inlined: the unused sums fold away), plus rows d0, d1 of D if d0
 * is not NULL (each sum, then + D: the order of put_sym_2xw). The sums
 * stay in nv vector registers per row for the whole l loop; they are
 * named, not an array, so that no compiler keeps them in memory. */
DKF__INLINE void nn_2xv_d(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                          const dkf_real_t *restrict d0, const dkf_real_t *restrict d1,
                          const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                          const dkf_real_t *restrict b, size_t k, size_t ldb, size_t nv)
{
    const dkf__vec_t z = {0};
    dkf__vec_t s00 = z, s01 = z, s02 = z, s03 = z, s10 = z, s11 = z, s12 = z, s13 = z;
    dkf__vec_t b0 = vload(b), b1 = z, b2 = z, b3 = z;
    dkf_real_t x0 = a0[0], x1 = a1[0];
    size_t l;
    if (nv > 1) b1 = vload(b + DKF__VL);
    if (nv > 2) b2 = vload(b + 2 * DKF__VL);
    if (nv > 3) b3 = vload(b + 3 * DKF__VL);
    s00 = b0 * x0, s10 = b0 * x1;
    if (nv > 1) s01 = b1 * x0, s11 = b1 * x1;
    if (nv > 2) s02 = b2 * x0, s12 = b2 * x1;
    if (nv > 3) s03 = b3 * x0, s13 = b3 * x1;
    for (l = 1; l < k; ++l) {
        const dkf_real_t *bl = b + l * ldb;
        x0 = a0[l * sa], x1 = a1[l * sa];
        b0 = vload(bl);
        s00 += b0 * x0, s10 += b0 * x1;
        if (nv > 1) {
            b1 = vload(bl + DKF__VL);
            s01 += b1 * x0, s11 += b1 * x1;
        }
        if (nv > 2) {
            b2 = vload(bl + 2 * DKF__VL);
            s02 += b2 * x0, s12 += b2 * x1;
        }
        if (nv > 3) {
            b3 = vload(bl + 3 * DKF__VL);
            s03 += b3 * x0, s13 += b3 * x1;
        }
    }
    if (d0 != NULL) {
        s00 += vload(d0), s10 += vload(d1);
        if (nv > 1) s01 += vload(d0 + DKF__VL), s11 += vload(d1 + DKF__VL);
        if (nv > 2) s02 += vload(d0 + 2 * DKF__VL), s12 += vload(d1 + 2 * DKF__VL);
        if (nv > 3) s03 += vload(d0 + 3 * DKF__VL), s13 += vload(d1 + 3 * DKF__VL);
    }
    vstore(c0, s00), vstore(c1, s10);
    if (nv > 1) vstore(c0 + DKF__VL, s01), vstore(c1 + DKF__VL, s11);
    if (nv > 2) vstore(c0 + 2 * DKF__VL, s02), vstore(c1 + 2 * DKF__VL, s12);
    if (nv > 3) vstore(c0 + 3 * DKF__VL, s03), vstore(c1 + 3 * DKF__VL, s13);
}

DKF__INLINE void nn_2xv(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                        const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                        const dkf_real_t *restrict b, size_t k, size_t ldb, size_t nv)
{
    nn_2xv_d(c0, c1, NULL, NULL, a0, a1, sa, b, k, ldb, nv);
}

DKF__INLINE void nn_2x8(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                        const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                        const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    nn_2xv(c0, c1, a0, a1, sa, b, k, ldb, 8 / DKF__VL);
}

DKF__INLINE void nn_2x4(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                        const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                        const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    nn_2xv(c0, c1, a0, a1, sa, b, k, ldb, 4 / DKF__VL);
}

/* 2 x 12 where that is 3 vectors a row (DKF__VL = 4: AVX double, SSE
 * float): one pass over k with 6 chains of sums, where a 2 x 8 and a 2 x 4
 * pass would make two, the second with only 2 chains, each waiting on
 * the add latency. Returns the columns done: 12, or 0 where vectors hold
 * another count (the caller then takes blocks of 8 and 4). */
DKF__INLINE size_t nn_2x12(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                           const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                           const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    if (DKF__VL != 4) return 0;
    nn_2xv(c0, c1, a0, a1, sa, b, k, ldb, 3);
    return 12;
}

/* 1 x 4: one vector of sums in float, two in double. */
DKF__INLINE void nn_1x4(dkf_real_t *restrict c0, const dkf_real_t *restrict a0, size_t sa,
                        const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    dkf__vec_t s0 = vload(b) * a0[0], s1 = s0;
    size_t l;
    if (DKF__VL == 2) s1 = vload(b + DKF__VL) * a0[0];
    for (l = 1; l < k; ++l) {
        const dkf_real_t *bl = b + l * ldb;
        s0 += vload(bl) * a0[l * sa];
        if (DKF__VL == 2) s1 += vload(bl + DKF__VL) * a0[l * sa];
    }
    vstore(c0, s0);
    if (DKF__VL == 2) vstore(c0 + DKF__VL, s1);
}
#else
DKF__INLINE void nn_2x8(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                        const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                        const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    dkf_real_t x0 = a0[0], x1 = a1[0];
    dkf_real_t s00 = x0 * b[0], s01 = x0 * b[1], s02 = x0 * b[2], s03 = x0 * b[3];
    dkf_real_t s04 = x0 * b[4], s05 = x0 * b[5], s06 = x0 * b[6], s07 = x0 * b[7];
    dkf_real_t s10 = x1 * b[0], s11 = x1 * b[1], s12 = x1 * b[2], s13 = x1 * b[3];
    dkf_real_t s14 = x1 * b[4], s15 = x1 * b[5], s16 = x1 * b[6], s17 = x1 * b[7];
    size_t l;
    for (l = 1; l < k; ++l) {
        const dkf_real_t *bl = b + l * ldb;
        x0 = a0[l * sa];
        x1 = a1[l * sa];
        s00 += x0 * bl[0], s01 += x0 * bl[1], s02 += x0 * bl[2], s03 += x0 * bl[3];
        s04 += x0 * bl[4], s05 += x0 * bl[5], s06 += x0 * bl[6], s07 += x0 * bl[7];
        s10 += x1 * bl[0], s11 += x1 * bl[1], s12 += x1 * bl[2], s13 += x1 * bl[3];
        s14 += x1 * bl[4], s15 += x1 * bl[5], s16 += x1 * bl[6], s17 += x1 * bl[7];
    }
    c0[0] = s00, c0[1] = s01, c0[2] = s02, c0[3] = s03;
    c0[4] = s04, c0[5] = s05, c0[6] = s06, c0[7] = s07;
    c1[0] = s10, c1[1] = s11, c1[2] = s12, c1[3] = s13;
    c1[4] = s14, c1[5] = s15, c1[6] = s16, c1[7] = s17;
}

DKF__INLINE void nn_2x4(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                        const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                        const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    dkf_real_t x0 = a0[0], x1 = a1[0];
    dkf_real_t s00 = x0 * b[0], s01 = x0 * b[1], s02 = x0 * b[2], s03 = x0 * b[3];
    dkf_real_t s10 = x1 * b[0], s11 = x1 * b[1], s12 = x1 * b[2], s13 = x1 * b[3];
    size_t l;
    for (l = 1; l < k; ++l) {
        const dkf_real_t *bl = b + l * ldb;
        x0 = a0[l * sa];
        x1 = a1[l * sa];
        s00 += x0 * bl[0], s01 += x0 * bl[1], s02 += x0 * bl[2], s03 += x0 * bl[3];
        s10 += x1 * bl[0], s11 += x1 * bl[1], s12 += x1 * bl[2], s13 += x1 * bl[3];
    }
    c0[0] = s00, c0[1] = s01, c0[2] = s02, c0[3] = s03;
    c1[0] = s10, c1[1] = s11, c1[2] = s12, c1[3] = s13;
}

DKF__INLINE void nn_1x4(dkf_real_t *restrict c0, const dkf_real_t *restrict a0, size_t sa,
                        const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    dkf_real_t x = a0[0];
    dkf_real_t s0 = x * b[0], s1 = x * b[1], s2 = x * b[2], s3 = x * b[3];
    size_t l;
    for (l = 1; l < k; ++l) {
        const dkf_real_t *bl = b + l * ldb;
        x = a0[l * sa];
        s0 += x * bl[0], s1 += x * bl[1], s2 += x * bl[2], s3 += x * bl[3];
    }
    c0[0] = s0, c0[1] = s1, c0[2] = s2, c0[3] = s3;
}

/* Plain C: 24 sums would not stay in registers (blocks of 8 and 4). */
DKF__INLINE size_t nn_2x12(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                           const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                           const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    (void)c0, (void)c1, (void)a0, (void)a1, (void)sa, (void)b, (void)k, (void)ldb;
    return 0;
}

#endif /* DKF__SIMD */

DKF__INLINE void nn_2x2(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                        const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                        const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    dkf_real_t x0 = a0[0], x1 = a1[0];
    dkf_real_t s00 = x0 * b[0], s01 = x0 * b[1], s10 = x1 * b[0], s11 = x1 * b[1];
    size_t l;
    for (l = 1; l < k; ++l) {
        const dkf_real_t *bl = b + l * ldb;
        x0 = a0[l * sa];
        x1 = a1[l * sa];
        s00 += x0 * bl[0], s01 += x0 * bl[1];
        s10 += x1 * bl[0], s11 += x1 * bl[1];
    }
    c0[0] = s00, c0[1] = s01, c1[0] = s10, c1[1] = s11;
}

/* The 2 x 2 block at column j of B = b: in double one vector per row; in
 * float, where a vector holds 4, the 2 x 4 block at column j - 2 (when
 * j >= 2), of which the last 2 columns are stored: the first two are
 * sums the caller has already, and cost nothing extra in a vector. */
DKF__INLINE void block_2x2(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                           const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                           const dkf_real_t *restrict b, size_t k, size_t ldb, size_t j)
{
#if DKF__SIMD
    if (DKF__VL == 2) {
        nn_2xv(c0, c1, a0, a1, sa, b, k, ldb, 1);
        return;
    }
    if (DKF__VL == 4 && j >= 2) {
        dkf_real_t s[8];
        nn_2xv(s, s + 4, a0, a1, sa, b - 2, k, ldb, 1);
        c0[0] = s[2], c0[1] = s[3], c1[0] = s[6], c1[1] = s[7];
        return;
    }
#endif
    (void)j;
    nn_2x2(c0, c1, a0, a1, sa, b, k, ldb);
}

DKF__INLINE void nn_2x1(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                        const dkf_real_t *restrict a0, const dkf_real_t *restrict a1, size_t sa,
                        const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    dkf_real_t s0 = a0[0] * b[0], s1 = a1[0] * b[0];
    size_t l;
    for (l = 1; l < k; ++l) {
        const dkf_real_t bl = b[l * ldb];
        s0 += a0[l * sa] * bl;
        s1 += a1[l * sa] * bl;
    }
    c0[0] = s0, c1[0] = s1;
}

DKF__INLINE dkf_real_t nn_1x1(const dkf_real_t *restrict a0, size_t sa,
                              const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    dkf_real_t s0 = a0[0] * b[0];
    size_t l;
    for (l = 1; l < k; ++l) s0 += a0[l * sa] * b[l * ldb];
    return s0;
}

/* Row c0 of C = A B (the last row of an odd row count). */
DKF__INLINE void mul_nn_row1(dkf_real_t *restrict c0, const dkf_real_t *restrict a0,
                             const dkf_real_t *restrict B, size_t k, size_t c)
{
    size_t j = 0;
    for (; j + 4 <= c; j += 4) nn_1x4(c0 + j, a0, 1, B + j, k, c);
    for (; j < c; ++j) c0[j] = nn_1x1(a0, 1, B + j, k, c);
}

/* Rows c0, c1 of C = A B (rows a0, a1 of A), blocks of 12 (where nn_2x12 has it
 * and blocks of 8 would leave 4 or more), 8, 4, 2, 1. */
DKF__INLINE void mul_nn_rows2(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                              const dkf_real_t *restrict a0, const dkf_real_t *restrict a1,
                              const dkf_real_t *restrict B, size_t k, size_t c)
{
    size_t j = 0;
    if (c >= 12 && c % 8 >= 4) j = nn_2x12(c0, c1, a0, a1, 1, B, k, c);
    for (; j + 8 <= c; j += 8) nn_2x8(c0 + j, c1 + j, a0, a1, 1, B + j, k, c);
    if (j + 4 <= c) {
        nn_2x4(c0 + j, c1 + j, a0, a1, 1, B + j, k, c);
        j += 4;
    }
    if (j + 2 <= c) {
        block_2x2(c0 + j, c1 + j, a0, a1, 1, B + j, k, c, j);
        j += 2;
    }
    if (j < c) nn_2x1(c0 + j, c1 + j, a0, a1, 1, B + j, k, c);
}

DKF__INLINE void inl_mul_nn(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r,
                            size_t k, size_t c)
{
    size_t i = 0;
    for (; i + 2 <= r; i += 2)
        mul_nn_rows2(C + i * c, C + (i + 1) * c, A + i * k, A + (i + 1) * k, B, k, c);
    if (i < r) mul_nn_row1(C + i * c, A + i * k, B, k, c);
}

/* Square blocks of a transpose, moved as vectors: DKF__TB x DKF__TB reals
 * from rows of A (row stride sa) to rows of At (stride st), by the
 * extension's two-vector shuffles (__builtin_shufflevector in Clang and
 * GCC >= 12, __builtin_shuffle before). Pure moves: the bits are those
 * of the scalar loop; why they pay where they are used is said at
 * mirror_upper and inl_transpose_input. DKF__VL in the preprocessor's
 * terms: 4 for double in 32 bytes or float in 16, 2 for double in 16;
 * other widths keep the scalar loop. */
#if DKF__SIMD && ((DKF__VEC_BYTES == 32 && !DKF_USE_FLOAT) || (DKF__VEC_BYTES == 16 && DKF_USE_FLOAT))
#define DKF__TB 4
#elif DKF__SIMD && DKF__VEC_BYTES == 16 && !DKF_USE_FLOAT
#define DKF__TB 2
#else
#define DKF__TB 0
#endif
#if DKF__TB && (defined(__clang__) || __GNUC__ >= 12)
#define DKF__SHUF2(a, b, i, j) __builtin_shufflevector(a, b, i, j)
#define DKF__SHUF4(a, b, i, j, k, l) __builtin_shufflevector(a, b, i, j, k, l)
#elif DKF__TB
#define DKF__SHUF2(a, b, i, j) __builtin_shuffle(a, b, (dkf__mask_t){i, j})
#define DKF__SHUF4(a, b, i, j, k, l) __builtin_shuffle(a, b, (dkf__mask_t){i, j, k, l})
#endif

#if DKF__TB == 4
/* unpack within 128-bit halves, then swap halves: rows r0..r3 to columns */
DKF__INLINE void transpose_block(dkf_real_t *restrict t, size_t st, const dkf_real_t *restrict a,
                                 size_t sa)
{
    const dkf__vec_t r0 = vload(a), r1 = vload(a + sa), r2 = vload(a + 2 * sa),
                     r3 = vload(a + 3 * sa);
    const dkf__vec_t t0 = DKF__SHUF4(r0, r1, 0, 4, 2, 6), t1 = DKF__SHUF4(r0, r1, 1, 5, 3, 7);
    const dkf__vec_t t2 = DKF__SHUF4(r2, r3, 0, 4, 2, 6), t3 = DKF__SHUF4(r2, r3, 1, 5, 3, 7);
    vstore(t, DKF__SHUF4(t0, t2, 0, 1, 4, 5));
    vstore(t + st, DKF__SHUF4(t1, t3, 0, 1, 4, 5));
    vstore(t + 2 * st, DKF__SHUF4(t0, t2, 2, 3, 6, 7));
    vstore(t + 3 * st, DKF__SHUF4(t1, t3, 2, 3, 6, 7));
}
#elif DKF__TB == 2
DKF__INLINE void transpose_block(dkf_real_t *restrict t, size_t st, const dkf_real_t *restrict a,
                                 size_t sa)
{
    const dkf__vec_t r0 = vload(a), r1 = vload(a + sa);
    vstore(t, DKF__SHUF2(r0, r1, 0, 2));
    vstore(t + st, DKF__SHUF2(r0, r1, 1, 3));
}
#endif

/* C's strict lower triangle from its upper one (C r x r): the blocks of
 * DKF__TB rows and columns off the diagonal as vectors (transpose_block),
 * the rest one by one. With DKF__TB, sym_product stores the upper
 * triangle's rows as they are summed and mirrors them here afterwards,
 * rather than a pair of scalars per column as it goes: the same reals,
 * fewer stores, and a mirror that is read as vectors next (the commit's
 * copy, the next step's products) is no longer stored one by one. */
DKF__INLINE void mirror_upper(dkf_real_t *C, size_t r)
{
    size_t i = 0, j, q, t;
#if DKF__TB
    for (; i + DKF__TB <= r; i += DKF__TB) {
        for (q = 1; q < DKF__TB; ++q)
            for (t = 0; t < q; ++t) C[(i + q) * r + i + t] = C[(i + t) * r + i + q];
        for (j = i + DKF__TB; j + DKF__TB <= r; j += DKF__TB)
            transpose_block(C + j * r + i, r, C + i * r + j, r);
        for (; j < r; ++j)
            for (q = 0; q < DKF__TB; ++q) C[j * r + i + q] = C[(i + q) * r + j];
    }
#else
    (void)q, (void)t;
#endif
    for (; i < r; ++i)
        for (j = i + 1; j < r; ++j) C[j * r + i] = C[i * r + j];
}

/* At (c x r) = A^T for A r x c (At must not overlap A). Inline: the
 * fixed-size Kalman steps transpose F and H with constant sizes. */
DKF__INLINE void inl_transpose(dkf_real_t *restrict At, const dkf_real_t *restrict A, size_t r,
                               size_t c)
{
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) At[j * r + i] = A[i * c + j];
}

/* inl_transpose with the blocks of DKF__TB rows and columns moved as
 * vectors (the same reals), for an A that was not just written: a vector
 * load of reals stored one by one moments before waits for those stores
 * (the DKF of seed 000, whose transposes read fresh results, took 9 %
 * longer in float with vector blocks), while a scalar load is forwarded
 * from any store. The Kalman step's F^T and H^T: the caller's model. */
DKF__INLINE void inl_transpose_input(dkf_real_t *restrict At, const dkf_real_t *restrict A,
                                     size_t r, size_t c)
{
    size_t i = 0, j;
#if DKF__TB
    const size_t cb = c - c % DKF__TB;
    for (; i + DKF__TB <= r; i += DKF__TB) {
        for (j = 0; j < cb; j += DKF__TB) transpose_block(At + j * r + i, r, A + i * c + j, c);
        for (; j < c; ++j) {
            size_t q;
            for (q = 0; q < DKF__TB; ++q) At[j * r + i + q] = A[(i + q) * c + j];
        }
    }
#endif
    for (; i < r; ++i)
        for (j = 0; j < c; ++j) At[j * r + i] = A[i * c + j];
}

/* Stands in for a NULL D of sym_product: adding +0 changes no sum (but
 * the sign of a zero), and the loops stay free of tests. */
static const dkf_real_t zero_row[DKF_MAX_DIM];

/* Stores a 2 x w block s (row i, then row i+1) of a symmetric result
 * plus D at columns j.., j >= i: c0 = &C(i,j), c1 = &C(i+1,j), d0 =
 * &D(i,j), d1 = &D(i+1,j), and mirrors it below the diagonal: lo =
 * &C(j,i), where C(j+q, i) and C(j+q, i+1) are adjacent (lo NULL: not
 * mirrored, the caller does it afterwards). On the diagonal
 * block (diag, j == i) the block's (i+1, i) element is the mirror of
 * C(i, i+1), not the block's own (equal in exact arithmetic) sum. */
/* Every s[q] read here was written by the block before it (nn_2x8 ...
 * nn_2x1 write 2 w sums). GCC 12 (float, -O2, with the step's loops
 * peeled) cannot tell and warns; zeroing s first cost 2-3 % of a step. */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
DKF__INLINE void put_sym_2xw(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                             dkf_real_t *restrict lo, const dkf_real_t *restrict d0,
                             const dkf_real_t *restrict d1, const dkf_real_t *s, size_t w, size_t r,
                             int diag)
{
    size_t q;
    for (q = 0; q < w; ++q) c0[q] = s[q] + d0[q];
    for (q = diag ? 1 : 0; q < w; ++q) c1[q] = s[w + q] + d1[q];
    if (lo == NULL) /* the caller mirrors afterwards (sym_product: mirror_upper) */
        return;
    if (diag) lo[r] = c0[1];
    for (q = diag ? 2 : 0; q < w; ++q) lo[q * r] = c0[q], lo[q * r + 1] = c1[q];
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

/* Where sym_rows2 mirrors the block at (i, j): C(j,i), or NULL where
 * sym_product mirrors the whole upper triangle afterwards (DKF__TB). */
DKF__INLINE dkf_real_t *lo_of(dkf_real_t *C, size_t i, size_t j, size_t r)
{
    return DKF__TB ? NULL : C + j * r + i;
}

/* Rows i, i+1 of the upper triangle of A B + D from column i on (and
 * their mirror, unless DKF__TB: then sym_product mirrors afterwards), with
 * A(i,l) = a0[l * sa], A(i+1,l) = a1[l * sa]; d0, d1 are rows i, i+1 of D. */
DKF__INLINE void sym_rows2(dkf_real_t *C, const dkf_real_t *a0, const dkf_real_t *a1, size_t sa,
                           const dkf_real_t *B, const dkf_real_t *d0, const dkf_real_t *d1,
                           size_t i, size_t r, size_t k)
{
    dkf_real_t *c0 = C + i * r, *c1 = c0 + r;
    dkf_real_t s[16];
    size_t j = i;
#if DKF__SIMD && DKF__TB
    /* blocks of whole vectors: the sums plus D go from the registers to C
     * (mirror_upper then writes the lower triangle, C(i+1,i) included) */
    for (; j + 8 <= r; j += 8)
        nn_2xv_d(c0 + j, c1 + j, d0 + j, d1 + j, a0, a1, sa, B + j, k, r, 8 / DKF__VL);
    if (j + 4 <= r) {
        nn_2xv_d(c0 + j, c1 + j, d0 + j, d1 + j, a0, a1, sa, B + j, k, r, 4 / DKF__VL);
        j += 4;
    }
#else
    for (; j + 8 <= r; j += 8) {
        nn_2x8(s, s + 8, a0, a1, sa, B + j, k, r);
        put_sym_2xw(c0 + j, c1 + j, lo_of(C, i, j, r), d0 + j, d1 + j, s, 8, r, j == i);
    }
    if (j + 4 <= r) {
        nn_2x4(s, s + 4, a0, a1, sa, B + j, k, r);
        put_sym_2xw(c0 + j, c1 + j, lo_of(C, i, j, r), d0 + j, d1 + j, s, 4, r, j == i);
        j += 4;
    }
#endif
    if (j + 2 <= r) {
        block_2x2(s, s + 2, a0, a1, sa, B + j, k, r, j);
        put_sym_2xw(c0 + j, c1 + j, lo_of(C, i, j, r), d0 + j, d1 + j, s, 2, r, j == i);
        j += 2;
    }
    if (j < r) { /* j > i here: r - i >= 2, and 1 is left after blocks */
        nn_2x1(s, s + 1, a0, a1, sa, B + j, k, r);
        put_sym_2xw(c0 + j, c1 + j, lo_of(C, i, j, r), d0 + j, d1 + j, s, 1, r, 0);
    }
}

/* C (r x r) = A B + D for a product known to be symmetric, A(i,l) =
 * A[i * si + l * sa]: only the upper triangle is computed, two rows at a
 * time from the diagonal on, and mirrored as it is stored. */
DKF__INLINE void sym_product(dkf_real_t *C, const dkf_real_t *A, size_t si, size_t sa,
                             const dkf_real_t *B, const dkf_real_t *D, size_t r, size_t k)
{
    size_t i = 0;
    for (; i + 2 <= r; i += 2) {
        const dkf_real_t *d0 = D != NULL ? D + i * r : zero_row;
        const dkf_real_t *d1 = D != NULL ? d0 + r : zero_row;
        sym_rows2(C, A + i * si, A + (i + 1) * si, sa, B, d0, d1, i, r, k);
    }
    if (i < r) /* the last row of an odd count: its diagonal (the rest is mirrored) */
        C[i * r + i] =
            nn_1x1(A + i * si, sa, B + i, k, r) + (D != NULL ? D[i * r + i] : DKF_R(0.0));
    if (DKF__TB) mirror_upper(C, r);
}

DKF__INLINE void inl_mul_nn_sym(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B,
                                const dkf_real_t *D, size_t r, size_t k)
{
    sym_product(C, A, k, 1, B, D, r, k);
}

/* C (r x r) = A^T B + D, A and B k x r, symmetric by construction: as
 * inl_mul_nn_sym, with A read down its columns. */
DKF__INLINE void inl_mul_tn_sym(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B,
                                const dkf_real_t *D, size_t r, size_t k)
{
    sym_product(C, A, 1, r, B, D, r, k);
}

/* One chain, summed in index order (dot4 and dot2 in kernels.c keep
 * exactly this order per pair). */
DKF__INLINE dkf_real_t inl_dot(const dkf_real_t *a, const dkf_real_t *b, size_t k)
{
    dkf_real_t s = DKF_R(0.0);
    size_t l;
    for (l = 0; l < k; ++l) s += a[l] * b[l];
    return s;
}

/* Whether any of n reals is NaN or infinite: x - x is +0 for every finite
 * x and NaN otherwise, and NaN != 0. Branch-free; with DKF__SIMD one
 * subtract, compare and OR per vector and no dependency chain but the
 * 1-cycle OR; in plain C four sums of x - x (a NaN survives every later
 * addition, so the total is 0 iff all are finite). Relies on IEEE
 * arithmetic, as all of dkf does: no -ffinite-math-only (so no
 * -ffast-math), under which x - x would fold to 0. */
DKF__INLINE int inl_any_nonfinite(const dkf_real_t *p, size_t n)
{
#if DKF__SIMD
    const dkf__vec_t z = {0};
    dkf__mask_t bad = {0};
    dkf_real_t tail = DKF_R(0.0);
    const size_t nv = n - n % DKF__VL;
    size_t i, q;
    for (i = 0; i < nv; i += DKF__VL) {
        const dkf__vec_t v = vload(p + i);
        bad |= v - v != z;
    }
    for (; i < n; ++i) tail += p[i] - p[i];
    for (q = 1; q < DKF__VL; ++q) bad[0] |= bad[q];
    return bad[0] != 0 || !(tail == DKF_R(0.0));
#else
    dkf_real_t s0 = DKF_R(0.0), s1 = DKF_R(0.0), s2 = DKF_R(0.0), s3 = DKF_R(0.0);
    const size_t n4 = n - n % 4;
    size_t i;
    for (i = 0; i < n4; i += 4) {
        s0 += p[i] - p[i];
        s1 += p[i + 1] - p[i + 1];
        s2 += p[i + 2] - p[i + 2];
        s3 += p[i + 3] - p[i + 3];
    }
    for (; i < n; ++i) s0 += p[i] - p[i];
    return !((s0 + s1) + (s2 + s3) == DKF_R(0.0));
#endif
}

/* Cholesky-Banachiewicz: row i of L needs only rows 0..i-1 of L and row i
 * of A, so every inner product runs along two contiguous rows, and W == A
 * works (each element is read before it is overwritten; only the lower
 * triangle of A is read). Divisions by L(j,j) become products with its
 * reciprocal: one division per row. Rows are taken two at a time, i and
 * k = i+1, and columns two at a time, j and j+1 (chol_rows2): the four
 * sums run together over l < j (each loaded element serves two
 * products), then the j+1 sums take their last term, l = j, from the
 * finished column j. Every sum starts at 0 and adds l = 0, 1, ... in
 * order, as inl_dot does, so L is the one-row loop's, bit for bit. A
 * failing pivot of row i returns before row k's diagonal, with row k's
 * columns < i already written (W is scratch on failure). */
DKF__INLINE void chol_cols2(dkf_real_t *wi, dkf_real_t *wk, const dkf_real_t *ai,
                            const dkf_real_t *ak, const dkf_real_t *W, const dkf_real_t *inv,
                            size_t n, size_t i)
{
    size_t j, l;
    for (j = 0; j + 1 < i; j += 2) {
        const dkf_real_t *wj = W + j * n, *wm = wj + n;
        dkf_real_t s00 = DKF_R(0.0), s01 = DKF_R(0.0), s10 = DKF_R(0.0), s11 = DKF_R(0.0);
        for (l = 0; l < j; ++l) {
            const dkf_real_t x = wi[l], y = wk[l], p = wj[l], q = wm[l];
            s00 += x * p;
            s01 += x * q;
            s10 += y * p;
            s11 += y * q;
        }
        wi[j] = (ai[j] - s00) * inv[j];
        wk[j] = (ak[j] - s10) * inv[j];
        s01 += wi[j] * wm[j];
        s11 += wk[j] * wm[j];
        wi[j + 1] = (ai[j + 1] - s01) * inv[j + 1];
        wk[j + 1] = (ak[j + 1] - s11) * inv[j + 1];
    }
    if (j < i) { /* the last column of an odd i */
        const dkf_real_t *wj = W + j * n;
        dkf_real_t s0 = DKF_R(0.0), s1 = DKF_R(0.0);
        for (l = 0; l < j; ++l) {
            s0 += wi[l] * wj[l];
            s1 += wk[l] * wj[l];
        }
        wi[j] = (ai[j] - s0) * inv[j];
        wk[j] = (ak[j] - s1) * inv[j];
    }
}

/* Row i's pivot from its finished columns < i: 0 on success, -1 for a
 * pivot that is not positive and finite. */
DKF__INLINE int chol_pivot(dkf_real_t *wi, dkf_real_t *inv, dkf_real_t d, size_t n, size_t i)
{
    size_t j;
    if (!(d > DKF_R(0.0) && d <= DKF_REAL_MAX)) return -1;
    d = DKF_SQRT(d);
    wi[i] = d;
    inv[i] = DKF_R(1.0) / d;
    for (j = i + 1; j < n; ++j) wi[j] = DKF_R(0.0);
    return 0;
}

/* Row i of the factor, one column at a time: the last row of an odd n. */
DKF__INLINE int inl_chol_last(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n,
                              size_t i)
{
    dkf_real_t *wi = W + i * n;
    const dkf_real_t *ai = A + i * n;
    size_t j;
    for (j = 0; j < i; ++j) wi[j] = (ai[j] - inl_dot(wi, W + j * n, j)) * inv[j];
    return chol_pivot(wi, inv, ai[i] - inl_dot(wi, wi, i), n, i);
}

/* Rows i and k = i+1, their columns < i finished: row i's diagonal, row
 * k's column i and diagonal. 0, or -1 for a pivot chol_pivot refuses.
 * quot = 0: row k's pivot is A(k,k) - sum_{l<=i} L(k,l)^2, one sum in
 * index order (the textbook's bits). quot = 1 (the Kalman step's S):
 * A(k,k) - (sum_{l<i} L(k,l)^2 + q (q / p)) with q = L(k,i) L(i,i) and
 * p = L(i,i)^2 before their roots: q / p is divided while sqrt(p) is taken,
 * so the second pivot waits for one product and two differences after
 * them instead of 1 / L(i,i), L(k,i) and its square (at m = 2 the whole
 * factorisation). Not d = p r - q^2 with both roots side by side: with
 * that rounding the ASKF's pinned P error was 7.3e-15, 2.6 times its
 * regression bound (test_filters_stress); the quotient form keeps the
 * stress tests' bounds. t = q / p is computed before p is checked and
 * used only after. */
DKF__INLINE int chol_diag2(dkf_real_t *wi, dkf_real_t *wk, const dkf_real_t *ai,
                           const dkf_real_t *ak, dkf_real_t *inv, size_t n, size_t i, int quot)
{
    dkf_real_t sd = DKF_R(0.0), sx = DKF_R(0.0), sk = DKF_R(0.0), p, q, t = DKF_R(0.0);
    size_t l;
    for (l = 0; l < i; ++l) {
        sd += wi[l] * wi[l];
        sx += wk[l] * wi[l];
        if (quot) sk += wk[l] * wk[l];
    }
    p = ai[i] - sd, q = ak[i] - sx;
    if (quot) t = q / p;
    if (chol_pivot(wi, inv, p, n, i) != 0) return -1;
    wk[i] = q * inv[i];
    if (quot) return chol_pivot(wk, inv, ak[i + 1] - (sk + q * t), n, i + 1);
    for (l = 0; l <= i; ++l) sk += wk[l] * wk[l];
    return chol_pivot(wk, inv, ak[i + 1] - sk, n, i + 1);
}

/* The factor, rows two at a time; quot as chol_diag2. */
DKF__INLINE int chol_rows(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n, int quot)
{
    size_t i;
    for (i = 0; i + 1 < n; i += 2) {
        dkf_real_t *wi = W + i * n, *wk = wi + n;
        const dkf_real_t *ai = A + i * n, *ak = ai + n;
        chol_cols2(wi, wk, ai, ak, W, inv, n, i);
        if (chol_diag2(wi, wk, ai, ak, inv, n, i, quot) != 0) return -1;
    }
    if (i < n) return inl_chol_last(W, inv, A, n, i); /* the last row of an odd n */
    return 0;
}

DKF__INLINE int inl_chol(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n)
{
    return chol_rows(W, inv, A, n, 0);
}

/* Joseph form of a covariance update for the gain K (n x m) of the
 * measurement H (m x n) with noise R (m x m, upper triangle read),
 * evaluated as written:
 *   P+ = A P A^T + K R K^T,   A = I - K H,
 * as one symmetric product with inner dimension n + m:
 *   P+ = G^T [A^T; -K^T],   G = [P A^T; -R K^T]   ((n+m) x n each),
 * the gain negated, which costs no bit (IEEE rounding is symmetric, so
 * every product, sum and difference is that of K, negated) and saves the
 * negation of H^T K^T.
 * A is formed explicitly: when the measurements pin the state (P+ << P)
 * A is tiny and its O(eps) rounding reaches P+ only as O(eps^2 |P|),
 * while a form that subtracts from P (P - K H P, or P - K(HP) + E K^T)
 * leaves O(eps |P|) in a result that may be far smaller than P. Both
 * terms are PSD in exact arithmetic whatever the gain; a gain error dK
 * enters only as dK S dK^T (docs/decisions.md item 17).
 * AK is (n+m) x n with -K^T (m x n) in its last m rows on entry; its
 * first n rows get A^T = I + H^T (-K^T). Ht = H^T (n x m) may be G
 * itself: it is read only before G is written. Rs (m x m) gets R mirrored from its
 * upper triangle. Pn must not overlap the others. O(n^3 + n^2 m). */
DKF__INLINE void inl_joseph(dkf_real_t *Pn, dkf_real_t *AK, dkf_real_t *G, dkf_real_t *Rs,
                            const dkf_real_t *P, const dkf_real_t *Ht, const dkf_real_t *R,
                            size_t n, size_t m)
{
    const dkf_real_t *Kt = AK + n * n; /* -K^T */
    size_t i, j;
    inl_mul_nn(AK, Ht, Kt, n, m, n); /* H^T (-K^T), then A^T = I - H^T K^T */
    for (i = 0; i < n; ++i) AK[i * n + i] += DKF_R(1.0);
    for (i = 0; i < m; ++i)
        for (j = 0; j < m; ++j) Rs[i * m + j] = i <= j ? R[i * m + j] : R[j * m + i];
    inl_mul_nn(G, P, AK, n, n, n);
    inl_mul_nn(G + n * n, Rs, Kt, m, m, n);
    inl_mul_tn_sym(Pn, G, AK, NULL, n, n + m);
}

/* Row wo of psd_pivots' trailing part: row wi (wo itself after the first
 * pair) loses f (row wk) and e (row wl), from column j0 (from the vector
 * boundary at or below it); dl is added to column i (the diagonal) first,
 * and + 0 to the other columns of that vector (a no-op but for the sign
 * of a zero, which no pivot's sign depends on). */
DKF__INLINE void pivot2_row(dkf_real_t *wo, const dkf_real_t *wi, const dkf_real_t *wk,
                            const dkf_real_t *wl, dkf_real_t f, dkf_real_t e, dkf_real_t dl,
                            size_t i, size_t j0, size_t n)
{
    size_t j;
#if DKF__SIMD
    /* lane q of the vector at unit + 3 - q0 is 1 for q = q0, else 0
     * (DKF__VL is 2 or 4 here) */
    static const dkf_real_t unit[7] = {DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(1.0),
                                       DKF_R(0.0), DKF_R(0.0), DKF_R(0.0)};
    j = j0 & ~(size_t)(DKF__VL - 1);
    if (j <= i && i < j + DKF__VL && j + DKF__VL <= n) { /* the diagonal's vector */
        const dkf__vec_t d = vload(unit + 3 - (i - j)) * dl;
        vstore(wo + j, (vload(wi + j) + d) - f * vload(wk + j) - e * vload(wl + j));
        j += DKF__VL;
    }
    for (; j + DKF__VL <= n; j += DKF__VL)
        vstore(wo + j, vload(wi + j) - f * vload(wk + j) - e * vload(wl + j));
#else
    j = j0;
#endif
    for (; j < n; ++j) wo[j] = (j == i ? wi[j] + dl : wi[j]) - f * wk[j] - e * wl[j];
}

/* Whether W = S + dl I (n x n, S's upper triangle read) is positive
 * definite: the pivots d_k of W = U^T D U (U unit upper triangular),
 * right-looking on W's upper triangle, two at a time. The first pair reads
 * S and adds dl to its diagonal as it reads it; its updates of the
 * trailing rows go to W, and the pairs after it work in W (S may be W
 * itself, dl 0 when W already holds the shift). So S is never copied:
 * a copy of the n x n result the caller has just stored was a stall (the
 * copy's vector loads waiting for the product's and mirror's stores to
 * land) as well as n^2 moves. With a = W(k,k), b = W(k,k+1),
 * c = W(k+1,k+1) (the trailing part after the pivots before k):
 * d_k = a and d_{k+1} = c - b^2 / a = det / a, det = a c - b^2, so both
 * are positive iff a > 0 and det > 0. Row k+1 loses l (row k), l = b / a,
 * and then each row i > k+1 loses f_i (row k) and e_i (row k+1, so
 * reduced), f_i = W(k,i) / d_k, e_i = W(k+1,i) / d_{k+1}: the Schur
 * complement, one pivot after the other, as an LDL^T computes it; the
 * next pair's a, b, c are computed first and carried in registers, and
 * the memory is updated from column k+4 on. An odd n ends on one pivot.
 * 1 if every a and det is positive and finite, else 0 at the first that
 * is not.
 * Why two at a time: the check is a chain of divisions, each pivot waiting
 * for the last one's update of the next rows, and a Kalman step runs it
 * twice (at n = 8 the step took 1215 ns with the former
 * Cholesky check and 602 without). Here 1 / d_k and 1 / det = 1 / (d_k
 * d_{k+1}) are two divisions that run side by side (1 / d_{k+1} is
 * a / det), and the trailing rows are updated by both pivots in one pass
 * (stored, then loaded by the next pair) instead of two. Why not
 * Cholesky: a square root and a division per pivot, and its rows'
 * columns one after another. Why not a 2 x 2 block inverse, rows
 * i > k+1 losing [W(k,i) W(k+1,i)] B^{-1} (rows k, k+1): for a nearly
 * singular block (a singular PSD P, shifted by delta) B^{-1} is huge and
 * its rounding reaches the next pivots as O(1) errors; the reduced row
 * k+1 keeps the LDL^T's accuracy (test_psd_check: a rank-1 P of n = 3).
 * W must be scaled so that a c and b^2 neither overflow nor underflow
 * (psd_shift_scale). The lower triangle of W is scratch (rows are
 * updated from a vector boundary at or below the diagonal), and so is the
 * sign of a zero (adding dl to a diagonal adds + 0 to the other lanes of
 * its vector; no pivot's sign depends on it). Every build runs the same
 * operations in the same order per entry (the vector lanes are the scalar
 * loop's), so the verdict does not depend on the build. */
DKF__INLINE int psd_pivots(dkf_real_t *W, const dkf_real_t *S, dkf_real_t dl, size_t n)
{
    const dkf_real_t *src = S;
    dkf_real_t a = S[0] + dl, b = DKF_R(0.0), c = DKF_R(0.0);
    size_t i, j, k;
    if (n > 1) b = S[1], c = S[n + 1] + dl;
    for (k = 0; k + 1 < n; k += 2) {
        const dkf_real_t *wk = src + k * n, *sl = src + (k + 1) * n;
        dkf_real_t *wl = W + (k + 1) * n;
        dkf_real_t ra, rd, l, det, f2 = DKF_R(0.0), e2 = DKF_R(0.0), f3 = DKF_R(0.0);
        dkf_real_t e3 = DKF_R(0.0), an = DKF_R(0.0), bn = DKF_R(0.0), cn = DKF_R(0.0);
        if (!(a > DKF_R(0.0) && a <= DKF_REAL_MAX)) return 0;
        ra = DKF_R(1.0) / a;
        det = a * c - b * b;
        if (!(det > DKF_R(0.0) && det <= DKF_REAL_MAX)) return 0;
        rd = a * (DKF_R(1.0) / det); /* 1 / d_{k+1} */
        l = b * ra;
        /* rows k+2, k+3 in columns k+2, k+3: the next pair's a, b, c (or
         * the last pivot), carried in registers */
        if (k + 2 < n) {
            const dkf_real_t u2 = wk[k + 2], v2 = sl[k + 2] - l * u2;
            f2 = u2 * ra, e2 = v2 * rd;
            an = (src[(k + 2) * n + k + 2] + dl) - f2 * u2 - e2 * v2;
            if (k + 3 < n) {
                const dkf_real_t u3 = wk[k + 3], v3 = sl[k + 3] - l * u3;
                f3 = u3 * ra, e3 = v3 * rd;
                bn = src[(k + 2) * n + k + 3] - f2 * u3 - e2 * v3;
                cn = (src[(k + 3) * n + k + 3] + dl) - f3 * u3 - e3 * v3;
            }
        }
        /* the rest, from column k+4: row k+1 reduced, then rows k+2 .. */
#if DKF__SIMD
        for (j = (k + 4) & ~(size_t)(DKF__VL - 1); j + DKF__VL <= n; j += DKF__VL)
            vstore(wl + j, vload(sl + j) - l * vload(wk + j));
#else
        j = k + 4;
#endif
        for (; j < n; ++j) wl[j] = sl[j] - l * wk[j];
        if (k + 4 < n) {
            pivot2_row(W + (k + 2) * n, src + (k + 2) * n, wk, wl, f2, e2, dl, k + 2, k + 4, n);
            pivot2_row(W + (k + 3) * n, src + (k + 3) * n, wk, wl, f3, e3, dl, k + 3, k + 4, n);
        }
        for (i = k + 4; i < n; ++i)
            pivot2_row(W + i * n, src + i * n, wk, wl, wk[i] * ra, wl[i] * rd, dl, i, i, n);
        a = an, b = bn, c = cn;
        src = W, dl = DKF_R(0.0); /* after the first pair: W, shifted */
    }
    /* the last pivot of an odd n */
    return k == n || (a > DKF_R(0.0) && a <= DKF_REAL_MAX);
}

/* 2^-e for a positive finite x = f 2^e, 1 <= f < 2, by its IEEE exponent
 * field: x 2^-e is in [1, 2), or in [2, 4) if x >= 2^emax, whose inverse
 * is not a normal number. A product with it is exact (no overflow, no
 * underflow but of entries 2^-emax below x). */
DKF__INLINE dkf_real_t pow2_inverse(dkf_real_t x)
{
#if DKF_USE_FLOAT
    uint32_t e, bits;
    float s;
    memcpy(&bits, &x, sizeof bits);
    e = (bits >> 23) & 0xffu; /* biased: x = f 2^(e - 127) */
    bits = (e <= 253u ? 254u - e : 1u) << 23;
#else
    uint64_t e, bits;
    double s;
    memcpy(&bits, &x, sizeof bits);
    e = (bits >> 52) & 0x7ffu; /* biased: x = f 2^(e - 1023) */
    bits = (e <= 2045u ? 2046u - e : 1u) << 52;
#endif
    memcpy(&s, &bits, sizeof s);
    return s;
}

/* inl_psd_within_rounding (below): whether the symmetric n x n P (its
 * lower triangle read) is positive semidefinite up to rounding, i.e.
 * lambda_min(P) >= -delta with delta = 4 n eps tr(P) + REAL_MIN: every
 * pivot of the LDL^T factorisation (psd_pivots) of P + delta I must be
 * positive (and finite). Why this test and this delta:
 *  - P may be PSD and singular (a filter started from P = 0, a state the
 *    measurements pin exactly): no pivot of P itself may be required to be
 *    positive, so the test shifts P; REAL_MIN keeps P = 0 (tr 0) passing.
 *  - A covariance update or predict computed in floating point has
 *    elementwise errors of a few (n + m) eps |P| in a well-formed update
 *    (the Joseph form's products); tr(P) >= lambda_max(P) >= |P(i,j)|, so
 *    4 n eps tr(P) is above the rounding of a PSD result (an exactly PSD
 *    P has computed lambda_min >= -(few n eps) tr P), and the LDL^T of
 *    the shifted matrix then has positive pivots: without pivoting on a
 *    positive definite matrix it has the Cholesky factorisation's
 *    backward error, (n + 1) eps |P|, which stays below the shift.
 *  - An indefinite P whose negative eigenvalue exceeds delta in size makes
 *    P + delta I indefinite, and no LDL^T of an indefinite matrix (up to
 *    its backward error) has only positive pivots (Sylvester's law of
 *    inertia); a negative diagonal beyond delta fails at its pivot. A
 *    shifted trace tr(P + delta I) that is not positive (some diagonal
 *    < 0), or not finite, fails at once.
 *  - The factorisation runs on s (P + delta I), s a power of 2, which
 *    changes no bit of any product, sum or quotient but where it would
 *    overflow or underflow: s = 1 while the shifted trace t is within
 *    2^(+-emax/4) (float 2^+-32, double 2^+-256), else the s that brings t
 *    into [1, 2) (psd_shift_scale). Either way a PSD P's entries are at
 *    most t and its pivots at least about delta >= 4 eps t, so a pair's
 *    a c, b^2 and det stay far from both limits. Unscaled, they would
 *    overflow for entries above 1.8e19 in float (1.3e154 in double) and
 *    underflow below 1.1e-19 (1.5e-154), refusing a positive definite P;
 *    scaled, the verdict does not depend on P's scale (test_psd_check).
 *  - A NaN or Inf anywhere in P's lower triangle or diagonal gives 0: on
 *    the diagonal it makes the trace non-finite; as b of a pair it makes
 *    det -Inf or NaN; as u_i = P(k,i) or v_i = P(k+1,i) (i beyond the
 *    pair) it enters W(i,i) as minus f_i u_i = u_i^2 / d_k (+Inf) or
 *    e_i v_i = v_i^2 / d_{k+1} (+Inf, or NaN from 0 Inf), making W(i,i)
 *    -Inf or NaN, and no later subtraction makes -Inf or NaN finite
 *    again. So a caller whose P is symmetric need not scan it for NaN
 *    first: it scans only when the check fails, to tell DKF_ERR_NONFINITE
 *    from DKF_ERR_NOT_SPD (the Kalman step and the DKF do; test_psd_check
 *    puts NaN, +Inf and -Inf at every position up to n = 17, in five
 *    columns above).
 * Returns 1 if PSD within delta, 0 otherwise. psd_pivots says why LDL^T
 * two pivots at a time, not Cholesky. psd_shift_scale gives delta and s
 * (0 if the shifted trace is not positive and finite); where s = 1 the
 * pivots read P's triangle and add delta (psd_pivots), else W is filled
 * with s times P's triangle first (psd_scaled_pivots). */
#if DKF_USE_FLOAT
#define DKF__PSD_T_LO 0x1p-32f
#define DKF__PSD_T_HI 0x1p32f
#else
#define DKF__PSD_T_LO 0x1p-256
#define DKF__PSD_T_HI 0x1p256
#endif
DKF__INLINE int psd_shift_scale(const dkf_real_t *P, size_t n, dkf_real_t *delta, dkf_real_t *s)
{
    dkf_real_t t0 = DKF_R(0.0), t1 = DKF_R(0.0), t2 = DKF_R(0.0), t3 = DKF_R(0.0), tr, t;
    size_t i;
    /* the trace in four sums (i mod 4), so that its chain of additions,
     * which every pivot waits for, is n/4 long */
    const size_t n4 = n - n % 4;
    for (i = 0; i < n4; i += 4) {
        t0 += P[i * (n + 1)], t1 += P[(i + 1) * (n + 1)];
        t2 += P[(i + 2) * (n + 1)], t3 += P[(i + 3) * (n + 1)];
    }
    for (i = n4; i < n; ++i) t0 += P[i * (n + 1)];
    tr = (t0 + t1) + (t2 + t3);
    *delta = DKF_R(4.0) * (dkf_real_t)n * DKF_REAL_EPSILON * tr + DKF_REAL_MIN;
    *s = DKF_R(1.0);
    if (tr >= DKF__PSD_T_LO && tr <= DKF__PSD_T_HI) return 1; /* then so is t */
    t = tr + (dkf_real_t)n * *delta;
    if (!(t > DKF_R(0.0) && t <= DKF_REAL_MAX)) return 0;
    if (t < DKF__PSD_T_LO || t > DKF__PSD_T_HI) *s = pow2_inverse(t);
    return 1;
}

/* d = -a, len reals that do not overlap (the Kalman step's and
 * dkf__joseph's negated gain: restrict lets GCC vectorise it). */
DKF__INLINE void inl_negate(dkf_real_t *restrict d, const dkf_real_t *restrict a, size_t len)
{
    size_t i;
    for (i = 0; i < len; ++i) d[i] = -a[i];
}

/* d = s a, len reals (d == a allowed). */
DKF__INLINE void scale_copy(dkf_real_t *d, const dkf_real_t *a, dkf_real_t s, size_t len)
{
#if DKF__SIMD
    const size_t nv = len - len % DKF__VL;
#else
    const size_t nv = 0;
#endif
    size_t i;
#if DKF__SIMD
    for (i = 0; i < nv; i += DKF__VL) vstore(d + i, vload(a + i) * s);
#endif
    for (i = nv; i < len; ++i) d[i] = a[i] * s;
}

/* The pivots of s (P + delta I), W holding s P's upper triangle (s != 1). */
DKF__INLINE int psd_scaled_pivots(dkf_real_t *W, const dkf_real_t *P, size_t n, dkf_real_t delta,
                                  dkf_real_t s)
{
    size_t i;
    for (i = 0; i < n; ++i) W[i * n + i] = (P[i * n + i] + delta) * s;
    return psd_pivots(W, W, DKF_R(0.0), n);
}

DKF__INLINE int inl_psd_within_rounding(dkf_real_t *restrict W, const dkf_real_t *restrict P,
                                        size_t n)
{
    dkf_real_t delta, s;
    if (!psd_shift_scale(P, n, &delta, &s)) return 0;
    inl_transpose(W, P, n, n); /* W's upper triangle: P's lower one */
    if (s == DKF_R(1.0)) return psd_pivots(W, W, delta, n);
    scale_copy(W, W, s, n * n);
    return psd_scaled_pivots(W, P, n, delta, s);
}

/* inl_psd_within_rounding for a P that is exactly symmetric, P(i,j) ==
 * P(j,i) bit for bit (a product stored with its mirror, or a difference
 * of two such): the same test and the same result, as W's upper triangle,
 * the only part psd_pivots reads, is the same reals either way, but the
 * pivots read P itself (scaled, a copy of P's rows) rather than a
 * transpose, which costs n^2 scalar stores that the pivots' vector loads
 * then wait for. For the covariances the Kalman step and the DKF commit
 * (measured 2026-12-06; CHANGELOG.md). */
DKF__INLINE int inl_psd_sym_within_rounding(dkf_real_t *restrict W, const dkf_real_t *restrict P,
                                            size_t n)
{
    dkf_real_t delta, s;
    if (!psd_shift_scale(P, n, &delta, &s)) return 0;
    if (s == DKF_R(1.0)) return psd_pivots(W, P, delta, n); /* no copy: its first pair reads P */
    scale_copy(W, P, s, n * n);
    return psd_scaled_pivots(W, P, n, delta, s);
}

/* Solves L w = b in place (forward substitution), b n x 1; inv from
 * inl_chol. Only the Kalman step uses it. */
DKF__INLINE void inl_tri_lower_solve_vec(const dkf_real_t *L, const dkf_real_t *inv, dkf_real_t *b,
                                         size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) b[i] = (b[i] - inl_dot(L + i * n, b, i)) * inv[i];
}

/* Two rows of a triangular solve on 4 columns: with x_q = x + q xs (rows
 * of the solved part, 4 columns each) and coefficients a[q cs], b[q cs],
 *   t  = (rh - sum_q a_q x_q) dh,          rh = bh[0..3] on entry,
 *   bg = ((rg - sum_q b_q x_q) - c t) dg,  rg = bg[0..3] on entry,
 * the sums over q = 0 .. k-1 in that order, then bh = t: row g's last term
 * comes from the finished row h. Each loaded x_q serves both rows; with
 * DKF__SIMD the 4 columns are 4 / DKF__VL vectors, whose lanes compute
 * what the scalars compute in the same order (the same bits). */
#if DKF__SIMD
/* solve_2x4 on nv vectors per row (nv = 4 / DKF__VL or 8 / DKF__VL, a
 * constant once inlined: the unused sums fold away), so solve_2x8 loads
 * each x_q row once for 8 columns of both rows. */
DKF__INLINE void solve_2xv(dkf_real_t *bh, dkf_real_t *bg, const dkf_real_t *x, ptrdiff_t xs,
                           const dkf_real_t *a, const dkf_real_t *b, ptrdiff_t cs, size_t k,
                           dkf_real_t dh, dkf_real_t c, dkf_real_t dg, size_t nv)
{
    const dkf__vec_t z = {0};
    dkf__vec_t t0 = vload(bh), t1 = z, t2 = z, t3 = z, u0 = vload(bg), u1 = z, u2 = z, u3 = z;
    size_t q;
    if (nv > 1) t1 = vload(bh + DKF__VL), u1 = vload(bg + DKF__VL);
    if (nv > 2) {
        t2 = vload(bh + 2 * DKF__VL), u2 = vload(bg + 2 * DKF__VL);
        t3 = vload(bh + 3 * DKF__VL), u3 = vload(bg + 3 * DKF__VL);
    }
    for (q = 0; q < k; ++q, x += xs, a += cs, b += cs) {
        const dkf__vec_t x0 = vload(x);
        t0 -= *a * x0, u0 -= *b * x0;
        if (nv > 1) {
            const dkf__vec_t x1 = vload(x + DKF__VL);
            t1 -= *a * x1, u1 -= *b * x1;
        }
        if (nv > 2) {
            const dkf__vec_t x2 = vload(x + 2 * DKF__VL), x3 = vload(x + 3 * DKF__VL);
            t2 -= *a * x2, u2 -= *b * x2, t3 -= *a * x3, u3 -= *b * x3;
        }
    }
    t0 *= dh, u0 -= c * t0, u0 *= dg;
    vstore(bh, t0), vstore(bg, u0);
    if (nv > 1) {
        t1 *= dh, u1 -= c * t1, u1 *= dg;
        vstore(bh + DKF__VL, t1), vstore(bg + DKF__VL, u1);
    }
    if (nv > 2) {
        t2 *= dh, u2 -= c * t2, u2 *= dg, t3 *= dh, u3 -= c * t3, u3 *= dg;
        vstore(bh + 2 * DKF__VL, t2), vstore(bg + 2 * DKF__VL, u2);
        vstore(bh + 3 * DKF__VL, t3), vstore(bg + 3 * DKF__VL, u3);
    }
}

DKF__INLINE void solve_2x4(dkf_real_t *bh, dkf_real_t *bg, const dkf_real_t *x, ptrdiff_t xs,
                           const dkf_real_t *a, const dkf_real_t *b, ptrdiff_t cs, size_t k,
                           dkf_real_t dh, dkf_real_t c, dkf_real_t dg)
{
    solve_2xv(bh, bg, x, xs, a, b, cs, k, dh, c, dg, 4 / DKF__VL);
}

DKF__INLINE void solve_2x8(dkf_real_t *bh, dkf_real_t *bg, const dkf_real_t *x, ptrdiff_t xs,
                           const dkf_real_t *a, const dkf_real_t *b, ptrdiff_t cs, size_t k,
                           dkf_real_t dh, dkf_real_t c, dkf_real_t dg)
{
    solve_2xv(bh, bg, x, xs, a, b, cs, k, dh, c, dg, 8 / DKF__VL);
}
#else
DKF__INLINE void solve_2x4(dkf_real_t *bh, dkf_real_t *bg, const dkf_real_t *x, ptrdiff_t xs,
                           const dkf_real_t *a, const dkf_real_t *b, ptrdiff_t cs, size_t k,
                           dkf_real_t dh, dkf_real_t c, dkf_real_t dg)
{
    dkf_real_t t0 = bh[0], t1 = bh[1], t2 = bh[2], t3 = bh[3];
    dkf_real_t u0 = bg[0], u1 = bg[1], u2 = bg[2], u3 = bg[3];
    size_t q;
    for (q = 0; q < k; ++q, x += xs, a += cs, b += cs) {
        const dkf_real_t p = *a, r = *b;
        t0 -= p * x[0], t1 -= p * x[1], t2 -= p * x[2], t3 -= p * x[3];
        u0 -= r * x[0], u1 -= r * x[1], u2 -= r * x[2], u3 -= r * x[3];
    }
    t0 *= dh, t1 *= dh, t2 *= dh, t3 *= dh;
    u0 -= c * t0, u1 -= c * t1, u2 -= c * t2, u3 -= c * t3;
    bh[0] = t0, bh[1] = t1, bh[2] = t2, bh[3] = t3;
    bg[0] = u0 * dg, bg[1] = u1 * dg, bg[2] = u2 * dg, bg[3] = u3 * dg;
}

/* the columns are independent: two 4-column blocks */
DKF__INLINE void solve_2x8(dkf_real_t *bh, dkf_real_t *bg, const dkf_real_t *x, ptrdiff_t xs,
                           const dkf_real_t *a, const dkf_real_t *b, ptrdiff_t cs, size_t k,
                           dkf_real_t dh, dkf_real_t c, dkf_real_t dg)
{
    solve_2x4(bh, bg, x, xs, a, b, cs, k, dh, c, dg);
    solve_2x4(bh + 4, bg + 4, x + 4, xs, a, b, cs, k, dh, c, dg);
}
#endif

/* The backward half of inl_chol_solve: L^T X = W in place for W n x c
 * (the forward half's result), in its order of terms (also used by a
 * solve whose forward half skips known zeros, src/diffkf.c). Rows are
 * taken two at a time, h = l-1 and g = l-2 (solve_2x4): both sums run
 * together over i > h, descending, then g takes its last term, i = h,
 * from the finished row h. That is the order of the one-row loop (i
 * descending), so the bits are the same. */
DKF__INLINE void inl_chol_backward(const dkf_real_t *L, const dkf_real_t *inv, dkf_real_t *B,
                                   size_t n, size_t c)
{
    size_t i, j, l;
    /* backward: L^T X = W; row l of X = (row l of W - sum_{i>l, descending}
     * L(i,l) X_i) / L(l,l) */
    for (l = n; l >= 2; l -= 2) {
        const size_t h = l - 1, g = l - 2;
        dkf_real_t *bh = B + h * c, *bg = B + g * c;
        const dkf_real_t dh = inv[h], dg = inv[g], lhg = L[h * n + g];
        const ptrdiff_t back = -(ptrdiff_t)c, up = -(ptrdiff_t)n;
        for (j = 0; j + 4 <= c; j += 4)
            solve_2x4(bh + j, bg + j, B + (n - 1) * c + j, back, L + (n - 1) * n + h,
                      L + (n - 1) * n + g, up, n - 1 - h, dh, lhg, dg);
        for (; j < c; ++j) {
            dkf_real_t t = bh[j], u = bg[j];
            for (i = n - 1; i > h; --i) {
                t -= L[i * n + h] * B[i * c + j];
                u -= L[i * n + g] * B[i * c + j];
            }
            t *= dh;
            bh[j] = t;
            u -= lhg * t;
            bg[j] = u * dg;
        }
    }
    if (l == 1) { /* row 0 of an odd n */
        dkf_real_t *b0 = B;
        for (j = 0; j < c; ++j) {
            dkf_real_t t = b0[j];
            for (i = n - 1; i > 0; --i) t -= L[i * n] * B[i * c + j];
            b0[j] = t * inv[0];
        }
    }
}

/* The forward half of inl_chol_solve: L W = B in place for B n x c (also
 * the whitening Lc^{-1} B of a carry, src/diffkf.c), 4 columns of B at a
 * time in registers, each element's terms in the textbook order (l
 * ascending). */
DKF__INLINE void inl_chol_forward(const dkf_real_t *L, const dkf_real_t *inv, dkf_real_t *B,
                                  size_t n, size_t c)
{
    size_t i, j, l;
    /* row i of W = (row i of B - sum_{l<i} L(i,l) W_l) / L(i,i) */
    for (i = 0; i < n; ++i) {
        dkf_real_t *bi = B + i * c;
        const dkf_real_t *li = L + i * n;
        const dkf_real_t d = inv[i];
        for (j = 0; j + 4 <= c; j += 4) {
            dkf_real_t t0 = bi[j], t1 = bi[j + 1], t2 = bi[j + 2], t3 = bi[j + 3];
            for (l = 0; l < i; ++l) {
                const dkf_real_t a = li[l];
                const dkf_real_t *bl = B + l * c + j;
                t0 -= a * bl[0];
                t1 -= a * bl[1];
                t2 -= a * bl[2];
                t3 -= a * bl[3];
            }
            bi[j] = t0 * d, bi[j + 1] = t1 * d, bi[j + 2] = t2 * d, bi[j + 3] = t3 * d;
        }
        for (; j < c; ++j) {
            dkf_real_t t = bi[j];
            for (l = 0; l < i; ++l) t -= li[l] * B[l * c + j];
            bi[j] = t * d;
        }
    }
}

/* L L^T X = B in place: both substitutions (row-major friendly,
 * independent chains), each element's terms in the textbook order
 * (forward: l ascending; backward: i descending), so the result is that
 * of the plain row-by-row loops. */
DKF__INLINE void inl_chol_solve(const dkf_real_t *L, const dkf_real_t *inv, dkf_real_t *B, size_t n,
                                size_t c)
{
    inl_chol_forward(L, inv, B, n, c);
    inl_chol_backward(L, inv, B, n, c);
}

#endif /* DKF_KERNELS_INLINE_H */
