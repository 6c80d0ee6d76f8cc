/*
 * wfusion_centre.c - the seed-002 weighted fusion centre (centre.h,
 * docs/design/network.md "The weighted-fusion centre"): the core's dkf_wfusion_t
 * (dkf/wfusion.h) as the fusion of a dkf_fcr_t runtime (fc_runtime.h:
 * payload ring, epochs, deadlines, checkpoints, rollback/replay, linger),
 * on LCM: node messages (x_i(k|k) in node_msg_t.xf) come in on
 * <prefix>_NODE_<i>, fused steps go out on <prefix>_FUSED (fused_t).
 *
 * The gains of the local Kalman filters do not depend on the data, so the
 * centre runs every node's gain recursion and every cross covariance P_ij
 * itself (dkf_wfusion_step with y == NULL) and takes only the estimates
 * from the nodes. Step k fuses the payloads present:
 * dkf_wfusion_fuse_scalar (Theorem 2: s0, P_S0, w) and
 * dkf_wfusion_fuse_matrix (Sun and Deng: x0, P0, A) with x[i] = NULL for
 * a node whose payload is missing, i.e. over the present sensors' sub-block
 * of (P_ij). With no payload at all the step is the prediction of the
 * previous fused estimate. The checkpoint is the whole core state (the
 * structs and their storage: the core has no save/restore of its own) and
 * the previous fused estimate.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "centre.h"
#include "centre_common.h"
#include "dkf/wfusion.h"
#include "fc_runtime.h"
#include "fusion_result.h"
#include "model.h"
#include "wf_model.h"

/* What is recorded of every step (the latest computation; the result file). */
typedef struct {
    double *x0, *P0, *xp, *Pp; /* N x n, N x n x n: matrix-weight fusion, its prior */
    double *s0, *PS0;          /* N: scalar-weight fusion of the signal */
    double *w;                 /* N x l scalar weights (0: absent) */
    int *A_unique, *w_unique;  /* N */
    int *used;                 /* N: sensors fused (0: the prediction alone) */
} wrecord_t;

struct dkf_net_wfusion {
    dkf_net_centre_t b;          /* scenario, LCM, runtime, journal, counters */
    dkf_wf_model_t md;
    dkf_wfusion_t fu;
    dkf_wfusion_local_t *nodes;  /* l */
    dkf_real_t *store;
    size_t store_len;
    /* the fused estimate of the last step (x(0|0), P(0|0) before step 1):
     * checkpointed with the core state */
    dkf_real_t *xlast, *Plast;   /* n, n x n */
    dkf_real_t *scratch;         /* xp, Pp, F P (3 n x n + n) */
    dkf_real_t *xin;             /* l x n: the payloads as dkf_real_t */
    size_t ck_len;               /* reals of the core fusion's checkpoint */
    size_t ck_size;              /* bytes of a checkpoint (that, then xlast, Plast) */
    wrecord_t rec;
};

/* ---- the runtime's operations ------------------------------------------------------ */

/* A node's local filter (re)started at k (a late start or a restart after
 * a gap) runs from the common prior at k - 1: the cross covariances the
 * centre computes do not hold for it, so its epoch is not followed and its
 * payloads stay masked (the other sensors' fusion is still exact). */
static int op_restart(void *user, size_t i, long k)
{
    dkf_net_wfusion_t *w = user;
    dkf_fcr_notef(w->b.rt, "wfusion: node %zu restarted at k=%ld: masked from then on", i, k);
    return -1;
}

/* A checkpoint: the core fusion's (dkf_wfusion_save: every local filter
 * and P_ij), then the previous fused estimate xlast, Plast. */
static int op_save(void *user, void *ckpt)
{
    dkf_net_wfusion_t *w = user;
    dkf_real_t *p = ckpt;
    if (dkf_wfusion_save(&w->fu, p, w->ck_len) != DKF_OK) return -1;
    memcpy(p + w->ck_len, w->xlast, (w->b.n + w->b.n * w->b.n) * sizeof *w->xlast);
    return 0;
}

static int op_restore(void *user, const void *ckpt)
{
    dkf_net_wfusion_t *w = user;
    const dkf_real_t *p = ckpt;
    if (dkf_wfusion_restore(&w->fu, p, w->ck_len) != DKF_OK) return -1;
    memcpy(w->xlast, p + w->ck_len, (w->b.n + w->b.n * w->b.n) * sizeof *w->xlast);
    return 0;
}

/* xp = F xlast, Pp = F Plast F^T + Q (the prior of step k in fused_t's xp,
 * Pp; the step itself when no node is present). */
