/*
 * centre_common.c - what both fusion centres share (centre_common.h).
 */
#include <stdio.h>
#include <string.h>

#include "centre.h"
#include "centre_common.h"
#include "model.h"

void dkf_net_centre_init(dkf_net_centre_t *c, const char *who, dkf_net_t *net,
                         const dkf_scenario_t *s, const char *prefix, int64_t deadline_us)
{
    c->who = who;
    c->net = net;
    c->s = s;
    c->l = s->nsensors;
    c->n = s->n;
    c->N = (long)s->steps;
    snprintf(c->prefix, sizeof c->prefix, "%s", prefix);
    dkf_net_chan(c->chan_out, prefix, "FUSED");
    c->model_id = dkf_net_model_id(s);
    c->deadline_us = deadline_us > 0 ? deadline_us : DKF_NET_DEADLINE_US;
    c->last_beat = INT64_MIN;
}

static void on_node_msg(const char *channel, const dkf_net_from_t *from, const void *data,
                        size_t len, int64_t recv_utime, void *user)
{
    dkf_net_centre_t *c = user;
    dkf_net_expect_t ex;
    ex.model_id = c->model_id;
    ex.nnodes = c->l;
    ex.n = c->n;
    ex.m = NULL;
    ex.kmax = c->N;
    dkf_fcr_node_message(c->rt, &ex, c->who, channel, from, data, len, recv_utime, &c->in,
                         &c->in_prev, &c->c);
}

int dkf_net_centre_start(dkf_net_centre_t *c, const dkf_fcr_ops_t *ops, void *user,
                         size_t ckpt_size, char *err, size_t errlen)
{
    dkf_fcr_config_t cfg;
    char chan[DKF_NET_CHAN_LEN + 16];
    cfg.nodes = c->l;
    cfg.steps = c->N;
    cfg.payload_size = sizeof(dkf_diffkf_msg_t);
    cfg.ckpt_size = ckpt_size;
    cfg.deadline_us = c->deadline_us;
    /* after step N: a node still sending is waited for this long */
    cfg.linger_us = 2 * c->deadline_us > DKF_NET_LINGER_US ? 2 * c->deadline_us
                                                           : DKF_NET_LINGER_US;
    c->rt = ckpt_size ? dkf_fcr_create(&cfg, ops, user) : NULL;
    if (c->rt == NULL) {
        snprintf(err, errlen, "%s: %s: no storage for the checkpoints", c->s->file, c->who);
        return -1;
    }
    snprintf(chan, sizeof chan, "%s_NODE_[0-9]+", c->prefix);
    if (c->net != NULL && dkf_net_subscribe(c->net, chan, on_node_msg, c) != 0) {
        snprintf(err, errlen, "%s: cannot subscribe to %s", c->who, chan);
        return -1;
    }
    return 0;
}

int dkf_net_centre_state(const dkf_net_centre_t *c)
{
    switch (dkf_fcr_state(c->rt)) {
    case DKF_FCR_DONE: return DKF_NET_DONE;
    case DKF_FCR_FAILED: return DKF_NET_FAILED;
    default: return DKF_NET_RUNNING;
    }
}

void dkf_net_centre_report(dkf_net_centre_t *c)
{
    dkf_net_status_t st;
    dkf_fcr_sync_counts(c->rt, &c->c);
    if (c->net == NULL) return;
    memset(&st, 0, sizeof st);
    st.utime = dkf_net_now_us();
    st.model_id = c->model_id;
    st.role = DKF_NET_ROLE_FUSION;
    st.id = -1;
    st.state = dkf_net_centre_state(c);
    st.k = dkf_fcr_done_k(c->rt);
    st.sent = c->c.sent;
    st.received = c->c.received;
    st.rejected = c->c.rejected;
    st.missed = c->c.missed;
    snprintf(st.detail, sizeof st.detail, "%s", dkf_fcr_note(c->rt));
    dkf_net_publish_status(c->net, c->prefix, &st);
}

void dkf_net_centre_tick(dkf_net_centre_t *c, int64_t mono_us, int64_t heartbeat_us)
{
    dkf_fcr_tick(c->rt, mono_us);
    dkf_fcr_sync_counts(c->rt, &c->c);
    if (heartbeat_us <= 0) heartbeat_us = DKF_NET_HEARTBEAT_US;
    if (c->last_beat != INT64_MIN && mono_us - c->last_beat < heartbeat_us) return;
    c->last_beat = mono_us;
    dkf_net_centre_report(c);
}

static dkf_fcr_doc_info_t doc_info(const dkf_net_centre_t *c)
{
    dkf_fcr_doc_info_t info;
    info.scenario = c->s->file;
    info.model_id = c->model_id;
    info.deadline_us = c->deadline_us;
    info.rejected = c->c.rejected;
    info.why = &c->c.why;
    return info;
}

void dkf_net_centre_journal(dkf_net_centre_t *c, FILE *f)
{
    const dkf_fcr_doc_info_t info = doc_info(c);
    c->journal = f;
    if (f != NULL && dkf_fcr_journal_header(f, c->rt, &info, dkf_net_now_us()) != 0) {
        dkf_fcr_notef(c->rt, "%s: cannot write the journal", c->who);
        c->journal = NULL;
    }
}

json_t *dkf_net_centre_journal_line(const dkf_net_centre_t *c, const dkf_fcr_step_t *st,
                                    int published)
{
    return c->journal != NULL ? dkf_fcr_journal_line(st, published) : NULL;
}

/* Flushed: what was computed survives a killed process (docs/guide/network.md,
 * "Result file"). */
void dkf_net_centre_journal_write(dkf_net_centre_t *c, const dkf_fcr_step_t *st, json_t *line)
{
    if (dkf_fcr_journal_write(c->journal, line, dkf_net_now_us()) != 0) {
        dkf_fcr_notef(c->rt, "%s: step k=%ld: cannot write the journal", c->who, st->k);
        c->journal = NULL; /* the caller still owns and closes it */
    }
}

int dkf_net_centre_publish(dkf_net_centre_t *c, const dkf_fcr_step_t *st, const double *xf,
                           const double *Pf, const double *xp, const double *Pp,
                           int64_t *utime)
{
    const size_t n = c->n, j = (size_t)(st->k - 1);
    return dkf_fcr_publish_fused(c->net, c->chan_out, c->rt, c->who, st, c->l, n, xf + j * n,
                                 Pf + j * n * n, xp + j * n, Pp + j * n * n, c->model_id,
                                 &c->seq, utime);
}

json_t *dkf_net_centre_result(const dkf_net_centre_t *c, json_t *outputs)
{
    const dkf_fcr_doc_info_t info = doc_info(c);
    return dkf_fcr_result_doc(c->rt, &info, outputs);
}

void dkf_net_centre_to_double(double *dst, const dkf_real_t *src, size_t len)
{
    size_t i;
    for (i = 0; i < len; ++i) dst[i] = (double)src[i];
}
