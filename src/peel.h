/*
 * src/peel.h - included first (before any definition) by the translation
 * units whose kernels run at small or fixed sizes: kernels.c, kernels_avx.c,
 * kf.c, kf_avx.c, diffkf.c. Not installed.
 *
 * With DKF_PEEL_LOOPS (config.h), under GCC optimising for speed, it turns
 * on complete peeling of loops with a small constant trip count
 * (-fpeel-loops, which -O3 turns on): at -O2 GCC unrolls such a loop only
 * where it estimates no growth of the code, so the fixed-size steps kept
 * a counter, a compare and a branch around each 2- or 4-element row of
 * their transposes, dot products, finiteness scans and LDL^T pivots.
 * A pragma rather than a flag in CMakeLists.txt: it travels with the
 * sources into a firmware's own build. Peeling changes no operation and
 * no order of operations, so the results are the same bits (the
 * benchmarks' checksums, and every vector test, are unchanged).
 * Measured (callgrind, instructions per step, double, Joseph, 2026-12-05;
 * docs/results/bench.md): KF n = 4 / 8 / 12 2380 / 7469 / 21597 -> 1928 / 5911 /
 * 16580; the DKF of seed 000 Example 1 5278 -> 4419.
 * Not under -Os (the firmware's build: each loop stays one copy) or -O0;
 * Clang has no such pragma.
 */
#ifndef DKF_PEEL_H
#define DKF_PEEL_H

#include "dkf/config.h"

#if DKF_PEEL_LOOPS && defined(__GNUC__) && !defined(__clang__) && defined(__OPTIMIZE__) && \
    !defined(__OPTIMIZE_SIZE__)
#pragma GCC optimize("peel-loops")
#endif

#endif
