/*
 * nlm.h - nonlinear models on the host: a scenario's `model` object
 * turned into the core's callback table (dkf/nl_model.h) plus its numeric
 * Q and R. Two sources, one result (docs/design/infofusion.md, "Models on the
 * host"; docs/reference/scenario-format.md, "Nonlinear cases"):
 *
 *   built-in named models ({"family": "s1_radar", ...}: nlm_builtin.c),
 *     the families of the seed-001 vector files;
 *   expression models ({"expr": {"f": [...], "g": [...]}, ...}:
 *     nlm_expr.c), parsed by muparser (Debian libmuparser-dev) in the
 *     variables x1..xn, d1..dp, with optional Jacobians "A", "G", "C",
 *     "H" as matrices of expression strings and "angles" (0-based
 *     indices of g that are angles).
 *
 * The model is x_{k+1} = f(x_k, d_k) + w_k, z_k = g(x_k, d_k) + v_k (the
 * paper's g is the core's h; A, G, C, H are Fx, Fd, Hx, Hd). Angle channels
 * are given to the filters through the table's y_diff: a - b wrapped to
 * [-pi, pi) in those channels (dkf/nerts.h unwraps cubature images around
 * h(x_pred) with it).
 *
 * Every problem found while loading is one "FILE: KEY: problem" line (the
 * JSON value readers' dkf_scn_fail, scn_values.h); a callback that fails at run time
 * (a non-finite value, e.g. a division by zero inside an expression)
 * returns non-zero, so the filter's step fails with DKF_ERR_MODEL and
 * leaves the filter untouched, and dkf_nlm_failure() says which
 * expression or model gave what.
 */
#ifndef DKF_HOST_NLM_H
#define DKF_HOST_NLM_H

#include <stddef.h>

#include <jansson.h>

#include "dkf/nl_model.h"

/* Longest expression string accepted (characters). */
#define DKF_NLM_EXPR_MAX 4096

typedef struct dkf_nlm dkf_nlm_t;

/* What a source implements, in double (nlm.c converts from and to
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

struct dkf_scn_ctx; /* scn_values.h */

/* The model of JSON object j at key path `path` of `file`, for a state of
 * n and an unknown input of p components (the case's init sizes them);
 * (x0, d0) is a point every expression is evaluated at once while loading
 * (a non-finite value there is refused: division by zero, log(0), ...).
 * NULL with a "FILE: KEY: problem" line in err. */
dkf_nlm_t *dkf_nlm_load(const json_t *j, const char *file, const char *path, size_t n, size_t p,
                        const double *x0, const double *d0, char *err, size_t errlen);
void dkf_nlm_free(dkf_nlm_t *m);

/* The reason the last callback of m failed ("" if none). */
const char *dkf_nlm_failure(const dkf_nlm_t *m);

/* For the sources: printf-style reason of a failing callback. */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
void dkf_nlm_set_failure(dkf_nlm_t *m, const char *fmt, ...);

/* The sources' loaders (nlm_builtin.c, nlm_expr.c): fill m->ops, m->impl,
 * m->m, m->angle and (built-in defaults) m->R from j. 0 or -1 (message
 * through c). m->n, m->p are set. */
int dkf_nlm_load_builtin(struct dkf_scn_ctx *c, dkf_nlm_t *m, const json_t *j, const char *path);
int dkf_nlm_load_expr(struct dkf_scn_ctx *c, dkf_nlm_t *m, const json_t *expr, const char *path,
                      const double *x0, const double *d0);

/* The names of the built-in families, ", "-separated (for messages). */
const char *dkf_nlm_builtin_names(void);

#endif /* DKF_HOST_NLM_H */
