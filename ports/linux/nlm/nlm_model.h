/*
 * nlm_model.h - the jansson-free half of the host's nonlinear models
 * (nlm.h): the model object dkf_nlm_t, the callbacks the core calls
 * (nlm_model.c: dkf_real_t <-> double, every value checked for
 * finiteness, the angle channels wrapped) and the built-in families'
 * arithmetic (nlm_family.c). nlm.h's loaders build these from JSON; the
 * Python package compiles these two files into its extension modules too
 * (python/src/nlm_builtin.cpp), so dkf.run_scenario runs the very code
 * dkf-run runs.
 */
#ifndef DKF_HOST_NLM_MODEL_H
#define DKF_HOST_NLM_MODEL_H

#include <stddef.h>

#include "dkf/nl_model.h"

typedef struct dkf_nlm dkf_nlm_t;

/* What a source implements, in double (nlm_model.c converts from and to
 * dkf_real_t and checks every value for finiteness). f_jac / h_jac NULL:
 * the core's forward differences (DKF_NL_FD_STEP, dkf/config.h). Each
 * returns 0, or -1 after writing its reason with dkf_nlm_set_failure. */
typedef struct {
    int (*f)(dkf_nlm_t *m, const double *x, const double *d, double *x_next);
    int (*h)(dkf_nlm_t *m, const double *x, const double *d, double *z);
    int (*f_jac)(dkf_nlm_t *m, const double *x, const double *d, double *Fx, double *Fd);
    int (*h_jac)(dkf_nlm_t *m, const double *x, const double *d, double *Hx, double *Hd);
    void (*destroy)(void *impl);
} dkf_nlm_ops_t;

struct dkf_nlm {
    dkf_nl_model_t model;  /* the core's table (model.ctx = this struct) */
    size_t n, m, p;        /* state, measurement, unknown input */
    double *Q;             /* n x n, row-major (model.Q) */
    double *R;             /* m x m (model.R, or the family's default) */
    unsigned char angle[DKF_MAX_DIM]; /* 1: channel i of g is an angle */
    size_t nangles;
    char source[32];       /* "expr" or the family name */
    char *path;            /* the model object's key path, for messages */
    const dkf_nlm_ops_t *ops;
    void *impl;            /* the source's own data */
    char failure[256];     /* the last callback failure, "" if none */
    double *jac_a, *jac_b; /* the Jacobians' blocks in double: max(n, m) x n, x max(p, 1) */
};

/* The reason the last callback of m failed ("" if none). */
const char *dkf_nlm_failure(const dkf_nlm_t *m);

/* For the sources: printf-style reason of a failing callback. */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
void dkf_nlm_set_failure(dkf_nlm_t *m, const char *fmt, ...);

/* Frees m (its source's impl through ops->destroy, Q, R, path, scratch). */
void dkf_nlm_free(dkf_nlm_t *m);

/* Once n, m, p, ops, impl and angle are set: the Jacobians' scratch and the
 * core's table (model.ctx = m; y_diff when a channel is an angle). 0, or -1
 * out of memory. */
int dkf_nlm_finish(dkf_nlm_t *m);

/* ---- the built-in families (nlm_family.c; nlm_builtin.c reads them) ---- */

#define DKF_NLM_MAX_SENSORS (DKF_MAX_DIM / 2)

/* A built-in model's parameters (m->impl; the arrays malloc'ed). */
typedef struct {
    /* lin_x_sin_d */
    double *A, *B, *C, *H; /* n x n, n x p, m x n, m x p */
    /* s1_* */
    double T, gain, omega; /* sample time, phi gain, the fixed turn rate (s1_ckf) */
    size_t L;              /* sensors */
    double sxy[2 * DKF_NLM_MAX_SENSORS];
    size_t per;            /* measurements per sensor: 3 (with phi) or 2 */
} dkf_nlm_family_t;

/* lin_x_sin_d; the s1_* coordinated turn with L range-bearing(-phi)
 * sensors. destroy frees a dkf_nlm_family_t. */
extern const dkf_nlm_ops_t dkf_nlm_lin_ops, dkf_nlm_s1_ops;

/* The family index of a name (0 lin_x_sin_d, 1 s1_radar, 2
 * s1_radar_stacked, 3 s1_ckf), -1 if none. */
int dkf_nlm_family_index(const char *name);

/* The names of the built-in families, ", "-separated (for messages). */
const char *dkf_nlm_builtin_names(void);

/* An s1_* model's measurement layout from b->L, b->per: m->m = per L and
 * the bearings' angle channels; m->ops = the s1 table. */
void dkf_nlm_s1_layout(dkf_nlm_t *m, const dkf_nlm_family_t *b);

/* Seed 001's sensor noise diag(0.2^2, 0.015^2, sigma_phi^2) per sensor
 * block into R (m x m, zeroed here), sigma_phi = 0.017 deg/s in rad/s. */
void dkf_nlm_s1_default_R(double *R, size_t m, const dkf_nlm_family_t *b);

#endif /* DKF_HOST_NLM_MODEL_H */
