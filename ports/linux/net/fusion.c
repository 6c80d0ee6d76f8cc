/*
 * fusion.c - the fusion centre: buffers node messages per step, runs the
 * core's dkf_diffkf_fc_t when a step is complete, publishes the fused
 * estimate (agents.h).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "agents.h"
#include "dkf/diffkf_fusion.h"
#include "model.h"

/* The messages of one step, by node. */
typedef struct {
    long k;                  /* the step held (0: empty) */
    size_t count;            /* nodes whose message is here */
    int64_t open_mono;       /* arrival (monotonic) of the first message */
    dkf_diffkf_msg_t *msg;   /* l, indexed by node */
    unsigned char *have;     /* l */
    int64_t *meas_utime;     /* l: when the measurement behind msg was published */
    int64_t *recv_utime;     /* l: when msg arrived */
} slot_t;

/* What is recorded of every published step (for the result file). */
typedef struct {
    double *xf, *xp, *Pf, *Pp;    /* N x n, N x n x n */
    int *degraded;                /* N */
    unsigned char *contributed;   /* N x l */
    int64_t *lat_first, *lat_last; /* N: fused publication - measurement publication */
} record_t;

struct dkf_net_fusion {
    dkf_net_t *net;
    const dkf_scenario_t *s;
    size_t l, n;
    long N;
    char prefix[DKF_NET_CHAN_LEN / 2];
    char chan_out[DKF_NET_CHAN_LEN];
    int64_t model_id, deadline_us;
    dkf_net_model_t *md;          /* l per-sensor models of the running step */
    dkf_diffkf_sensor_t *sens;    /* l, pointing into md */
    dkf_diffkf_fc_t fc;
    dkf_diffkf_fc_node_t *fcn;
    dkf_real_t *fc_store;
    slot_t slot[DKF_NET_WINDOW];
    long done_k;                  /* last published step */
    int broken;                   /* a step was degraded: fc is behind (provisional) */
    dkf_real_t *px, *pP, *tmp, *work; /* prior carried while broken, n x n scratch */
    dkf_net_fused_t out;
    dkf_diffkf_msg_t in;          /* the message being decoded */
    int64_t *seq_max, *got;       /* per node: largest seq seen, messages accepted */
    record_t rec;
    dkf_net_counts_t c;
    int state;
    int64_t seq, last_beat;
    char error[160];
};

static void fu_note(dkf_net_fusion_t *fu, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(fu->error, sizeof fu->error, fmt, ap);
    va_end(ap);
}

static slot_t *slot_of(dkf_net_fusion_t *fu, long k)
{
    return &fu->slot[(size_t)k % DKF_NET_WINDOW];
}

static void slot_clear(dkf_net_fusion_t *fu, slot_t *sl)
{
    sl->k = 0;
    sl->count = 0;
    sl->open_mono = 0;
    memset(sl->have, 0, fu->l);
}

static void to_double(double *dst, const dkf_real_t *src, size_t len)
{
    size_t i;
    for (i = 0; i < len; ++i) dst[i] = (double)src[i];
}

/* Loads every sensor's share of step k (dynamics at k, model at kmeas). */
static int load_sensors(dkf_net_fusion_t *fu, size_t k, size_t kmeas)
{
    size_t i;
    for (i = 0; i < fu->l; ++i) {
        if (dkf_net_model_dyn(&fu->md[i], fu->s, i, k) != 0 ||
            dkf_net_model_meas(&fu->md[i], fu->s, i, kmeas) != 0)
            return -1;
        fu->sens[i].B = &fu->md[i].B;
        fu->sens[i].Rd = &fu->md[i].Rd;
        fu->sens[i].meas = fu->md[i].meas;
    }
    return 0;
}

/* x_{k+1|k} = F_k x, P_{k+1|k} = F_k P F_k^T + Q_k for the carried prior
 * (the prediction-only path of a degraded step). */