static dkf_status_t predict(dkf_net_wfusion_t *w, dkf_mat_t *xp, dkf_mat_t *Pp)
{
    const size_t n = w->b.n;
    dkf_mat_t xl = DKF_MAT(n, 1, w->xlast), Pl = DKF_MAT(n, n, w->Plast);
    dkf_mat_t FP = DKF_MAT(n, n, w->scratch + 2 * n * n + n);
    dkf_status_t st = dkf_mat_mul(xp, &w->md.F, &xl);
    if (st == DKF_OK) st = dkf_mat_mul(&FP, &w->md.F, &Pl);
    if (st == DKF_OK) st = dkf_mat_mul_abt(Pp, &FP, &w->md.F);
    if (st == DKF_OK) st = dkf_mat_add(Pp, Pp, &w->md.Q);
    if (st == DKF_OK) st = dkf_mat_symmetrise(Pp);
    return st;
}

/* Step k: every gain and P_ij (dkf_wfusion_step, y == NULL), then both
 * fusions over the payloads present. A fusion the core refuses (P_S or the
 * joint sub-block indefinite beyond rounding) leaves the prediction: one
 * refusal counted. -1 only if the gain recursion itself fails. */
static int op_step(void *user, long k, const void *const *pay, unsigned char *contrib)
{
    dkf_net_wfusion_t *w = user;
    const size_t n = w->b.n, l = w->b.l, j = (size_t)(k - 1);
    const dkf_mat_t *x[DKF_NET_MAX_NODES];
    dkf_mat_t xv[DKF_NET_MAX_NODES];
    dkf_mat_t xp = DKF_MAT(n, 1, w->scratch), Pp = DKF_MAT(n, n, w->scratch + n);
    dkf_mat_t xl = DKF_MAT(n, 1, w->xlast), Pl = DKF_MAT(n, n, w->Plast);
    dkf_status_t st;
    size_t i, used = 0;
    int refused = 0;
    if ((st = predict(w, &xp, &Pp)) != DKF_OK ||
        (st = dkf_wfusion_step(&w->fu, &w->md.dyn, w->md.meas, NULL)) != DKF_OK) {
        dkf_fcr_notef(w->b.rt, "wfusion: step k=%ld: dkf_wfusion_step failed: %s", k,
                      dkf_status_str(st));
        return -1;
    }
    for (i = 0; i < l; ++i) {
        x[i] = NULL;
        contrib[i] = 0;
        if (pay[i] == NULL) continue;
        {
            const dkf_diffkf_msg_t *m = pay[i];
            memcpy(w->xin + i * n, m->xf, n * sizeof *w->xin);
        }
        xv[i] = (dkf_mat_t)DKF_MAT(n, 1, w->xin + i * n);
        x[i] = &xv[i];
        ++used;
    }
    dkf_net_centre_to_double(w->rec.xp + j * n, xp.data, n);
    dkf_net_centre_to_double(w->rec.Pp + j * n * n, Pp.data, n * n);
    memset(w->rec.w + j * l, 0, l * sizeof(double));
    w->rec.s0[j] = 0;
    w->rec.PS0[j] = 0;
    w->rec.A_unique[j] = w->rec.w_unique[j] = 0;
    if (used > 0) {
        st = dkf_wfusion_fuse_scalar(&w->fu, x);
        if (st == DKF_OK) st = dkf_wfusion_fuse_matrix(&w->fu, x);
        if (st != DKF_OK) {
            dkf_fcr_notef(w->b.rt, "wfusion: step k=%ld: the fusion of %zu nodes failed: %s "
                          "(the prediction is used)", k, used, dkf_status_str(st));
            ++refused;
            used = 0;
        }
    }
    if (used > 0) {
        for (i = 0; i < l; ++i) contrib[i] = x[i] != NULL;
        (void)dkf_mat_copy(&xl, &w->fu.xf);
        (void)dkf_mat_copy(&Pl, &w->fu.Pf);
        w->rec.s0[j] = (double)w->fu.s0;
        w->rec.PS0[j] = (double)w->fu.PS0;
        dkf_net_centre_to_double(w->rec.w + j * l, w->fu.w.data, l);
        w->rec.A_unique[j] = w->fu.A_unique;
        w->rec.w_unique[j] = w->fu.w_unique;
    } else {
        /* no estimate to fuse: the prediction alone */
        (void)dkf_mat_copy(&xl, &xp);
        (void)dkf_mat_copy(&Pl, &Pp);
    }
    w->rec.used[j] = (int)used;
    dkf_net_centre_to_double(w->rec.x0 + j * n, w->xlast, n);
    dkf_net_centre_to_double(w->rec.P0 + j * n * n, w->Plast, n * n);
    return refused;
}

