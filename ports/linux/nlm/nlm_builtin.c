/*
 * nlm_builtin.c - the built-in named models (nlm.h) read from a model
 * object: every `model.family` of the seed-001 vector files
 * (tests/vectors/infofusion), its keys checked and its parameters filled in
 * a dkf_nlm_family_t (the families and what they compute: nlm_family.c).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nlm.h"
#include "scn_values.h"

/* ---- loading ------------------------------------------------------------------- */

/* j[key]: a matrix of rows x cols (rows 0: any number of rows, returned). */
static int get_matrix(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *key,
                      size_t *rows, size_t cols, double **out)
{
    const json_t *v = json_object_get(j, key);
    char p[DKF_SCN_PATH_LEN];
    size_t r, cc;
    dkf_scn_subkey(p, path, key);
    if (v == NULL) return dkf_scn_fail(c, p, "missing key");
    if (dkf_scn_parse_matrix(c, v, p, &r, &cc, out) != 0) return -1;
    if ((*rows != 0 && r != *rows) || cc != cols || r > DKF_MAX_DIM)
        return dkf_scn_fail(c, p, "expected %s%zu x %zu, got %zu x %zu",
                            *rows == 0 ? "at most " : "", *rows == 0 ? (size_t)DKF_MAX_DIM : *rows,
                            cols, r, cc);
    *rows = r;
    return 0;
}

static int get_number(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *key,
                      double def, int required, double *out)
{
    const json_t *v = json_object_get(j, key);
    char p[DKF_SCN_PATH_LEN];
    dkf_scn_subkey(p, path, key);
    if (v == NULL) {
        if (required) return dkf_scn_fail(c, p, "missing key");
        *out = def;
        return 0;
    }
    if (!json_is_number(v) || !isfinite(json_number_value(v)))
        return dkf_scn_fail(c, p, "expected a finite number, got %s", dkf_scn_json_kind(v));
    *out = json_number_value(v);
    return 0;
}

static int load_lin(dkf_scn_ctx_t *c, dkf_nlm_t *m, dkf_nlm_family_t *b, const json_t *j,
                    const char *path)
{
    size_t rows = m->n, mm = 0;
    const json_t *bj = json_object_get(j, "b");
    char p[DKF_SCN_PATH_LEN];
    if (m->p == 0)
        return dkf_scn_fail(c, path, "family lin_x_sin_d needs an unknown input (init d0 of "
                            "at least one value)");
    if (get_matrix(c, j, path, "A", &rows, m->n, &b->A) != 0) return -1;
    dkf_scn_subkey(p, path, "b");
    if (bj != NULL && dkf_scn_nest_depth(bj) == 1) {
        size_t len;
        if (m->p != 1)
            return dkf_scn_fail(c, p, "a vector b is for p = 1; give an n x p matrix (p = %zu)",
                                m->p);
        if (dkf_scn_parse_vector(c, bj, p, &len, &b->B) != 0) return -1;
        if (len != m->n) return dkf_scn_fail(c, p, "expected %zu values, got %zu", m->n, len);
    } else {
        rows = m->n;
        if (get_matrix(c, j, path, "b", &rows, m->p, &b->B) != 0) return -1;
    }
    if (get_matrix(c, j, path, "C", &mm, m->n, &b->C) != 0) return -1;
    m->m = mm;
    if (get_matrix(c, j, path, "H", &mm, m->p, &b->H) != 0) return -1;
    m->ops = &dkf_nlm_lin_ops;
    return 0;
}

static int load_s1(dkf_scn_ctx_t *c, dkf_nlm_t *m, dkf_nlm_family_t *b, const json_t *j,
                   const char *path, int stacked, int ckf)
{
    const json_t *xy = json_object_get(j, "sensor_xy");
    char p[DKF_SCN_PATH_LEN];
    size_t l, len;
    double *v = NULL;
    const size_t want_p = ckf ? 0 : 1;
    if (m->n != 4 || m->p != want_p)
        return dkf_scn_fail(c, path, "family %s has n = 4 (xi, xi_dot, eta, eta_dot) and p = "
                            "%zu%s; the case's init gives n = %zu, p = %zu", m->source, want_p,
                            ckf ? "" : " (omega)", m->n, m->p);
    if (get_number(c, j, path, "T", 1.0, 0, &b->T) != 0) return -1;
    if (get_number(c, j, path, "phi_gain", 10.0, 0, &b->gain) != 0) return -1;
    if (get_number(c, j, path, "omega_fixed", 0.0, ckf, &b->omega) != 0) return -1;
    dkf_scn_subkey(p, path, "sensor_xy");
    if (xy == NULL) return dkf_scn_fail(c, p, "missing key");
    if (!stacked) {
        if (dkf_scn_parse_vector(c, xy, p, &len, &v) != 0) return -1;
        if (len != 2) {
            free(v);
            return dkf_scn_fail(c, p, "expected [x, y], got %zu values", len);
        }
        b->L = 1;
        memcpy(b->sxy, v, 2 * sizeof *v);
        free(v);
    } else {
        size_t rows = 0;
        if (get_matrix(c, j, path, "sensor_xy", &rows, 2, &v) != 0) {
            free(v);
            return -1;
        }
        if (rows > DKF_NLM_MAX_SENSORS || 3 * rows > DKF_MAX_DIM) {
            free(v);
            return dkf_scn_fail(c, p, "%zu sensors: at most %d (3 per sensor <= %d)", rows,
                                DKF_MAX_DIM / 3, DKF_MAX_DIM);
        }
        b->L = rows;
        memcpy(b->sxy, v, 2 * rows * sizeof *v);
        free(v);
    }
    for (l = 0; l < 2 * b->L; ++l)
        if (!isfinite(b->sxy[l])) return dkf_scn_fail(c, p, "not finite");
    b->per = ckf ? 2 : 3;
    dkf_nlm_s1_layout(m, b);
    if (json_object_get(j, "R") != NULL || !stacked) return 0;
    if ((m->R = calloc(m->m * m->m, sizeof *m->R)) == NULL)
        return dkf_scn_fail(c, NULL, "out of memory");
    dkf_nlm_s1_default_R(m->R, m->m, b);
    return 0;
}

int dkf_nlm_load_builtin(dkf_scn_ctx_t *c, dkf_nlm_t *m, const json_t *j, const char *path)
{
    dkf_nlm_family_t *b;
    char p[DKF_SCN_PATH_LEN];
    const int i = dkf_nlm_family_index(m->source);
    dkf_scn_subkey(p, path, "family");
    if (i < 0)
        return dkf_scn_fail(c, p, "unknown family '%s' (built-in: %s; or give \"expr\")",
                            json_string_value(json_object_get(j, "family")),
                            dkf_nlm_builtin_names());
    if ((b = calloc(1, sizeof *b)) == NULL) return dkf_scn_fail(c, NULL, "out of memory");
    m->impl = b;
    m->ops = &dkf_nlm_lin_ops; /* destroy from here on; the loaders set the real table */
    if (i == 0) return load_lin(c, m, b, j, path);
    return load_s1(c, m, b, j, path, i == 2, i == 3);
}
