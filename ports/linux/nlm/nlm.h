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

#include "nlm_model.h" /* dkf_nlm_t, its callbacks, the families' arithmetic */

/* Longest expression string accepted (characters). */
#define DKF_NLM_EXPR_MAX 4096

struct dkf_scn_ctx; /* scn_values.h */

/* The model of JSON object j at key path `path` of `file`, for a state of
 * n and an unknown input of p components (the case's init sizes them);
 * (x0, d0) is a point every expression is evaluated at once while loading
 * (a non-finite value there is refused: division by zero, log(0), ...).
 * NULL with a "FILE: KEY: problem" line in err. */
dkf_nlm_t *dkf_nlm_load(const json_t *j, const char *file, const char *path, size_t n, size_t p,
                        const double *x0, const double *d0, char *err, size_t errlen);

/* The sources' loaders (nlm_builtin.c, nlm_expr.c): fill m->ops, m->impl,
 * m->m, m->angle and (built-in defaults) m->R from j. 0 or -1 (message
 * through c). m->n, m->p are set. */
int dkf_nlm_load_builtin(struct dkf_scn_ctx *c, dkf_nlm_t *m, const json_t *j, const char *path);
int dkf_nlm_load_expr(struct dkf_scn_ctx *c, dkf_nlm_t *m, const json_t *expr, const char *path,
                      const double *x0, const double *d0);

#endif /* DKF_HOST_NLM_H */
