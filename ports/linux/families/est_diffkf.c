/*
 * est_diffkf.c - the Difference KF kind (dkf/diffkf.h) of the estimator: step k
 * consumes y_{k+1}; fused: one local filter per sensor and the fusion
 * centre (dkf/diffkf_fusion.h) fed with their messages.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/diffkf.h"
#include "dkf/diffkf_fusion.h"
#include "est_family.h"
#include "est_kind.h"
#include "node_roles.h"
#include "util.h"

/* The kind's state (e->state): stacked, one filter; fused, a local filter
 * per group and the fusion centre fed with their messages. */
typedef struct {
    dkf_diffkf_t dkf;
    dkf_diffkf_t *locals;    /* fused: node filters, one per group */
    dkf_real_t **local_storage;
    dkf_diffkf_fc_t fc;
    dkf_diffkf_fc_node_t *nodes;
    dkf_real_t *fc_storage;
    dkf_diffkf_msg_t *msgs;
    dkf_diffkf_sensor_t *fcs;
} dkf_state_t;

static dkf_state_t *dkf_of(const dkf_est_t *e)
{
    return (dkf_state_t *)e->state;
}

static void dkf_release(dkf_est_t *e)
{
    dkf_state_t *d = dkf_of(e);
    size_t j;
    for (j = 0; d->local_storage != NULL && j < e->ngroups; ++j) free(d->local_storage[j]);
    free(d->local_storage);
    free(d->locals);
    free(d->nodes);
    free(d->msgs);
    free(d->fcs);
    free(d->fc_storage);
}

