/*
 * round_agent.c - the neighbour-round protocol of a graph node
 * (round_agent.h).
 */
#include "round_agent.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "net.h"

/* My packets of the last HISTORY rounds are kept to answer a neighbour that
 * still waits in one of them (its retransmits ask): a node that joined
 * from one neighbour's last round may find another neighbour a few rounds
 * further on, and must be able to catch up without a round timeout. That
 * neighbour, which had given it up, waits for it again while its history
 * holds the rounds the node lacks (dkf_ra_receive). */
#define HISTORY 16
/* DONE packets a finished node still sends once it awaits nothing (retry_us apart) */
#define GRACE 5

struct dkf_ra {
    dkf_ra_config_t cfg;
    dkf_ra_opts_t o;
    size_t deg, self;           /* row entries; self = position of cfg.id */
    size_t pkt;                 /* the largest packet of a round (reals) */
    dkf_real_t *rx, *nx;        /* deg x pkt: this round's / next round's packets, row order */
    dkf_real_t *cur;            /* my packet of this round */
    dkf_real_t *hist;           /* HISTORY x pkt: my packets of the rounds before (a ring) */
    dkf_real_t *next;           /* the filter's next packet */
    size_t cur_len, hist_len[HISTORY], hist_next;
    unsigned char *have, *have_nx, *absent, *done, *missed; /* deg flags each */
    int64_t *heard;             /* deg: last packet of a round <= t + 1 (liveness) */
    long t;                     /* global round index (k - 1) * rounds + round; -1: none */
    long hist_t[HISTORY];       /* the round of each history slot (-1: none) */
    long T;                     /* steps * rounds */
    size_t k;                   /* step in progress (1..steps), steps + 1 when finished */
    size_t k_first;             /* the first step run (1, or after a join) */
    size_t join_k, join_e;      /* joining: the newest step k whose last round a
                                 * neighbour (row position join_e) sent, in cur; 0: none */
    int state;
    int64_t round_start, last_pub, linger_start;
    int64_t grace_start;        /* linger: when nothing was awaited any more (0: not yet) */
    unsigned char *deg_step;    /* per step: degraded */
    unsigned char *miss_step;   /* steps x deg: neighbour missing in the step */
    dkf_ra_counters_t cnt;
    char err[256];
};

static size_t largest_packet(const dkf_net_tw_expect_t *ex)

{
    return ex->info_len > ex->est_len ? ex->info_len : ex->est_len;
}

dkf_ra_t *dkf_ra_new(const dkf_ra_config_t *cfg, const dkf_ra_opts_t *o, char *err,
                     size_t errlen)
{
    const size_t steps = cfg->ex.steps;
    dkf_ra_t *a;
    size_t e;
    if (cfg->deg > DKF_RA_MAX_DEG) {
        snprintf(err, errlen, "node %zu: %zu neighbours, at most %d supported", cfg->id,
                 cfg->deg - 1, DKF_RA_MAX_DEG - 1);
        return NULL;
    }
    if (largest_packet(&cfg->ex) > DKF_NET_TW_MAX_LEN) {
        snprintf(err, errlen, "node %zu: packets of %zu reals, at most %d", cfg->id,
                 largest_packet(&cfg->ex), (int)DKF_NET_TW_MAX_LEN);
        return NULL;
    }
    if ((a = calloc(1, sizeof *a)) == NULL) goto oom;
    a->cfg = *cfg;
    a->o = *o;
    a->deg = cfg->deg;
    for (e = 0; e < a->deg; ++e)
        if (cfg->row[e] == cfg->id) a->self = e;
    a->pkt = largest_packet(&cfg->ex);
    a->t = -1;
    for (e = 0; e < HISTORY; ++e) a->hist_t[e] = -1;
    a->T = (long)(steps * cfg->ex.rounds);
    a->rx = calloc(2 * a->deg * a->pkt + (2 + HISTORY) * a->pkt + 1, sizeof *a->rx);
    a->have = calloc(5 * a->deg + steps + steps * a->deg, 1);
    a->heard = calloc(a->deg, sizeof *a->heard);
    if (a->rx == NULL || a->have == NULL || a->heard == NULL) goto oom;
    a->nx = a->rx + a->deg * a->pkt;
    a->cur = a->nx + a->deg * a->pkt;
    a->next = a->cur + a->pkt;
    a->hist = a->next + a->pkt;
    a->have_nx = a->have + a->deg;
    a->absent = a->have_nx + a->deg;
    a->done = a->absent + a->deg;
    a->missed = a->done + a->deg;
    a->deg_step = a->missed + a->deg;
    a->miss_step = a->deg_step + steps;
    return a;
oom:
    dkf_ra_free(a);
    snprintf(err, errlen, "node %zu: out of memory", cfg->id);
    return NULL;
}

