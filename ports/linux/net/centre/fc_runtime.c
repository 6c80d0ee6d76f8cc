/*
 * fc_runtime.c - the fusion centre's payload ring, epochs, deadlines,
 * checkpoints, rollback/replay and linger (fc_runtime.h; docs/design/network.md
 * "Faults"), with the fusion itself behind a dkf_fcr_ops_t table.
 *
 * Node i's contribution to step k may need its payloads of steps k and k-1
 * (the Difference KF rebuilds z^i_k from both); a message carries the payload
 * of its own step and of the previous one, so a lost message is recovered by
 * the next; a payload that arrives after its step was published (within
 * DKF_FCR_CKPT steps) restores the checkpoint taken before that step and
 * replays every step since with the data now known, which gives exactly what
 * the centre would have computed had the payload been on time.
 *
 * The work late data can force is bounded, whoever sends it and however
 * fast (docs/guide/network.md, "Threat model"): a revision rolls back at once
 * only if no rollback happened since the last first publication or for a
 * deadline; otherwise it waits, merged with any other, and runs before the
 * next step is published (or a deadline later). So between two first
 * publications there are at most two rollbacks, each recomputing at most
 * DKF_FCR_CKPT steps.
 */
#define _POSIX_C_SOURCE 200112L /* clock_gettime */

#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fc_runtime.h"

/* Payloads kept per node: DKF_FCR_CKPT revisable steps, the present one and
 * DKF_FCR_WINDOW ahead, indexed by k modulo RING. */
#define RING (DKF_FCR_WINDOW + DKF_FCR_CKPT + 2)
#define NCKPT (DKF_FCR_CKPT + 1)
#define EPOCHS 8 /* epochs remembered per node */
#define ALIGN 16 /* payload and checkpoint slots start at multiples of this */

/* One node's payload of step k, however it arrived (its bytes: slot_of). */
typedef struct {
    long k;              /* the step held (0: empty) */
    long epoch;
    int direct;          /* step k's own message arrived (not only the next one's copy) */
    int64_t meas_utime, recv_utime;
} slot_t;

/* An epoch of a node's local filter: it (re)started at k_start. */
typedef struct {
    long epoch, k_start;
    int assumed;  /* epoch 0 from step 1, until a message says otherwise */
    int usable;   /* 0: it started at a step older than every checkpoint */
    int applied;  /* the restart was mirrored (counted once) */
} epoch_t;

/* One run of a node's process as its sequence numbers count it: a
 * (re)start, told apart by (epoch, k_start) (a process restarted without
 * --epoch repeats the epoch but not the first step). */
typedef struct {
    long epoch, k_start;
    int64_t seq_max; /* largest seq seen (-1: none) */
} incarnation_t;

typedef struct {
    slot_t slot[RING];
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

typedef struct {
    int *degraded, *first_degraded, *revisions;
    unsigned char *contributed, *first_contributed;
    int64_t *lat_first, *lat_last;
    int64_t *t_arrive, *t_wait, *t_compute, *t_publish; /* N: lat_last's parts (-1) */
} record_t;

struct dkf_fcr {
    dkf_fcr_config_t cfg;
    const dkf_fcr_ops_t *ops;
    void *user;
    size_t l, pay_stride, ck_stride;
    long N;
    peer_t *peer;                 /* l */
    unsigned char *pay;           /* l x RING payload slots of pay_stride bytes */
    const void **in;              /* l: the running step's payloads (NULL: missing) */
    unsigned char *contrib;       /* l */
    long open_k[RING];            /* step k opened (its first payload arrived) at open_mono */
    int64_t open_mono[RING];
    unsigned char *ck;            /* NCKPT checkpoints: state after step ck_k[j] */
    long ck_k[NCKPT];
    long done_k;                  /* last published step */
    long newest_k;                /* newest step of any message accepted */
    long join_k;                  /* first step fused from data (steps before it were
                                     skipped: a centre started or restarted mid-run) */
    int64_t first_recv, newest_recv; /* arrival of the first and the newest message */
    int64_t comp_begin, comp_end; /* wall clock around the last ops->step */
    int64_t done_mono;            /* when step done_k was first published (monotonic):
                                     step done_k + 1 opens then at the latest */
    long revise_k;                /* first published step late data changed (LONG_MAX:
                                     none): recomputed by the next rollback */
    long rolled_k;                /* done_k at the last rollback (-1: none yet) */
    int64_t rolled_mono;          /* and its time (monotonic) */
    record_t rec;
    dkf_fcr_steps_t steps;        /* read-only view of rec */
    dkf_fcr_counts_t c;
    int state;
    char note[DKF_FCR_NOTE_LEN];
};

void dkf_fcr_notef(dkf_fcr_t *rt, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(rt->note, sizeof rt->note, fmt, ap);
    va_end(ap);
}

/* Wall clock, us (the clock of the time stamps in messages): only recorded,
 * never used to decide anything. */
static int64_t wall_us(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_REALTIME, &ts) != 0) return 0;
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

