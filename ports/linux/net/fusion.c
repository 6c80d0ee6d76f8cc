/*
 * fusion.c - the fusion centre (agents.h, docs/network.md "Faults"):
 * buffers node payloads per (node, step), runs the core's dkf_diffkf_fc_t
 * step by step (dkf_diffkf_fc_step_partial: the centralized DKF given the
 * nodes' rows it can rebuild), publishes every step by its deadline, and
 * rolls back to a checkpoint and replays when a payload of a published
 * step arrives late.
 *
 * Node i's z^i_k can be rebuilt from its payloads of steps k and k-1 (or of
 * k alone at the first step of an epoch). A message carries the payload of
 * its own step and of the previous one, so a lost message is recovered by
 * the next; a payload that arrives after its step was published (within
 * DKF_NET_CKPT steps) restores the checkpoint taken before that step and
 * replays every step since with the data now known, which gives exactly
 * what the FC would have computed had the payload been on time.
 */
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "agents.h"
#include "dkf/diffkf_fusion.h"
#include "model.h"
#include "util.h"

/* Payloads kept per node: DKF_NET_CKPT revisable steps, the present one and
 * DKF_NET_WINDOW ahead, indexed by k modulo RING. */
#define RING (DKF_NET_WINDOW + DKF_NET_CKPT + 2)
#define EPOCHS 8 /* epochs remembered per node */

/* One node's x^i_{k|k}, x^i_{k|k-1} of step k, however it arrived. */
typedef struct {
    long k;              /* the step held (0: empty) */
    long epoch;
    int direct;          /* step k's own message arrived (not only the next one's copy) */
    dkf_diffkf_msg_t msg;
    int64_t meas_utime, recv_utime;
} payload_t;

/* An epoch of a node's local filter: it (re)started at k_start. */
typedef struct {
    long epoch, k_start;
    int assumed;  /* epoch 0 from step 1, until a message says otherwise */
    int usable;   /* 0: it started at a step older than every checkpoint */
    int applied;  /* the replica was restarted for it (counted once) */
} epoch_t;

/* One run of a node's process as its sequence numbers count it: a
 * (re)start, told apart by (epoch, k_start) (a process restarted without
 * --epoch repeats the epoch but not the first step). */
typedef struct {
    long epoch, k_start;
    int64_t seq_max; /* largest seq seen (-1: none) */
} incarnation_t;

typedef struct {
    payload_t pay[RING];
    epoch_t ep[EPOCHS];  /* by increasing epoch (and k_start) */
    size_t nep;
    incarnation_t inc[EPOCHS]; /* the newest runs of the process */
    size_t ninc;
    int64_t made_before; /* messages made by runs dropped from inc[] */
    int64_t got;         /* distinct messages accepted (their own step) */
    long k_max;          /* newest step of a message accepted from it (0: none) */
    int64_t last_recv;   /* its arrival (recv_utime; INT64_MIN: never heard) */
    int64_t last_mono;   /* the same arrival on the centre's monotonic clock */
} peer_t;

/* What is recorded of every step (for the result file). */
typedef struct {
    double *xf, *xp, *Pf, *Pp;        /* N x n, N x n x n: the latest computation */
    int *degraded, *first_degraded;   /* N */
    int *revisions;                   /* N: recomputations after the first publication */
    unsigned char *contributed;       /* N x l (latest) */
    unsigned char *first_contributed; /* N x l (at the first publication) */
    int64_t *lat_first, *lat_last;    /* N: fused publication - measurement publication */
} record_t;

typedef struct {
    int64_t duplicates, redundant, late, too_late, ahead, old_epoch, conflicts;
    int64_t rollbacks, replayed, revised_sent, restarts, core_masked, lost_epochs, pushed;
} fault_counts_t;

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
    dkf_real_t *P0_local;         /* l x n x n: the priors of node (re)starts */
    peer_t *peer;                 /* l */
    long open_k[RING];            /* step k opened (its first payload arrived) at open_mono */
    int64_t open_mono[RING];
    dkf_real_t *ck;               /* DKF_NET_CKPT + 1 checkpoints: state after step ck_k[j] */
    long ck_k[DKF_NET_CKPT + 1];
    size_t ck_len;
    long done_k;                  /* last published step */
    long newest_k;                /* newest step of any message accepted */
    long join_k;                  /* first step fused from data (steps before it were
                                     skipped: a centre started or restarted mid-run) */
    int64_t first_recv, newest_recv; /* arrival of the first and the newest message */
    FILE *journal;                /* one JSON line per computed step (NULL: none) */
    int64_t done_mono;            /* when it was first published (monotonic): step
                                     done_k + 1 opens then at the latest */
    int64_t linger_us;            /* after step N: how long a node still sending may
                                     be waited for (settled) */
    dkf_diffkf_msg_t *msgs;       /* l: the running step's messages */
    unsigned char *present, *contrib; /* l */
    dkf_net_fused_t out;
    dkf_diffkf_msg_t in, in_prev; /* the message being decoded */
    record_t rec;
    dkf_net_counts_t c;
    fault_counts_t fx;
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

static void to_double(double *dst, const dkf_real_t *src, size_t len)
{
    size_t i;
    for (i = 0; i < len; ++i) dst[i] = (double)src[i];
}

static const char *cond_str(dkf_diffkf_fc_cond_t c)
{
    static const char *const names[] = {
        "no fault", "argument", "storage", "p_i > n", "p_i > m_i", "stacked capacity",
        "prior", "model", "A rank", "B singular", "L not SPD", "K rank", "non-finite",
        "message node", "message step", "message dimension", "message non-finite", "sequence"};
    return (size_t)c < sizeof names / sizeof names[0] ? names[c] : "?";
}