/* Step st->k on <prefix>_FUSED as fused_t: xf, Pf = x0, P0 (matrix
 * weights), xp, Pp = their prior F x0(k-1), F P0 F^T + Q. */
static int op_publish(void *user, const dkf_fcr_step_t *st, int64_t *utime)
{
    dkf_net_wfusion_t *w = user;
    return dkf_net_centre_publish(&w->b, st, w->rec.x0, w->rec.P0, w->rec.xp, w->rec.Pp, utime);
}

static void op_record(void *user, const dkf_fcr_step_t *st, int published)
{
    dkf_net_wfusion_t *w = user;
    const size_t n = w->b.n, l = w->b.l, j = (size_t)(st->k - 1);
    json_t *o = dkf_net_centre_journal_line(&w->b, st, published);
    if (o == NULL) return;
    dkf_fcr_json_set_block(o, "x0", w->rec.x0 + j * n, n, 0);
    dkf_fcr_json_set_block(o, "P0", w->rec.P0 + j * n * n, n, n);
    json_object_set_new(o, "s0", json_real(w->rec.s0[j]));
    json_object_set_new(o, "PS0", json_real(w->rec.PS0[j]));
    dkf_fcr_json_set_block(o, "w", w->rec.w + j * l, l, 0);
    json_object_set_new(o, "used", json_integer(w->rec.used[j]));
    dkf_net_centre_journal_write(&w->b, st, o);
}

static void op_state(void *user, int state)
{
    dkf_net_wfusion_t *w = user;
    (void)state;
    dkf_net_centre_report(&w->b);
}

static const dkf_fcr_ops_t wf_ops = {op_step,    op_restart, op_save,  op_restore,
                                     op_publish, op_record,  op_state, dkf_net_copy_node_payload};

void dkf_net_wfusion_tick(dkf_net_wfusion_t *w, int64_t mono_us, int64_t heartbeat_us)
{
    dkf_net_centre_tick(&w->b, mono_us, heartbeat_us);
}

/* ---- set-up --------------------------------------------------------------------------- */

static int wf_alloc(dkf_net_wfusion_t *w)
{
    const size_t l = w->b.l, n = w->b.n, N = (size_t)w->b.N;
    w->nodes = calloc(l, sizeof *w->nodes);
    w->xlast = calloc(n + n * n, sizeof *w->xlast);
    w->scratch = calloc(3 * n * n + n, sizeof *w->scratch);
    w->xin = calloc(l * n, sizeof *w->xin);
    w->rec.x0 = calloc(N * n, sizeof(double));
    w->rec.xp = calloc(N * n, sizeof(double));
    w->rec.P0 = calloc(N * n * n, sizeof(double));
    w->rec.Pp = calloc(N * n * n, sizeof(double));
    w->rec.s0 = calloc(N, sizeof(double));
    w->rec.PS0 = calloc(N, sizeof(double));
    w->rec.w = calloc(N * l, sizeof(double));
    w->rec.A_unique = calloc(N, sizeof(int));
    w->rec.w_unique = calloc(N, sizeof(int));
    w->rec.used = calloc(N, sizeof(int));
    if (!w->nodes || !w->xlast || !w->scratch || !w->xin || !w->rec.x0 || !w->rec.xp ||
        !w->rec.P0 || !w->rec.Pp || !w->rec.s0 || !w->rec.PS0 || !w->rec.w ||
        !w->rec.A_unique || !w->rec.w_unique || !w->rec.used)
        return -1;
    w->Plast = w->xlast + n;
    return 0;
}

/* The core fusion (every local filter from the common prior), the runtime
 * with its checkpoint of the state before step 1 and the node
 * subscription. -1 with err. */
static int wf_setup(dkf_net_wfusion_t *w, char *err, size_t errlen)
{
    const dkf_scenario_t *s = w->b.s;
    const size_t n = w->b.n;
    dkf_status_t st;
    if (dkf_wf_model_load(s, &w->md, err, errlen) != 0) return -1;
    w->store_len = dkf_wfusion_storage_len(n, w->b.l, w->md.m);
    w->store = w->store_len ? calloc(w->store_len, sizeof *w->store) : NULL;
    if (w->store == NULL) {
        snprintf(err, errlen, "%s: wfusion: no storage for the fusion (n = %zu, %zu sensors)",
                 s->file, n, w->b.l);
        return -1;
    }
    st = dkf_wfusion_init(&w->fu, n, w->b.l, w->md.m, w->nodes, w->store, w->store_len, &w->md.Hs,
                          &w->md.x0, &w->md.P0);
    if (st != DKF_OK) {
        snprintf(err, errlen, "%s: wfusion: dkf_wfusion_init failed: %s", s->file,
                 dkf_status_str(st));
        return -1;
    }
    memcpy(w->xlast, w->md.x0.data, n * sizeof *w->xlast);
    memcpy(w->Plast, w->md.P0.data, n * n * sizeof *w->Plast);
    w->ck_len = dkf_wfusion_checkpoint_len(&w->fu);
    w->ck_size = (w->ck_len + n + n * n) * sizeof *w->xlast;
    return dkf_net_centre_start(&w->b, &wf_ops, w, w->ck_size, err, errlen);
}

