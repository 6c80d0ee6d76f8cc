/*
 * fusion_result.c - the result document and the journal of a fusion centre
 * (fusion_result.h; docs/guide/network.md, "dkf-fusion's result file").
 */
#include <stdio.h>
#include <string.h>

#include "dkf/config.h"
#include "fusion_result.h"
#include "util.h"

/* The node indices whose flag is set in row j of an N x l bitmap. */
static json_t *json_nodes(const unsigned char *bits, size_t l)
{
    json_t *c = json_array();
    size_t i;
    for (i = 0; i < l; ++i)
        if (bits[i]) json_array_append_new(c, json_integer((json_int_t)i));
    return c;
}

static void set_int(json_t *o, const char *key, int64_t v)
{
    json_object_set_new(o, key, json_integer((json_int_t)v));
}

static void set_model_id(json_t *o, int64_t model_id)
{
    char id[32];
    snprintf(id, sizeof id, "%016llx", (unsigned long long)(uint64_t)model_id);
    json_object_set_new(o, "model_id", json_string(id));
}

void dkf_fcr_json_set_block(json_t *o, const char *key, const double *v, size_t rows,
                            size_t cols)
{
    json_object_set_new(o, key, dkf_json_doubles(v, rows, cols));
}

void dkf_fcr_json_set_rows(json_t *o, const char *key, const double *v, size_t steps,
                           size_t rows, size_t cols)
{
    const size_t len = rows * (cols ? cols : 1);
    json_t *a = json_array();
    size_t j;
    for (j = 0; j < steps; ++j) json_array_append_new(a, dkf_json_doubles(v + j * len, rows, cols));
    json_object_set_new(o, key, a);
}

/* Every epoch a message announced, per node: [{epoch, k_start, usable}]. */
static json_t *json_epochs(const dkf_fcr_t *rt, size_t l)
{
    json_t *all = json_array();
    dkf_fcr_epoch_t ep[16];
    size_t i, j, ne;
    for (i = 0; i < l; ++i) {
        json_t *a = json_array();
        ne = dkf_fcr_epochs(rt, i, ep, sizeof ep / sizeof ep[0]);
        for (j = 0; j < ne && j < sizeof ep / sizeof ep[0]; ++j) {
            json_t *e = json_object();
            set_int(e, "epoch", ep[j].epoch);
            set_int(e, "k_start", ep[j].k_start);
            json_object_set_new(e, "usable", json_boolean(ep[j].usable));
            json_array_append_new(a, e);
        }
        json_array_append_new(all, a);
    }
    return all;
}

static json_t *json_faults(const dkf_fcr_counts_t *c)
{
    json_t *faults = json_object();
    set_int(faults, "duplicates", c->duplicates);
    set_int(faults, "recovered_by_redundancy", c->redundant);
    set_int(faults, "late_data", c->late);
    set_int(faults, "too_late", c->too_late);
    set_int(faults, "too_far_ahead", c->ahead);
    set_int(faults, "old_epoch", c->old_epoch);
    set_int(faults, "epoch_conflicts", c->conflicts);
    set_int(faults, "lost_epochs", c->lost_epochs);
    set_int(faults, "rollbacks", c->rollbacks);
    set_int(faults, "rollbacks_deferred", c->deferred);
    set_int(faults, "replayed_steps", c->replayed);
    set_int(faults, "revised_published", c->revised_sent);
    set_int(faults, "core_refusals", c->core_masked);
    set_int(faults, "restarts_applied", c->restarts);
    set_int(faults, "pushed_by_window", c->pushed);
    return faults;
}

/* counters: per node, the rejections, the step counts and the faults. */
static json_t *json_counters(const dkf_fcr_t *rt, size_t l, const dkf_fcr_doc_info_t *info,
                             int64_t degraded, int64_t revised)
{
    const dkf_fcr_counts_t *c = dkf_fcr_counts(rt);
    json_t *counts = json_object(), *why = json_object(), *got = json_array();
    json_t *sent = json_array(), *lost = json_array();
    size_t i, v;
    for (i = 0; i < l; ++i) {
        int64_t g, made;
        dkf_fcr_node_traffic(rt, i, &g, &made);
        json_array_append_new(got, json_integer((json_int_t)g));
        json_array_append_new(sent, json_integer((json_int_t)made));
        json_array_append_new(lost, json_integer((json_int_t)(made - g)));
    }
    for (v = 1; v < DKF_NET_NVERDICTS; ++v)
        json_object_set_new(why, dkf_net_verdict_str((dkf_net_verdict_t)v),
                            json_integer((json_int_t)(info->why ? info->why->by[v] : 0)));
    json_object_set_new(counts, "received", got);
    json_object_set_new(counts, "sent_by_node", sent);
    json_object_set_new(counts, "not_received", lost);
    set_int(counts, "rejected", info->rejected);
    json_object_set_new(counts, "rejected_by_reason", why);
    set_int(counts, "stale", c->stale);
    set_int(counts, "degraded_steps", degraded);
    set_int(counts, "degraded_at_first_publication", c->missed);
    set_int(counts, "revised_steps", revised);
    set_int(counts, "published", c->sent);
    json_object_set_new(counts, "faults", json_faults(c));
    return counts;
}