static int predict_prior(dkf_net_fusion_t *fu, size_t k)
{
    const size_t n = fu->n;
    dkf_mat_t x = DKF_MAT(n, 1, fu->px), P = DKF_MAT(n, n, fu->pP);
    dkf_mat_t t = DKF_MAT(n, 1, fu->tmp), T = DKF_MAT(n, n, fu->tmp);
    if (dkf_net_model_dyn(&fu->md[0], fu->s, 0, k) != 0) return -1;
    if (dkf_mat_mul(&t, &fu->md[0].F, &x) != DKF_OK || dkf_mat_copy(&x, &t) != DKF_OK) return -1;
    if (dkf_mat_congruence(&T, &fu->md[0].F, &P, fu->work) != DKF_OK ||
        dkf_mat_add(&P, &T, &fu->md[0].Q) != DKF_OK)
        return -1;
    return 0;
}

/* Fills fu->out's envelope and contributors for step k from its slot. */
static void out_envelope(dkf_net_fusion_t *fu, long k, const slot_t *sl)
{
    dkf_net_fused_t *o = &fu->out;
    size_t i;
    o->k = k;
    o->nnodes = fu->l;
    o->n = fu->n;
    o->meas_utime_first = o->meas_utime_last = o->msg_utime_last = 0;
    for (i = 0; i < fu->l; ++i) {
        const int have = sl != NULL && sl->k == k && sl->have[i];
        o->contributed[i] = (unsigned char)have;
        if (!have) continue;
        if (o->meas_utime_first == 0 || sl->meas_utime[i] < o->meas_utime_first)
            o->meas_utime_first = sl->meas_utime[i];
        if (sl->meas_utime[i] > o->meas_utime_last) o->meas_utime_last = sl->meas_utime[i];
        if (sl->recv_utime[i] > o->msg_utime_last) o->msg_utime_last = sl->recv_utime[i];
    }
}

/* Publishes fu->out (already filled) as step k, records it, frees the slot. */
static void publish_step(dkf_net_fusion_t *fu, long k)
{
    static unsigned char buf[DKF_NET_MAX_MSG];
    dkf_net_fused_t *o = &fu->out;
    const size_t n = fu->n, j = (size_t)(k - 1);
    size_t len;
    o->meta.utime = dkf_net_now_us();
    o->meta.model_id = fu->model_id;
    o->meta.seq = fu->seq++;
    if (dkf_net_encode_fused(buf, sizeof buf, &len, o) != 0 ||
        dkf_net_publish(fu->net, fu->chan_out, buf, len) != 0)
        fu_note(fu, "fusion: step k=%ld: cannot publish", k);
    else
        ++fu->c.sent;
    memcpy(fu->rec.xf + j * n, o->xf, n * sizeof(double));
    memcpy(fu->rec.xp + j * n, o->xp, n * sizeof(double));
    memcpy(fu->rec.Pf + j * n * n, o->Pf, n * n * sizeof(double));
    memcpy(fu->rec.Pp + j * n * n, o->Pp, n * n * sizeof(double));
    fu->rec.degraded[j] = o->degraded;
    memcpy(fu->rec.contributed + j * fu->l, o->contributed, fu->l);
    fu->rec.lat_first[j] = o->meas_utime_first ? o->meta.utime - o->meas_utime_first : -1;
    fu->rec.lat_last[j] = o->meas_utime_last ? o->meta.utime - o->meas_utime_last : -1;
    if (o->degraded) ++fu->c.missed;
    slot_clear(fu, slot_of(fu, k));
    fu->done_k = k;
    if (k >= fu->N) {
        fu->state = DKF_NET_DONE;
        dkf_net_fusion_report(fu);
    }
}

/* Step k without (all) messages: the prediction x_{k|k-1}, P_{k|k-1} is
 * published as both the filtered and the predicted estimate, and carried
 * forward with F_k, Q_k. Provisional (docs/network.md, "Faults"): the core
 * FC cannot resume after a lost message, so every later step is degraded. */
static void degrade_step(dkf_net_fusion_t *fu, long k)
{
    const size_t n = fu->n;
    dkf_net_fused_t *o = &fu->out;
    if (!fu->broken) {
        memcpy(fu->px, fu->fc.central.xp.data, n * sizeof(dkf_real_t));
        memcpy(fu->pP, fu->fc.central.Pp.data, n * n * sizeof(dkf_real_t));
        fu->broken = 1;
    }
    out_envelope(fu, k, slot_of(fu, k));
    o->degraded = 1;
    to_double(o->xf, fu->px, n);
    to_double(o->xp, fu->px, n);
    to_double(o->Pf, fu->pP, n * n);
    to_double(o->Pp, fu->pP, n * n);
    if (predict_prior(fu, (size_t)k) != 0)
        fu_note(fu, "fusion: step k=%ld: prediction failed", k);
    publish_step(fu, k);
}