/* ---- epochs and payloads ---------------------------------------------------------- */

/* The epoch that owns step k of node i (the newest that started at or
 * before k), or NULL (a late node before its start). */
static epoch_t *owner(dkf_net_fusion_t *fu, size_t i, long k)
{
    peer_t *p = &fu->peer[i];
    size_t j = p->nep;
    while (j > 0) {
        --j;
        if (p->ep[j].k_start <= k) return &p->ep[j];
    }
    return NULL;
}

/* Node i's payload of step k, if it is there and belongs to the epoch that
 * owns k (a usable one). */
static const payload_t *payload(dkf_net_fusion_t *fu, size_t i, long k)
{
    const payload_t *q = &fu->peer[i].pay[(size_t)k % RING];
    const epoch_t *e = owner(fu, i, k);
    if (q->k != k || e == NULL || !e->usable || q->epoch != e->epoch) return NULL;
    return q;
}

/* 1 if the checkpoint taken after step k is still in the ring. */
static int have_ckpt(const dkf_net_fusion_t *fu, long k)
{
    return k >= 0 && fu->ck_k[(size_t)k % (DKF_NET_CKPT + 1)] == k;
}

/* Registers (epoch, k_start) of node i. Returns the first step whose
 * computation it changes (a restart at k_start), LONG_MAX if none, or -1 if
 * it contradicts what is known (then the message is ignored). */
static long note_epoch(dkf_net_fusion_t *fu, size_t i, long epoch, long k_start)
{
    peer_t *p = &fu->peer[i];
    size_t j, at;
    epoch_t e;
    for (j = 0; j < p->nep; ++j) {
        epoch_t *q = &p->ep[j];
        if (q->epoch != epoch) continue;
        if (q->k_start == k_start) return LONG_MAX;
        if (!q->assumed) return -1;
        /* a late start of epoch 0: the assumption is replaced */
        q->k_start = k_start;
        q->assumed = 0;
        q->usable = k_start == 1 || k_start > fu->done_k || have_ckpt(fu, k_start - 1);
        if (!q->usable) ++fu->fx.lost_epochs;
        return k_start;
    }
    /* a new epoch: epochs and their starts increase together */
    for (at = 0; at < p->nep && p->ep[at].epoch < epoch; ++at) {
    }
    if ((at > 0 && p->ep[at - 1].k_start > k_start) ||
        (at < p->nep && p->ep[at].k_start < k_start))
        return -1;
    if (at > 0 && p->ep[at - 1].assumed && k_start == 1) return -1;
    e.epoch = epoch;
    e.k_start = k_start;
    e.assumed = 0;
    e.usable = k_start == 1 || k_start > fu->done_k || have_ckpt(fu, k_start - 1);
    e.applied = 0;
    if (!e.usable) ++fu->fx.lost_epochs;
    if (p->nep == EPOCHS) { /* forget the oldest */
        memmove(&p->ep[0], &p->ep[1], (EPOCHS - 1) * sizeof p->ep[0]);
        --p->nep;
        if (at > 0) --at;
    }
    memmove(&p->ep[at + 1], &p->ep[at], (p->nep - at) * sizeof p->ep[0]);
    p->ep[at] = e;
    ++p->nep;
    return k_start;
}

/* Stores node i's payload of step k; returns 1 if it is new information.
 * meas_utime: the publication of y^i_{k+1} (its own message), 0 for the
 * copy in message k+1 (that message's time is y^i_{k+2}'s). */
static int store_payload(dkf_net_fusion_t *fu, size_t i, long epoch, const dkf_diffkf_msg_t *m,
                         int direct, int64_t meas_utime, int64_t recv_utime)
{
    peer_t *p = &fu->peer[i];
    const long k = (long)m->k;
    payload_t *q = &p->pay[(size_t)k % RING];
    const epoch_t *e = owner(fu, i, k);
    if (e == NULL || e->epoch != epoch) {
        if (direct) {
            ++fu->fx.old_epoch;
            ++fu->c.stale;
            fu_note(fu, "fusion: node %zu step k=%ld of epoch %ld: not the epoch of that step",
                    i, k, epoch);
        }
        return 0;
    }
    if (k > fu->done_k + DKF_NET_WINDOW || k <= fu->done_k - DKF_NET_CKPT) {
        if (direct) {
            if (k > fu->done_k) ++fu->fx.ahead; else ++fu->fx.too_late;
            ++fu->c.stale;
            fu_note(fu, "fusion: node %zu step k=%ld is %s", i, k,
                    k > fu->done_k ? "too far ahead" : "too late to revise");
        }
        return 0;
    }
    if (q->k == k && q->epoch == epoch) {
        if (direct && q->direct) {
            ++fu->fx.duplicates;
            ++fu->c.stale;
            fu_note(fu, "fusion: node %zu step k=%ld: duplicate", i, k);
        } else if (direct) {
            q->direct = 1; /* its copy came first (reordered or after a drop) */
            q->meas_utime = meas_utime; /* the copy had no measurement time */
            ++p->got;
            ++fu->c.received;
        }
        return 0;
    }
    q->k = k;
    q->epoch = epoch;
    q->direct = direct;
    q->msg = *m;
    q->meas_utime = meas_utime;
    q->recv_utime = recv_utime;
    if (direct) {
        ++p->got;
        ++fu->c.received;
    } else {
        ++fu->fx.redundant;
    }
    if (fu->open_k[(size_t)k % RING] != k) {
        fu->open_k[(size_t)k % RING] = k;
        fu->open_mono[(size_t)k % RING] = dkf_net_mono_us();
    }
    return 1;
}

