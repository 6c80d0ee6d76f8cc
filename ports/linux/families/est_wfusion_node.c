/*
 * est_wfusion_node.c - the wfusion family's sensor-node role (family.h,
 * dkf_node_ops_t): sensor i's local Kalman filter of seed 002 (Theorem 1,
 * dkf_wfusion_local_step of dkf/wfusion.h) as dkf-node runs it, one
 * measurement at a time. y_i(k) completes step k itself (same_step = 1).
 *
 * The payload (dkf_node_estimate_t, sent as node_msg_t): xf = x_i(k|k), xp = x_i(k|k-1) = F_{k-1}
 * x_i(k-1|k-1) (the prediction the step started from; the weighted fusion
 * centre uses xf only). Covariances are not sent: the centre runs the
 * same gain recursion and every P_ij itself (docs/guide/network.md, "The
 * weighted-fusion centre").
 *
 * A (re)start at k0 > 1 (a late node, or one restarted after a gap) starts
 * again from the common prior (x00, P00) as if it were the prior of time
 * k0 - 1; the centre's cross covariances do not hold for such a filter,
 * so the centre masks the node from that epoch on.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/wfusion.h"
#include "family.h"
#include "node_roles.h"
#include "wf_model.h"

struct dkf_node_filter {
    const dkf_scenario_t *s;
    size_t id, n, m;
    dkf_wf_model_t md;
    dkf_wfusion_local_t loc;
    dkf_real_t *store;
    size_t store_len;
    long k;                     /* the step just completed (0: none) */
    dkf_real_t xp[DKF_MAX_DIM]; /* x_i(k|k-1) of that step */
    dkf_real_t y[DKF_MAX_DIM];
};

static void node_destroy(dkf_node_filter_t *nf)
{
    if (nf == NULL) return;
    dkf_wf_model_free(&nf->md);
    free(nf->store);
    free(nf);
}

static dkf_status_t node_init(dkf_node_filter_t *nf)
{
    return dkf_wfusion_local_init(&nf->loc, nf->n, nf->m, nf->store, nf->store_len, &nf->md.x0,
                                  &nf->md.P0);
}

static dkf_node_filter_t *node_create(const dkf_filter_t *f, const dkf_scenario_t *s, size_t id,
                                      char *err, size_t errlen)
{
    dkf_node_filter_t *nf = calloc(1, sizeof *nf);
    (void)f;
    if (nf == NULL) goto oom;
    if (dkf_wf_model_load(s, &nf->md, err, errlen) != 0) {
        free(nf);
        return NULL;
    }
    nf->s = s;
    nf->id = id;
    nf->n = s->n;
    nf->m = nf->md.m[id];
    nf->store_len = DKF_WFUSION_LOCAL_STORAGE_LEN(nf->n, nf->m);
    if ((nf->store = calloc(nf->store_len, sizeof *nf->store)) == NULL) goto oom;
    return dkf_host_node_created(nf, node_destroy, s, id, "dkf_wfusion_local_init",
                                 node_init(nf), err, errlen);
oom:
    return dkf_host_node_created(nf, node_destroy, s, id, NULL, DKF_OK, err, errlen);
}

/* Local step k on y_i(k): xp = F_{k-1} x(k-1|k-1) kept for the payload. */
static int node_step(dkf_node_filter_t *nf, long k, const double *y, char *err, size_t errlen)
{
    dkf_mat_t yv = DKF_MAT(nf->m, 1, nf->y), xp = DKF_MAT(nf->n, 1, nf->xp);
    dkf_status_t st;
    if (k < 1 || k > (long)nf->s->steps) {
        snprintf(err, errlen, "node %zu: the scenario has no step k=%ld", nf->id, k);
        return DKF_EXIT_RUN;
    }
    dkf_scn_to_real(nf->y, y, nf->m);
    st = dkf_mat_mul(&xp, &nf->md.F, &nf->loc.x);
    if (st == DKF_OK)
        st = dkf_wfusion_local_step(&nf->loc, &nf->md.dyn, &nf->md.meas[nf->id], &yv);
    if (st != DKF_OK) {
        snprintf(err, errlen, "node %zu: step k=%ld: dkf_wfusion_local_step failed: %s (%d)",
                 nf->id, k, dkf_status_str(st), (int)st);
        return DKF_EXIT_RUN;
    }
    nf->k = k;
    return DKF_EXIT_OK;
}

/* (Re)start from the common prior, then step k0 on y_i(k0). */
static int node_start(dkf_node_filter_t *nf, long k0, const double *y, char *err, size_t errlen)
{
    dkf_status_t st = node_init(nf);
    if (st != DKF_OK) {
        snprintf(err, errlen, "node %zu: step k=%ld: dkf_wfusion_local_init failed: %s (%d)",
                 nf->id, k0, dkf_status_str(st), (int)st);
        return DKF_EXIT_RUN;
    }
    nf->k = 0;
    return node_step(nf, k0, y, err, errlen);
}

static int node_payload(const dkf_node_filter_t *nf, dkf_node_estimate_t *est)
{
    if (nf->k < 1 || nf->k > (long)UINT32_MAX) return -1;
    memset(est, 0, sizeof *est);
    est->k = (uint32_t)nf->k;
    est->n = (uint16_t)nf->n;
    memcpy(est->xf, nf->loc.x.data, nf->n * sizeof est->xf[0]);
    memcpy(est->xp, nf->xp, nf->n * sizeof est->xp[0]);
    return 0;
}

const dkf_node_ops_t dkf_host_wfusion_node_ops = {
    node_create, node_start, node_step, node_payload, node_destroy, 1,
};