static const char *cond_str(dkf_diffkf_fc_cond_t c)
{
    static const char *const names[] = {
        "no fault", "argument", "storage", "p_i > n", "p_i > m_i", "stacked capacity",
        "prior", "model", "A rank", "B singular", "L not SPD", "K rank", "non-finite",
        "message node", "message step", "message dimension", "message non-finite", "sequence"};
    return (size_t)c < sizeof names / sizeof names[0] ? names[c] : "?";
}

/* Every message of step k is here and the FC is in step: one FC step. */
static void fuse_step(dkf_net_fusion_t *fu, long k)
{
    const size_t n = fu->n;
    slot_t *sl = slot_of(fu, k);
    dkf_net_fused_t *o = &fu->out;
    dkf_diffkf_fc_fault_t fault;
    dkf_status_t st;
    if (load_sensors(fu, (size_t)k, (size_t)k + 1) != 0) {
        fu_note(fu, "fusion: the scenario has no model for step k=%ld", k);
        degrade_step(fu, k);
        return;
    }
    /* the prior x_{k|k-1}, P_{k|k-1} is the central filter's xp before the step */
    to_double(o->xp, fu->fc.central.xp.data, n);
    to_double(o->Pp, fu->fc.central.Pp.data, n * n);
    st = dkf_diffkf_fc_step(&fu->fc, &fu->md[0].F, &fu->md[0].Q, fu->sens, sl->msg, &fault);
    if (st != DKF_OK) {
        if (fault.node == DKF_DIFFKF_FC_NO_NODE)
            fu_note(fu, "fusion: step k=%ld: dkf_diffkf_fc_step failed: %s (%s)", k,
                    dkf_status_str(st), cond_str(fault.which));
        else
            fu_note(fu, "fusion: step k=%ld: dkf_diffkf_fc_step failed: %s (%s, node %zu)", k,
                    dkf_status_str(st), cond_str(fault.which), fault.node);
        degrade_step(fu, k);
        return;
    }
    out_envelope(fu, k, sl);
    o->degraded = 0;
    to_double(o->xf, fu->fc.central.xf.data, n);
    to_double(o->Pf, fu->fc.central.Pf.data, n * n);
    publish_step(fu, k);
}

/* Publishes every step that can be published now. */
static void advance(dkf_net_fusion_t *fu)
{
    while (fu->done_k < fu->N) {
        const long k = fu->done_k + 1;
        slot_t *sl = slot_of(fu, k);
        if (sl->k != k || sl->count < fu->l) break;
        if (fu->broken)
            degrade_step(fu, k);
        else
            fuse_step(fu, k);
    }
}

static void on_node_msg(const char *channel, const void *data, size_t len, int64_t recv_utime,
                        void *user)
{
    dkf_net_fusion_t *fu = user;
    dkf_net_expect_t ex;
    dkf_net_meta_t meta;
    dkf_net_verdict_t v;
    slot_t *sl;
    long k;
    size_t i;
    if (fu->state == DKF_NET_DONE) return;
    ex.model_id = fu->model_id;
    ex.nnodes = fu->l;
    ex.node = dkf_net_chan_index(channel);
    if (ex.node < 0) ex.node = (long)fu->l; /* no index in the name: no node matches */
    ex.n = fu->n;
    ex.m = NULL;
    ex.kmax = fu->N;
    v = dkf_net_decode_node_msg(data, len, &ex, &fu->in, &meta, &fu->c.why);
    if (v != DKF_NET_ACCEPT) {
        ++fu->c.rejected;
        fu_note(fu, "fusion: message on %s rejected: %s", channel, dkf_net_verdict_str(v));
        return;
    }
    i = fu->in.node;
    if (meta.seq > fu->seq_max[i]) fu->seq_max[i] = meta.seq;
    k = (long)fu->in.k;
    if (k <= fu->done_k || k > fu->done_k + DKF_NET_WINDOW) {
        ++fu->c.stale;
        fu_note(fu, "fusion: node %zu step k=%ld is %s", i, k,
                k <= fu->done_k ? "late (already published)" : "too far ahead");
        return;
    }
    sl = slot_of(fu, k);
    if (sl->k != k) {
        slot_clear(fu, sl);
        sl->k = k;
        sl->open_mono = dkf_net_mono_us();
    }
    if (sl->have[i]) {
        ++fu->c.stale;
        fu_note(fu, "fusion: node %zu step k=%ld: duplicate", i, k);
        return;
    }
    ++fu->c.received;
    ++fu->got[i];
    sl->msg[i] = fu->in;
    sl->have[i] = 1;
    sl->meas_utime[i] = meta.meas_utime;
    sl->recv_utime[i] = recv_utime;
    ++sl->count;
    advance(fu);
}

