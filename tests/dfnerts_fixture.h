/*
 * The linear network of the DF-DNERTSIF tests (test_dfnerts_props.c,
 * test_dfnerts_mc.c): x = [position, velocity], one unknown input d
 * entering the dynamics (G) and every sensor (Hd), four sensors with two
 * channels each, as tests/nerts_fixture.h's lin_x_sin_d model with the
 * sine dropped (lxs_t.linear = 1):
 *   x_{k+1} = F x_k + G d_k + w,  w ~ N(0, Q)
 *   z_l     = H_l x + D_l d + v,  v ~ N(0, diag(R_l))
 * Sensors 2 and 3 see d in channels that depend strongly on x: Algorithm
 * 3's mixed joint covariance is indefinite on this network.
 */
#ifndef DFNERTS_FIXTURE_H
#define DFNERTS_FIXTURE_H

#define DFN_NODES 4
#define DFN_N 2
#define DFN_M 2

static const double dfn_F[4] = {1, 1, 0, 1}, dfn_G[2] = {0.5, 1}, dfn_Q[4] = {0.01, 0, 0, 0.04};
static const double dfn_H[DFN_NODES][4] = {{1, 0, 0.5, 0.2}, {1, 0, 0, 1}, {0, 1, 1, 0.3},
                                           {1, 1, 2, 0}};
static const double dfn_D[DFN_NODES][2] = {{0, 1}, {0, 1}, {1, 0.5}, {0.5, 1}};
static const double dfn_R[DFN_NODES][2] = {{0.1, 0.05}, {0.2, 0.1}, {0.05, 0.3}, {0.1, 0.1}};

#endif /* DFNERTS_FIXTURE_H */