/* ---- one step of the core fusion centre ------------------------------------------- */

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

static void note_fault(dkf_net_fusion_t *fu, long k, const char *call, dkf_status_t st,
                       const dkf_diffkf_fc_fault_t *fault)
{
    if (fault->node == DKF_DIFFKF_FC_NO_NODE)
        fu_note(fu, "fusion: step k=%ld: %s failed: %s (%s)", k, call, dkf_status_str(st),
                cond_str(fault->which));
    else
        fu_note(fu, "fusion: step k=%ld: %s failed: %s (%s, node %zu)", k, call,
                dkf_status_str(st), cond_str(fault->which), fault->node);
}

/* Mirrors the (re)starts of local filters at step k (before the step). */
static void restart_nodes(dkf_net_fusion_t *fu, long k)
{
    const size_t n = fu->n;
    size_t i;
    for (i = 0; i < fu->l; ++i) {
        epoch_t *e = owner(fu, i, k);
        dkf_diffkf_sensor_t sk;
        dkf_mat_t P0 = DKF_MAT(n, n, fu->P0_local + i * n * n);
        dkf_diffkf_fc_fault_t fault = {DKF_DIFFKF_FC_NO_FAULT, 0};
        dkf_status_t st;
        if (e == NULL || !e->usable || e->k_start != k || k == 1) continue;
        if (dkf_net_model_meas(&fu->md[i], fu->s, i, (size_t)k) != 0) {
            e->usable = 0;
            continue;
        }
        sk.B = NULL;
        sk.Rd = NULL;
        sk.meas = fu->md[i].meas;
        st = dkf_diffkf_fc_restart_node(&fu->fc, i, (size_t)k, &P0, &sk, &fault);
        if (st != DKF_OK) {
            /* the replica cannot follow this epoch: the node stays masked */
            note_fault(fu, k, "dkf_diffkf_fc_restart_node", st, &fault);
            e->usable = 0;
            ++fu->fx.lost_epochs;
            continue;
        }
        /* counted once, whether first applied on time or in a replay */
        if (!e->applied) ++fu->fx.restarts;
        e->applied = 1;
    }
}

/* Saves the FC state after step k into the checkpoint ring. */
static void save_ckpt(dkf_net_fusion_t *fu, long k)
{
    const size_t j = (size_t)k % (DKF_NET_CKPT + 1);
    if (dkf_diffkf_fc_save(&fu->fc, fu->ck + j * fu->ck_len, fu->ck_len) == DKF_OK)
        fu->ck_k[j] = k;
    else
        fu->ck_k[j] = -1;
}

/* Step k = fc.k + 1 with the payloads known now; records it. A node the
 * core refuses (rank, model) is masked and the step retried, so a step
 * always completes unless the central filter itself fails. 0 or -1. */
static int compute_step(dkf_net_fusion_t *fu, long k)
{
    const size_t n = fu->n, l = fu->l, j = (size_t)(k - 1);
    dkf_diffkf_fc_fault_t fault = {DKF_DIFFKF_FC_NO_FAULT, 0};
    dkf_status_t st = DKF_OK;
    size_t i, tries;
    restart_nodes(fu, k);
    if (load_sensors(fu, (size_t)k, (size_t)k + 1) != 0) {
        fu_note(fu, "fusion: the scenario has no model for step k=%ld", k);
        return -1;
    }
    for (i = 0; i < l; ++i) {
        const payload_t *q = payload(fu, i, k);
        fu->present[i] = q != NULL;
        if (q != NULL) {
            fu->msgs[i] = q->msg;
        } else {
            memset(&fu->msgs[i], 0, sizeof fu->msgs[i]);
            fu->msgs[i].node = (uint16_t)i;
            fu->msgs[i].k = (uint32_t)k;
            fu->msgs[i].n = (uint16_t)n;
        }
    }
    /* the prior x_{k|k-1}, P_{k|k-1} is the central filter's xp before the step */
    to_double(fu->rec.xp + j * n, fu->fc.central.xn.data, n);
    to_double(fu->rec.Pp + j * n * n, fu->fc.central.Pn.data, n * n);
    for (tries = 0; tries <= l; ++tries) {
        st = dkf_diffkf_fc_step_partial(&fu->fc, &fu->md[0].F, &fu->md[0].Q, fu->sens, fu->msgs,
                                        fu->present, fu->contrib, &fault);
        if (st == DKF_OK) break;
        note_fault(fu, k, "dkf_diffkf_fc_step_partial", st, &fault);
        ++fu->fx.core_masked;
        if (fault.node != DKF_DIFFKF_FC_NO_NODE && fault.node < l && fu->present[fault.node])
            fu->present[fault.node] = 0;
        else if (memchr(fu->present, 1, l) != NULL)
            memset(fu->present, 0, l); /* the prediction alone */
        else
            break;
    }
    if (st != DKF_OK) return -1;
    to_double(fu->rec.xf + j * n, fu->fc.central.xf.data, n);
    to_double(fu->rec.Pf + j * n * n, fu->fc.central.Pf.data, n * n);
    memcpy(fu->rec.contributed + j * l, fu->contrib, l);
    fu->rec.degraded[j] = memchr(fu->contrib, 0, l) != NULL;
    save_ckpt(fu, k);
    return 0;
}