void dkf_net_fusion_tick(dkf_net_fusion_t *fu, int64_t mono_us, int64_t heartbeat_us)
{
    while (fu->state != DKF_NET_DONE && fu->done_k < fu->N) {
        /* step done_k + 1 opened with its first message or with any later step's */
        const long k = fu->done_k + 1;
        int64_t open = 0;
        size_t j;
        for (j = 0; j < DKF_NET_WINDOW; ++j) {
            const slot_t *sl = &fu->slot[j];
            if (sl->k >= k && (open == 0 || sl->open_mono < open)) open = sl->open_mono;
            /* (monotonic time is never 0 on a running system) */
        }
        if (open == 0 || mono_us - open < fu->deadline_us) break;
        fu_note(fu, "fusion: step k=%ld missed its deadline", k);
        degrade_step(fu, k);
        advance(fu);
    }
    if (heartbeat_us <= 0) heartbeat_us = DKF_NET_HEARTBEAT_US;
    if (fu->last_beat != INT64_MIN && mono_us - fu->last_beat < heartbeat_us) return;
    fu->last_beat = mono_us;
    dkf_net_fusion_report(fu);
}

/* ---- set-up --------------------------------------------------------------------- */

static int fu_alloc(dkf_net_fusion_t *fu)
{
    const size_t l = fu->l, n = fu->n, N = (size_t)fu->N;
    size_t j;
    fu->md = calloc(l, sizeof *fu->md);
    fu->sens = calloc(l, sizeof *fu->sens);
    fu->fcn = calloc(l, sizeof *fu->fcn);
    fu->px = calloc(n, sizeof *fu->px);
    fu->pP = calloc(n * n, sizeof *fu->pP);
    fu->tmp = calloc(n * n, sizeof *fu->tmp);
    fu->work = calloc(DKF_MAT_CONGRUENCE_WORK(n, n), sizeof *fu->work);
    fu->seq_max = calloc(l, sizeof *fu->seq_max);
    fu->got = calloc(l, sizeof *fu->got);
    fu->rec.xf = calloc(N * n, sizeof(double));
    fu->rec.xp = calloc(N * n, sizeof(double));
    fu->rec.Pf = calloc(N * n * n, sizeof(double));
    fu->rec.Pp = calloc(N * n * n, sizeof(double));
    fu->rec.degraded = calloc(N, sizeof(int));
    fu->rec.contributed = calloc(N * l, 1);
    fu->rec.lat_first = calloc(N, sizeof(int64_t));
    fu->rec.lat_last = calloc(N, sizeof(int64_t));
    if (!fu->md || !fu->sens || !fu->fcn || !fu->px || !fu->pP || !fu->tmp || !fu->work ||
        !fu->seq_max || !fu->got || !fu->rec.xf || !fu->rec.xp || !fu->rec.Pf || !fu->rec.Pp ||
        !fu->rec.degraded || !fu->rec.contributed || !fu->rec.lat_first || !fu->rec.lat_last)
        return -1;
    for (j = 0; j < l; ++j) {
        fu->seq_max[j] = -1;
        if (dkf_net_model_init(&fu->md[j], fu->s, j) != 0) return -1;
    }
    for (j = 0; j < DKF_NET_WINDOW; ++j) {
        slot_t *sl = &fu->slot[j];
        sl->msg = calloc(l, sizeof *sl->msg);
        sl->have = calloc(l, 1);
        sl->meas_utime = calloc(l, sizeof(int64_t));
        sl->recv_utime = calloc(l, sizeof(int64_t));
        if (!sl->msg || !sl->have || !sl->meas_utime || !sl->recv_utime) return -1;
    }
    return 0;
}

