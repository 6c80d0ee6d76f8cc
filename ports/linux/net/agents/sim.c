/*
 * sim.c - the simulator: publishes a scenario's measurements and truth,
 * watches the fusion centre's output and every process's status
 * (agents.h).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "agents.h"
#include "model.h"

/* What the simulator last heard from one process. */
typedef struct {
    int heard;      /* a status with our model id arrived */
    int optional;   /* not waited for (a node that may never start, or start late) */
    int state;
    int64_t wrong_model; /* a status with another model id arrived (its id) */
    char detail[160];
} peer_t;

struct dkf_net_sim {
    dkf_net_t *net;
    const dkf_scenario_t *s;
    char prefix[DKF_NET_CHAN_LEN / 2];
    int64_t model_id;
    int64_t *seq;    /* per sensor */
    int64_t tseq;
    long fused_k;
    peer_t *nodes;   /* nsensors */
    peer_t fusion;
    int state;
    int64_t last_beat;
    dkf_net_counts_t c;
};

static void on_status(const char *channel, const dkf_net_from_t *from, const void *data,
                      size_t len, int64_t recv_utime, void *user)
{
    dkf_net_sim_t *sim = user;
    dkf_net_status_t st;
    peer_t *p = NULL;
    (void)channel;
    (void)recv_utime;
    /* a status names its sender: with authentication it must be the signer */
    if (dkf_net_decode_status(data, len, from, &st, &sim->c.why) != DKF_NET_ACCEPT) {
        ++sim->c.rejected;
        return;
    }
    if (st.role == DKF_NET_ROLE_NODE && st.id >= 0 && (size_t)st.id < sim->s->nsensors)
        p = &sim->nodes[st.id];
    else if (st.role == DKF_NET_ROLE_FUSION)
        p = &sim->fusion;
    if (p == NULL) return;
    if (st.model_id != sim->model_id) {
        p->wrong_model = st.model_id ? st.model_id : 1;
        return;
    }
    p->heard = 1;
    p->state = st.state;
    /* the fusion centre's status carries its last published step: a lost
     * fused datagram (the last one above all) is confirmed by it */
    if (p == &sim->fusion && st.k > sim->fused_k && st.k <= (long)sim->s->steps)
        sim->fused_k = st.k;
    snprintf(p->detail, sizeof p->detail, "%s", st.detail);
}

static void on_fused(const char *channel, const dkf_net_from_t *from, const void *data,
                     size_t len, int64_t recv_utime, void *user)
{
    dkf_net_sim_t *sim = user;
    static dkf_net_fused_t f;
    dkf_net_expect_t ex;
    (void)channel;
    (void)recv_utime;
    if (!dkf_net_from_is(from, DKF_NET_ROLE_FUSION, -1)) { /* auth.c lets only the centre sign */
        dkf_net_reject(&sim->c.why, DKF_NET_REJ_SENDER);
        ++sim->c.rejected;
        return;
    }
    ex.model_id = sim->model_id;
    ex.nnodes = sim->s->nsensors;
    ex.node = -1;
    ex.n = sim->s->n;
    ex.m = NULL;
    ex.kmax = (long)sim->s->steps;
    if (dkf_net_decode_fused(data, len, &ex, &f, &sim->c.why) != DKF_NET_ACCEPT) {
        ++sim->c.rejected;
        return;
    }
    ++sim->c.received;
    if (f.k > sim->fused_k) sim->fused_k = f.k;
}

dkf_net_sim_t *dkf_net_sim_create(dkf_net_t *net, const dkf_scenario_t *s, const char *prefix,
                                  char *err, size_t errlen)
{
    dkf_net_sim_t *sim = calloc(1, sizeof *sim);
    char chan[DKF_NET_CHAN_LEN];
    if (sim == NULL || (sim->seq = calloc(s->nsensors, sizeof *sim->seq)) == NULL ||
        (sim->nodes = calloc(s->nsensors, sizeof *sim->nodes)) == NULL) {
        snprintf(err, errlen, "sim: out of memory");
        dkf_net_sim_free(sim);
        return NULL;
    }
    sim->net = net;
    sim->s = s;
    snprintf(sim->prefix, sizeof sim->prefix, "%s", prefix);
    sim->model_id = dkf_net_model_id(s);
    sim->state = DKF_NET_STARTING;
    sim->last_beat = INT64_MIN;
    dkf_net_chan(chan, prefix, "STATUS");
    if (dkf_net_subscribe(net, chan, on_status, sim) != 0) goto nosub;
    dkf_net_chan(chan, prefix, "FUSED");
    if (dkf_net_subscribe(net, chan, on_fused, sim) != 0) goto nosub;
    return sim;
nosub:
    snprintf(err, errlen, "sim: cannot subscribe to %s", chan);
    dkf_net_sim_free(sim);
    return NULL;
}

void dkf_net_sim_free(dkf_net_sim_t *sim)
{
    if (sim == NULL) return;
    free(sim->seq);
    free(sim->nodes);
    free(sim);
}