void dkf_ra_free(dkf_ra_t *a)
{
    if (a == NULL) return;
    free(a->rx);
    free(a->have);
    free(a->heard);
    free(a);
}

static int fail(dkf_ra_t *a)
{
    a->state = DKF_RA_FAILED;
    return a->state;
}

/* retransmit: 0 first publication, 1 re-publication while waiting (the
 * wire flag), 2 an answer to a neighbour's re-publication (flag clear). */
static int publish(dkf_ra_t *a, long t, int kind, const dkf_real_t *v, size_t len,
                   int retransmit, int64_t now)
{
    static unsigned char buf[DKF_RA_MAX_MSG];
    static dkf_net_tw_pkt_t p;
    size_t n;
    const long R = (long)a->cfg.ex.rounds;
    memset(&p, 0, sizeof p);
    p.utime = dkf_net_now_us();
    p.model_id = a->cfg.ex.model_id;
    p.node = (long)a->cfg.id;
    p.k = kind == DKF_NET_TW_KIND_DONE ? (long)a->cfg.ex.steps + 1 : t / R + 1;
    p.round = kind == DKF_NET_TW_KIND_DONE ? 0 : t % R;
    p.kind = kind;
    p.retransmit = retransmit == 1;
    p.len = len;
    if (len > 0) memcpy(p.v, v, len * sizeof *v);
    if (dkf_net_encode_tw(buf, sizeof buf, &n, &p) != 0 || a->o.send(a->o.user, buf, n) != 0) {
        snprintf(a->err, sizeof a->err, "node %zu: cannot publish", a->cfg.id);
        a->state = DKF_RA_FAILED;
        return -1;
    }
    ++a->cnt.sent;
    if (retransmit == 1) ++a->cnt.retransmits;
    else if (retransmit == 2) ++a->cnt.answers;
    else a->cnt.reals_sent += len; /* the filter's own traffic, first publications */
    a->last_pub = now;
    return 0;
}

static void shape(const dkf_ra_t *a, long t, int *kind, size_t *len)
{
    dkf_net_tw_shape(&a->cfg.ex, (size_t)t % a->cfg.ex.rounds, kind, len);
}

/* Enters round t with my packet v: early packets of t become current. */
/* My packet of round a->t into the history. */
static void remember(dkf_ra_t *a)
{
    const size_t s = a->hist_next;
    memcpy(a->hist + s * a->pkt, a->cur, a->cur_len * sizeof *a->cur);
    a->hist_len[s] = a->cur_len;
    a->hist_t[s] = a->t;
    a->hist_next = (s + 1) % HISTORY;
}

static int enter_round(dkf_ra_t *a, long t, const dkf_real_t *v, int64_t now)
{
    int kind;
    size_t len, e;
    shape(a, t, &kind, &len);
    if (a->t >= 0) remember(a);
    memcpy(a->cur, v, len * sizeof *v);
    a->cur_len = len;
    a->t = t;
    memcpy(a->rx, a->nx, a->deg * a->pkt * sizeof *a->rx);
    memcpy(a->have, a->have_nx, a->deg);
    for (e = 0; e < a->deg; ++e)
        if (a->have[e]) a->absent[e] = 0;
    memset(a->have_nx, 0, a->deg);
    memcpy(a->rx + a->self * a->pkt, a->cur, len * sizeof *v);
    a->have[a->self] = 1;
    a->round_start = now;
    return publish(a, t, kind, a->cur, len, 0, now);
}

