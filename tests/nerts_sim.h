/*
 * Simulated data for the nerts tests: truth x_k = f(x_{k-1}, d_{k-1}) +
 * w_{k-1}, z_k = h(x_k, d_k) + v_k with w ~ N(0, Q), v ~ N(0, R) drawn
 * from the fixed-seed test PRNG through Cholesky factors in double
 * (test_dchol, independent of the library), and d_k a deterministic function
 * of k given by the test. Static inline, as nerts_fixture.h.
 */
#ifndef NERTS_SIM_H
#define NERTS_SIM_H

#include <math.h>
#include <stddef.h>

#include "dkf/nl_model.h"
#include "dkf_test.h"

#define SIM_STEPS 120
#define SIM_DIM 36

typedef struct {
    size_t n, m, p, steps;
    dkf_real_t X[SIM_STEPS + 1][SIM_DIM]; /* x_0 .. x_steps */
    dkf_real_t D[SIM_STEPS + 1][SIM_DIM]; /* d_0 .. d_steps */
    dkf_real_t Z[SIM_STEPS + 1][SIM_DIM]; /* z_1 .. z_steps (Z[0] unused) */
} sim_t;

typedef double (*sim_input_fn)(size_t k, size_t j);

static inline void sim_run(sim_t *s, const dkf_nl_model_t *md, const dkf_real_t *x0,
                           sim_input_fn dfun, const double *Q, const double *R, size_t steps,
                           test_rng_t *rng)
{
    double LQ[SIM_DIM * SIM_DIM], LR[SIM_DIM * SIM_DIM], w[SIM_DIM];
    dkf_real_t y[SIM_DIM];
    size_t k, i;
    s->n = md->n;
    s->m = md->m;
    s->p = md->p;
    s->steps = steps;
    test_dchol(LQ, Q, md->n);
    test_dchol(LR, R, md->m);
    for (i = 0; i < md->n; ++i) s->X[0][i] = x0[i];
    for (k = 0; k <= steps; ++k)
        for (i = 0; i < md->p; ++i) s->D[k][i] = (dkf_real_t)dfun(k, i);
    for (k = 1; k <= steps; ++k) {
        (void)md->f(md->ctx, k - 1, s->X[k - 1], s->D[k - 1], NULL, s->X[k]);
        test_draw(rng, w, LQ, md->n);
        for (i = 0; i < md->n; ++i) s->X[k][i] += (dkf_real_t)w[i];
        (void)md->h(md->ctx, k, s->X[k], s->D[k], NULL, y);
        test_draw(rng, w, LR, md->m);
        for (i = 0; i < md->m; ++i) s->Z[k][i] = y[i] + (dkf_real_t)w[i];
    }
}

#endif /* NERTS_SIM_H */
