/*
 * node.c - node i: a family's node role (family.h, dkf_node_ops_t: e.g.
 * the dkf family's local Difference KF) on sensor i's measurements, with
 * the transport, measurement order, epochs and test faults (agents.h).
 * The role's estimate (dkf_node_estimate_t) goes out as the node message.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "agents.h"
#include "model.h"
#include "registry.h"

struct dkf_net_node {
    dkf_net_t *net;
    const dkf_scenario_t *s;
    size_t id;
    char prefix[DKF_NET_CHAN_LEN / 2];
    char chan_out[DKF_NET_CHAN_LEN];
    int64_t model_id;
    size_t *m;                /* every sensor's m (the codec checks ours) */
    const dkf_node_ops_t *ops; /* the filter's node role */
    dkf_node_filter_t *nf;    /* its local filter */
    dkf_net_meas_t ybuf;      /* the measurement being handled */
    dkf_diffkf_msg_t msg;     /* the message being sent */
    dkf_diffkf_msg_t prev;    /* the previous step's payload (redundancy 1) */
    int has_prev;
    long next;                /* the measurement time expected next (0: not started) */
    long epoch, k_start;      /* restart counter and first step of this epoch */
    int state;
    int64_t seq, last_beat;
    dkf_net_counts_t c;
    dkf_net_faults_t fx;      /* fault injection (tests) */
    uint64_t rng;
    int held;                 /* a message is held back (reordering) */
    unsigned char hold_buf[DKF_NET_MAX_MSG];
    size_t hold_len;
    int exited;               /* --exit-at reached */
    int64_t fx_dropped, fx_duplicated, fx_reordered;
    char error[160];
};

static void node_fail(dkf_net_node_t *nd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(nd->error, sizeof nd->error, fmt, ap);
    va_end(ap);
    nd->state = DKF_NET_FAILED;
    dkf_net_node_report(nd);
}

/* splitmix64: the fault draws, reproducible from (seed, node id). */
static double node_draw(dkf_net_node_t *nd)
{
    uint64_t z = (nd->rng += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0) * 100.0; /* [0, 100) */
}

static int node_publish(dkf_net_node_t *nd, const void *buf, size_t len)
{
    if (dkf_net_publish(nd->net, nd->chan_out, buf, len) != 0) return -1;
    ++nd->c.sent;
    return 0;
}

/* Sends a held-back message now (reordering), if any. */
static int node_flush(dkf_net_node_t *nd)
{
    if (!nd->held) return 0;
    nd->held = 0;
    return node_publish(nd, nd->hold_buf, nd->hold_len);
}

/* Sends one encoded message through the test faults: drop, duplicate,
 * hold back past the next message. Three draws per message whatever the
 * outcome, so a run is reproducible from the seed alone. */
static int node_send(dkf_net_node_t *nd, const unsigned char *buf, size_t len)
{
    const double u_drop = node_draw(nd), u_dup = node_draw(nd), u_reo = node_draw(nd);
    int rc = 0;
    if (u_drop < nd->fx.drop_pct) {
        ++nd->fx_dropped;
        return node_flush(nd);
    }
    if (u_reo < nd->fx.reorder_pct && !nd->held) {
        memcpy(nd->hold_buf, buf, len);
        nd->hold_len = len;
        nd->held = 1;
        ++nd->fx_reordered;
        return 0;
    }
    rc |= node_publish(nd, buf, len);
    if (u_dup < nd->fx.dup_pct) {
        rc |= node_publish(nd, buf, len);
        ++nd->fx_duplicated;
    }
    rc |= node_flush(nd);
    return rc;
}

/* The node message of node id carrying est. */
static void node_msg(dkf_diffkf_msg_t *msg, size_t id, const dkf_node_estimate_t *est)
{
    msg->node = (uint16_t)id;
    msg->k = est->k;
    msg->n = est->n;
    memcpy(msg->xf, est->xf, sizeof msg->xf);
    memcpy(msg->xp, est->xp, sizeof msg->xp);
}

