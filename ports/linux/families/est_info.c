/*
 * est_info.c - the information filter kind (dkf/info.h) of the estimator;
 * fused: the sensors' contributions summed (dkf_info_fuse).
 */
#include "est_internal.h"

#include <stdio.h>
#include <stdlib.h>

#include "util.h"

static void record_info(dkf_est_t *e, const char *ykey, const char *Ykey)
{
    dkf_est_record_mat(e, ykey, &e->info.y, 1);
    dkf_est_record_mat(e, Ykey, &e->info.Y, 0);
}

static dkf_status_t info_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                              const char **what)
{
    size_t len = DKF_INFO_STORAGE_LEN(e->n);
    *what = "dkf_info_init";
    e->storage = calloc(len, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    e->x = &e->info.x;
    e->P = &e->info.P;
    return dkf_info_init(&e->info, e->n, e->storage, len, x0, P0);
}

static dkf_status_t info_predict(dkf_est_t *e, const char **what)
{
    dkf_status_t st;
    *what = "dkf_info_predict";
    st = dkf_info_predict(&e->info, &(dkf_kf_dyn_t){&e->F, &e->Q});
    if (st == DKF_OK) record_info(e, e->names->yp, e->names->Yp);
    return st;
}

static dkf_status_t info_update(dkf_est_t *e, const char **what)
{
    dkf_status_t st;
    size_t j;
    for (j = 0; j < e->ngroups; ++j) {
        dkf_est_group_t *g = &e->groups[j];
        st = dkf_info_contribution(&g->i, &g->I, &(dkf_kf_meas_t){&g->H, &g->R}, &g->y,
                                   g->work);
        if (st != DKF_OK) {
            if (e->mode == DKF_EST_FUSED)
                snprintf(e->what, sizeof e->what, "dkf_info_contribution of sensor %zu",
                         g->idx[0]);
            else
                snprintf(e->what, sizeof e->what, "dkf_info_contribution");
            *what = e->what;
            return st;
        }
        e->ivec[j] = g->i;
        e->Imat[j] = g->I;
    }
    if (e->mode == DKF_EST_FUSED && !e->opts.no_record) {
        json_t *il = json_array(), *Il = json_array();
        for (j = 0; j < e->ngroups; ++j) {
            json_array_append_new(il, dkf_json_from_mat(&e->groups[j].i, 1));
            json_array_append_new(Il, dkf_json_from_mat(&e->groups[j].I, 0));
        }
        dkf_json_append(e->series, e->names->i, il);
        dkf_json_append(e->series, e->names->I, Il);
    }
    *what = "dkf_info_fuse";
    st = dkf_info_fuse(&e->info, e->ivec, e->Imat, e->ngroups);
    if (st == DKF_OK) record_info(e, e->names->yf, e->names->Yf);
    return st;
}

static const dkf_est_kind_t dkf_est_info = {
    .name = "info", .fused = 1, .init = info_init, .predict = info_predict, .update = info_update};

/* its registry family (est_run.c's operations) */
DKF_EST_FAMILY(info, "IF", 0, NULL,
              "information filter (dkf/info.h); with several\n"
              "                           sensors it also writes `fused`");