/* Start: x_{1|0} = F_0 x_{0|0} and the first measurement y_1 (diffkf.h). */
static dkf_status_t dkf_stacked_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                                     const char **what)
{
    dkf_state_t *d = dkf_of(e);
    dkf_est_group_t *g = &e->groups[0];
    size_t len = DKF_DIFFKF_STORAGE_LEN(e->n, g->m, g->p);
    dkf_status_t st;
    *what = "dkf_diffkf_init";
    e->storage = calloc(len, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    st = dkf_diffkf_init(&d->dkf, e->n, g->m, g->p, e->storage, len, x0, P0);
    if (st != DKF_OK) return st;
    dkf_est_load_FQ(e, 0);
    dkf_est_group_meas(g, e->s, 1);
    *what = "dkf_diffkf_start";
    e->x = &d->dkf.xf;
    e->P = &d->dkf.Pf;
    return dkf_diffkf_start(&d->dkf, &e->F, &e->Q, &g->meas, &g->y);
}

static void record_dkf_step(dkf_est_t *e, const dkf_diffkf_t *f)
{
    dkf_est_record_mat(e, "z", &f->z, 1);
    dkf_est_record_mat(e, "dz", &f->dz, 1);
    dkf_est_record_mat(e, "J", &f->J, 0);
    dkf_est_record_mat(e, "L", &f->L, 0);
    dkf_est_record_mat(e, "K", &f->K, 0);
}

/* Step k consumes y_{k+1}: dynamics at k (F, Q, B, Rd), model at k+1. */
static dkf_status_t dkf_stacked_step(dkf_est_t *e, long k, const char **what)
{
    dkf_est_group_t *g = &e->groups[0];
    dkf_ui_dyn_t dyn = dkf_est_group_dyn(e, g);
    dkf_status_t st;
    dkf_est_load_FQ(e, k);
    dkf_est_group_load_dyn(g, e->s, k);
    dkf_est_group_meas(g, e->s, k + 1);
    *what = "dkf_diffkf_step";
    st = dkf_diffkf_step(&dkf_of(e)->dkf, &dyn, &g->meas, &g->y);
    if (st == DKF_OK) record_dkf_step(e, &dkf_of(e)->dkf);
    return st;
}

static const char *fc_what(dkf_est_t *e, const char *call, const dkf_diffkf_fc_fault_t *f)
{
    if (f->node == DKF_DIFFKF_FC_NO_NODE)
        snprintf(e->what, sizeof e->what, "%s (%s)", call, dkf_diffkf_fc_cond_str(f->which));
    else
        snprintf(e->what, sizeof e->what, "%s (node %zu: %s)", call, f->node,
                 dkf_diffkf_fc_cond_str(f->which));
    return e->what;
}

static dkf_status_t dkf_fused_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                                   const char **what)
{
    dkf_state_t *d = dkf_of(e);
    size_t l = e->ngroups, n = e->n, i, len;
    size_t *m = calloc(l, sizeof *m), *p = calloc(l, sizeof *p);
    dkf_real_t *Pl = calloc(l * n * n, sizeof *Pl);
    const dkf_mat_t **Pv = calloc(l, sizeof *Pv);
    dkf_mat_t *Pm = calloc(l, sizeof *Pm);
    dkf_diffkf_fc_fault_t fault;
    dkf_status_t st = DKF_ERR_CAPACITY;
    *what = "out of memory";
    d->locals = calloc(l, sizeof *d->locals);
    d->local_storage = calloc(l, sizeof *d->local_storage);
    d->nodes = calloc(l, sizeof *d->nodes);
    d->msgs = calloc(l, sizeof *d->msgs);
    d->fcs = calloc(l, sizeof *d->fcs);
    if (m == NULL || p == NULL || Pl == NULL || Pv == NULL || Pm == NULL || d->locals == NULL ||
        d->local_storage == NULL || d->nodes == NULL || d->msgs == NULL || d->fcs == NULL)
        goto done;
    /* node filters, each from its own prior P00_local[i] */
    for (i = 0; i < l; ++i) {
        dkf_est_group_t *g = &e->groups[i];
        m[i] = g->m;
        p[i] = g->p;
        dkf_scn_to_real(Pl + i * n * n, dkf_scn_P00_local(e->s, g->idx[0]), n * n);
        Pm[i] = (dkf_mat_t)DKF_MAT(n, n, Pl + i * n * n);
        Pv[i] = &Pm[i];
        len = DKF_DIFFKF_STORAGE_LEN(n, g->m, g->p);
        if ((d->local_storage[i] = calloc(len, sizeof **d->local_storage)) == NULL) goto done;
        st = dkf_diffkf_init(&d->locals[i], n, g->m, g->p, d->local_storage[i], len, x0, &Pm[i]);
        if (st != DKF_OK) {
            snprintf(e->what, sizeof e->what, "dkf_diffkf_init of node %zu", i);
            *what = e->what;
            goto done;
        }
    }
    len = dkf_diffkf_fc_storage_len(n, l, m, p);
    st = DKF_ERR_CAPACITY;
    *what = "dkf_diffkf_fc_storage_len";
    if (len == 0 || (d->fc_storage = calloc(len, sizeof *d->fc_storage)) == NULL) goto done;
    st = dkf_diffkf_fc_init(&d->fc, d->nodes, l, n, m, p, d->fc_storage, len, x0, P0,
                            (const dkf_mat_t *const *)Pv, &fault);
    if (st != DKF_OK) {
        *what = fc_what(e, "dkf_diffkf_fc_init", &fault);
        goto done;
    }
    /* start: every node and the FC predict to k = 1 and take y_1 */
    dkf_est_load_FQ(e, 0);
    for (i = 0; i < l; ++i) {
        dkf_est_group_t *g = &e->groups[i];
        dkf_est_group_meas(g, e->s, 1);
        dkf_est_group_load_dyn(g, e->s, 1); /* fc_start checks B of step 1 */
        st = dkf_diffkf_start(&d->locals[i], &e->F, &e->Q, &g->meas, &g->y);
        if (st != DKF_OK) {
            snprintf(e->what, sizeof e->what, "dkf_diffkf_start of node %zu", i);
            *what = e->what;
            goto done;
        }
        d->fcs[i].B = &g->B;
        d->fcs[i].Rd = NULL;
        d->fcs[i].meas = g->meas;
    }
    st = dkf_diffkf_fc_start(&d->fc, &e->F, &e->Q, d->fcs, &fault);
    if (st != DKF_OK) *what = fc_what(e, "dkf_diffkf_fc_start", &fault);
    e->x = &d->fc.central.xf;
    e->P = &d->fc.central.Pf;
done:
    free(m);
    free(p);
    free(Pl);
    free(Pv);
    free(Pm);
    return st;
}