/* Publishes the recorded step k (revision r). */
static void publish_step(dkf_net_fusion_t *fu, long k, int revision)
{
    static unsigned char buf[DKF_NET_MAX_MSG];
    dkf_net_fused_t *o = &fu->out;
    const size_t n = fu->n, l = fu->l, j = (size_t)(k - 1);
    size_t i, len;
    o->k = k;
    o->nnodes = l;
    o->n = n;
    o->degraded = fu->rec.degraded[j];
    o->revision = revision;
    o->meas_utime_first = o->meas_utime_last = o->msg_utime_last = 0;
    for (i = 0; i < l; ++i) {
        const payload_t *q = payload(fu, i, k);
        o->contributed[i] = fu->rec.contributed[j * l + i];
        if (!o->contributed[i] || q == NULL) continue;
        if (q->recv_utime > o->msg_utime_last) o->msg_utime_last = q->recv_utime;
        if (q->meas_utime == 0) continue; /* known from a copy only: y^i_{k+1}'s time unknown */
        if (o->meas_utime_first == 0 || q->meas_utime < o->meas_utime_first)
            o->meas_utime_first = q->meas_utime;
        if (q->meas_utime > o->meas_utime_last) o->meas_utime_last = q->meas_utime;
    }
    memcpy(o->xf, fu->rec.xf + j * n, n * sizeof(double));
    memcpy(o->xp, fu->rec.xp + j * n, n * sizeof(double));
    memcpy(o->Pf, fu->rec.Pf + j * n * n, n * n * sizeof(double));
    memcpy(o->Pp, fu->rec.Pp + j * n * n, n * n * sizeof(double));
    o->meta.utime = dkf_net_now_us();
    o->meta.model_id = fu->model_id;
    o->meta.seq = fu->seq++;
    if (dkf_net_encode_fused(buf, sizeof buf, &len, o) != 0 ||
        dkf_net_publish(fu->net, fu->chan_out, buf, len) != 0)
        fu_note(fu, "fusion: step k=%ld: cannot publish", k);
    else
        ++fu->c.sent;
    if (revision == 0) {
        fu->rec.first_degraded[j] = o->degraded;
        memcpy(fu->rec.first_contributed + j * l, o->contributed, l);
        fu->rec.lat_first[j] = o->meas_utime_first ? o->meta.utime - o->meas_utime_first : -1;
        fu->rec.lat_last[j] = o->meas_utime_last ? o->meta.utime - o->meas_utime_last : -1;
        if (o->degraded) ++fu->c.missed;
    } else {
        ++fu->fx.revised_sent;
    }
}

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

/* Appends step k as it stands now (first computation or a replay) to the
 * journal, one JSON line, flushed: what was computed survives a killed
 * process (docs/network.md, "Result file"). */
static void journal_step(dkf_net_fusion_t *fu, long k, int published)
{
    const size_t n = fu->n, l = fu->l, j = (size_t)(k - 1);
    json_t *o;
    if (fu->journal == NULL) return;
    o = json_object();
    set_int(o, "k", k);
    set_int(o, "revision", fu->rec.revisions[j]);
    json_object_set_new(o, "status", json_string(fu->rec.degraded[j] ? "degraded" : "complete"));
    json_object_set_new(o, "contributors", json_nodes(fu->rec.contributed + j * l, l));
    json_object_set_new(o, "published", json_boolean(published));
    json_object_set_new(o, "xf", dkf_json_doubles(fu->rec.xf + j * n, n, 0));
    json_object_set_new(o, "xp", dkf_json_doubles(fu->rec.xp + j * n, n, 0));
    json_object_set_new(o, "Pf", dkf_json_doubles(fu->rec.Pf + j * n * n, n, n));
    json_object_set_new(o, "Pp", dkf_json_doubles(fu->rec.Pp + j * n * n, n, n));
    set_int(o, "utime", dkf_net_now_us());
    if (json_dumpf(o, fu->journal, JSON_COMPACT | JSON_REAL_PRECISION(17)) != 0 ||
        fputc('\n', fu->journal) == EOF || fflush(fu->journal) != 0) {
        fu_note(fu, "fusion: step k=%ld: cannot write the journal", k);
        fu->journal = NULL; /* the caller still owns and closes it */
    }
    json_decref(o);
}

static void fail(dkf_net_fusion_t *fu)
{
    fu->state = DKF_NET_FAILED;
    dkf_net_fusion_report(fu);
}

/* Computes and publishes step done_k + 1 for the first time (at monotonic
 * time now). */
static void next_step(dkf_net_fusion_t *fu, int64_t now)
{
    const long k = fu->done_k + 1;
    if (compute_step(fu, k) != 0) {
        fail(fu);
        return;
    }
    fu->done_k = k;
    fu->done_mono = now;
    if (k >= fu->join_k) publish_step(fu, k, 0);
    journal_step(fu, k, k >= fu->join_k);
}

/* 1 once step N is out and nothing more is coming that could revise a step:
 * every node heard from has every payload its epochs own of the steps still
 * revisable, or has been silent for linger_us (docs/network.md, "End of a
 * run"). Without it a payload held back at the end (reordered, or a node
 * slowed down by the load) would leave its last steps degraded for good. */