/* Step a->k is committed: who was missing in it. */
static void record_step(dkf_ra_t *a)
{
    const size_t j = a->k - 1;
    size_t e;
    memcpy(a->miss_step + j * a->deg, a->missed, a->deg);
    for (e = 0; e < a->deg; ++e) a->deg_step[j] |= a->missed[e];
    if (a->deg_step[j]) ++a->cnt.degraded_steps;
    memset(a->missed, 0, a->deg);
}

static int finish(dkf_ra_t *a, int64_t now)
{
    a->state = DKF_RA_LINGER;
    a->linger_start = now;
    remember(a); /* answers to retransmits of the last round */
    a->t = a->T;
    return publish(a, 0, DKF_NET_TW_KIND_DONE, NULL, 0, 0, now);
}

/* Starts step a->k (or finishes): its round 0, or the whole step locally. */
static int begin_step(dkf_ra_t *a, int64_t now)
{
    while (a->k <= a->cfg.ex.steps) {
        const int rc = a->cfg.ops->begin_step(a->cfg.filter, a->k, a->next, a->err, sizeof a->err);
        if (rc < 0) return fail(a);
        if (rc == 0) return enter_round(a, (long)((a->k - 1) * a->cfg.ex.rounds), a->next, now);
        record_step(a);
        ++a->k;
    }
    return finish(a, now);
}

/* Round a->t is complete (or given up): the filter's next packet, or the
 * step's end. */
static int complete_round(dkf_ra_t *a, int64_t now)
{
    const size_t r = (size_t)a->t % a->cfg.ex.rounds;
    const int rc = a->cfg.ops->complete_round(a->cfg.filter, a->k, r, a->rx, a->pkt, a->have,
                                              a->next, a->err, sizeof a->err);
    if (rc < 0) return fail(a);
    if (rc == 0) return enter_round(a, a->t + 1, a->next, now);
    record_step(a);
    ++a->k;
    return begin_step(a, now);
}

int dkf_ra_start(dkf_ra_t *a, int64_t now_us)
{
    if (a->k != 0 || a->state == DKF_RA_JOINING) return a->state;
    a->k = a->k_first = 1;
    return begin_step(a, now_us);
}

int dkf_ra_join(dkf_ra_t *a, int64_t now_us)
{
    (void)now_us;
    if (a->k != 0 || a->state == DKF_RA_JOINING) return a->state;
    if (a->cfg.ops->rejoin == NULL) {
        snprintf(a->err, sizeof a->err, "node %zu: this filter cannot join a running network",
                 a->cfg.id);
        return fail(a);
    }
    a->state = DKF_RA_JOINING;
    return a->state;
}

/* Joining: the neighbour at row position e sent packet p. A packet of the
 * last round of a step with a step after it, newer than the one kept, is
 * kept for the join (in cur, unused until then). */
static void join_candidate(dkf_ra_t *a, long e, const dkf_net_tw_pkt_t *p)
{
    if (p->kind == DKF_NET_TW_KIND_DONE || (size_t)p->round + 1 != a->cfg.ex.rounds ||
        (size_t)p->k >= a->cfg.ex.steps || (size_t)p->k <= a->join_k)
        return;
    a->join_k = (size_t)p->k;
    a->join_e = (size_t)e;
    memcpy(a->cur, p->v, p->len * sizeof p->v[0]);
}

/* Joins after step join_k from the kept packet: at a poll, so from the
 * newest one of everything received before it (a backlog in the receive
 * queue, read at once, does not start the node from an old step). */
static int join(dkf_ra_t *a, int64_t now)
{
    const size_t k = a->join_k;
    if (a->cfg.ops->rejoin(a->cfg.filter, k, a->cur, a->next, a->err, sizeof a->err) != 0)
        return fail(a);
    a->state = DKF_RA_RUNNING;
    a->k = a->k_first = k + 1;
    a->heard[a->join_e] = now;
    return enter_round(a, (long)(k * a->cfg.ex.rounds), a->next, now);
}