static json_t *json_i64s(const int64_t *v, size_t len)
{
    json_t *a = json_array();
    size_t j;
    for (j = 0; j < len; ++j) json_array_append_new(a, json_integer((json_int_t)v[j]));
    return a;
}

json_t *dkf_fcr_result_doc(const dkf_fcr_t *rt, const dkf_fcr_doc_info_t *info, json_t *outputs)
{
    const dkf_fcr_steps_t *r = dkf_fcr_steps(rt);
    const size_t K = (size_t)dkf_fcr_done_k(rt);
    size_t l, j;
    json_t *doc = json_object(), *ks = json_array(), *status = json_array();
    json_t *contrib = json_array();
    json_t *fstatus = json_array(), *fcontrib = json_array(), *revs = json_array();
    json_t *lat = json_object(), *parts = json_object();
    int64_t degraded = 0, revised = 0;
    l = dkf_fcr_config(rt)->nodes;
    for (j = 0; j < K; ++j) {
        json_array_append_new(ks, json_integer((json_int_t)j + 1));
        json_array_append_new(status, json_string(r->degraded[j] ? "degraded" : "complete"));
        json_array_append_new(fstatus,
                              json_string(r->first_degraded[j] ? "degraded" : "complete"));
        json_array_append_new(contrib, json_nodes(r->contributed + j * l, l));
        json_array_append_new(fcontrib, json_nodes(r->first_contributed + j * l, l));
        json_array_append_new(revs, json_integer((json_int_t)r->revisions[j]));
        degraded += r->degraded[j];
        revised += r->revisions[j] > 0;
    }
    json_object_set_new(lat, "first", json_i64s(r->lat_first, K));
    json_object_set_new(lat, "last", json_i64s(r->lat_last, K));
    json_object_set_new(parts, "arrive", json_i64s(r->t_arrive, K));
    json_object_set_new(parts, "wait", json_i64s(r->t_wait, K));
    json_object_set_new(parts, "compute", json_i64s(r->t_compute, K));
    json_object_set_new(parts, "publish", json_i64s(r->t_publish, K));
    json_object_set_new(lat, "last_parts", parts);
    json_object_set_new(doc, "scenario", json_string(info->scenario));
    json_object_set_new(doc, "real", json_string(DKF_USE_FLOAT ? "float" : "double"));
    set_model_id(doc, info->model_id);
    set_int(doc, "N", dkf_fcr_config(rt)->steps);
    set_int(doc, "deadline_us", info->deadline_us);
    set_int(doc, "checkpoints", DKF_FCR_CKPT);
    set_int(doc, "joined_at", dkf_fcr_join_k(rt));
    json_object_set_new(doc, "k", ks);
    json_object_set_new(doc, "outputs", outputs);
    json_object_set_new(doc, "status", status);
    json_object_set_new(doc, "contributors", contrib);
    json_object_set_new(doc, "revisions", revs);
    json_object_set_new(doc, "first_status", fstatus);
    json_object_set_new(doc, "first_contributors", fcontrib);
    json_object_set_new(doc, "epochs", json_epochs(rt, l));
    json_object_set_new(doc, "latency_us", lat);
    json_object_set_new(doc, "counters", json_counters(rt, l, info, degraded, revised));
    if (dkf_fcr_note(rt)[0] != '\0')
        json_object_set_new(doc, "last_note", json_string(dkf_fcr_note(rt)));
    return doc;
}

int dkf_fcr_journal_header(FILE *f, const dkf_fcr_t *rt, const dkf_fcr_doc_info_t *info,
                           int64_t utime)
{
    json_t *o = json_object();
    int r = 0;
    json_object_set_new(o, "journal", json_string("dkf-fusion"));
    json_object_set_new(o, "scenario", json_string(info->scenario));
    set_model_id(o, info->model_id);
    set_int(o, "N", dkf_fcr_config(rt)->steps);
    set_int(o, "start_utime", utime);
    if (json_dumpf(o, f, JSON_COMPACT) != 0 || fputc('\n', f) == EOF || fflush(f) != 0) r = -1;
    json_decref(o);
    return r;
}