static int settled(dkf_net_fusion_t *fu, int64_t now)
{
    const long k0 = fu->N - DKF_NET_CKPT + 1 > fu->join_k ? fu->N - DKF_NET_CKPT + 1 : fu->join_k;
    size_t i;
    long k;
    if (fu->done_k < fu->N) return 0;
    for (i = 0; i < fu->l; ++i) {
        const peer_t *p = &fu->peer[i];
        if (p->last_mono == INT64_MIN || now - p->last_mono >= fu->linger_us) continue;
        for (k = k0; k <= fu->N; ++k) {
            const epoch_t *e = owner(fu, i, k);
            if (e != NULL && e->usable && payload(fu, i, k) == NULL) return 0;
        }
    }
    return 1;
}

static void finish_if_settled(dkf_net_fusion_t *fu, int64_t now)
{
    if (fu->state != DKF_NET_RUNNING || !settled(fu, now)) return;
    fu->state = DKF_NET_DONE;
    dkf_net_fusion_report(fu);
}

/* New data for step j <= done_k: back to the checkpoint after step j-1,
 * every step since recomputed and published again (revision > 0), so a
 * subscriber holds the final value of every step. */
static void roll_back(dkf_net_fusion_t *fu, long j)
{
    const size_t c = (size_t)(j - 1) % (DKF_NET_CKPT + 1);
    long k;
    if (!have_ckpt(fu, j - 1) ||
        dkf_diffkf_fc_restore(&fu->fc, fu->ck + c * fu->ck_len, fu->ck_len) != DKF_OK) {
        ++fu->fx.too_late;
        fu_note(fu, "fusion: no checkpoint before step k=%ld: late data ignored", j);
        return;
    }
    ++fu->fx.rollbacks;
    for (k = j; k <= fu->done_k; ++k) {
        if (compute_step(fu, k) != 0) {
            fail(fu);
            return;
        }
        ++fu->rec.revisions[k - 1];
        ++fu->fx.replayed;
        if (k >= fu->join_k) publish_step(fu, k, fu->rec.revisions[k - 1]);
        journal_step(fu, k, k >= fu->join_k);
    }
}

/* 1 if node i's payload of step k is not worth waiting for
 * (docs/decisions.md, "a late step never holds back the steps behind it";
 * docs/network.md, "Deadlines"): the node has moved on (its message of step k+2 or
 * later arrived, and message k+1 would have carried a copy of payload k),
 * or it has been silent for a deadline of arrivals from the others (dead,
 * never started, or cut off). Both are judged on what has arrived, never on
 * the fusion centre's own clock, so a centre that falls behind catches up
 * at the speed it reads its socket. */
static int given_up(const dkf_net_fusion_t *fu, size_t i, long k)
{
    const peer_t *p = &fu->peer[i];
    const int64_t heard = p->last_recv != INT64_MIN ? p->last_recv : fu->first_recv;
    if (p->k_max >= k + 2) return 1;
    return fu->first_recv != INT64_MIN && fu->newest_recv - heard >= fu->deadline_us;
}

/* 1 if step k has nothing more to wait for: it has opened (a payload of it
 * or of a later step arrived) and every node whose epoch owns k has its
 * payload there or is given up on (a late node before its start owns
 * nothing). */
static int step_ready(dkf_net_fusion_t *fu, long k)
{
    size_t i;
    if (fu->newest_k < k) return 0;
    for (i = 0; i < fu->l; ++i) {
        const epoch_t *e = owner(fu, i, k);
        if (e != NULL && e->usable && payload(fu, i, k) == NULL && !given_up(fu, i, k)) return 0;
    }
    return 1;
}

/* Publishes every step that has all it can get. */
static void advance(dkf_net_fusion_t *fu)
{
    while (fu->state == DKF_NET_RUNNING && fu->done_k < fu->N) {
        if (!step_ready(fu, fu->done_k + 1)) break;
        next_step(fu, dkf_net_mono_us());
    }
    finish_if_settled(fu, dkf_net_mono_us());
}

/* A payload of step k arrived: the window follows it. Steps more than
 * DKF_NET_WINDOW behind k are published now with what they have, so no
 * payload is ever discarded as too far ahead and one slow step cannot hold
 * back the steps behind it. */
static void follow_window(dkf_net_fusion_t *fu, long k)
{
    while (fu->state == DKF_NET_RUNNING && fu->done_k < fu->N &&
           fu->done_k < k - DKF_NET_WINDOW) {
        ++fu->fx.pushed;
        fu_note(fu, "fusion: step k=%ld pushed out of the window by step k=%ld",
                fu->done_k + 1, k);
        next_step(fu, dkf_net_mono_us());
    }
}

/* The first message a centre gets, of step k: a centre started (or
 * restarted) after the nodes joins at the first step it has a payload of
 * (k - 1 from the copy, or k). The steps before are computed without data
 * (the prediction; the nodes' replicas run their data-independent
 * recursions, so they stay in sync) and recorded, not published. */
static void join_at(dkf_net_fusion_t *fu, long k)
{
    fu->join_k = k < 1 ? 1 : k;
    while (fu->state == DKF_NET_RUNNING && fu->done_k + 1 < fu->join_k)
        next_step(fu, dkf_net_mono_us());
    if (fu->join_k > 1)
        fu_note(fu, "fusion: joined the run at step k=%ld (steps before it skipped)",
                fu->join_k);
}

/* Messages made by node i, from the sequence numbers of each of its runs. */
static void count_made(peer_t *p, long epoch, long k_start, int64_t seq)
{
    size_t j;
    for (j = 0; j < p->ninc; ++j)
        if (p->inc[j].epoch == epoch && p->inc[j].k_start == k_start) break;
    if (j == p->ninc) {
        if (p->ninc == EPOCHS) { /* forget the oldest run, keep its count */
            p->made_before += p->inc[0].seq_max + 1;
            memmove(p->inc, p->inc + 1, (EPOCHS - 1) * sizeof p->inc[0]);
            --p->ninc;
        }
        j = p->ninc++;
        p->inc[j].epoch = epoch;
        p->inc[j].k_start = k_start;
        p->inc[j].seq_max = -1;
    }
    if (seq > p->inc[j].seq_max) p->inc[j].seq_max = seq;
}