/* fc init + start; -1 with err naming the call and the fault. */
static int fc_setup(dkf_net_fusion_t *fu, char *err, size_t errlen)
{
    const dkf_scenario_t *s = fu->s;
    const size_t l = fu->l, n = fu->n;
    size_t m[DKF_NET_MAX_NODES], p[DKF_NET_MAX_NODES], i, len;
    dkf_real_t *P = calloc((l + 1) * n * n + n, sizeof *P), *F0 = NULL;
    dkf_mat_t x0, P0, Pl[DKF_NET_MAX_NODES], F0m, Q0m;
    const dkf_mat_t *Plp[DKF_NET_MAX_NODES];
    dkf_diffkf_fc_fault_t fault = {DKF_DIFFKF_FC_NO_FAULT, 0};
    dkf_status_t st;
    const char *call = "dkf_diffkf_fc_init";
    if (P == NULL) return -1;
    for (i = 0; i < l; ++i) {
        m[i] = fu->md[i].m;
        p[i] = fu->md[i].p;
    }
    len = dkf_diffkf_fc_storage_len(n, l, m, p);
    fu->fc_store = len ? calloc(len, sizeof *fu->fc_store) : NULL;
    F0 = calloc(2 * n * n, sizeof *F0);
    if (fu->fc_store == NULL || F0 == NULL) {
        snprintf(err, errlen, "%s: fusion: no storage for the fusion centre", s->file);
        free(P);
        free(F0);
        return -1;
    }
    dkf_scn_to_real(P, dkf_scn_at(dkf_scn_init(s, "x00"), 0), n);
    dkf_scn_to_real(P + n, dkf_scn_P00_central(s), n * n);
    x0 = (dkf_mat_t)DKF_MAT(n, 1, P);
    P0 = (dkf_mat_t)DKF_MAT(n, n, P + n);
    for (i = 0; i < l; ++i) {
        dkf_scn_to_real(P + n + (i + 1) * n * n, dkf_scn_P00_local(s, i), n * n);
        Pl[i] = (dkf_mat_t)DKF_MAT(n, n, P + n + (i + 1) * n * n);
        Plp[i] = &Pl[i];
    }
    st = dkf_diffkf_fc_init(&fu->fc, fu->fcn, l, n, m, p, fu->fc_store, len, &x0, &P0, Plp,
                            &fault);
    if (st == DKF_OK) {
        /* start: F_0, Q_0 and the models at 1 (B of step 1 for the FC's check) */
        call = "dkf_diffkf_fc_start";
        F0m = (dkf_mat_t)DKF_MAT(n, n, F0);
        Q0m = (dkf_mat_t)DKF_MAT(n, n, F0 + n * n);
        if (dkf_net_model_dyn(&fu->md[0], s, 0, 0) != 0 || load_sensors(fu, 1, 1) != 0) {
            st = DKF_ERR_ARG;
        } else {
            dkf_scn_to_real(F0, dkf_scn_at(dkf_scn_model(s, "F"), 0), n * n);
            dkf_scn_to_real(F0 + n * n, dkf_scn_at(dkf_scn_model(s, "Q"), 0), n * n);
            st = dkf_diffkf_fc_start(&fu->fc, &F0m, &Q0m, fu->sens, &fault);
        }
    }
    free(P);
    free(F0);
    if (st != DKF_OK) {
        if (fault.node == DKF_DIFFKF_FC_NO_NODE)
            snprintf(err, errlen, "%s: fusion: %s failed: %s (%s)", s->file, call,
                     dkf_status_str(st), cond_str(fault.which));
        else
            snprintf(err, errlen, "%s: fusion: %s failed: %s (%s, node %zu)", s->file, call,
                     dkf_status_str(st), cond_str(fault.which), fault.node);
        return -1;
    }
    return 0;
}

