/*
 * est_info.c - the information filter kind (dkf/info.h) of the estimator;
 * fused: the sensors' contributions summed (dkf_info_fuse).
 */
#include <stdio.h>
#include <stdlib.h>

#include "dkf/info.h"
#include "est_family.h"
#include "est_kind.h"
#include "util.h"

/* The kind's state (e->state): the filter and every group's contribution
 * (i_j, I_j), summed by dkf_info_fuse. */
typedef struct {
    dkf_info_t info;
    dkf_mat_t *i, *I;   /* ngroups views into buf */
    dkf_real_t *buf;    /* their data, then the contribution's work */
    dkf_real_t *work;
} info_state_t;

static info_state_t *info_of(const dkf_est_t *e)
{
    return (info_state_t *)e->state;
}

static void record_info(dkf_est_t *e, const char *ykey, const char *Ykey)
{
    dkf_est_record_mat(e, ykey, &info_of(e)->info.y, 1);
    dkf_est_record_mat(e, Ykey, &info_of(e)->info.Y, 0);
}

/* The contributions' views and the work of the largest group. */
static int contributions_init(dkf_est_t *e)
{
    info_state_t *st = info_of(e);
    size_t n = e->n, l = e->ngroups, j, mmax = 0;
    for (j = 0; j < l; ++j)
        if (e->groups[j].m > mmax) mmax = e->groups[j].m;
    st->i = calloc(l, sizeof *st->i);
    st->I = calloc(l, sizeof *st->I);
    st->buf = calloc(l * (n + n * n) + DKF_INFO_CONTRIB_WORK(n, mmax), sizeof *st->buf);
    if (st->i == NULL || st->I == NULL || st->buf == NULL) return -1;
    for (j = 0; j < l; ++j) {
        st->i[j] = (dkf_mat_t)DKF_MAT(n, 1, st->buf + j * (n + n * n));
        st->I[j] = (dkf_mat_t)DKF_MAT(n, n, st->buf + j * (n + n * n) + n);
    }
    st->work = st->buf + l * (n + n * n);
    return 0;
}

static void info_release(dkf_est_t *e)
{
    free(info_of(e)->i);
    free(info_of(e)->I);
    free(info_of(e)->buf);
}

static dkf_status_t info_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                              const char **what)
{
    size_t len = DKF_INFO_STORAGE_LEN(e->n);
    *what = "dkf_info_init";
    e->storage = calloc(len, sizeof *e->storage);
    if (e->storage == NULL || contributions_init(e) != 0) return DKF_ERR_CAPACITY;
    e->x = &info_of(e)->info.x;
    e->P = &info_of(e)->info.P;
    return dkf_info_init(&info_of(e)->info, e->n, e->storage, len, x0, P0);
}

static dkf_status_t info_predict(dkf_est_t *e, const char **what)
{
    dkf_status_t st;
    *what = "dkf_info_predict";
    st = dkf_info_predict(&info_of(e)->info, &(dkf_kf_dyn_t){&e->F, &e->Q});
    if (st == DKF_OK) record_info(e, e->names->yp, e->names->Yp);
    return st;
}

static dkf_status_t info_update(dkf_est_t *e, const char **what)
{
    info_state_t *c = info_of(e);
    dkf_status_t st;
    size_t j;
    for (j = 0; j < e->ngroups; ++j) {
        dkf_est_group_t *g = &e->groups[j];
        st = dkf_info_contribution(&c->i[j], &c->I[j], &(dkf_kf_meas_t){&g->H, &g->R}, &g->y,
                                   c->work);
        if (st != DKF_OK) {
            if (e->mode == DKF_EST_FUSED)
                snprintf(e->what, sizeof e->what, "dkf_info_contribution of sensor %zu",
                         g->idx[0]);
            else
                snprintf(e->what, sizeof e->what, "dkf_info_contribution");
            *what = e->what;
            return st;
        }
    }
    if (e->mode == DKF_EST_FUSED && !e->opts.no_record) {
        json_t *il = json_array(), *Il = json_array();
        for (j = 0; j < e->ngroups; ++j) {
            json_array_append_new(il, dkf_json_from_mat(&c->i[j], 1));
            json_array_append_new(Il, dkf_json_from_mat(&c->I[j], 0));
        }
        dkf_json_append(e->series, e->names->i, il);
        dkf_json_append(e->series, e->names->I, Il);
    }
    *what = "dkf_info_fuse";
    st = dkf_info_fuse(&c->info, c->i, c->I, e->ngroups);
    if (st == DKF_OK) record_info(e, e->names->yf, e->names->Yf);
    return st;
}

static const dkf_est_kind_t dkf_est_info = {
    .name = "info", .fused = 1, .state_size = sizeof(info_state_t), .init = info_init,
    .predict = info_predict, .update = info_update, .release = info_release};

/* its registry family (est_run.c's operations) */
DKF_EST_FAMILY(info, "IF", 0, NULL,
              "information filter (dkf/info.h); with several\n"
              "                           sensors it also writes `fused`");