static int64_t made_by(const peer_t *p)
{
    int64_t made = p->made_before;
    size_t j;
    for (j = 0; j < p->ninc; ++j) made += p->inc[j].seq_max + 1;
    return made;
}

static void on_node_msg(const char *channel, const void *data, size_t len, int64_t recv_utime,
                        void *user)
{
    dkf_net_fusion_t *fu = user;
    dkf_net_expect_t ex;
    dkf_net_meta_t meta;
    dkf_net_verdict_t v;
    peer_t *p;
    long dirty = LONG_MAX, e;
    size_t i;
    if (fu->state != DKF_NET_RUNNING) return;
    ex.model_id = fu->model_id;
    ex.nnodes = fu->l;
    ex.node = dkf_net_chan_index(channel);
    if (ex.node < 0) ex.node = (long)fu->l; /* no index in the name: no node matches */
    ex.n = fu->n;
    ex.m = NULL;
    ex.kmax = fu->N;
    v = dkf_net_decode_node_msg(data, len, &ex, &fu->in, &fu->in_prev, &meta, &fu->c.why);
    if (v != DKF_NET_ACCEPT) {
        ++fu->c.rejected;
        fu_note(fu, "fusion: message on %s rejected: %s", channel, dkf_net_verdict_str(v));
        return;
    }
    i = fu->in.node;
    p = &fu->peer[i];
    count_made(p, meta.epoch, meta.k_start, meta.seq);
    if (fu->first_recv == INT64_MIN) {
        fu->first_recv = recv_utime;
        if (fu->done_k == 0) join_at(fu, meta.has_prev ? (long)fu->in_prev.k : (long)fu->in.k);
    }
    e = note_epoch(fu, i, meta.epoch, meta.k_start);
    if (e < 0) {
        ++fu->fx.conflicts;
        ++fu->c.stale;
        fu_note(fu, "fusion: node %zu: epoch %ld from k=%ld contradicts its earlier messages", i,
                meta.epoch, meta.k_start);
        return;
    }
    if (e <= fu->done_k) dirty = e;
    /* arrivals (the clock of given_up) and the newest step heard of */
    if (recv_utime > fu->newest_recv) fu->newest_recv = recv_utime;
    p->last_recv = recv_utime;
    p->last_mono = dkf_net_mono_us();
    if ((long)fu->in.k > p->k_max) p->k_max = (long)fu->in.k;
    if ((long)fu->in.k > fu->newest_k) fu->newest_k = (long)fu->in.k;
    follow_window(fu, (long)fu->in.k);
    if (meta.has_prev &&
        store_payload(fu, i, meta.epoch, &fu->in_prev, 0, 0, recv_utime) &&
        (long)fu->in_prev.k <= fu->done_k && (long)fu->in_prev.k < dirty)
        dirty = (long)fu->in_prev.k;
    if (store_payload(fu, i, meta.epoch, &fu->in, 1, meta.meas_utime, recv_utime) &&
        (long)fu->in.k <= fu->done_k && (long)fu->in.k < dirty)
        dirty = (long)fu->in.k;
    if (dirty <= fu->done_k) {
        ++fu->fx.late;
        roll_back(fu, dirty);
    }
    advance(fu);
}

