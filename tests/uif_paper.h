/*
 * The paper's example system (seed 004, docs/design/derivation-seed003-004.md)
 * of the unknown-input filter tests test_uif_mc.c and test_uif_props.c:
 * n = 5 states, p = 3 inputs, m = 5 measurements, row-major doubles. x_{k+1} = A x_k + G d_k + w_k, y_k = C x_k + H d_k + v_k with
 * C = I, R = cov(v) below and Q = cov(w) = 1e-2 R (R's pattern).
 */
#ifndef UIF_PAPER_H
#define UIF_PAPER_H

static const double PA[25] = {0.5, 2, 0, 0, 0, 0, 0.2, 1, 0, 1, 0, 0, 0.3, 0, 1,
                              0,   0, 0, 0.7, 1, 0, 0, 0, 0, 0.1};
static const double PG[15] = {1, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0};
static const double PH[15] = {0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0};
static const double PR[25] = {1e-2, 0, 0, 5e-3, 0, 0, 1e-2, 0, 0, 3e-3, 0, 0, 1e-2,
                              0,    0, 5e-3, 0, 0, 1e-2, 0, 0, 3e-3, 0, 0, 1e-2};

#endif /* UIF_PAPER_H */