dkf_net_fusion_t *dkf_net_fusion_create(dkf_net_t *net, const dkf_scenario_t *s,
                                        const char *prefix, int64_t deadline_us, char *err,
                                        size_t errlen)
{
    dkf_net_fusion_t *fu = calloc(1, sizeof *fu);
    char chan[DKF_NET_CHAN_LEN + 16];
    if (fu == NULL) {
        snprintf(err, errlen, "fusion: out of memory");
        return NULL;
    }
    fu->net = net;
    fu->s = s;
    fu->l = s->nsensors;
    fu->n = s->n;
    fu->N = (long)s->steps;
    snprintf(fu->prefix, sizeof fu->prefix, "%s", prefix);
    dkf_net_chan(fu->chan_out, prefix, "FUSED");
    fu->model_id = dkf_net_model_id(s);
    fu->deadline_us = deadline_us > 0 ? deadline_us : DKF_NET_DEADLINE_US;
    fu->state = DKF_NET_RUNNING;
    fu->last_beat = INT64_MIN;
    if (fu_alloc(fu) != 0) {
        snprintf(err, errlen, "fusion: out of memory");
        dkf_net_fusion_free(fu);
        return NULL;
    }
    if (fc_setup(fu, err, errlen) != 0) {
        dkf_net_fusion_free(fu);
        return NULL;
    }
    snprintf(chan, sizeof chan, "%s_NODE_[0-9]+", prefix);
    if (dkf_net_subscribe(net, chan, on_node_msg, fu) != 0) {
        snprintf(err, errlen, "fusion: cannot subscribe to %s", chan);
        dkf_net_fusion_free(fu);
        return NULL;
    }
    return fu;
}

void dkf_net_fusion_free(dkf_net_fusion_t *fu)
{
    size_t j;
    if (fu == NULL) return;
    for (j = 0; fu->md != NULL && j < fu->l; ++j) dkf_net_model_free(&fu->md[j]);
    for (j = 0; j < DKF_NET_WINDOW; ++j) {
        free(fu->slot[j].msg);
        free(fu->slot[j].have);
        free(fu->slot[j].meas_utime);
        free(fu->slot[j].recv_utime);
    }
    free(fu->md);
    free(fu->sens);
    free(fu->fcn);
    free(fu->fc_store);
    free(fu->px);
    free(fu->pP);
    free(fu->tmp);
    free(fu->work);
    free(fu->seq_max);
    free(fu->got);
    free(fu->rec.xf);
    free(fu->rec.xp);
    free(fu->rec.Pf);
    free(fu->rec.Pp);
    free(fu->rec.degraded);
    free(fu->rec.contributed);
    free(fu->rec.lat_first);
    free(fu->rec.lat_last);
    free(fu);
}

void dkf_net_fusion_report(dkf_net_fusion_t *fu)
{
    dkf_net_status_t st;
    memset(&st, 0, sizeof st);
    st.utime = dkf_net_now_us();
    st.model_id = fu->model_id;
    st.role = DKF_NET_ROLE_FUSION;
    st.id = -1;
    st.state = fu->state;
    st.k = fu->done_k;
    st.sent = fu->c.sent;
    st.received = fu->c.received;
    st.rejected = fu->c.rejected;
    st.missed = fu->c.missed;
    snprintf(st.detail, sizeof st.detail, "%s", fu->error);
    dkf_net_publish_status(fu->net, fu->prefix, &st);
}

int dkf_net_fusion_state(const dkf_net_fusion_t *fu) { return fu->state; }
long dkf_net_fusion_k(const dkf_net_fusion_t *fu) { return fu->done_k; }
const dkf_net_counts_t *dkf_net_fusion_counts(const dkf_net_fusion_t *fu) { return &fu->c; }

/* ---- result document -------------------------------------------------------------- */

/* rows x cols doubles as a list (cols == 0: a flat vector of rows). */
static json_t *json_block(const double *v, size_t rows, size_t cols)
{
    json_t *a = json_array();
    size_t i, j;
    for (i = 0; i < rows; ++i) {
        if (cols == 0) {
            json_array_append_new(a, json_real(v[i]));
        } else {
            json_t *r = json_array();
            for (j = 0; j < cols; ++j) json_array_append_new(r, json_real(v[i * cols + j]));
            json_array_append_new(a, r);
        }
    }
    return a;
}

