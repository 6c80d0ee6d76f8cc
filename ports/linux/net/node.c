/*
 * node.c - node i: the local Difference KF on sensor i's measurements
 * (agents.h).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "agents.h"
#include "dkf/diffkf.h"
#include "dkf/diffkf_fusion.h"
#include "model.h"

struct dkf_net_node {
    dkf_net_t *net;
    const dkf_scenario_t *s;
    size_t id;
    char prefix[DKF_NET_CHAN_LEN / 2];
    char chan_out[DKF_NET_CHAN_LEN];
    int64_t model_id;
    size_t *m;                /* every sensor's m (the codec checks ours) */
    dkf_net_model_t md;
    dkf_diffkf_t f;
    dkf_real_t *store;
    dkf_real_t y[DKF_MAX_DIM];
    dkf_net_meas_t ybuf;      /* the measurement being handled */
    dkf_diffkf_msg_t msg;     /* the message being sent */
    long next;                /* the measurement time expected next */
    int state;
    int64_t seq, last_beat;
    dkf_net_counts_t c;
    char error[160];
};

int dkf_net_publish_status(dkf_net_t *net, const char *prefix, const dkf_net_status_t *st)
{
    unsigned char buf[512];
    char chan[DKF_NET_CHAN_LEN];
    size_t len;
    if (dkf_net_encode_status(buf, sizeof buf, &len, st) != 0) return -1;
    dkf_net_chan(chan, prefix, "STATUS");
    return dkf_net_publish(net, chan, buf, len);
}

static void node_fail(dkf_net_node_t *nd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(nd->error, sizeof nd->error, fmt, ap);
    va_end(ap);
    nd->state = DKF_NET_FAILED;
    dkf_net_node_report(nd);
}

/* Step k of the local filter with y_{k+1} (k = 0: the start with y_1),
 * then the message of step k. */
static void node_advance(dkf_net_node_t *nd, const dkf_net_meas_t *y)
{
    const size_t k = (size_t)y->k - 1;
    dkf_mat_t yv = DKF_MAT(nd->md.m, 1, nd->y);
    dkf_status_t st;
    dkf_scn_to_real(nd->y, y->y, y->m);
    if (dkf_net_model_dyn(&nd->md, nd->s, nd->id, k) != 0 ||
        dkf_net_model_meas(&nd->md, nd->s, nd->id, k + 1) != 0) {
        node_fail(nd, "node %zu: the scenario has no model for step k=%zu", nd->id, k);
        return;
    }
    if (k == 0)
        st = dkf_diffkf_start(&nd->f, &nd->md.F, &nd->md.Q, &nd->md.meas, &yv);
    else
        st = dkf_diffkf_step(&nd->f, &nd->md.dyn, &nd->md.meas, &yv);
    if (st != DKF_OK) {
        node_fail(nd, "node %zu: step k=%zu: %s failed: %s (%d)", nd->id, k,
                  k == 0 ? "dkf_diffkf_start" : "dkf_diffkf_step", dkf_status_str(st), (int)st);
        return;
    }
    nd->next = y->k + 1;
    nd->state = DKF_NET_RUNNING;
    if (k >= 1) {
        unsigned char buf[DKF_NET_MAX_MSG];
        dkf_net_meta_t meta;
        size_t len;
        st = dkf_diffkf_msg_fill(&nd->msg, (uint16_t)nd->id, &nd->f);
        meta.utime = dkf_net_now_us();
        meta.model_id = nd->model_id;
        meta.seq = nd->seq;
        meta.meas_utime = y->meta.utime;
        if (st != DKF_OK || dkf_net_encode_node_msg(buf, sizeof buf, &len, &nd->msg, &meta) != 0 ||
            dkf_net_publish(nd->net, nd->chan_out, buf, len) != 0) {
            node_fail(nd, "node %zu: step k=%zu: cannot publish the message", nd->id, k);
            return;
        }
        ++nd->seq;
        ++nd->c.sent;
        if (k >= nd->s->steps) {
            nd->state = DKF_NET_DONE;
            dkf_net_node_report(nd);
        }
    }
}

static void on_meas(const char *channel, const void *data, size_t len, int64_t recv_utime,
                    void *user)
{
    dkf_net_node_t *nd = user;
    dkf_net_expect_t ex;
    dkf_net_verdict_t v;
    (void)channel;
    (void)recv_utime;
    if (nd->state == DKF_NET_FAILED || nd->state == DKF_NET_DONE) return;
    ex.model_id = nd->model_id;
    ex.nnodes = nd->s->nsensors;
    ex.node = (long)nd->id;
    ex.n = nd->s->n;
    ex.m = nd->m;
    ex.kmax = (long)nd->s->steps + 1;
    v = dkf_net_decode_meas(data, len, &ex, &nd->ybuf, &nd->c.why);
    if (v != DKF_NET_ACCEPT) {
        ++nd->c.rejected;
        snprintf(nd->error, sizeof nd->error, "node %zu: measurement on %s rejected: %s", nd->id,
                 channel, dkf_net_verdict_str(v));
        return;
    }
    if (nd->ybuf.k != nd->next) {
        /* The Difference KF needs consecutive y (it differences y_{k+1}
         * against y_k): a gap stops this node until the fault-handling
         * extension (docs/network.md, "Faults"). */
        ++nd->c.stale;
        if (nd->ybuf.k > nd->next) nd->c.missed += nd->ybuf.k - nd->next;
        snprintf(nd->error, sizeof nd->error, "node %zu: measurement k=%ld out of sequence "
                 "(expected k=%ld)", nd->id, nd->ybuf.k, nd->next);
        return;
    }
    ++nd->c.received;
    node_advance(nd, &nd->ybuf);
}