static size_t round_up(size_t v) { return (v + ALIGN - 1) / ALIGN * ALIGN; }

static unsigned char *slot_bytes(const dkf_fcr_t *rt, size_t i, long k)
{
    return rt->pay + (i * RING + (size_t)k % RING) * rt->pay_stride;
}

/* ---- epochs and payloads ---------------------------------------------------------- */

/* The epoch that owns step k of node i (the newest that started at or
 * before k), or NULL (a late node before its start). */
static epoch_t *owner(const dkf_fcr_t *rt, size_t i, long k)
{
    peer_t *p = &rt->peer[i];
    size_t j = p->nep;
    while (j > 0) {
        --j;
        if (p->ep[j].k_start <= k) return &p->ep[j];
    }
    return NULL;
}

/* Node i's payload of step k, if it is there and belongs to the epoch that
 * owns k (a usable one). */
static const slot_t *payload(const dkf_fcr_t *rt, size_t i, long k)
{
    const slot_t *q = &rt->peer[i].slot[(size_t)k % RING];
    const epoch_t *e = owner(rt, i, k);
    if (q->k != k || e == NULL || !e->usable || q->epoch != e->epoch) return NULL;
    return q;
}

/* 1 if the checkpoint taken after step k is still in the ring. */
static int have_ckpt(const dkf_fcr_t *rt, long k)
{
    return k >= 0 && rt->ck_k[(size_t)k % NCKPT] == k;
}

/* 1 if an epoch starting at k_start can still be followed. */
static int can_follow(const dkf_fcr_t *rt, long k_start)
{
    return k_start == 1 || k_start > rt->done_k || have_ckpt(rt, k_start - 1);
}

/* Registers (epoch, k_start) of node i. Returns the first step whose
 * computation it changes (a restart at k_start), LONG_MAX if none, or -1 if
 * it contradicts what is known (then the message is ignored). */