dkf_net_wfusion_t *dkf_net_wfusion_create(dkf_net_t *net, const dkf_scenario_t *s,
                                          const char *prefix, int64_t deadline_us, char *err,
                                          size_t errlen)
{
    dkf_net_wfusion_t *w = calloc(1, sizeof *w);
    if (w == NULL) {
        snprintf(err, errlen, "wfusion: out of memory");
        return NULL;
    }
    dkf_net_centre_init(&w->b, "wfusion", net, s, prefix, deadline_us);
    if (wf_alloc(w) != 0) {
        snprintf(err, errlen, "wfusion: out of memory");
        dkf_net_wfusion_free(w);
        return NULL;
    }
    if (wf_setup(w, err, errlen) != 0) {
        dkf_net_wfusion_free(w);
        return NULL;
    }
    return w;
}

void dkf_net_wfusion_free(dkf_net_wfusion_t *w)
{
    if (w == NULL) return;
    dkf_fcr_free(w->b.rt);
    dkf_wf_model_free(&w->md);
    free(w->nodes);
    free(w->store);
    free(w->xlast);
    free(w->scratch);
    free(w->xin);
    free(w->rec.x0);
    free(w->rec.xp);
    free(w->rec.P0);
    free(w->rec.Pp);
    free(w->rec.s0);
    free(w->rec.PS0);
    free(w->rec.w);
    free(w->rec.A_unique);
    free(w->rec.w_unique);
    free(w->rec.used);
    free(w);
}

int dkf_net_wfusion_state(const dkf_net_wfusion_t *w) { return dkf_net_centre_state(&w->b); }
void dkf_net_wfusion_report(dkf_net_wfusion_t *w) { dkf_net_centre_report(&w->b); }
void dkf_net_wfusion_journal(dkf_net_wfusion_t *w, FILE *f) { dkf_net_centre_journal(&w->b, f); }
long dkf_net_wfusion_k(const dkf_net_wfusion_t *w) { return dkf_fcr_done_k(w->b.rt); }
const dkf_net_counts_t *dkf_net_wfusion_counts(const dkf_net_wfusion_t *w) { return &w->b.c; }
dkf_fcr_t *dkf_net_wfusion_runtime(dkf_net_wfusion_t *w) { return w->b.rt; }

static json_t *real_rows(const double *v, size_t K)
{
    json_t *a = json_array();
    size_t j;
    for (j = 0; j < K; ++j) json_array_append_new(a, json_real(v[j]));
    return a;
}

static json_t *int_rows(const int *v, size_t K)
{
    json_t *a = json_array();
    size_t j;
    for (j = 0; j < K; ++j) json_array_append_new(a, json_integer(v[j]));
    return a;
}

/* The result document (fusion_result.h) with outputs.wfusion.{x0, P0, xp,
 * Pp, s0, PS0, w, used, A_unique, w_unique}. */
json_t *dkf_net_wfusion_result(const dkf_net_wfusion_t *w)
{
    const size_t n = w->b.n, l = w->b.l, K = (size_t)dkf_fcr_done_k(w->b.rt);
    json_t *outputs = json_object(), *o = json_object();
    dkf_fcr_json_set_rows(o, "x0", w->rec.x0, K, n, 0);
    dkf_fcr_json_set_rows(o, "P0", w->rec.P0, K, n, n);
    dkf_fcr_json_set_rows(o, "xp", w->rec.xp, K, n, 0);
    dkf_fcr_json_set_rows(o, "Pp", w->rec.Pp, K, n, n);
    json_object_set_new(o, "s0", real_rows(w->rec.s0, K));
    json_object_set_new(o, "PS0", real_rows(w->rec.PS0, K));
    dkf_fcr_json_set_rows(o, "w", w->rec.w, K, l, 0);
    json_object_set_new(o, "used", int_rows(w->rec.used, K));
    json_object_set_new(o, "A_unique", int_rows(w->rec.A_unique, K));
    json_object_set_new(o, "w_unique", int_rows(w->rec.w_unique, K));
    json_object_set_new(outputs, "wfusion", o);
    return dkf_net_centre_result(&w->b, outputs);
}
