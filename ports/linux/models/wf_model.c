/*
 * wf_model.c - a weighted-fusion scenario's model in dkf_real_t
 * (wf_model.h).
 */
#include "wf_model.h"

#include <stdlib.h>
#include <string.h>

#include "util.h"

void dkf_wf_model_free(dkf_wf_model_t *mdl)
{
    if (mdl == NULL) return;
    free(mdl->m);
    free(mdl->H);
    free(mdl->R);
    free(mdl->meas);
    free(mdl->y);
    free(mdl->data);
    memset(mdl, 0, sizeof *mdl);
}

/* view v = rows x cols at *cursor (advanced), filled from src (NULL: 0). */
static void bind(dkf_mat_t *v, size_t rows, size_t cols, dkf_real_t **cursor, const double *src)
{
    v->rows = rows;
    v->cols = cols;
    v->data = *cursor;
    if (src != NULL) dkf_scn_to_real(v->data, src, rows * cols);
    *cursor += rows * cols;
}

int dkf_wf_model_load(const dkf_scenario_t *s, dkf_wf_model_t *mdl, char *err, size_t errlen)
{
    const dkf_scn_mat_t *F, *Q, *Hs, *x0, *P0;
    size_t i, n, l, total;
    dkf_real_t *cur;
    memset(mdl, 0, sizeof *mdl);
    F = dkf_scn_model(s, "F");
    Q = dkf_scn_model(s, "Q");
    Hs = dkf_scn_model(s, "Hs");
    x0 = dkf_scn_init(s, "x00");
    P0 = dkf_scn_init(s, "P00");
    if (s->layout != DKF_SCN_LAYOUT_WFCASES || F == NULL || Q == NULL || Hs == NULL ||
        x0 == NULL || P0 == NULL)
        return dkf_failf(err, errlen, -1, "%s: cases: not a weighted-fusion case (expected "
                         "Phi, Gamma, Qe, H, R, H_signal, P0, x_hat0: seed 002)", s->file);
    n = s->n;
    l = s->nsensors;
    mdl->n = n;
    mdl->l = l;
    total = 2 * n * n + n + n + n * n;
    mdl->m = calloc(l, sizeof *mdl->m);
    mdl->H = calloc(l, sizeof *mdl->H);
    mdl->R = calloc(l, sizeof *mdl->R);
    mdl->meas = calloc(l, sizeof *mdl->meas);
    mdl->y = calloc(l, sizeof *mdl->y);
    for (i = 0; mdl->m != NULL && i < l; ++i) {
        const size_t mi = s->sensors[i].m;
        mdl->m[i] = mi;
        if (mi > mdl->m_max) mdl->m_max = mi;
        total += mi * n + mi * mi + mi;
    }
    mdl->data = calloc(total, sizeof *mdl->data);
    if (mdl->m == NULL || mdl->H == NULL || mdl->R == NULL || mdl->meas == NULL ||
        mdl->y == NULL || mdl->data == NULL) {
        dkf_wf_model_free(mdl);
        return dkf_failf(err, errlen, -1, "%s: out of memory", s->file);
    }
    cur = mdl->data;
    bind(&mdl->F, n, n, &cur, F->data);
    bind(&mdl->Q, n, n, &cur, Q->data);
    bind(&mdl->Hs, 1, n, &cur, Hs->data);
    bind(&mdl->x0, n, 1, &cur, x0->data);
    bind(&mdl->P0, n, n, &cur, P0->data);
    mdl->dyn.F = &mdl->F;
    mdl->dyn.Q = &mdl->Q;
    for (i = 0; i < l; ++i) {
        const size_t mi = mdl->m[i];
        bind(&mdl->H[i], mi, n, &cur, dkf_scn_sensor_model(s, i, "H")->data);
        bind(&mdl->R[i], mi, mi, &cur, dkf_scn_sensor_model(s, i, "R")->data);
        bind(&mdl->y[i], mi, 1, &cur, NULL);
        mdl->meas[i].H = &mdl->H[i];
        mdl->meas[i].R = &mdl->R[i];
    }
    return 0;
}

int dkf_wf_model_y(dkf_wf_model_t *mdl, const dkf_scenario_t *s, long t)
{
    size_t i;
    for (i = 0; i < mdl->l; ++i) {
        const double *y = dkf_scn_y(s, i, t);
        if (y == NULL) return -1;
        dkf_scn_to_real(mdl->y[i].data, y, mdl->m[i]);
    }
    return 0;
}