json_t *dkf_fcr_journal_line(const dkf_fcr_step_t *st, int published)
{
    json_t *o = json_object();
    set_int(o, "k", st->k);
    set_int(o, "revision", st->revision);
    json_object_set_new(o, "status", json_string(st->degraded ? "degraded" : "complete"));
    json_object_set_new(o, "contributors", json_nodes(st->contributed, st->nodes));
    json_object_set_new(o, "published", json_boolean(published));
    return o;
}

int dkf_fcr_journal_write(FILE *f, json_t *line, int64_t utime)
{
    int r = 0;
    set_int(line, "utime", utime);
    if (json_dumpf(line, f, JSON_COMPACT | JSON_REAL_PRECISION(17)) != 0 ||
        fputc('\n', f) == EOF || fflush(f) != 0)
        r = -1;
    json_decref(line);
    return r;
}

/* ---- the node messages ------------------------------------------------------------------ */

void dkf_fcr_sync_counts(const dkf_fcr_t *rt, dkf_net_counts_t *c)
{
    const dkf_fcr_counts_t *r = dkf_fcr_counts(rt);
    c->sent = r->sent;
    c->received = r->received;
    c->stale = r->stale;
    c->missed = r->missed;
}

void dkf_fcr_node_message(dkf_fcr_t *rt, dkf_net_expect_t *ex, const char *who,
                          const char *channel, const dkf_net_from_t *from, const void *data,
                          size_t len, int64_t recv_utime,
                          dkf_diffkf_msg_t *in, dkf_diffkf_msg_t *in_prev, dkf_net_counts_t *c)
{
    dkf_net_meta_t meta;
    dkf_net_verdict_t v;
    dkf_fcr_msg_t m;
    if (dkf_fcr_state(rt) != DKF_FCR_RUNNING) return;
    /* the sender's node: the signer's, or without authentication the channel's */
    ex->node = dkf_net_from_node(from, channel);
    if (ex->node < 0) ex->node = (long)ex->nnodes; /* none: no node matches */
    v = dkf_net_decode_node_msg(data, len, ex, in, in_prev, &meta, &c->why);
    if (v != DKF_NET_ACCEPT) {
        ++c->rejected;
        dkf_fcr_notef(rt, "%s: message on %s rejected: %s", who, channel, dkf_net_verdict_str(v));
        return;
    }
    m.node = in->node;
    m.k = (long)in->k;
    m.epoch = meta.epoch;
    m.k_start = meta.k_start;
    m.seq = meta.seq;
    m.meas_utime = meta.meas_utime;
    m.recv_utime = recv_utime;
    m.pay = in;
    m.prev = meta.has_prev ? in_prev : NULL;
    (void)dkf_fcr_receive(rt, &m, dkf_net_mono_us());
    dkf_fcr_sync_counts(rt, c);
}

int dkf_fcr_publish_fused(dkf_net_t *net, const char *chan, dkf_fcr_t *rt, const char *who,
                          const dkf_fcr_step_t *st, size_t nnodes, size_t n, const double *xf,
                          const double *Pf, const double *xp, const double *Pp,
                          int64_t model_id, int64_t *seq, int64_t *utime)
{
    static unsigned char buf[DKF_NET_MAX_MSG];
    static dkf_net_fused_t o;
    size_t len;
    o.k = st->k;
    o.nnodes = nnodes;
    o.n = n;
    o.degraded = st->degraded;
    o.revision = st->revision;
    memcpy(o.contributed, st->contributed, nnodes);
    o.meas_utime_first = st->meas_utime_first;
    o.meas_utime_last = st->meas_utime_last;
    o.msg_utime_last = st->recv_utime_last;
    memcpy(o.xf, xf, n * sizeof(double));
    memcpy(o.xp, xp, n * sizeof(double));
    memcpy(o.Pf, Pf, n * n * sizeof(double));
    memcpy(o.Pp, Pp, n * n * sizeof(double));
    o.meta.utime = *utime = dkf_net_now_us();
    o.meta.model_id = model_id;
    o.meta.seq = (*seq)++;
    if (dkf_net_encode_fused(buf, sizeof buf, &len, &o) != 0 ||
        dkf_net_publish(net, chan, buf, len) != 0) {
        dkf_fcr_notef(rt, "%s: step k=%ld: cannot publish", who, st->k);
        return -1;
    }
    return 0;
}
