/*
 * nlm.c - a scenario's nonlinear model object -> dkf_nl_model_t (nlm.h):
 * the dispatch to the built-in families (nlm_builtin.c) and the
 * expression models (nlm_expr.c), the numeric Q and R, the angle
 * channels; the callbacks the core calls are nlm_model.c's.
 */
#include "nlm.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scn_values.h"

/* ---- loading ------------------------------------------------------------------- */

/* The keys a model object may have: the expression form, every built-in
 * family's parameters (nlm_builtin.c), the noises; `sensor`, `sensors`:
 * the vectors' descriptions of the sensors. */
static const char *const model_keys[] = {"family", "expr", "angles", "Q", "R", "A", "b", "C", "H",
                                         "T", "omega_fixed", "phi_gain", "sensor_xy", "sensor",
                                         "sensors", NULL};

/* model[key] as an r x r matrix into *out (NULL if absent and !required). */
static int square_matrix(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *key,
                         size_t r, int required, double **out)
{
    const json_t *v = json_object_get(j, key);
    char p[DKF_SCN_PATH_LEN];
    size_t rows, cols;
    double *a;
    dkf_scn_subkey(p, path, key);
    if (v == NULL) {
        if (!required) return 0;
        return dkf_scn_fail(c, p, "missing key (the %zu x %zu %s noise covariance)", r, r,
                            key[0] == 'Q' ? "state" : "measurement");
    }
    if (dkf_scn_parse_matrix(c, v, p, &rows, &cols, &a) != 0) return -1;
    if (rows != r || cols != r) {
        free(a);
        return dkf_scn_fail(c, p, "expected %zu x %zu, got %zu x %zu", r, r, rows, cols);
    }
    if (dkf_scn_check_symmetric(c, p, a, r) != 0 ||
        dkf_scn_check_definite(c, p, a, r, key[0] == 'R',
                               key[0] == 'R' ? "the measurement noise covariance R must be SPD"
                                             : "the process noise covariance Q must be symmetric "
                                               "PSD") != 0) {
        free(a);
        return -1;
    }
    free(*out);
    *out = a;
    return 0;
}

/* "angles": [0-based indices of g], each at most once. */
static int parse_angles(dkf_scn_ctx_t *c, dkf_nlm_t *m, const json_t *a, const char *path)
{
    size_t i;
    char p[DKF_SCN_PATH_LEN];
    if (!json_is_array(a))
        return dkf_scn_fail(c, path, "expected a list of measurement indices, got %s",
                            dkf_scn_json_kind(a));
    memset(m->angle, 0, sizeof m->angle);
    m->nangles = 0;
    for (i = 0; i < json_array_size(a); ++i) {
        long v;
        dkf_scn_subidx(p, path, i);
        if (dkf_scn_get_integer(c, json_array_get(a, i), p, 0.0, (double)m->m - 1.0, &v) != 0)
            return -1;
        if (m->angle[v])
            return dkf_scn_fail(c, p, "index %ld listed twice", v);
        m->angle[v] = 1;
        m->nangles++;
    }
    return 0;
}

dkf_nlm_t *dkf_nlm_load(const json_t *j, const char *file, const char *path, size_t n, size_t p,
                        const double *x0, const double *d0, char *err, size_t errlen)
{
    dkf_scn_ctx_t c;
    dkf_nlm_t *m;
    const json_t *expr, *family, *angles;
    char pk[DKF_SCN_PATH_LEN];
    int rc;
    c.file = file != NULL ? file : "(null)";
    c.err = err;
    c.errlen = errlen;
    if (!json_is_object(j)) {
        dkf_scn_fail(&c, path, "expected a model object, got %s", dkf_scn_json_kind(j));
        return NULL;
    }
    if (n == 0 || n > DKF_MAX_DIM || p > DKF_MAX_DIM) {
        dkf_scn_fail(&c, path, "state of %zu and input of %zu components: the core takes 1..%d "
                     "and 0..%d", n, p, DKF_MAX_DIM, DKF_MAX_DIM);
        return NULL;
    }
    if ((m = calloc(1, sizeof *m)) == NULL || (m->path = dkf_scn_dupstr(path)) == NULL) {
        free(m);
        dkf_scn_fail(&c, NULL, "out of memory");
        return NULL;
    }
    m->n = n;
    m->p = p;
    if (dkf_scn_check_keys(&c, j, path, model_keys, NULL) != 0) {
        dkf_nlm_free(m);
        return NULL;
    }
    expr = json_object_get(j, "expr");
    family = json_object_get(j, "family");
    if (expr != NULL) {
        dkf_scn_subkey(pk, path, "expr");
        snprintf(m->source, sizeof m->source, "expr");
        rc = dkf_nlm_load_expr(&c, m, expr, pk, x0, d0);
    } else if (json_is_string(family)) {
        snprintf(m->source, sizeof m->source, "%.31s", json_string_value(family));
        rc = dkf_nlm_load_builtin(&c, m, j, path);
    } else {
        dkf_scn_subkey(pk, path, family != NULL ? "family" : "expr");
        rc = dkf_scn_fail(&c, pk, family != NULL
                          ? "expected the name of a built-in model (one of %s)"
                          : "missing key (give \"expr\": {\"f\": [...], \"g\": [...]} or a "
                            "built-in \"family\": one of %s)", dkf_nlm_builtin_names());
    }
    /* "angles" beside "expr" or inside it, not both */
    angles = json_object_get(j, "angles");
    dkf_scn_subkey(pk, path, "angles");
    if (expr != NULL && json_object_get(expr, "angles") != NULL) {
        if (rc == 0 && angles != NULL)
            rc = dkf_scn_fail(&c, pk, "given twice (also in expr.angles): keep one");
        angles = json_object_get(expr, "angles");
        dkf_scn_subkey(pk, path, "expr.angles");
    }
    if (rc == 0 && angles != NULL) rc = parse_angles(&c, m, angles, pk);
    if (rc == 0) rc = square_matrix(&c, j, path, "Q", n, 1, &m->Q);
    if (rc == 0) rc = square_matrix(&c, j, path, "R", m->m, m->R == NULL, &m->R);
    if (rc == 0 && dkf_nlm_finish(m) != 0) rc = dkf_scn_fail(&c, NULL, "out of memory");
    if (rc != 0) {
        dkf_nlm_free(m);
        return NULL;
    }
    return m;
}