/* The history slot of my packet of round t, or -1. */
static long history_slot(const dkf_ra_t *a, long t)
{
    long s;
    for (s = 0; s < HISTORY; ++s)
        if (a->hist_t[s] == t) return s;
    return -1;
}

/* Row position of node j, or -1. */
static long row_pos(const dkf_ra_t *a, long j)
{
    size_t e;
    for (e = 0; e < a->deg; ++e)
        if ((long)a->cfg.row[e] == j) return (long)e;
    return -1;
}

dkf_net_verdict_t dkf_ra_receive(dkf_ra_t *a, long chan_node, const void *data, size_t len,
                                 int64_t now_us)
{
    static dkf_net_tw_pkt_t p;
    dkf_net_tw_expect_t ex = a->cfg.ex;
    dkf_net_verdict_t v;
    long e, t;
    ex.node = chan_node;
    v = dkf_net_decode_tw(data, len, &ex, &p, &a->cnt.rej);
    if (v != DKF_NET_ACCEPT) return v;
    e = row_pos(a, p.node);
    if (e < 0 || (size_t)e == a->self) { /* not a neighbour (a subscription filters these) */
        ++a->cnt.rej.total;
        ++a->cnt.rej.by[DKF_NET_REJ_NODE];
        return DKF_NET_REJ_NODE;
    }
    ++a->cnt.received;
    if (a->state == DKF_RA_JOINING) {
        join_candidate(a, e, &p);
        return v;
    }
    if (p.kind == DKF_NET_TW_KIND_DONE || (p.k - 1) * (long)a->cfg.ex.rounds + p.round <= a->t + 1)
        a->heard[e] = now_us; /* alive, and not gone past us */
    if (p.kind == DKF_NET_TW_KIND_DONE) {
        a->done[e] = 1;
        return v;
    }
    t = (p.k - 1) * (long)a->cfg.ex.rounds + p.round;
    if (t == a->t && a->state == DKF_RA_RUNNING) {
        if (a->have[e]) ++a->cnt.duplicates;
        memcpy(a->rx + (size_t)e * a->pkt, p.v, p.len * sizeof p.v[0]);
        a->have[e] = 1;
        a->absent[e] = 0;
    } else if (t == a->t + 1 && a->state == DKF_RA_RUNNING) {
        /* present again from round t on (enter_round), not in this round:
         * a neighbour that joined at t never sends this round's packet */
        memcpy(a->nx + (size_t)e * a->pkt, p.v, p.len * sizeof p.v[0]);
        a->have_nx[e] = 1;
    } else if (t < a->t) {
        const long s = history_slot(a, t);
        ++a->cnt.stale;
        /* a neighbour I gave up is heard again behind me (it joined, or it
         * fell back): it is waited for again from this round on. It cannot
         * send a packet of this round before it has caught up, which it does
         * through my answers while my history holds round t (and so every
         * round after it); not waited for, it would stay behind for good. */
        if (s >= 0) a->absent[e] = 0;
        /* the neighbour still waits in a round I left: it may lack mine */
        if (s >= 0 && p.retransmit) {
            int kind;
            size_t plen;
            shape(a, t, &kind, &plen);
            (void)publish(a, t, kind, a->hist + (size_t)s * a->pkt, a->hist_len[s], 2, now_us);
        }
    } else {
        ++a->cnt.ahead;
    }
    return v;
}

static int round_ready(const dkf_ra_t *a)
{
    size_t e;
    for (e = 0; e < a->deg; ++e)
        if (!a->have[e] && !a->absent[e]) return 0;
    return 1;
}

/* When the round may complete without the packets still missing: a
 * neighbour is given up only after a full timeout of silence, counted from
 * the round's start or from its last packet (a neighbour that is itself
 * waiting re-publishes, so it is never given up while it lives). */