/* Encodes and sends the message of the step just completed. */
static int node_emit(dkf_net_node_t *nd, const dkf_net_meas_t *y)
{
    unsigned char buf[DKF_NET_MAX_MSG];
    dkf_node_estimate_t est;
    dkf_net_meta_t meta;
    size_t len;
    if (nd->ops->payload(nd->nf, &est) != 0) return -1;
    node_msg(&nd->msg, nd->id, &est);
    meta.utime = dkf_net_now_us();
    meta.model_id = nd->model_id;
    meta.seq = nd->seq;
    meta.meas_utime = y->meta.utime;
    meta.epoch = nd->epoch;
    meta.k_start = nd->k_start;
    meta.has_prev = nd->has_prev;
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &nd->msg, &nd->prev, &meta) != 0) return -1;
    ++nd->seq;
    if (node_send(nd, buf, len) != 0) return -1;
    dkf_net_copy_node_msg(&nd->prev, &nd->msg);
    nd->has_prev = 1;
    return 0;
}

/* Step k of the local filter with y_{k+1}, or the (re)start on y_{k0},
 * then the message of step k. */
static void node_advance(dkf_net_node_t *nd, const dkf_net_meas_t *y)
{
    const int starting = nd->next == 0;
    /* the step y completes (the Difference KF: y_{k+1} completes step k) */
    const long k = starting || nd->ops->same_step ? y->k : y->k - 1;
    char why[sizeof nd->error];
    if (starting) {
        if (nd->ops->start(nd->nf, y->k, y->y, why, sizeof why) != DKF_EXIT_OK) {
            node_fail(nd, "%s", why);
            return;
        }
        nd->k_start = y->k;
        nd->has_prev = 0;
        nd->seq = 0;
    } else {
        if (nd->fx.exit_at > 0 && k >= nd->fx.exit_at) {
            /* a crash before step k's message: no final status, nothing flushed */
            nd->exited = 1;
            snprintf(nd->error, sizeof nd->error, "node %zu: exiting at step k=%ld (--exit-at)",
                     nd->id, k);
            return;
        }
        if (nd->ops->step(nd->nf, k, y->y, why, sizeof why) != DKF_EXIT_OK) {
            node_fail(nd, "%s", why);
            return;
        }
    }
    nd->next = y->k + 1;
    nd->state = DKF_NET_RUNNING;
    if (starting && !nd->ops->same_step) return;
    if (node_emit(nd, y) != 0) {
        node_fail(nd, "node %zu: step k=%ld: cannot publish the message", nd->id, k);
        return;
    }
    if (k >= (long)nd->s->steps) {
        if (node_flush(nd) != 0) {
            node_fail(nd, "node %zu: cannot publish the held message", nd->id);
            return;
        }
        nd->state = DKF_NET_DONE;
        dkf_net_node_report(nd);
    }
}

static void on_meas(const char *channel, const dkf_net_from_t *from, const void *data,
                    size_t len, int64_t recv_utime, void *user)
{
    dkf_net_node_t *nd = user;
    dkf_net_expect_t ex;
    dkf_net_verdict_t v;
    (void)recv_utime;
    if (nd->state == DKF_NET_FAILED || nd->state == DKF_NET_DONE || nd->exited) return;
    ex.model_id = nd->model_id;
    ex.nnodes = nd->s->nsensors;
    ex.node = (long)nd->id;
    ex.n = nd->s->n;
    ex.m = nd->m;
    ex.kmax = (long)nd->s->steps + 1;
    /* measurements come from the simulator (auth.c lets no one else sign
     * them; checked again here, where the sender is known) */
    v = dkf_net_from_is(from, DKF_NET_ROLE_SIM, -1)
            ? dkf_net_decode_meas(data, len, &ex, &nd->ybuf, &nd->c.why)
            : dkf_net_reject(&nd->c.why, DKF_NET_REJ_SENDER);
    if (v != DKF_NET_ACCEPT) {
        ++nd->c.rejected;
        snprintf(nd->error, sizeof nd->error, "node %zu: measurement on %s rejected: %s", nd->id,
                 channel, dkf_net_verdict_str(v));
        return;
    }
    if (nd->next == 0) {
        /* not started: join at the first measurement at or after --join-at
         * (y_{N+1} completes no step of its own, so it cannot start one) */
        if (nd->ybuf.k < nd->fx.join_at || nd->ybuf.k > (long)nd->s->steps) {
            ++nd->c.stale;
            return;
        }
    } else if (nd->ybuf.k != nd->next) {
        /* The Difference KF differences y_{k+1} against y_k: after a gap the
         * node restarts its filter on this measurement (a new epoch), which
         * the fusion centre mirrors; an old or repeated y is ignored. */
        ++nd->c.stale;
        snprintf(nd->error, sizeof nd->error, "node %zu: measurement k=%ld out of sequence "
                 "(expected k=%ld)", nd->id, nd->ybuf.k, nd->next);
        if (nd->ybuf.k < nd->next || nd->ybuf.k > (long)nd->s->steps) return;
        nd->c.missed += nd->ybuf.k - nd->next;
        if (node_flush(nd) != 0) {
            node_fail(nd, "node %zu: cannot publish the held message", nd->id);
            return;
        }
        ++nd->epoch;
        nd->next = 0;
    }
    ++nd->c.received;
    node_advance(nd, &nd->ybuf);
}