void dkf_net_fusion_tick(dkf_net_fusion_t *fu, int64_t mono_us, int64_t heartbeat_us)
{
    while (fu->state == DKF_NET_RUNNING && fu->done_k < fu->N) {
        /* Step done_k + 1 opened with its first payload or any later step's,
         * or when step done_k was published: once the first step is out,
         * nothing (all nodes' messages lost or held back) can make the FC
         * wait for more than one deadline. */
        const long k = fu->done_k + 1;
        int64_t open = fu->done_k > 0 ? fu->done_mono : 0;
        size_t j;
        for (j = 0; j < RING; ++j)
            if (fu->open_k[j] >= k && (open == 0 || fu->open_mono[j] < open))
                open = fu->open_mono[j];
        /* (monotonic time is never 0 on a running system) */
        if (open == 0 || mono_us - open < fu->deadline_us) break;
        fu_note(fu, "fusion: step k=%ld missed its deadline", k);
        next_step(fu, mono_us);
        advance(fu);
    }
    finish_if_settled(fu, mono_us);
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
    fu->P0_local = calloc(l * n * n, sizeof *fu->P0_local);
    fu->peer = calloc(l, sizeof *fu->peer);
    fu->msgs = calloc(l, sizeof *fu->msgs);
    fu->present = calloc(l, 1);
    fu->contrib = calloc(l, 1);
    fu->rec.xf = calloc(N * n, sizeof(double));
    fu->rec.xp = calloc(N * n, sizeof(double));
    fu->rec.Pf = calloc(N * n * n, sizeof(double));
    fu->rec.Pp = calloc(N * n * n, sizeof(double));
    fu->rec.degraded = calloc(N, sizeof(int));
    fu->rec.first_degraded = calloc(N, sizeof(int));
    fu->rec.revisions = calloc(N, sizeof(int));
    fu->rec.contributed = calloc(N * l, 1);
    fu->rec.first_contributed = calloc(N * l, 1);
    fu->rec.lat_first = calloc(N, sizeof(int64_t));
    fu->rec.lat_last = calloc(N, sizeof(int64_t));
    if (!fu->md || !fu->sens || !fu->fcn || !fu->P0_local || !fu->peer || !fu->msgs ||
        !fu->present || !fu->contrib || !fu->rec.xf || !fu->rec.xp || !fu->rec.Pf ||
        !fu->rec.Pp || !fu->rec.degraded || !fu->rec.first_degraded || !fu->rec.revisions ||
        !fu->rec.contributed || !fu->rec.first_contributed || !fu->rec.lat_first ||
        !fu->rec.lat_last)
        return -1;
    for (j = 0; j < l; ++j) {
        peer_t *p = &fu->peer[j];
        p->last_recv = INT64_MIN;
        p->last_mono = INT64_MIN;
        /* until a message says otherwise, node j started normally at step 1 */
        p->nep = 1;
        p->ep[0].epoch = 0;
        p->ep[0].k_start = 1;
        p->ep[0].assumed = 1;
        p->ep[0].usable = 1;
        if (dkf_net_model_init(&fu->md[j], fu->s, j) != 0) return -1;
        dkf_scn_to_real(fu->P0_local + j * n * n, dkf_scn_P00_local(fu->s, j), n * n);
    }
    for (j = 0; j <= DKF_NET_CKPT; ++j) fu->ck_k[j] = -1;
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
    if (st == DKF_OK) {
        /* the checkpoint ring, and the state after the start (before step 1) */
        fu->ck_len = dkf_diffkf_fc_checkpoint_len(&fu->fc);
        fu->ck = calloc((DKF_NET_CKPT + 1) * fu->ck_len, sizeof *fu->ck);
        if (fu->ck_len == 0 || fu->ck == NULL) {
            snprintf(err, errlen, "%s: fusion: no storage for the checkpoints", s->file);
            return -1;
        }
        save_ckpt(fu, 0);
    }
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
    fu->linger_us = 2 * fu->deadline_us > DKF_NET_LINGER_US ? 2 * fu->deadline_us
                                                             : DKF_NET_LINGER_US;
    fu->state = DKF_NET_RUNNING;
    fu->last_beat = INT64_MIN;
    fu->first_recv = fu->newest_recv = INT64_MIN;
    fu->join_k = 1;
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
    free(fu->md);
    free(fu->sens);
    free(fu->fcn);
    free(fu->fc_store);
    free(fu->P0_local);
    free(fu->peer);
    free(fu->msgs);
    free(fu->present);
    free(fu->contrib);
    free(fu->ck);
    free(fu->rec.xf);
    free(fu->rec.xp);
    free(fu->rec.Pf);
    free(fu->rec.Pp);
    free(fu->rec.degraded);
    free(fu->rec.first_degraded);
    free(fu->rec.revisions);
    free(fu->rec.contributed);
    free(fu->rec.first_contributed);
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

void dkf_net_fusion_journal(dkf_net_fusion_t *fu, FILE *f)
{
    json_t *o = json_object();
    char id[32];
    fu->journal = f;
    if (f == NULL) {
        json_decref(o);
        return;
    }
    /* a header line per run of the centre: a restarted one appends its own */
    snprintf(id, sizeof id, "%016llx", (unsigned long long)(uint64_t)fu->model_id);
    json_object_set_new(o, "journal", json_string("dkf-fusion"));
    json_object_set_new(o, "scenario", json_string(fu->s->file));
    json_object_set_new(o, "model_id", json_string(id));
    set_int(o, "N", fu->N);
    set_int(o, "start_utime", dkf_net_now_us());
    if (json_dumpf(o, f, JSON_COMPACT) != 0 || fputc('\n', f) == EOF || fflush(f) != 0) {
        fu_note(fu, "fusion: cannot write the journal");
        fu->journal = NULL;
    }
    json_decref(o);
}

int dkf_net_fusion_state(const dkf_net_fusion_t *fu) { return fu->state; }
long dkf_net_fusion_k(const dkf_net_fusion_t *fu) { return fu->done_k; }
const dkf_net_counts_t *dkf_net_fusion_counts(const dkf_net_fusion_t *fu) { return &fu->c; }

/* ---- result document -------------------------------------------------------------- */

/* Every epoch a message announced, per node: [{epoch, k_start, usable}]. */
static json_t *json_epochs(const dkf_net_fusion_t *fu)
{
    json_t *all = json_array();
    size_t i, j;
    for (i = 0; i < fu->l; ++i) {
        const peer_t *p = &fu->peer[i];
        json_t *a = json_array();
        for (j = 0; j < p->nep; ++j) {
            json_t *e;
            if (p->ep[j].assumed) continue;
            e = json_object();
            set_int(e, "epoch", p->ep[j].epoch);
            set_int(e, "k_start", p->ep[j].k_start);
            json_object_set_new(e, "usable", json_boolean(p->ep[j].usable));
            json_array_append_new(a, e);
        }
        json_array_append_new(all, a);
    }
    return all;
}

json_t *dkf_net_fusion_result(const dkf_net_fusion_t *fu)
{
    const size_t n = fu->n, l = fu->l, K = (size_t)fu->done_k;
    json_t *doc = json_object(), *ks = json_array(), *fused = json_object();
    json_t *xf = json_array(), *xp = json_array(), *Pf = json_array(), *Pp = json_array();
    json_t *status = json_array(), *contrib = json_array(), *lf = json_array(), *ll = json_array();
    json_t *fstatus = json_array(), *fcontrib = json_array(), *revs = json_array();
    json_t *counts = json_object(), *why = json_object(), *got = json_array(), *sent = json_array();
    json_t *lost = json_array(), *outputs = json_object(), *lat = json_object();
    json_t *faults = json_object();
    char id[32];
    size_t j, i, v;
    int64_t degraded = 0, revised = 0;
    for (j = 0; j < K; ++j) {
        json_array_append_new(ks, json_integer((json_int_t)j + 1));
        json_array_append_new(xf, dkf_json_doubles(fu->rec.xf + j * n, n, 0));
        json_array_append_new(xp, dkf_json_doubles(fu->rec.xp + j * n, n, 0));
        json_array_append_new(Pf, dkf_json_doubles(fu->rec.Pf + j * n * n, n, n));
        json_array_append_new(Pp, dkf_json_doubles(fu->rec.Pp + j * n * n, n, n));
        json_array_append_new(status, json_string(fu->rec.degraded[j] ? "degraded" : "complete"));
        json_array_append_new(fstatus,
                              json_string(fu->rec.first_degraded[j] ? "degraded" : "complete"));
        json_array_append_new(contrib, json_nodes(fu->rec.contributed + j * l, l));
        json_array_append_new(fcontrib, json_nodes(fu->rec.first_contributed + j * l, l));
        json_array_append_new(revs, json_integer((json_int_t)fu->rec.revisions[j]));
        json_array_append_new(lf, json_integer((json_int_t)fu->rec.lat_first[j]));
        json_array_append_new(ll, json_integer((json_int_t)fu->rec.lat_last[j]));
        degraded += fu->rec.degraded[j];
        revised += fu->rec.revisions[j] > 0;
    }
    json_object_set_new(fused, "xf", xf);
    json_object_set_new(fused, "xp", xp);
    json_object_set_new(fused, "Pf", Pf);
    json_object_set_new(fused, "Pp", Pp);
    json_object_set_new(outputs, "fused", fused);
    json_object_set_new(lat, "first", lf);
    json_object_set_new(lat, "last", ll);
    for (i = 0; i < l; ++i) {
        const peer_t *p = &fu->peer[i];
        const int64_t made = made_by(p);
        json_array_append_new(got, json_integer((json_int_t)p->got));
        json_array_append_new(sent, json_integer((json_int_t)made));
        json_array_append_new(lost, json_integer((json_int_t)(made - p->got)));
    }
    for (v = 1; v < DKF_NET_NVERDICTS; ++v)
        json_object_set_new(why, dkf_net_verdict_str((dkf_net_verdict_t)v),
                            json_integer((json_int_t)fu->c.why.by[v]));
    set_int(faults, "duplicates", fu->fx.duplicates);
    set_int(faults, "recovered_by_redundancy", fu->fx.redundant);
    set_int(faults, "late_data", fu->fx.late);
    set_int(faults, "too_late", fu->fx.too_late);
    set_int(faults, "too_far_ahead", fu->fx.ahead);
    set_int(faults, "old_epoch", fu->fx.old_epoch);
    set_int(faults, "epoch_conflicts", fu->fx.conflicts);
    set_int(faults, "lost_epochs", fu->fx.lost_epochs);
    set_int(faults, "rollbacks", fu->fx.rollbacks);
    set_int(faults, "replayed_steps", fu->fx.replayed);
    set_int(faults, "revised_published", fu->fx.revised_sent);
    set_int(faults, "core_refusals", fu->fx.core_masked);
    set_int(faults, "restarts_applied", fu->fx.restarts);
    set_int(faults, "pushed_by_window", fu->fx.pushed);
    json_object_set_new(counts, "received", got);
    json_object_set_new(counts, "sent_by_node", sent);
    json_object_set_new(counts, "not_received", lost);
    set_int(counts, "rejected", fu->c.rejected);
    json_object_set_new(counts, "rejected_by_reason", why);
    set_int(counts, "stale", fu->c.stale);
    set_int(counts, "degraded_steps", degraded);
    set_int(counts, "degraded_at_first_publication", fu->c.missed);
    set_int(counts, "revised_steps", revised);
    set_int(counts, "published", fu->c.sent);
    json_object_set_new(counts, "faults", faults);
    snprintf(id, sizeof id, "%016llx", (unsigned long long)(uint64_t)fu->model_id);
    json_object_set_new(doc, "scenario", json_string(fu->s->file));
    json_object_set_new(doc, "real", json_string(DKF_USE_FLOAT ? "float" : "double"));
    json_object_set_new(doc, "model_id", json_string(id));
    set_int(doc, "N", fu->N);
    set_int(doc, "deadline_us", fu->deadline_us);
    set_int(doc, "checkpoints", DKF_NET_CKPT);
    set_int(doc, "joined_at", fu->join_k);
    json_object_set_new(doc, "k", ks);
    json_object_set_new(doc, "outputs", outputs);
    json_object_set_new(doc, "status", status);
    json_object_set_new(doc, "contributors", contrib);
    json_object_set_new(doc, "revisions", revs);
    json_object_set_new(doc, "first_status", fstatus);
    json_object_set_new(doc, "first_contributors", fcontrib);
    json_object_set_new(doc, "epochs", json_epochs(fu));
    json_object_set_new(doc, "latency_us", lat);
    json_object_set_new(doc, "counters", counts);
    if (fu->error[0] != '\0') json_object_set_new(doc, "last_note", json_string(fu->error));
    return doc;
}
