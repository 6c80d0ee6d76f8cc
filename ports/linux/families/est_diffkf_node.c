/*
 * est_diffkf_node.c - the dkf family's sensor-node role (family.h,
 * dkf_node_ops_t): sensor i's local Difference KF (dkf/diffkf.h) as
 * dkf-node runs it, one measurement at a time, restartable.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/diffkf.h"
#include "dkf/diffkf_fusion.h"
#include "family.h"
#include "node_roles.h"
#include "sensor_model.h"

struct dkf_node_filter {
    const dkf_scenario_t *s;
    size_t id;
    dkf_sensor_model_t md;
    dkf_diffkf_t f;
    dkf_real_t *store;
    size_t store_len;
    dkf_real_t *P0;          /* the scenario's P00_local[id] (every (re)start) */
    dkf_real_t x0[DKF_MAX_DIM];
    dkf_real_t y[DKF_MAX_DIM];
};

static void node_destroy(dkf_node_filter_t *nf)
{
    if (nf == NULL) return;
    dkf_sensor_model_free(&nf->md);
    free(nf->store);
    free(nf->P0);
    free(nf);
}

/* dkf_diffkf_init from the scenario's prior (x00, P00_local[id]). */
static dkf_status_t node_init(dkf_node_filter_t *nf)
{
    const size_t n = nf->s->n;
    dkf_mat_t mx0 = DKF_MAT(n, 1, nf->x0), mP0 = DKF_MAT(n, n, nf->P0);
    return dkf_diffkf_init(&nf->f, n, nf->md.m, nf->md.p, nf->store, nf->store_len, &mx0, &mP0);
}

static dkf_node_filter_t *node_create(const dkf_filter_t *f, const dkf_scenario_t *s, size_t id,
                                      char *err, size_t errlen)
{
    dkf_node_filter_t *nf = calloc(1, sizeof *nf);
    (void)f;
    if (nf == NULL || dkf_sensor_model_init(&nf->md, s, id) != 0) goto oom;
    nf->store_len = DKF_DIFFKF_STORAGE_LEN(s->n, nf->md.m, nf->md.p);
    nf->store = calloc(nf->store_len, sizeof *nf->store);
    nf->P0 = calloc(s->n * s->n, sizeof *nf->P0);
    if (nf->store == NULL || nf->P0 == NULL) goto oom;
    nf->s = s;
    nf->id = id;
    dkf_scn_to_real(nf->x0, dkf_scn_at(dkf_scn_init(s, "x00"), 0), s->n);
    dkf_scn_to_real(nf->P0, dkf_scn_P00_local(s, id), s->n * s->n);
    return dkf_host_node_created(nf, node_destroy, s, id, "dkf_diffkf_init", node_init(nf), err,
                                 errlen);
oom:
    return dkf_host_node_created(nf, node_destroy, s, id, NULL, DKF_OK, err, errlen);
}

/* Loads the dynamics at kd and the sensor model at km, and y. */
static int node_load(dkf_node_filter_t *nf, size_t kd, size_t km, size_t k, const double *y,
                     char *err, size_t errlen)
{
    if (dkf_sensor_model_dyn(&nf->md, nf->s, nf->id, kd) != 0 ||
        dkf_sensor_model_meas(&nf->md, nf->s, nf->id, km) != 0) {
        snprintf(err, errlen, "node %zu: the scenario has no model for step k=%zu", nf->id, k);
        return DKF_EXIT_RUN;
    }
    dkf_scn_to_real(nf->y, y, nf->md.m);
    return DKF_EXIT_OK;
}

static int node_failed(const dkf_node_filter_t *nf, size_t k, const char *call, dkf_status_t st,
                       char *err, size_t errlen)
{
    snprintf(err, errlen, "node %zu: step k=%zu: %s failed: %s (%d)", nf->id, k, call,
             dkf_status_str(st), (int)st);
    return DKF_EXIT_RUN;
}

/* The normal start (F_0, Q_0 from x_{0|0}, P_{0|0}) at k0 = 1, else the
 * general start with (x00, P00_local[id]) as the prior of time k0
 * (F0 = Q0 = NULL), which the fusion centre mirrors with
 * dkf_diffkf_fc_restart_node. */
static int node_start(dkf_node_filter_t *nf, long k0, const double *y, char *err, size_t errlen)
{
    const size_t k = (size_t)k0;
    dkf_mat_t yv = DKF_MAT(nf->md.m, 1, nf->y);
    dkf_status_t st;
    int rc = node_load(nf, 0, k, k, y, err, errlen);
    if (rc != DKF_EXIT_OK) return rc;
    if ((st = node_init(nf)) != DKF_OK) return node_failed(nf, k, "dkf_diffkf_init", st, err, errlen);
    if (k == 1) {
        st = dkf_diffkf_start(&nf->f, &nf->md.F, &nf->md.Q, &nf->md.meas, &yv);
    } else {
        st = dkf_diffkf_start(&nf->f, NULL, NULL, &nf->md.meas, &yv);
        /* the filter counts from 0: its steps (and messages) carry absolute times */
        if (st == DKF_OK) st = dkf_diffkf_set_time(&nf->f, k - 1);
    }
    return st == DKF_OK ? DKF_EXIT_OK : node_failed(nf, k, "dkf_diffkf_start", st, err, errlen);
}

/* Step k: the dynamics at k, the sensor model at k+1, y_{k+1}. */
static int node_step(dkf_node_filter_t *nf, long k, const double *y, char *err, size_t errlen)
{
    dkf_mat_t yv = DKF_MAT(nf->md.m, 1, nf->y);
    dkf_status_t st;
    int rc = node_load(nf, (size_t)k, (size_t)k + 1, (size_t)k, y, err, errlen);
    if (rc != DKF_EXIT_OK) return rc;
    st = dkf_diffkf_step(&nf->f, &nf->md.dyn, &nf->md.meas, &yv);
    return st == DKF_OK ? DKF_EXIT_OK
                        : node_failed(nf, (size_t)k, "dkf_diffkf_step", st, err, errlen);
}

/* x_{k|k}, x_{k|k-1} of the step just completed, as the core's node
 * message carries them (dkf_diffkf_msg_fill checks k). */
static int node_payload(const dkf_node_filter_t *nf, dkf_node_estimate_t *est)
{
    dkf_diffkf_msg_t msg;
    if (dkf_diffkf_msg_fill(&msg, 0, &nf->f) != DKF_OK) return -1;
    est->k = msg.k;
    est->n = msg.n;
    memcpy(est->xf, msg.xf, sizeof est->xf);
    memcpy(est->xp, msg.xp, sizeof est->xp);
    return 0;
}

const dkf_node_ops_t dkf_host_diffkf_node_ops = {
    node_create, node_start, node_step, node_payload, node_destroy, 0,
};