static int64_t deadline(const dkf_ra_t *a)
{
    const int64_t d = a->t == 0 ? a->o.start_timeout_us : a->o.round_timeout_us;
    int64_t last = a->round_start;
    size_t e;
    for (e = 0; e < a->deg; ++e)
        if (!a->have[e] && !a->absent[e] && a->heard[e] > last) last = a->heard[e];
    return last + d;
}

static int linger_over(const dkf_ra_t *a, int64_t now)
{
    size_t e;
    if (now - a->linger_start >= a->o.round_timeout_us) return 1;
    for (e = 0; e < a->deg; ++e)
        if (e != a->self && !a->done[e] && !a->absent[e]) return 0;
    return 1;
}

int dkf_ra_poll(dkf_ra_t *a, int64_t now_us)
{
    size_t e;
    if (a->state == DKF_RA_JOINING && a->join_k > 0) join(a, now_us);
    while (a->state == DKF_RA_RUNNING) {
        if (!round_ready(a)) {
            if (now_us < deadline(a)) break;
            for (e = 0; e < a->deg; ++e)
                if (!a->have[e] && !a->absent[e]) {
                    a->absent[e] = 1;
                    a->missed[e] = 1;
                    ++a->cnt.absent_marks;
                }
        }
        for (e = 0; e < a->deg; ++e) a->missed[e] |= (unsigned char)!a->have[e];
        complete_round(a, now_us);
    }
    if (a->state == DKF_RA_RUNNING && now_us - a->last_pub >= a->o.retry_us) {
        int kind;
        size_t len;
        shape(a, a->t, &kind, &len);
        publish(a, a->t, kind, a->cur, a->cur_len, 1, now_us);
    }
    if (a->state == DKF_RA_LINGER) {
        /* once nothing is awaited, DONE goes out GRACE more times before the
         * node leaves: a neighbour that lost the others still learns that
         * this node is done instead of lingering to its round timeout */
        if (a->grace_start == 0 && linger_over(a, now_us)) a->grace_start = now_us;
        if (a->grace_start != 0 && now_us - a->grace_start >= GRACE * a->o.retry_us)
            a->state = DKF_RA_FINISHED;
        else if (now_us - a->last_pub >= a->o.retry_us)
            publish(a, 0, DKF_NET_TW_KIND_DONE, NULL, 0, 1, now_us);
    }
    return a->state;
}

int64_t dkf_ra_wait_us(const dkf_ra_t *a, int64_t now_us)
{
    int64_t w = a->last_pub + a->o.retry_us - now_us;
    if (a->state == DKF_RA_JOINING) return a->join_k > 0 ? 0 : a->o.retry_us;
    if (a->state == DKF_RA_RUNNING && deadline(a) - now_us < w) w = deadline(a) - now_us;
    if (a->state == DKF_RA_LINGER && a->linger_start + a->o.round_timeout_us - now_us < w)
        w = a->linger_start + a->o.round_timeout_us - now_us;
    return w < 0 ? 0 : w;
}

void dkf_ra_chan(char *out, const char *prefix, size_t node)
{
    snprintf(out, DKF_NET_CHAN_LEN, "%s_%zu", prefix, node);
}

long dkf_ra_chan_node(const char *channel, const char *prefix)
{
    const size_t pl = strlen(prefix);
    const char *p;
    long v = 0;
    if (strncmp(channel, prefix, pl) != 0 || channel[pl] != '_') return -1;
    p = channel + pl + 1;
    if (*p == '\0') return -1;
    if (p[0] == '0' && p[1] != '\0') return -1;
    for (; *p != '\0'; ++p) {
        if (*p < '0' || *p > '9' || v > 100000000L) return -1;
        v = v * 10 + (*p - '0');
    }
    return v;
}

int dkf_ra_subscription(char *out, size_t cap, const char *prefix, const size_t *row, size_t deg,
                        size_t self)
{
    size_t e, used;
    int r = snprintf(out, cap, "%s_(", prefix), first = 1;
    if (r < 0 || (size_t)r >= cap) return -1;
    used = (size_t)r;
    for (e = 0; e < deg; ++e) {
        if (row[e] == self) continue;
        r = snprintf(out + used, cap - used, "%s%zu", first ? "" : "|", row[e]);
        if (r < 0 || (size_t)r >= cap - used) return -1;
        used += (size_t)r;
        first = 0;
    }
    if (first) return -1; /* no neighbour: nothing to subscribe to */
    r = snprintf(out + used, cap - used, ")");
    return (r < 0 || (size_t)r >= cap - used) ? -1 : 0;
}