dkf_net_node_t *dkf_net_node_create(dkf_net_t *net, const dkf_scenario_t *s, size_t id,
                                    const char *prefix, char *err, size_t errlen)
{
    dkf_net_node_t *nd;
    char chan[DKF_NET_CHAN_LEN];
    size_t i, len;
    dkf_real_t x0[DKF_MAX_DIM];
    dkf_mat_t mx0, mP0;
    dkf_real_t *P0;
    dkf_status_t st;
    if (id >= s->nsensors) {
        snprintf(err, errlen, "%s: --id %zu: the scenario has %zu sensors (0..%zu)", s->file, id,
                 s->nsensors, s->nsensors - 1);
        return NULL;
    }
    nd = calloc(1, sizeof *nd);
    if (nd == NULL || dkf_net_model_init(&nd->md, s, id) != 0) goto oom;
    nd->m = calloc(s->nsensors, sizeof *nd->m);
    len = DKF_DIFFKF_STORAGE_LEN(s->n, nd->md.m, nd->md.p);
    nd->store = calloc(len, sizeof *nd->store);
    P0 = calloc(s->n * s->n, sizeof *P0);
    if (nd->m == NULL || nd->store == NULL || P0 == NULL) {
        free(P0);
        goto oom;
    }
    for (i = 0; i < s->nsensors; ++i) nd->m[i] = s->sensors[i].m;
    nd->net = net;
    nd->s = s;
    nd->id = id;
    snprintf(nd->prefix, sizeof nd->prefix, "%s", prefix);
    dkf_net_chan_node(nd->chan_out, prefix, id);
    nd->model_id = dkf_net_model_id(s);
    nd->next = 1;
    nd->state = DKF_NET_STARTING;
    nd->last_beat = INT64_MIN;
    dkf_scn_to_real(x0, dkf_scn_at(dkf_scn_init(s, "x00"), 0), s->n);
    dkf_scn_to_real(P0, dkf_scn_P00_local(s, id), s->n * s->n);
    mx0 = (dkf_mat_t)DKF_MAT(s->n, 1, x0);
    mP0 = (dkf_mat_t)DKF_MAT(s->n, s->n, P0);
    st = dkf_diffkf_init(&nd->f, s->n, nd->md.m, nd->md.p, nd->store, len, &mx0, &mP0);
    free(P0);
    if (st != DKF_OK) {
        snprintf(err, errlen, "%s: node %zu: dkf_diffkf_init failed: %s (%d)", s->file, id,
                 dkf_status_str(st), (int)st);
        dkf_net_node_free(nd);
        return NULL;
    }
    dkf_net_chan_meas(chan, prefix, id);
    if (dkf_net_subscribe(net, chan, on_meas, nd) != 0) {
        snprintf(err, errlen, "node %zu: cannot subscribe to %s", id, chan);
        dkf_net_node_free(nd);
        return NULL;
    }
    return nd;
oom:
    snprintf(err, errlen, "node %zu: out of memory", id);
    dkf_net_node_free(nd);
    return NULL;
}

void dkf_net_node_free(dkf_net_node_t *nd)
{
    if (nd == NULL) return;
    dkf_net_model_free(&nd->md);
    free(nd->store);
    free(nd->m);
    free(nd);
}

void dkf_net_node_report(dkf_net_node_t *nd)
{
    dkf_net_status_t st;
    memset(&st, 0, sizeof st);
    st.utime = dkf_net_now_us();
    st.model_id = nd->model_id;
    st.role = DKF_NET_ROLE_NODE;
    st.id = (int)nd->id;
    st.state = nd->state;
    st.k = nd->next >= 2 ? nd->next - 2 : 0;
    st.sent = nd->c.sent;
    st.received = nd->c.received;
    st.rejected = nd->c.rejected;
    st.missed = nd->c.missed;
    snprintf(st.detail, sizeof st.detail, "%s", nd->error);
    dkf_net_publish_status(nd->net, nd->prefix, &st);
}

void dkf_net_node_tick(dkf_net_node_t *nd, int64_t mono_us, int64_t heartbeat_us)
{
    if (heartbeat_us <= 0) heartbeat_us = DKF_NET_HEARTBEAT_US;
    if (nd->last_beat != INT64_MIN && mono_us - nd->last_beat < heartbeat_us) return;
    nd->last_beat = mono_us;
    dkf_net_node_report(nd);
}

int dkf_net_node_state(const dkf_net_node_t *nd) { return nd->state; }
const char *dkf_net_node_error(const dkf_net_node_t *nd) { return nd->error; }
const dkf_net_counts_t *dkf_net_node_counts(const dkf_net_node_t *nd) { return &nd->c; }