static long note_epoch(dkf_fcr_t *rt, size_t i, long epoch, long k_start)
{
    peer_t *p = &rt->peer[i];
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
        q->usable = can_follow(rt, k_start);
        if (!q->usable) ++rt->c.lost_epochs;
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
    e.usable = can_follow(rt, k_start);
    e.applied = 0;
    if (!e.usable) ++rt->c.lost_epochs;
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

/* Stores node i's payload of step k (arrived at mono); returns 1 if it is
 * new information. meas_utime: the time stamp of the measurement that
 * completed step k (its own message), 0 for the copy in message k+1. */
static int store_payload(dkf_fcr_t *rt, size_t i, long epoch, long k, const void *bytes,
                         int direct, int64_t meas_utime, int64_t recv_utime, int64_t mono)
{
    peer_t *p = &rt->peer[i];
    slot_t *q = &p->slot[(size_t)k % RING];
    const epoch_t *e = owner(rt, i, k);
    if (e == NULL || e->epoch != epoch) {
        if (direct) {
            ++rt->c.old_epoch;
            ++rt->c.stale;
            dkf_fcr_notef(rt, "fusion: node %zu step k=%ld of epoch %ld: not the epoch of that step",
                          i, k, epoch);
        }
        return 0;
    }
    if (k > rt->done_k + DKF_FCR_WINDOW || k <= rt->done_k - DKF_FCR_CKPT) {
        if (direct) {
            if (k > rt->done_k) ++rt->c.ahead; else ++rt->c.too_late;
            ++rt->c.stale;
            dkf_fcr_notef(rt, "fusion: node %zu step k=%ld is %s", i, k,
                          k > rt->done_k ? "too far ahead" : "too late to revise");
        }
        return 0;
    }
    if (q->k == k && q->epoch == epoch) {
        if (direct && q->direct) {
            ++rt->c.duplicates;
            ++rt->c.stale;
            dkf_fcr_notef(rt, "fusion: node %zu step k=%ld: duplicate", i, k);
        } else if (direct) {
            q->direct = 1; /* its copy came first (reordered or after a drop) */
            q->meas_utime = meas_utime; /* the copy had no measurement time */
            ++p->got;
            ++rt->c.received;
        }
        return 0;
    }
    q->k = k;
    q->epoch = epoch;
    q->direct = direct;
    if (rt->ops->copy != NULL)
        rt->ops->copy(rt->user, slot_bytes(rt, i, k), bytes);
    else
        memcpy(slot_bytes(rt, i, k), bytes, rt->cfg.payload_size);
    q->meas_utime = meas_utime;
    q->recv_utime = recv_utime;
    if (direct) {
        ++p->got;
        ++rt->c.received;
    } else {
        ++rt->c.redundant;
    }
    if (rt->open_k[(size_t)k % RING] != k) {
        rt->open_k[(size_t)k % RING] = k;
        rt->open_mono[(size_t)k % RING] = mono;
    }
    return 1;
}

/* ---- one step --------------------------------------------------------------------- */

/* Mirrors the (re)starts of local filters at step k (before the step). */
static void restart_nodes(dkf_fcr_t *rt, long k)
{
    size_t i;
    for (i = 0; i < rt->l; ++i) {
        epoch_t *e = owner(rt, i, k);
        if (e == NULL || !e->usable || e->k_start != k || k == 1) continue;
        if (rt->ops->restart != NULL && rt->ops->restart(rt->user, i, k) != 0) {
            /* the user cannot follow this epoch: the node stays masked */
            e->usable = 0;
            ++rt->c.lost_epochs;
            continue;
        }
        /* counted once, whether first applied on time or in a replay */
        if (!e->applied) ++rt->c.restarts;
        e->applied = 1;
    }
}

/* Saves the user's state after step k into the checkpoint ring. */
static void save_ckpt(dkf_fcr_t *rt, long k)
{
    const size_t j = (size_t)k % NCKPT;
    rt->ck_k[j] = rt->ops->save(rt->user, rt->ck + j * rt->ck_stride) == 0 ? k : -1;
}

/* Step k (the user's state is at k-1) with the payloads known now; records
 * it. 0 or -1. */
static int compute_step(dkf_fcr_t *rt, long k)
{
    const size_t l = rt->l, j = (size_t)(k - 1);
    size_t i;
    int refused;
    restart_nodes(rt, k);
    for (i = 0; i < l; ++i) {
        rt->in[i] = payload(rt, i, k) != NULL ? slot_bytes(rt, i, k) : NULL;
        rt->contrib[i] = 0;
    }
    rt->comp_begin = wall_us();
    refused = rt->ops->step(rt->user, k, rt->in, rt->contrib);
    rt->comp_end = wall_us();
    if (refused < 0) return -1;
    rt->c.core_masked += refused;
    for (i = 0; i < l; ++i) rt->contrib[i] = rt->contrib[i] != 0 && rt->in[i] != NULL;
    memcpy(rt->rec.contributed + j * l, rt->contrib, l);
    rt->rec.degraded[j] = memchr(rt->contrib, 0, l) != NULL;
    save_ckpt(rt, k);
    return 0;
}

/* Step k as recorded now, with the time stamps of its contributors. */
static void step_view(const dkf_fcr_t *rt, long k, dkf_fcr_step_t *st)
{
    const size_t l = rt->l, j = (size_t)(k - 1);
    size_t i;
    st->k = k;
    st->revision = rt->rec.revisions[j];
    st->degraded = rt->rec.degraded[j];
    st->nodes = l;
    st->contributed = rt->rec.contributed + j * l;
    st->meas_utime_first = st->meas_utime_last = st->recv_utime_last = 0;
    for (i = 0; i < l; ++i) {
        const slot_t *q = payload(rt, i, k);
        if (!st->contributed[i] || q == NULL) continue;
        if (q->recv_utime > st->recv_utime_last) st->recv_utime_last = q->recv_utime;
        if (q->meas_utime == 0) continue; /* known from a copy only: its time unknown */
        if (st->meas_utime_first == 0 || q->meas_utime < st->meas_utime_first)
            st->meas_utime_first = q->meas_utime;
        if (q->meas_utime > st->meas_utime_last) st->meas_utime_last = q->meas_utime;
    }
}

/* Step j's first publication at utime split into the parts of lat_last
 * (docs/design/network.md, "Where the latency goes"): the last contributing
 * measurement to its node message's arrival, arrival to the step's
 * computation, the computation, and its end to the publication. */
static void record_parts(dkf_fcr_t *rt, size_t j, const dkf_fcr_step_t *st, int64_t utime)
{
    const int known = st->meas_utime_last != 0 && st->recv_utime_last != 0 && utime != 0;
    rt->rec.t_arrive[j] = known ? st->recv_utime_last - st->meas_utime_last : -1;
    rt->rec.t_wait[j] = known ? rt->comp_begin - st->recv_utime_last : -1;
    rt->rec.t_compute[j] = rt->comp_end - rt->comp_begin;
    rt->rec.t_publish[j] = utime != 0 ? utime - rt->comp_end : -1;
}

/* Publishes (from the join on) and records the step just computed. */
static void emit_step(dkf_fcr_t *rt, long k)
{
    const size_t l = rt->l, j = (size_t)(k - 1);
    const int published = k >= rt->join_k;
    dkf_fcr_step_t st;
    int64_t utime = 0;
    step_view(rt, k, &st);
    if (published) {
        if (rt->ops->publish(rt->user, &st, &utime) == 0) ++rt->c.sent;
        if (st.revision == 0) {
            rt->rec.first_degraded[j] = st.degraded;
            memcpy(rt->rec.first_contributed + j * l, st.contributed, l);
            rt->rec.lat_first[j] = st.meas_utime_first ? utime - st.meas_utime_first : -1;
            rt->rec.lat_last[j] = st.meas_utime_last ? utime - st.meas_utime_last : -1;
            record_parts(rt, j, &st, utime);
            if (st.degraded) ++rt->c.missed;
        } else {
            ++rt->c.revised_sent;
        }
    }
    if (rt->ops->record != NULL) rt->ops->record(rt->user, &st, published);
}

static void set_state(dkf_fcr_t *rt, int state)
{
    rt->state = state;
    if (rt->ops->state != NULL) rt->ops->state(rt->user, state);
}

static void roll_back(dkf_fcr_t *rt, int64_t now);

/* Computes and publishes step done_k + 1 for the first time (at monotonic
 * time now), after the revision waiting if any. */
static void next_step(dkf_fcr_t *rt, int64_t now)
{
    const long k = rt->done_k + 1;
    if (rt->revise_k <= rt->done_k) roll_back(rt, now); /* the waiting revision first */
    if (rt->state != DKF_FCR_RUNNING) return;
    if (compute_step(rt, k) != 0) {
        set_state(rt, DKF_FCR_FAILED);
        return;
    }
    rt->done_k = k;
    rt->done_mono = now;
    emit_step(rt, k);
}

/* 1 once step N is out and nothing more is coming that could revise a step:
 * every node heard from has every payload its epochs own of the steps still
 * revisable, or has been silent for linger_us (docs/design/network.md, "End of a
 * run"). Without it a payload held back at the end (reordered, or a node
 * slowed down by the load) would leave its last steps degraded for good. */
static int settled(const dkf_fcr_t *rt, int64_t now)
{
    const long k0 = rt->N - DKF_FCR_CKPT + 1 > rt->join_k ? rt->N - DKF_FCR_CKPT + 1 : rt->join_k;
    size_t i;
    long k;
    if (rt->done_k < rt->N || rt->revise_k <= rt->done_k) return 0;
    for (i = 0; i < rt->l; ++i) {
        const peer_t *p = &rt->peer[i];
        if (p->last_mono == INT64_MIN || now - p->last_mono >= rt->cfg.linger_us) continue;
        for (k = k0; k <= rt->N; ++k) {
            const epoch_t *e = owner(rt, i, k);
            if (e != NULL && e->usable && payload(rt, i, k) == NULL) return 0;
        }
    }
    return 1;
}

static void finish_if_settled(dkf_fcr_t *rt, int64_t now)
{
    if (rt->state == DKF_FCR_RUNNING && settled(rt, now)) set_state(rt, DKF_FCR_DONE);
}

/* The revision waiting (revise_k <= done_k): back to the checkpoint after
 * step j-1 = revise_k - 1, every step since recomputed and published again
 * (revision > 0), so a subscriber holds the final value of every step. */
static void roll_back(dkf_fcr_t *rt, int64_t now)
{
    const long j = rt->revise_k;
    const size_t c = (size_t)(j - 1) % NCKPT;
    long k;
    rt->revise_k = LONG_MAX;
    rt->rolled_k = rt->done_k;
    rt->rolled_mono = now;
    if (!have_ckpt(rt, j - 1) || rt->ops->restore(rt->user, rt->ck + c * rt->ck_stride) != 0) {
        ++rt->c.too_late;
        dkf_fcr_notef(rt, "fusion: no checkpoint before step k=%ld: late data ignored", j);
        return;
    }
    ++rt->c.rollbacks;
    for (k = j; k <= rt->done_k; ++k) {
        if (compute_step(rt, k) != 0) {
            set_state(rt, DKF_FCR_FAILED);
            return;
        }
        ++rt->rec.revisions[k - 1];
        ++rt->c.replayed;
        emit_step(rt, k);
    }
}

/* Rolls back for the revision waiting if the budget allows it now: no
 * rollback since the last first publication, or none for a deadline. */
static void revise_if_due(dkf_fcr_t *rt, int64_t now)
{
    if (rt->state != DKF_FCR_RUNNING || rt->revise_k > rt->done_k) return;
    if (rt->rolled_k == rt->done_k && now - rt->rolled_mono < rt->cfg.deadline_us) {
        ++rt->c.deferred;
        return;
    }
    roll_back(rt, now);
}

/* ---- when a step is fused ---------------------------------------------------------- */

/* 1 if node i's payload of step k is not worth waiting for
 * (docs/decisions.md, "a late step never holds back the steps behind it";
 * docs/design/network.md, "Deadlines"): the node has moved on (its message of step k+2 or
 * later arrived, and message k+1 would have carried a copy of payload k),
 * or it has been silent for a deadline of arrivals from the others (dead,
 * never started, or cut off). Both are judged on what has arrived, never on
 * the centre's own clock, so a centre that falls behind catches up at the
 * speed it reads its socket. */
static int given_up(const dkf_fcr_t *rt, size_t i, long k)
{
    const peer_t *p = &rt->peer[i];
    const int64_t heard = p->last_recv != INT64_MIN ? p->last_recv : rt->first_recv;
    if (p->k_max >= k + 2) return 1;
    return rt->first_recv != INT64_MIN && rt->newest_recv - heard >= rt->cfg.deadline_us;
}

/* 1 if step k has nothing more to wait for: it has opened (a payload of it
 * or of a later step arrived) and every node whose epoch owns k has its
 * payload there or is given up on (a late node before its start owns
 * nothing). */
static int step_ready(const dkf_fcr_t *rt, long k)
{
    size_t i;
    if (rt->newest_k < k) return 0;
    for (i = 0; i < rt->l; ++i) {
        const epoch_t *e = owner(rt, i, k);
        if (e != NULL && e->usable && payload(rt, i, k) == NULL && !given_up(rt, i, k)) return 0;
    }
    return 1;
}

/* Publishes every step that has all it can get. */
static void advance(dkf_fcr_t *rt, int64_t now)
{
    while (rt->state == DKF_FCR_RUNNING && rt->done_k < rt->N) {
        if (!step_ready(rt, rt->done_k + 1)) break;
        next_step(rt, now);
    }
    finish_if_settled(rt, now);
}

/* A payload of step k arrived: the window follows it. Steps more than
 * DKF_FCR_WINDOW behind k are published now with what they have, so no
 * payload is ever discarded as too far ahead and one slow step cannot hold
 * back the steps behind it. */
static void follow_window(dkf_fcr_t *rt, long k, int64_t now)
{
    while (rt->state == DKF_FCR_RUNNING && rt->done_k < rt->N &&
           rt->done_k < k - DKF_FCR_WINDOW) {
        ++rt->c.pushed;
        dkf_fcr_notef(rt, "fusion: step k=%ld pushed out of the window by step k=%ld",
                      rt->done_k + 1, k);
        next_step(rt, now);
    }
}

/* The first message a centre gets, of step k: a centre started (or
 * restarted) after the nodes joins at the first step it has a payload of
 * (k - 1 from the copy, or k). The steps before are computed without data
 * (for the Difference KF the prediction; the nodes' replicas run their
 * data-independent recursions, so they stay in sync) and recorded, not
 * published. */
static void join_at(dkf_fcr_t *rt, long k, int64_t now)
{
    rt->join_k = k < 1 ? 1 : k;
    while (rt->state == DKF_FCR_RUNNING && rt->done_k + 1 < rt->join_k) next_step(rt, now);
    if (rt->join_k > 1)
        dkf_fcr_notef(rt, "fusion: joined the run at step k=%ld (steps before it skipped)",
                      rt->join_k);
}

/* Messages made by a node, from the sequence numbers of each of its runs. */
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

static int msg_in_range(const dkf_fcr_t *rt, const dkf_fcr_msg_t *m)
{
    return m->node < rt->l && m->k >= 1 && m->k <= rt->N && m->epoch >= 0 &&
           m->k_start >= 1 && m->k_start <= m->k && m->pay != NULL &&
           (m->prev == NULL || m->k - 1 >= m->k_start);
}

int dkf_fcr_receive(dkf_fcr_t *rt, const dkf_fcr_msg_t *m, int64_t mono_us)
{
    const size_t i = m->node;
    peer_t *p;
    long dirty = LONG_MAX, e;
    if (rt->state != DKF_FCR_RUNNING || !msg_in_range(rt, m)) return -1;
    p = &rt->peer[i];
    count_made(p, m->epoch, m->k_start, m->seq);
    if (rt->first_recv == INT64_MIN) {
        rt->first_recv = m->recv_utime;
        if (rt->done_k == 0) join_at(rt, m->prev != NULL ? m->k - 1 : m->k, mono_us);
    }
    e = note_epoch(rt, i, m->epoch, m->k_start);
    if (e < 0) {
        ++rt->c.conflicts;
        ++rt->c.stale;
        dkf_fcr_notef(rt, "fusion: node %zu: epoch %ld from k=%ld contradicts its earlier messages",
                      i, m->epoch, m->k_start);
        return 0;
    }
    if (e <= rt->done_k) dirty = e;
    /* arrivals (the clock of given_up) and the newest step heard of */
    if (m->recv_utime > rt->newest_recv) rt->newest_recv = m->recv_utime;
    p->last_recv = m->recv_utime;
    p->last_mono = mono_us;
    if (m->k > p->k_max) p->k_max = m->k;
    if (m->k > rt->newest_k) rt->newest_k = m->k;
    follow_window(rt, m->k, mono_us);
    if (m->prev != NULL &&
        store_payload(rt, i, m->epoch, m->k - 1, m->prev, 0, 0, m->recv_utime, mono_us) &&
        m->k - 1 <= rt->done_k && m->k - 1 < dirty)
        dirty = m->k - 1;
    if (store_payload(rt, i, m->epoch, m->k, m->pay, 1, m->meas_utime, m->recv_utime, mono_us) &&
        m->k <= rt->done_k && m->k < dirty)
        dirty = m->k;
    if (dirty <= rt->done_k) {
        ++rt->c.late;
        if (dirty < rt->revise_k) rt->revise_k = dirty;
        revise_if_due(rt, mono_us);
    }
    advance(rt, mono_us);
    return 0;
}

void dkf_fcr_tick(dkf_fcr_t *rt, int64_t mono_us)
{
    while (rt->state == DKF_FCR_RUNNING && rt->done_k < rt->N) {
        /* Step done_k + 1 opened with its first payload or any later step's,
         * or when step done_k was published: once the first step is out,
         * nothing (all nodes' messages lost or held back) can make the
         * centre wait for more than one deadline. */
        const long k = rt->done_k + 1;
        int64_t open = rt->done_k > 0 ? rt->done_mono : 0;
        size_t j;
        for (j = 0; j < RING; ++j)
            if (rt->open_k[j] >= k && (open == 0 || rt->open_mono[j] < open))
                open = rt->open_mono[j];
        /* (monotonic time is never 0 on a running system) */
        if (open == 0 || mono_us - open < rt->cfg.deadline_us) break;
        dkf_fcr_notef(rt, "fusion: step k=%ld missed its deadline", k);
        next_step(rt, mono_us);
        advance(rt, mono_us);
    }
    revise_if_due(rt, mono_us);
    finish_if_settled(rt, mono_us);
}

/* ---- set-up and queries ------------------------------------------------------------ */

static int config_ok(const dkf_fcr_config_t *c, const dkf_fcr_ops_t *ops)
{
    return c->nodes >= 1 && c->nodes <= DKF_FCR_MAX_NODES && c->steps >= 1 &&
           c->steps <= DKF_FCR_MAX_STEPS && c->payload_size > 0 &&
           c->payload_size <= ((size_t)1 << 24) && c->ckpt_size > 0 &&
           c->ckpt_size <= ((size_t)1 << 28) && c->deadline_us > 0 && c->linger_us > 0 &&
           ops != NULL && ops->step != NULL && ops->save != NULL && ops->restore != NULL &&
           ops->publish != NULL;
}

static int rec_alloc(record_t *r, size_t N, size_t l)
{
    r->degraded = calloc(N, sizeof(int));
    r->first_degraded = calloc(N, sizeof(int));
    r->revisions = calloc(N, sizeof(int));
    r->contributed = calloc(N * l, 1);
    r->first_contributed = calloc(N * l, 1);
    r->lat_first = calloc(N, sizeof(int64_t));
    r->lat_last = calloc(N, sizeof(int64_t));
    r->t_arrive = calloc(N, sizeof(int64_t));
    r->t_wait = calloc(N, sizeof(int64_t));
    r->t_compute = calloc(N, sizeof(int64_t));
    r->t_publish = calloc(N, sizeof(int64_t));
    return r->degraded && r->first_degraded && r->revisions && r->contributed &&
                   r->first_contributed && r->lat_first && r->lat_last && r->t_arrive &&
                   r->t_wait && r->t_compute && r->t_publish
               ? 0
               : -1;
}

dkf_fcr_t *dkf_fcr_create(const dkf_fcr_config_t *cfg, const dkf_fcr_ops_t *ops, void *user)
{
    dkf_fcr_t *rt;
    size_t j;
    if (cfg == NULL || !config_ok(cfg, ops)) return NULL;
    rt = calloc(1, sizeof *rt);
    if (rt == NULL) return NULL;
    rt->cfg = *cfg;
    rt->ops = ops;
    rt->user = user;
    rt->l = cfg->nodes;
    rt->N = cfg->steps;
    rt->pay_stride = round_up(cfg->payload_size);
    rt->ck_stride = round_up(cfg->ckpt_size);
    rt->peer = calloc(rt->l, sizeof *rt->peer);
    rt->pay = calloc(rt->l * RING, rt->pay_stride);
    rt->in = calloc(rt->l, sizeof *rt->in);
    rt->contrib = calloc(rt->l, 1);
    rt->ck = calloc(NCKPT, rt->ck_stride);
    if (!rt->peer || !rt->pay || !rt->in || !rt->contrib || !rt->ck ||
        rec_alloc(&rt->rec, (size_t)rt->N, rt->l) != 0) {
        dkf_fcr_free(rt);
        return NULL;
    }
    for (j = 0; j < rt->l; ++j) {
        peer_t *p = &rt->peer[j];
        p->last_recv = INT64_MIN;
        p->last_mono = INT64_MIN;
        /* until a message says otherwise, node j started normally at step 1 */
        p->nep = 1;
        p->ep[0].epoch = 0;
        p->ep[0].k_start = 1;
        p->ep[0].assumed = 1;
        p->ep[0].usable = 1;
    }
    for (j = 0; j < NCKPT; ++j) rt->ck_k[j] = -1;
    rt->state = DKF_FCR_RUNNING;
    rt->revise_k = LONG_MAX;
    rt->rolled_k = -1;
    rt->first_recv = rt->newest_recv = INT64_MIN;
    rt->join_k = 1;
    rt->steps.degraded = rt->rec.degraded;
    rt->steps.first_degraded = rt->rec.first_degraded;
    rt->steps.revisions = rt->rec.revisions;
    rt->steps.contributed = rt->rec.contributed;
    rt->steps.first_contributed = rt->rec.first_contributed;
    rt->steps.lat_first = rt->rec.lat_first;
    rt->steps.lat_last = rt->rec.lat_last;
    rt->steps.t_arrive = rt->rec.t_arrive;
    rt->steps.t_wait = rt->rec.t_wait;
    rt->steps.t_compute = rt->rec.t_compute;
    rt->steps.t_publish = rt->rec.t_publish;
    save_ckpt(rt, 0); /* the state before step 1 */
    return rt;
}

void dkf_fcr_free(dkf_fcr_t *rt)
{
    if (rt == NULL) return;
    free(rt->peer);
    free(rt->pay);
    free(rt->in);
    free(rt->contrib);
    free(rt->ck);
    free(rt->rec.degraded);
    free(rt->rec.first_degraded);
    free(rt->rec.revisions);
    free(rt->rec.contributed);
    free(rt->rec.first_contributed);
    free(rt->rec.lat_first);
    free(rt->rec.lat_last);
    free(rt->rec.t_arrive);
    free(rt->rec.t_wait);
    free(rt->rec.t_compute);
    free(rt->rec.t_publish);
    free(rt);
}

const dkf_fcr_config_t *dkf_fcr_config(const dkf_fcr_t *rt) { return &rt->cfg; }
int dkf_fcr_state(const dkf_fcr_t *rt) { return rt->state; }
long dkf_fcr_done_k(const dkf_fcr_t *rt) { return rt->done_k; }
long dkf_fcr_join_k(const dkf_fcr_t *rt) { return rt->join_k; }
const dkf_fcr_counts_t *dkf_fcr_counts(const dkf_fcr_t *rt) { return &rt->c; }
const dkf_fcr_steps_t *dkf_fcr_steps(const dkf_fcr_t *rt) { return &rt->steps; }
const char *dkf_fcr_note(const dkf_fcr_t *rt) { return rt->note; }

void dkf_fcr_node_traffic(const dkf_fcr_t *rt, size_t i, int64_t *got, int64_t *made)
{
    *got = i < rt->l ? rt->peer[i].got : 0;
    *made = i < rt->l ? made_by(&rt->peer[i]) : 0;
}

size_t dkf_fcr_epochs(const dkf_fcr_t *rt, size_t i, dkf_fcr_epoch_t *out, size_t cap)
{
    size_t j, n = 0;
    if (i >= rt->l) return 0;
    for (j = 0; j < rt->peer[i].nep; ++j) {
        const epoch_t *e = &rt->peer[i].ep[j];
        if (e->assumed) continue;
        if (n < cap) {
            out[n].epoch = e->epoch;
            out[n].k_start = e->k_start;
            out[n].usable = e->usable;
        }
        ++n;
    }
    return n;
}