int dkf_net_sim_publish(dkf_net_sim_t *sim, long j)
{
    const dkf_scenario_t *s = sim->s;
    static dkf_net_meas_t y;
    static dkf_net_truth_t t;
    unsigned char buf[DKF_NET_MAX_MSG];
    char chan[DKF_NET_CHAN_LEN];
    const double *x;
    size_t i, len;
    sim->state = DKF_NET_RUNNING;
    for (i = 0; i < s->nsensors; ++i) {
        const double *v = dkf_scn_y(s, i, j);
        if (v == NULL) continue;
        y.meta.utime = dkf_net_now_us();
        y.meta.model_id = sim->model_id;
        y.meta.seq = sim->seq[i];
        y.meta.meas_utime = 0;
        y.node = i;
        y.k = j;
        y.m = s->sensors[i].m;
        memcpy(y.y, v, y.m * sizeof(double));
        dkf_net_chan_meas(chan, sim->prefix, i);
        if (dkf_net_encode_meas(buf, sizeof buf, &len, &y) != 0 ||
            dkf_net_publish(sim->net, chan, buf, len) != 0)
            return -1;
        ++sim->seq[i];
        ++sim->c.sent;
    }
    x = dkf_scn_truth(s, j);
    if (x != NULL) {
        t.meta.utime = dkf_net_now_us();
        t.meta.model_id = sim->model_id;
        t.meta.seq = sim->tseq++;
        t.k = j;
        t.n = s->n;
        memcpy(t.x, x, s->n * sizeof(double));
        dkf_net_chan(chan, sim->prefix, "TRUTH");
        if (dkf_net_encode_truth(buf, sizeof buf, &len, &t) != 0 ||
            dkf_net_publish(sim->net, chan, buf, len) != 0)
            return -1;
    }
    return 0;
}

int dkf_net_sim_optional_node(dkf_net_sim_t *sim, size_t i)
{
    if (i >= sim->s->nsensors) return -1;
    sim->nodes[i].optional = 1;
    return 0;
}

long dkf_net_sim_last(const dkf_net_sim_t *sim) { return (long)sim->s->steps + 1; }
long dkf_net_sim_fused_k(const dkf_net_sim_t *sim) { return sim->fused_k; }
const dkf_net_counts_t *dkf_net_sim_counts(const dkf_net_sim_t *sim) { return &sim->c; }

int dkf_net_sim_ready(const dkf_net_sim_t *sim, char *why, size_t whylen)
{
    size_t i, off = 0;
    int ok = 1;
    if (why != NULL && whylen > 0) why[0] = '\0';
    for (i = 0; i < sim->s->nsensors; ++i) {
        if (sim->nodes[i].optional ||
            (sim->nodes[i].heard && sim->nodes[i].state != DKF_NET_FAILED))
            continue;
        ok = 0;
        if (why != NULL && off < whylen)
            off += (size_t)snprintf(why + off, whylen - off, "%snode %zu", off ? ", " : "", i);
    }
    if (!sim->fusion.heard || sim->fusion.state == DKF_NET_FAILED) {
        ok = 0;
        if (why != NULL && off < whylen)
            snprintf(why + off, whylen - off, "%sfusion", off ? ", " : "");
    }
    return ok;
}

int dkf_net_sim_trouble(const dkf_net_sim_t *sim, char *why, size_t whylen)
{
    size_t i;
    for (i = 0; i <= sim->s->nsensors; ++i) {
        const peer_t *p = i < sim->s->nsensors ? &sim->nodes[i] : &sim->fusion;
        char who[32];
        if (i < sim->s->nsensors)
            snprintf(who, sizeof who, "node %zu", i);
        else
            snprintf(who, sizeof who, "fusion");
        if (p->wrong_model) {
            snprintf(why, whylen, "%s runs another model (id %016llx, ours %016llx)", who,
                     (unsigned long long)(uint64_t)p->wrong_model,
                     (unsigned long long)(uint64_t)sim->model_id);
            return 1;
        }
        if (p->heard && p->state == DKF_NET_FAILED) {
            snprintf(why, whylen, "%s failed: %s", who, p->detail);
            return 1;
        }
    }
    return 0;
}

void dkf_net_sim_report(dkf_net_sim_t *sim, int state)
{
    dkf_net_status_t st;
    sim->state = state;
    memset(&st, 0, sizeof st);
    st.utime = dkf_net_now_us();
    st.model_id = sim->model_id;
    st.role = DKF_NET_ROLE_SIM;
    st.id = -1;
    st.state = state;
    st.k = sim->fused_k;
    st.sent = sim->c.sent;
    st.received = sim->c.received;
    st.rejected = sim->c.rejected;
    dkf_net_publish_status(sim->net, sim->prefix, &st);
}

void dkf_net_sim_tick(dkf_net_sim_t *sim, int64_t mono_us, int64_t heartbeat_us)
{
    if (heartbeat_us <= 0) heartbeat_us = DKF_NET_HEARTBEAT_US;
    if (sim->last_beat != INT64_MIN && mono_us - sim->last_beat < heartbeat_us) return;
    sim->last_beat = mono_us;
    dkf_net_sim_report(sim, sim->state);
}