const size_t *dkf_ra_row(const dkf_ra_t *a, size_t *deg)
{
    *deg = a->deg;
    return a->cfg.row;
}

int dkf_ra_neighbours_regex(const dkf_ra_t *a, const char *prefix, char *out, size_t cap)
{
    return dkf_ra_subscription(out, cap, prefix, a->cfg.row, a->deg, a->cfg.id);
}

static json_t *counters_json(const dkf_ra_t *a)
{
    const dkf_ra_counters_t *c = &a->cnt;
    json_t *o = json_object(), *by = json_object();
    int v;
    json_object_set_new(o, "sent", json_integer((json_int_t)c->sent));
    json_object_set_new(o, "reals_sent", json_integer((json_int_t)c->reals_sent));
    json_object_set_new(o, "retransmits", json_integer((json_int_t)c->retransmits));
    json_object_set_new(o, "answers", json_integer((json_int_t)c->answers));
    json_object_set_new(o, "received", json_integer((json_int_t)c->received));
    json_object_set_new(o, "duplicates", json_integer((json_int_t)c->duplicates));
    json_object_set_new(o, "stale", json_integer((json_int_t)c->stale));
    json_object_set_new(o, "ahead", json_integer((json_int_t)c->ahead));
    json_object_set_new(o, "absent_marks", json_integer((json_int_t)c->absent_marks));
    json_object_set_new(o, "degraded_steps", json_integer((json_int_t)c->degraded_steps));
    json_object_set_new(o, "rejected", json_integer((json_int_t)c->rej.total));
    for (v = 1; v < DKF_NET_NVERDICTS; ++v)
        json_object_set_new(by, dkf_net_verdict_str((dkf_net_verdict_t)v),
                            json_integer((json_int_t)c->rej.by[v]));
    json_object_set_new(o, "rejected_by_reason", by);
    return o;
}

void dkf_ra_result_json(const dkf_ra_t *a, size_t steps, json_t *doc)
{
    json_t *nb = json_array(), *dg = json_array(), *ms = json_array();
    size_t j, e;
    for (e = 0; e < a->deg; ++e)
        if (e != a->self) json_array_append_new(nb, json_integer((json_int_t)a->cfg.row[e]));
    for (j = 1; j <= steps; ++j) {
        json_t *miss = json_array();
        json_array_append_new(dg, json_boolean(dkf_ra_step_degraded(a, j)));
        for (e = 0; e < a->deg; ++e)
            if (dkf_ra_step_missing(a, j, e))
                json_array_append_new(miss, json_integer((json_int_t)a->cfg.row[e]));
        json_array_append_new(ms, miss);
    }
    json_object_set_new(doc, "neighbours", nb);
    json_object_set_new(doc, "degraded", dg);
    json_object_set_new(doc, "missing", ms);
    json_object_set_new(doc, "counters", counters_json(a));
}

int dkf_ra_state(const dkf_ra_t *a) { return a->state; }
const char *dkf_ra_error(const dkf_ra_t *a) { return a->err; }
const dkf_ra_counters_t *dkf_ra_counters(const dkf_ra_t *a) { return &a->cnt; }
size_t dkf_ra_steps_done(const dkf_ra_t *a) { return a->k == 0 ? 0 : a->k - 1; }
size_t dkf_ra_first_step(const dkf_ra_t *a) { return a->k_first; }
int dkf_ra_step_degraded(const dkf_ra_t *a, size_t j) { return a->deg_step[j - 1]; }
int dkf_ra_step_missing(const dkf_ra_t *a, size_t j, size_t e)
{
    return a->miss_step[(j - 1) * a->deg + e];
}