json_t *dkf_net_fusion_result(const dkf_net_fusion_t *fu)
{
    const size_t n = fu->n, l = fu->l, K = (size_t)fu->done_k;
    json_t *doc = json_object(), *ks = json_array(), *fused = json_object();
    json_t *xf = json_array(), *xp = json_array(), *Pf = json_array(), *Pp = json_array();
    json_t *status = json_array(), *contrib = json_array(), *lf = json_array(), *ll = json_array();
    json_t *counts = json_object(), *why = json_object(), *got = json_array(), *sent = json_array();
    json_t *lost = json_array(), *outputs = json_object(), *lat = json_object();
    char id[32];
    size_t j, i, v;
    for (j = 0; j < K; ++j) {
        json_t *c = json_array();
        json_array_append_new(ks, json_integer((json_int_t)j + 1));
        json_array_append_new(xf, json_block(fu->rec.xf + j * n, n, 0));
        json_array_append_new(xp, json_block(fu->rec.xp + j * n, n, 0));
        json_array_append_new(Pf, json_block(fu->rec.Pf + j * n * n, n, n));
        json_array_append_new(Pp, json_block(fu->rec.Pp + j * n * n, n, n));
        json_array_append_new(status, json_string(fu->rec.degraded[j] ? "degraded" : "complete"));
        for (i = 0; i < l; ++i)
            if (fu->rec.contributed[j * l + i]) json_array_append_new(c, json_integer((json_int_t)i));
        json_array_append_new(contrib, c);
        json_array_append_new(lf, json_integer((json_int_t)fu->rec.lat_first[j]));
        json_array_append_new(ll, json_integer((json_int_t)fu->rec.lat_last[j]));
    }
    json_object_set_new(fused, "xf", xf);
    json_object_set_new(fused, "xp", xp);
    json_object_set_new(fused, "Pf", Pf);
    json_object_set_new(fused, "Pp", Pp);
    json_object_set_new(outputs, "fused", fused);
    json_object_set_new(lat, "first", lf);
    json_object_set_new(lat, "last", ll);
    for (i = 0; i < l; ++i) {
        json_array_append_new(got, json_integer((json_int_t)fu->got[i]));
        json_array_append_new(sent, json_integer((json_int_t)(fu->seq_max[i] + 1)));
        json_array_append_new(lost, json_integer((json_int_t)(fu->seq_max[i] + 1 - fu->got[i])));
    }
    for (v = 1; v < DKF_NET_NVERDICTS; ++v)
        json_object_set_new(why, dkf_net_verdict_str((dkf_net_verdict_t)v),
                            json_integer((json_int_t)fu->c.why.by[v]));
    json_object_set_new(counts, "received", got);
    json_object_set_new(counts, "sent_by_node", sent);
    json_object_set_new(counts, "not_received", lost);
    json_object_set_new(counts, "rejected", json_integer((json_int_t)fu->c.rejected));
    json_object_set_new(counts, "rejected_by_reason", why);
    json_object_set_new(counts, "stale", json_integer((json_int_t)fu->c.stale));
    json_object_set_new(counts, "degraded_steps", json_integer((json_int_t)fu->c.missed));
    json_object_set_new(counts, "published", json_integer((json_int_t)fu->c.sent));
    snprintf(id, sizeof id, "%016llx", (unsigned long long)(uint64_t)fu->model_id);
    json_object_set_new(doc, "scenario", json_string(fu->s->file));
    json_object_set_new(doc, "real", json_string(DKF_USE_FLOAT ? "float" : "double"));
    json_object_set_new(doc, "model_id", json_string(id));
    json_object_set_new(doc, "N", json_integer((json_int_t)fu->N));
    json_object_set_new(doc, "k", ks);
    json_object_set_new(doc, "outputs", outputs);
    json_object_set_new(doc, "status", status);
    json_object_set_new(doc, "contributors", contrib);
    json_object_set_new(doc, "latency_us", lat);
    json_object_set_new(doc, "counters", counts);
    if (fu->error[0] != '\0') json_object_set_new(doc, "last_note", json_string(fu->error));
    return doc;
}
