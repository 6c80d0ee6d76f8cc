/*
 * wfn_model.c - the weighted-fusion network's model loader (wfn_model.h).
 */
#include "wfn_model.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* dst = matrix src at k (shapes must agree); -1 if absent. */
static int load(dkf_mat_t *dst, const dkf_scn_mat_t *src, size_t k)
{
    const double *v = src ? dkf_scn_at(src, k) : NULL;
    if (v == NULL || src->rows != dst->rows || src->cols != dst->cols) return -1;
    dkf_scn_to_real(dst->data, v, dst->rows * dst->cols);
    return 0;
}

static int shape(const dkf_scn_mat_t *m, size_t r, size_t c)
{
    return m != NULL && m->rows == r && m->cols == c;
}

int dkf_wfn_is_wfusion(const dkf_scenario_t *s)
{
    size_t i;
    if (dkf_scn_model(s, "Hs") == NULL) return 0;
    for (i = 0; i < s->nsensors; ++i)
        if (dkf_scn_sensor_model(s, i, "A") != NULL) return 0;
    return 1;
}

int dkf_wfn_check(const dkf_scenario_t *s, char *err, size_t errlen)
{
    const size_t n = s->n, l = s->nsensors, N = s->steps;
    size_t i, k;
    const char *key = NULL;
    size_t at = 0, who = 0;
    if (n == 0 || l == 0 || n * l + n > DKF_MAX_DIM) {
        snprintf(err, errlen, "%s: model: n l + n = %zu exceeds DKF_MAX_DIM = %d (n = %zu, "
                 "%zu sensors)", s->file, n * l + n, DKF_MAX_DIM, n, l);
        return -1;
    }
    if (!shape(dkf_scn_model(s, "Hs"), 1, n)) key = "Hs";
    else if (!shape(dkf_scn_init(s, "x00"), n, 1) && !shape(dkf_scn_init(s, "x00"), 1, n))
        key = "init.x00";
    else if (!shape(dkf_scn_init(s, "P00"), n, n)) key = "init.P00";
    for (k = 0; key == NULL && k < N; ++k) {
        at = k;
        if (dkf_scn_model(s, "F") == NULL || dkf_scn_at(dkf_scn_model(s, "F"), k) == NULL)
            key = "F";
        else if (dkf_scn_model(s, "Q") == NULL || dkf_scn_at(dkf_scn_model(s, "Q"), k) == NULL)
            key = "Q";
    }
    for (i = 0; key == NULL && i < l; ++i) {
        const size_t m = s->sensors[i].m;
        who = i;
        for (k = 1; key == NULL && k <= N; ++k) {
            const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, i, "H");
            const dkf_scn_mat_t *R = dkf_scn_sensor_model(s, i, "R");
            at = k;
            if (!shape(H, m, n) || dkf_scn_at(H, k) == NULL) key = "H";
            else if (!shape(R, m, m) || dkf_scn_at(R, k) == NULL) key = "R";
            else if (dkf_scn_y(s, i, (long)k) == NULL) key = "y";
        }
    }
    if (key != NULL) {
        snprintf(err, errlen, "%s: %s: missing or misshaped for the weighted-fusion network "
                 "(sensor %zu, k=%zu)", s->file, key, who, at);
        return -1;
    }
    return 0;
}

void dkf_wfn_model_free(dkf_wfn_model_t *md)
{
    free(md->buf);
    free(md->m);
    free(md->H);
    free(md->R);
    free(md->meas);
    memset(md, 0, sizeof *md);
}

int dkf_wfn_model_init(dkf_wfn_model_t *md, const dkf_scenario_t *s)
{
    const size_t n = s->n, l = s->nsensors;
    size_t i, len = 3 * n * n + 2 * n, off;
    memset(md, 0, sizeof *md);
    md->n = n;
    md->l = l;
    md->m = calloc(l, sizeof *md->m);
    md->H = calloc(l, sizeof *md->H);
    md->R = calloc(l, sizeof *md->R);
    md->meas = calloc(l, sizeof *md->meas);
    if (md->m == NULL || md->H == NULL || md->R == NULL || md->meas == NULL) goto fail;
    for (i = 0; i < l; ++i) {
        md->m[i] = s->sensors[i].m;
        len += md->m[i] * n + md->m[i] * md->m[i];
    }
    if ((md->buf = calloc(len, sizeof *md->buf)) == NULL) goto fail;
    md->F = (dkf_mat_t)DKF_MAT(n, n, md->buf);
    md->Q = (dkf_mat_t)DKF_MAT(n, n, md->buf + n * n);
    md->P0 = (dkf_mat_t)DKF_MAT(n, n, md->buf + 2 * n * n);
    md->x0 = (dkf_mat_t)DKF_MAT(n, 1, md->buf + 3 * n * n);
    md->Hs = (dkf_mat_t)DKF_MAT(1, n, md->buf + 3 * n * n + n);
    off = 3 * n * n + 2 * n;
    for (i = 0; i < l; ++i) {
        md->H[i] = (dkf_mat_t)DKF_MAT(md->m[i], n, md->buf + off);
        off += md->m[i] * n;
        md->R[i] = (dkf_mat_t)DKF_MAT(md->m[i], md->m[i], md->buf + off);
        off += md->m[i] * md->m[i];
        md->meas[i].H = &md->H[i];
        md->meas[i].R = &md->R[i];
    }
    md->dyn.F = &md->F;
    md->dyn.Q = &md->Q;
    {
        const dkf_scn_mat_t *x0 = dkf_scn_init(s, "x00");
        const double *v = x0 ? dkf_scn_at(x0, 0) : NULL;
        if (v == NULL || x0->rows * x0->cols != n) goto fail;
        dkf_scn_to_real(md->x0.data, v, n);
    }
    if (load(&md->P0, dkf_scn_init(s, "P00"), 0) != 0 ||
        load(&md->Hs, dkf_scn_model(s, "Hs"), 0) != 0)
        goto fail;
    return 0;
fail:
    dkf_wfn_model_free(md);
    return -1;
}

int dkf_wfn_model_at(dkf_wfn_model_t *md, const dkf_scenario_t *s, size_t k)
{
    size_t i;
    if (k < 1 || load(&md->F, dkf_scn_model(s, "F"), k - 1) != 0 ||
        load(&md->Q, dkf_scn_model(s, "Q"), k - 1) != 0)
        return -1;
    for (i = 0; i < md->l; ++i)
        if (load(&md->H[i], dkf_scn_sensor_model(s, i, "H"), k) != 0 ||
            load(&md->R[i], dkf_scn_sensor_model(s, i, "R"), k) != 0)
            return -1;
    return 0;
}