void dkf_net_node_faults(dkf_net_node_t *nd, const dkf_net_faults_t *fx)
{
    nd->fx = *fx;
    nd->epoch = fx->epoch;
    nd->rng = fx->seed * 0x100000001b3ULL + (uint64_t)nd->id + 1;
}

int dkf_net_node_exited(const dkf_net_node_t *nd) { return nd->exited; }
void dkf_net_node_fault_counts(const dkf_net_node_t *nd, int64_t *dropped, int64_t *duplicated,
                               int64_t *reordered)
{
    *dropped = nd->fx_dropped;
    *duplicated = nd->fx_duplicated;
    *reordered = nd->fx_reordered;
}
long dkf_net_node_epoch(const dkf_net_node_t *nd) { return nd->epoch; }
long dkf_net_node_k_start(const dkf_net_node_t *nd) { return nd->next ? nd->k_start : 0; }

dkf_net_node_t *dkf_net_node_create(dkf_net_t *net, const dkf_scenario_t *s,
                                    const dkf_filter_t *f, size_t id, const char *prefix,
                                    char *err, size_t errlen)
{
    dkf_net_node_t *nd;
    char chan[DKF_NET_CHAN_LEN];
    size_t i;
    if (f->family->node == NULL) {
        snprintf(err, errlen, "--filter %s: has no node role", f->name);
        return NULL;
    }
    if (id >= s->nsensors) {
        snprintf(err, errlen, "%s: --id %zu: the scenario has %zu sensors (0..%zu)", s->file, id,
                 s->nsensors, s->nsensors - 1);
        return NULL;
    }
    nd = calloc(1, sizeof *nd);
    if (nd == NULL || (nd->m = calloc(s->nsensors, sizeof *nd->m)) == NULL) {
        snprintf(err, errlen, "node %zu: out of memory", id);
        free(nd);
        return NULL;
    }
    for (i = 0; i < s->nsensors; ++i) nd->m[i] = s->sensors[i].m;
    nd->net = net;
    nd->s = s;
    nd->id = id;
    snprintf(nd->prefix, sizeof nd->prefix, "%s", prefix);
    dkf_net_chan_node(nd->chan_out, prefix, id);
    nd->model_id = dkf_net_model_id(s);
    nd->next = 0;
    nd->state = DKF_NET_STARTING;
    nd->last_beat = INT64_MIN;
    nd->rng = (uint64_t)id + 1;
    nd->ops = f->family->node;
    if ((nd->nf = nd->ops->create(f, s, id, err, errlen)) == NULL) {
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
}

void dkf_net_node_free(dkf_net_node_t *nd)
{
    if (nd == NULL) return;
    if (nd->nf != NULL) nd->ops->destroy(nd->nf);
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
    /* last step whose message was made */
    st.k = nd->next >= 2 ? nd->next - (nd->ops->same_step ? 1 : 2) : 0;
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