static json_t *json_vec(const dkf_real_t *v, size_t n)
{
    dkf_mat_t M = DKF_MAT(n, 1, (dkf_real_t *)v);
    return dkf_json_from_mat(&M, 1);
}

static dkf_status_t dkf_fused_step(dkf_est_t *e, long k, const char **what)
{
    dkf_state_t *d = dkf_of(e);
    size_t l = e->ngroups, i, n = e->n;
    dkf_diffkf_fc_fault_t fault;
    dkf_status_t st;
    dkf_est_load_FQ(e, k);
    for (i = 0; i < l; ++i) {
        dkf_est_group_t *g = &e->groups[i];
        dkf_ui_dyn_t dyn = dkf_est_group_dyn(e, g);
        dkf_est_group_load_dyn(g, e->s, k);
        dkf_est_group_meas(g, e->s, k + 1);
        st = dkf_diffkf_step(&d->locals[i], &dyn, &g->meas, &g->y);
        if (st == DKF_OK) st = dkf_diffkf_msg_fill(&d->msgs[i], (uint16_t)i, &d->locals[i]);
        if (st != DKF_OK) {
            snprintf(e->what, sizeof e->what, "node %zu: dkf_diffkf_step", i);
            *what = e->what;
            return st;
        }
        d->fcs[i].B = &g->B;
        d->fcs[i].Rd = &g->Rd;
        d->fcs[i].meas = g->meas;
    }
    st = dkf_diffkf_fc_step(&d->fc, &e->F, &e->Q, d->fcs, d->msgs, &fault);
    if (st != DKF_OK) {
        *what = fc_what(e, "dkf_diffkf_fc_step", &fault);
        return st;
    }
    record_dkf_step(e, &d->fc.central);
    if (!e->opts.no_record) {
        json_t *msgs = json_array(), *rec = json_array();
        for (i = 0; i < l; ++i) {
            json_array_append_new(msgs, json_pack("{s:o, s:o}", "xf", json_vec(d->msgs[i].xf, n),
                                                  "xp", json_vec(d->msgs[i].xp, n)));
            json_array_append_new(rec, json_pack("{s:o, s:o, s:o}", "dz",
                                                 dkf_json_from_mat(&d->nodes[i].dz, 1), "z",
                                                 dkf_json_from_mat(&d->nodes[i].z, 1), "K",
                                                 dkf_json_from_mat(&d->nodes[i].rep.K, 0)));
        }
        dkf_json_append(e->series, "messages", msgs);
        dkf_json_append(e->series, "fc_recovered", rec);
    }
    return DKF_OK;
}

static dkf_status_t dkf_kind_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                                  const char **what)
{
    if (e->mode == DKF_EST_FUSED) return dkf_fused_init(e, x0, P0, what);
    return dkf_stacked_init(e, x0, P0, what);
}

/* Records x_{k|k-1} (before the step: the DKF's step k updates it), then steps. */
static dkf_status_t dkf_kind_step(dkf_est_t *e, long k, const char **what)
{
    const dkf_diffkf_t *f = &dkf_of(e)->dkf;
    if (e->mode == DKF_EST_FUSED) f = &dkf_of(e)->fc.central;
    memcpy(e->xpk.data, f->xn.data, e->n * sizeof *e->xpk.data);
    dkf_est_record_mat(e, e->names->xp, &f->xn, 1);
    dkf_est_record_mat(e, e->names->Pp, &f->Pn, 0);
    if (e->mode == DKF_EST_FUSED) return dkf_fused_step(e, k, what);
    return dkf_stacked_step(e, k, what);
}

static const dkf_est_kind_t dkf_est_dkf = {
    .name = "dkf", .needs_ui = 1, .fused = 1, .y_ahead = 1, .state_size = sizeof(dkf_state_t),
    .init = dkf_kind_init, .step = dkf_kind_step, .release = dkf_release};

/* its registry family (est_run.c's operations) */
DKF_EST_FAMILY(dkf, "DKF", 0, &dkf_host_diffkf_node_ops,
              "Difference KF (dkf/diffkf.h); needs D, B, Rd and\n"
              "                           y_1..y_{N+1}; xp = x_{k|k-1}. With several sensors\n"
              "                           also `fused` (fusion centre, dkf/diffkf_fusion.h)");
