/*
 * fuzz_nerts.h - what fuzz_core_nerts.c and fuzz_core_dfnerts.c share
 * beyond fuzz_core.h: one node's dimensions, prior and the lin_x_sin_d
 * model of tests/nerts_fixture.h built from byte-edited matrices.
 */
#ifndef DKF_FUZZ_NERTS_H
#define DKF_FUZZ_NERTS_H

#include "fuzz_core.h"
#include "../nerts_fixture.h"

/* The matrix b (r x c, edited) into the model's doubles. */
static inline void fz_to_doubles(double *dst, const fz_mat_t *b, size_t r, size_t c)
{
    size_t i;
    for (i = 0; i < r * c; ++i) dst[i] = (double)b->d[i];
}

/* The model c (c->n, c->m, c->p set) from the edited A (n x n), B (n x p),
 * C (m x n), H (m x p) and a fault: 1 f fails, 2 h fails, 3 h gives NaN,
 * 4 the linear model (sin dropped); any other value none. */
static inline void fz_lxs_model(lxs_t *c, const fz_mat_t *A, const fz_mat_t *B,
                                const fz_mat_t *C, const fz_mat_t *H, uint8_t fault)
{
    fz_to_doubles(c->A, A, c->n, c->n);
    fz_to_doubles(c->B, B, c->n, c->p);
    fz_to_doubles(c->C, C, c->m, c->n);
    fz_to_doubles(c->H, H, c->m, c->p);
    c->fail_f = fault == 1;
    c->fail_h = fault == 2;
    c->nan_h = fault == 3;
    c->linear = fault == 4;
}

/* One node: its dimensions, the model c (md its callbacks), the prior and
 * the step's model matrices, Q, R, z. */
typedef struct {
    size_t n, m, p;
    lxs_t c;
    dkf_nl_model_t md;
    fz_mat_t x0, P0, d0, Pd0, Pxd0, A, B, C, H, Q, R, zz;
} fz_node_t;

/* The default prior, then byte-chosen edits (fz_nerts_prior). */
static inline void fz_node_prior(fz_t *z, fz_node_t *o)
{
    fz_mat_t *const prior[] = {&o->x0, &o->P0, &o->d0, &o->Pd0, &o->Pxd0};
    fz_nerts_prior(z, prior, o->n, o->p);
}

/* n in 1..nmax, m in 1..mmax, p in 0..pmax, analytic or differenced
 * Jacobians, then the byte-edited prior (fz_node_prior). */
static inline void fz_node_decode(fz_t *z, fz_node_t *o, size_t nmax, size_t mmax, size_t pmax)
{
    o->n = fz_dim(z, nmax);
    o->m = fz_dim(z, mmax);
    o->p = fz_byte(z) % (pmax + 1);
    memset(&o->c, 0, sizeof o->c);
    o->c.n = o->n, o->c.m = o->m, o->c.p = o->p;
    o->md = lxs_model(&o->c, fz_byte(z) & 1);
    fz_node_prior(z, o);
}

/* The step's A, B, C, H, Q, R, z at their defaults, then byte-chosen edits
 * of them and of the harness's extra matrices (count), into the model with
 * a fault (fz_lxs_model). */
static inline void fz_node_step(fz_t *z, fz_node_t *o, fz_mat_t *const extra[], size_t count,
                                uint8_t fault)
{
    fz_mat_t *mats[9] = {&o->A, &o->B, &o->C, &o->H, &o->Q, &o->R, &o->zz};
    const size_t n = o->n, m = o->m, p = o->p;
    size_t k;
    for (k = 0; k < count && k < 2; ++k) mats[7 + k] = extra[k];
    fz_set(&o->A, n, n, DKF_R(0.9), DKF_R(0.05));
    fz_set(&o->B, n, p, DKF_R(0.5), DKF_R(0.1));
    fz_set(&o->C, m, n, DKF_R(1.0), DKF_R(0.2));
    fz_set(&o->H, m, p, DKF_R(1.0), DKF_R(0.0));
    fz_set(&o->Q, n, n, DKF_R(0.1), DKF_R(0.0));
    fz_set(&o->R, m, m, DKF_R(0.5), DKF_R(0.0));
    fz_set(&o->zz, m, 1, DKF_R(0.3), DKF_R(0.3));
    fz_edit(z, mats, 7 + k);
    fz_lxs_model(&o->c, &o->A, &o->B, &o->C, &o->H, fault);
}

/* The prior's optional parts (d0, Pd0, Pxd0): NULL when p = 0. */
#define FZ_NODE_D(o, field) ((o)->p > 0 ? &(o)->field.v : NULL)

#endif /* DKF_FUZZ_NERTS_H */
