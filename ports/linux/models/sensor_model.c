/*
 * sensor_model.c - one sensor's Difference-KF model from a scenario
 * (sensor_model.h).
 */
#include "sensor_model.h"

#include <stdlib.h>
#include <string.h>

int dkf_sensor_model_init(dkf_sensor_model_t *md, const dkf_scenario_t *s, size_t i)
{
    const size_t n = s->n, m = s->sensors[i].m, p = dkf_scn_sensor_model(s, i, "D")->cols;
    dkf_real_t *b;
    memset(md, 0, sizeof *md);
    b = calloc(2 * n * n + 2 * p * p + m * n + m * p + m * m, sizeof *b);
    if (b == NULL) return -1;
    md->n = n;
    md->m = m;
    md->p = p;
    md->buf = b;
    md->F = (dkf_mat_t)DKF_MAT(n, n, b);
    md->Q = (dkf_mat_t)DKF_MAT(n, n, b + n * n);
    md->B = (dkf_mat_t)DKF_MAT(p, p, b + 2 * n * n);
    md->Rd = (dkf_mat_t)DKF_MAT(p, p, b + 2 * n * n + p * p);
    b += 2 * n * n + 2 * p * p;
    md->H = (dkf_mat_t)DKF_MAT(m, n, b);
    md->D = (dkf_mat_t)DKF_MAT(m, p, b + m * n);
    md->R = (dkf_mat_t)DKF_MAT(m, m, b + m * n + m * p);
    md->dyn.F = &md->F;
    md->dyn.Q = &md->Q;
    md->dyn.B = &md->B;
    md->dyn.Rd = &md->Rd;
    md->meas.H = &md->H;
    md->meas.D = &md->D;
    md->meas.R = &md->R;
    return 0;
}

void dkf_sensor_model_free(dkf_sensor_model_t *md)
{
    free(md->buf);
    md->buf = NULL;
}

/* dst (rows x cols of the view) = matrix `name` at k; -1 if absent. */
static int load(dkf_mat_t *dst, const dkf_scn_mat_t *src, size_t k)
{
    const double *v = src ? dkf_scn_at(src, k) : NULL;
    if (v == NULL || src->rows != dst->rows || src->cols != dst->cols) return -1;
    dkf_scn_to_real(dst->data, v, dst->rows * dst->cols);
    return 0;
}

int dkf_sensor_model_dyn(dkf_sensor_model_t *md, const dkf_scenario_t *s, size_t i, size_t k)
{
    if (load(&md->F, dkf_scn_model(s, "F"), k) || load(&md->Q, dkf_scn_model(s, "Q"), k) ||
        load(&md->B, dkf_scn_sensor_model(s, i, "B"), k) ||
        load(&md->Rd, dkf_scn_sensor_model(s, i, "Rd"), k))
        return -1;
    return 0;
}

int dkf_sensor_model_meas(dkf_sensor_model_t *md, const dkf_scenario_t *s, size_t i, size_t k)
{
    if (load(&md->H, dkf_scn_sensor_model(s, i, "H"), k) ||
        load(&md->D, dkf_scn_sensor_model(s, i, "D"), k) ||
        load(&md->R, dkf_scn_sensor_model(s, i, "R"), k))
        return -1;
    return 0;
}
