/*
 * The fusion-centre runtime (fc_runtime.h) on its own: no LCM, no
 * transport, no clock. A toy fusion stands behind the operations table and
 * the test hands in synthetic node messages with made-up arrival times and
 * a fake monotonic clock, so every rule is exercised deterministically:
 * complete steps, duplicates, reordering (a payload known from the next
 * message's copy first), a late payload inside the checkpoint window
 * (rollback + replay = the on-time result) and outside it (ignored), a
 * silent node (given up on from the others' arrivals), a node that moves on,
 * the window that follows the arrivals, a restart (new epoch), the join of
 * a centre started mid-run, and the linger after step N.
 *
 * The toy fusion: s_k = s_{k-1} / 2 + sum over the payloads used of v^i_k,
 * with v^i_k = 100 i + k (+ 1000 epoch). Halving makes the order of the
 * steps matter, so a replay that starts from the wrong checkpoint or skips a
 * step gives another number. Every value is a sum of small integers and
 * their halves (exact in double), so results are compared with ==.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "fc_runtime.h"

#define L 3
#define N 20
#define DEADLINE 1000000 /* us */
#define LINGER 2000000   /* us */
#define MAXK (2 * DKF_FCR_WINDOW) /* longest run (the window's test) */

typedef struct {
    long node, k, epoch;
    double v;
} toy_pay_t;

typedef struct {
    long k;   /* the step the state is after */
    double s;
} toy_state_t;

/* What the toy centre published / recorded. */
typedef struct {
    toy_state_t st;
    double value[MAXK + 1];          /* latest publication of step k */
    int revision[MAXK + 1];
    int degraded[MAXK + 1];
    unsigned char contrib[MAXK + 1][L];
    int published;                /* publications */
    int recorded, recorded_unpublished;
    int order_error;              /* a step not after the state's step */
    int restarts[L];
    long restart_k[L];
    int fail_restart;             /* restart op refuses */
    int states;                   /* state callbacks */
    int last_state;
    int64_t utime;
    long computed;                /* calls of the step operation */
} toy_t;

static int toy_step(void *user, long k, const void *const *pay, unsigned char *contrib)
{
    toy_t *t = user;
    size_t i;
    double s = t->st.s / 2;
    ++t->computed;
    if (t->st.k != k - 1) t->order_error = 1;
    for (i = 0; i < L; ++i) {
        const toy_pay_t *p = pay[i];
        contrib[i] = p != NULL;
        if (p == NULL) continue;
        if (p->node != (long)i || p->k != k) t->order_error = 1;
        s += p->v;
    }
    t->st.k = k;
    t->st.s = s;
    return 0;
}

static int toy_restart(void *user, size_t node, long k)
{
    toy_t *t = user;
    if (t->fail_restart) return -1;
    ++t->restarts[node];
    t->restart_k[node] = k;
    return 0;
}

static int toy_save(void *user, void *ckpt)
{
    memcpy(ckpt, &((toy_t *)user)->st, sizeof(toy_state_t));
    return 0;
}

static int toy_restore(void *user, const void *ckpt)
{
    memcpy(&((toy_t *)user)->st, ckpt, sizeof(toy_state_t));
    return 0;
}

static int toy_publish(void *user, const dkf_fcr_step_t *st, int64_t *utime)
{
    toy_t *t = user;
    assert_true(st->k >= 1 && st->k <= MAXK);
    assert_int_equal(st->nodes, L);
    t->value[st->k] = t->st.s;
    t->revision[st->k] = st->revision;
    t->degraded[st->k] = st->degraded;
    memcpy(t->contrib[st->k], st->contributed, L);
    ++t->published;
    *utime = t->utime;
    return 0;
}

static void toy_record(void *user, const dkf_fcr_step_t *st, int published)
{
    toy_t *t = user;
    (void)st;
    ++t->recorded;
    if (!published) ++t->recorded_unpublished;
}

static void toy_state(void *user, int state)
{
    toy_t *t = user;
    ++t->states;
    t->last_state = state;
}

static const dkf_fcr_ops_t toy_ops = {toy_step,    toy_restart, toy_save, toy_restore,
                                      toy_publish, toy_record,  toy_state, NULL};

/* The toy's configuration: L nodes, `steps` steps. */
static dkf_fcr_config_t toy_config(long steps)
{
    dkf_fcr_config_t c;
    c.nodes = L;
    c.steps = steps;
    c.payload_size = sizeof(toy_pay_t);
    c.ckpt_size = sizeof(toy_state_t);
    c.deadline_us = DEADLINE;
    c.linger_us = LINGER;
    return c;
}

static dkf_fcr_t *open_rt(toy_t *t)
{
    const dkf_fcr_config_t c = toy_config(N);
    dkf_fcr_t *rt;
    memset(t, 0, sizeof *t);
    rt = dkf_fcr_create(&c, &toy_ops, t);
    assert_non_null(rt);
    return rt;
}

static double v_of(long i, long k, long epoch) { return (double)(100 * i + k + 1000 * epoch); }

/* Node i's message of step k (with the copy of k-1 if with_prev and
 * k-1 >= k_start), arriving at recv (wall) and mono (monotonic). */
static int send_msg(dkf_fcr_t *rt, long i, long k, long epoch, long k_start, int with_prev,
                    int64_t recv, int64_t mono)
{
    toy_pay_t cur, prev;
    dkf_fcr_msg_t m;
    cur.node = prev.node = i;
    cur.k = k;
    prev.k = k - 1;
    cur.epoch = prev.epoch = epoch;
    cur.v = v_of(i, k, epoch);
    prev.v = v_of(i, k - 1, epoch);
    m.node = (size_t)i;
    m.k = k;
    m.epoch = epoch;
    m.k_start = k_start;
    m.seq = k - k_start;
    m.meas_utime = recv - 10;
    m.recv_utime = recv;
    m.pay = &cur;
    m.prev = with_prev && k - 1 >= k_start ? &prev : NULL;
    return dkf_fcr_receive(rt, &m, mono);
}

/* The toy state after steps 1..K with the payloads of the nodes in use[k][i]. */
static double expected(long K, unsigned char use[][L])
{
    double s = 0;
    long k, i;
    for (k = 1; k <= K; ++k) {
        s /= 2;
        for (i = 0; i < L; ++i)
            if (use == NULL || use[k][i]) s += v_of(i, k, 0);
    }
    return s;
}

/* Arrival times: step k's messages at 10 ms * k (wall and monotonic alike:
 * a fake clock that never jumps by a deadline unless a test says so). */
#define T(k) ((int64_t)(k) * 10000 + 5000000)

/* All nodes send every step in order: each step is published once, complete,
 * as soon as its last payload arrives (no tick), with the all-data value;
 * after step N the run is DONE at once (nothing left to wait for). */
static void test_fcr_complete_in_order(void **state)
{
    toy_t t;
    dkf_fcr_t *rt = open_rt(&t);
    long k, i;
    (void)state;
    for (k = 1; k <= N; ++k) {
        for (i = 0; i < L; ++i) {
            assert_int_equal(dkf_fcr_done_k(rt), k - 1); /* waits for the last node */
            assert_int_equal(send_msg(rt, i, k, 0, 1, 1, T(k), T(k)), 0);
        }
        assert_int_equal(dkf_fcr_done_k(rt), k);
        assert_true(t.value[k] == expected(k, NULL));
        assert_int_equal(t.degraded[k], 0);
    }
    assert_int_equal(t.published, N);
    assert_int_equal(t.recorded, N);
    assert_int_equal(t.order_error, 0);
    assert_int_equal(dkf_fcr_state(rt), DKF_FCR_DONE);
    assert_int_equal(t.states, 1);
    assert_int_equal(t.last_state, DKF_FCR_DONE);
    assert_int_equal(dkf_fcr_counts(rt)->received, L * N);
    assert_int_equal(dkf_fcr_counts(rt)->sent, N);
    assert_int_equal(dkf_fcr_counts(rt)->missed, 0);
    assert_int_equal(dkf_fcr_counts(rt)->redundant, 0); /* copies of known payloads */
    /* latency: the publication stamp (0 here) minus meas_utime */
    assert_int_equal(dkf_fcr_steps(rt)->lat_first[0], -(T(1) - 10));
    /* a message after DONE is not looked at */
    assert_int_equal(send_msg(rt, 0, N, 0, 1, 1, T(N), T(N)), -1);
    dkf_fcr_free(rt);
}

/* lat_last in parts: arrival - measurement (10 us in send_msg), the wait
 * and the computation on the wall clock, and the publication stamp: they
 * add up to lat_last exactly; without a publication stamp the parts that
 * need it are -1 (unknown), the computation is still measured. */
static void test_fcr_latency_parts(void **state)
{
    toy_t t;
    dkf_fcr_t *rt = open_rt(&t);
    const dkf_fcr_steps_t *r = dkf_fcr_steps(rt);
    long i;
    (void)state;
    t.utime = T(1) + 500;
    for (i = 0; i < L; ++i) assert_int_equal(send_msg(rt, i, 1, 0, 1, 1, T(1), T(1)), 0);
    t.utime = 0;
    for (i = 0; i < L; ++i) assert_int_equal(send_msg(rt, i, 2, 0, 1, 1, T(2), T(2)), 0);
    assert_int_equal(dkf_fcr_done_k(rt), 2);
    assert_int_equal(r->lat_last[0], 510);
    assert_int_equal(r->t_arrive[0], 10);
    assert_true(r->t_compute[0] >= 0);
    assert_int_equal(r->t_arrive[0] + r->t_wait[0] + r->t_compute[0] + r->t_publish[0], 510);
    assert_int_equal(r->t_arrive[1], -1);
    assert_int_equal(r->t_wait[1], -1);
    assert_int_equal(r->t_publish[1], -1);
    assert_true(r->t_compute[1] >= 0);
    dkf_fcr_free(rt);
}

/* Every message of node 1 twice, and node 2's messages of even steps held
 * back until after the next one (its copy arrives first). Nothing changes
 * in the result; the extra copies are counted as duplicates, the reordered
 * payloads as recovered by redundancy, and no step is recomputed. */
static void test_fcr_duplicates_and_reorder(void **state)
{
    toy_t t;
    dkf_fcr_t *rt = open_rt(&t);
    long k;
    (void)state;
    for (k = 1; k <= N; ++k) {
        send_msg(rt, 0, k, 0, 1, 1, T(k), T(k));
        send_msg(rt, 1, k, 0, 1, 1, T(k), T(k));
        send_msg(rt, 1, k, 0, 1, 1, T(k), T(k));
        if (k % 2 == 1) {
            send_msg(rt, 2, k, 0, 1, 1, T(k), T(k));
            if (k > 1) send_msg(rt, 2, k - 1, 0, 1, 1, T(k), T(k)); /* the held one */
        } else if (k == N) {
            send_msg(rt, 2, k, 0, 1, 1, T(k), T(k));
        }
    }
    assert_int_equal(dkf_fcr_done_k(rt), N);
    assert_true(t.value[N] == expected(N, NULL));
    for (k = 1; k <= N; ++k) assert_int_equal(t.revision[k], 0);
    assert_int_equal(t.published, N);
    assert_int_equal(t.order_error, 0);
    assert_int_equal(dkf_fcr_counts(rt)->duplicates, N);
    assert_int_equal(dkf_fcr_counts(rt)->stale, N);
    /* even steps but N: payload known first from the copy in message k+1 */
    assert_int_equal(dkf_fcr_counts(rt)->redundant, N / 2 - 1);
    assert_int_equal(dkf_fcr_counts(rt)->rollbacks, 0);
    /* the held messages still count as received (the copy had no meas time) */
    assert_int_equal(dkf_fcr_counts(rt)->received, L * N);
    assert_int_equal(dkf_fcr_state(rt), DKF_FCR_DONE);
    dkf_fcr_free(rt);
}

/* Node 2's message of step 5 is lost and message 6 carries no copy (as if
 * it had been lost too and 6 were resent without it); its messages 6, 7
 * are held back as well. Step 5 reaches its deadline (fake clock) and is
 * published degraded, and steps 6, 7 too. Then message 5 arrives (late,
 * within the checkpoint window): the runtime restores the checkpoint after
 * step 4 and replays 5..done_k, each published again with revision 1, and
 * the result is exactly the on-time one. Messages 6 and 7 follow at once:
 * the rollback budget (one rollback between first publications, or per
 * deadline) is spent, so their revision waits, merged into one, and runs a
 * deadline later (or before the next step is published). Later a payload
 * of a step more than DKF_FCR_CKPT behind is ignored (too late), counted,
 * nothing recomputed. */
static void test_fcr_late_within_and_outside_window(void **state)
{
    toy_t t;
    dkf_fcr_t *rt = open_rt(&t);
    long k, i, done;
    unsigned char use[N + 1][L];
    (void)state;
    memset(use, 1, sizeof use);
    for (k = 1; k <= 4; ++k)
        for (i = 0; i < L; ++i) send_msg(rt, i, k, 0, 1, 1, T(k), T(k));
    assert_int_equal(dkf_fcr_done_k(rt), 4);
    for (k = 5; k <= 7; ++k)
        for (i = 0; i < 2; ++i) send_msg(rt, i, k, 0, 1, 1, T(k), T(k));
    /* no deadline has passed: node 2 is neither given up nor moved on */
    dkf_fcr_tick(rt, T(7));
    assert_int_equal(dkf_fcr_done_k(rt), 4);
    dkf_fcr_tick(rt, T(5) + DEADLINE); /* step 5 opened at T(5) */
    assert_true(dkf_fcr_done_k(rt) >= 5);
    dkf_fcr_tick(rt, T(7) + 3 * DEADLINE);
    done = dkf_fcr_done_k(rt);
    assert_int_equal(done, 7);
    for (k = 5; k <= 7; ++k) {
        assert_int_equal(t.degraded[k], 1);
        assert_int_equal(t.contrib[k][2], 0);
        use[k][2] = 0;
    }
    assert_true(t.value[7] == expected(7, use));
    assert_int_equal(dkf_fcr_counts(rt)->missed, 3);
    /* message 5 (without copy: k_start = 5 would make it a restart, so the
     * copy of 4 rides along, which is known already) */
    send_msg(rt, 2, 5, 0, 1, 1, T(8), T(8));
    assert_int_equal(dkf_fcr_counts(rt)->rollbacks, 1);
    assert_int_equal(dkf_fcr_counts(rt)->late, 1);
    assert_int_equal(dkf_fcr_counts(rt)->replayed, 3);
    assert_int_equal(dkf_fcr_counts(rt)->revised_sent, 3);
    assert_int_equal(t.revision[5], 1);
    assert_int_equal(t.revision[7], 1);
    assert_int_equal(t.contrib[5][2], 1);
    use[5][2] = 1;
    assert_true(t.value[7] == expected(7, use));
    assert_int_equal(t.order_error, 0);
    /* 6 and 7 arrive: one revision of 6..7 waits (budget spent) */
    send_msg(rt, 2, 6, 0, 1, 1, T(8), T(8));
    send_msg(rt, 2, 7, 0, 1, 1, T(8), T(8));
    assert_int_equal(dkf_fcr_counts(rt)->rollbacks, 1);
    assert_int_equal(dkf_fcr_counts(rt)->deferred, 2);
    assert_int_equal(t.revision[7], 1);
    dkf_fcr_tick(rt, T(8) + DEADLINE - 1); /* not yet */
    assert_int_equal(dkf_fcr_counts(rt)->rollbacks, 1);
    dkf_fcr_tick(rt, T(8) + DEADLINE); /* 6 revises 6..7 (from the checkpoint after 5) */
    assert_int_equal(dkf_fcr_counts(rt)->rollbacks, 2);
    assert_int_equal(dkf_fcr_counts(rt)->replayed, 5);
    assert_int_equal(t.revision[6], 2);
    assert_int_equal(t.revision[7], 2);
    assert_true(t.value[7] == expected(7, NULL));
    assert_int_equal(dkf_fcr_steps(rt)->first_degraded[6], 1); /* as first published */
    assert_int_equal(dkf_fcr_steps(rt)->degraded[6], 0);       /* in the end */
    /* steps 8..19 complete; then a payload of step 7 (>= CKPT behind) */
    for (k = 8; k <= 19; ++k)
        for (i = 0; i < L; ++i) send_msg(rt, i, k, 0, 1, 1, T(k), T(k));
    assert_int_equal(dkf_fcr_done_k(rt), 19);
    {
        const int64_t stale = dkf_fcr_counts(rt)->stale, pub = t.published;
        const double v = t.value[19];
        send_msg(rt, 2, 19 - DKF_FCR_CKPT, 0, 1, 0, T(19), T(19));
        assert_int_equal(dkf_fcr_counts(rt)->stale, stale + 1);
        assert_int_equal(dkf_fcr_counts(rt)->too_late, 1);
        assert_int_equal(dkf_fcr_counts(rt)->rollbacks, 2);
        assert_int_equal(t.published, pub);
        assert_true(t.value[19] == v);
    }
    assert_int_equal(t.order_error, 0);
    dkf_fcr_free(rt);
}

/* A node whose messages are valid (as a holder of its key can make them)
 * but that tries to make the centre work: 10 000 messages in no time, each
 * announcing a new epoch that restarts inside the revisable steps and
 * carrying its payloads. Each would roll back and replay; the budget lets
 * one rollback through between first publications (or per deadline), so
 * the stream costs at most DKF_FCR_CKPT step computations now, as many a
 * deadline later, and 1 + 2 DKF_FCR_CKPT per step published afterwards,
 * whatever the number of messages (docs/guide/network.md, "Threat model"). */
static void test_fcr_late_stream_bounded(void **state)
{
    toy_t t;
    dkf_fcr_t *rt = open_rt(&t);
    long k, i, e, before;
    (void)state;
    for (k = 1; k <= 10; ++k)
        for (i = 0; i < L; ++i) send_msg(rt, i, k, 0, 1, 1, T(k), T(k));
    assert_int_equal(dkf_fcr_done_k(rt), 10);
    before = t.computed;
    for (e = 1; e <= 10000; ++e) send_msg(rt, 2, 10, e, 7, 1, T(11), T(11));
    assert_int_equal(dkf_fcr_counts(rt)->late, 10000);
    assert_int_equal(dkf_fcr_counts(rt)->rollbacks, 1);
    assert_int_equal(dkf_fcr_counts(rt)->deferred, 9999);
    assert_true(t.computed - before <= DKF_FCR_CKPT); /* measured: 4 (steps 7..10) */
    print_message("10000 late epochs: %ld step computations\n", t.computed - before);
    dkf_fcr_tick(rt, T(11) + DEADLINE); /* the merged revision */
    assert_int_equal(dkf_fcr_counts(rt)->rollbacks, 2);
    assert_true(t.computed - before <= 2 * DKF_FCR_CKPT);
    /* the same stream again at once, then the next step: all of it waits
     * (the tick's rollback spent the budget) and runs before step 11 is
     * first published */
    for (e = 10001; e <= 20000; ++e) send_msg(rt, 2, 10, e, 8, 1, T(11), T(11) + DEADLINE);
    before = t.computed;
    for (i = 0; i < 2; ++i) send_msg(rt, i, 11, 0, 1, 1, T(11), T(11) + DEADLINE);
    send_msg(rt, 2, 11, 20000, 8, 1, T(11), T(11) + DEADLINE);
    assert_int_equal(dkf_fcr_done_k(rt), 11);
    assert_true(t.computed - before <= 1 + DKF_FCR_CKPT);
    assert_int_equal(dkf_fcr_counts(rt)->rollbacks, 3);
    assert_int_equal(t.order_error, 0);
    dkf_fcr_free(rt);
}

/* Node 2 never sends, and no tick is ever called (no deadline passes on
 * the centre's clock). The others' arrivals are the clock of "given up":
 * once they span a deadline since the first arrival, node 2 is given up on
 * and every step is published degraded with nodes 0, 1, from arrivals
 * alone. After step N the run is DONE: node 2 was never heard. */
static void test_fcr_silent_node(void **state)
{
    toy_t t;
    dkf_fcr_t *rt = open_rt(&t);
    long k, i;
    unsigned char use[N + 1][L];
    (void)state;
    memset(use, 1, sizeof use);
    for (k = 1; k <= N; ++k) {
        /* arrivals 100 ms apart: the deadline spans 10 steps */
        const int64_t at = 5000000 + (int64_t)k * 100000;
        for (i = 0; i < 2; ++i) send_msg(rt, i, k, 0, 1, 1, at, at);
        use[k][2] = 0;
        if (k < 11) assert_int_equal(dkf_fcr_done_k(rt), 0);
        else assert_int_equal(dkf_fcr_done_k(rt), k);
    }
    for (k = 1; k <= N; ++k) {
        assert_int_equal(t.degraded[k], 1);
        assert_int_equal(t.contrib[k][0] + t.contrib[k][1], 2);
    }
    assert_true(t.value[N] == expected(N, use));
    assert_int_equal(dkf_fcr_state(rt), DKF_FCR_DONE);
    assert_int_equal(dkf_fcr_counts(rt)->missed, N);
    dkf_fcr_free(rt);
}

/* Node 2's message k+2 says its payload k is not coming (a node that moved
 * on): its payload of step 5 lost for good (messages 5 and 6 lost), step 5
 * is published degraded on the arrival of message 7, with no deadline. */
static void test_fcr_moved_on(void **state)
{
    toy_t t;
    dkf_fcr_t *rt = open_rt(&t);
    long k, i;
    (void)state;
    for (k = 1; k <= 7; ++k)
        for (i = 0; i < L; ++i)
            if (!(i == 2 && (k == 5 || k == 6))) send_msg(rt, i, k, 0, 1, 1, T(k), T(k));
    /* message 7 (and its copy of 6) makes steps 5 and 6 ready */
    assert_int_equal(dkf_fcr_done_k(rt), 7);
    assert_int_equal(t.degraded[5], 1);
    assert_int_equal(t.contrib[5][2], 0);
    assert_int_equal(t.degraded[6], 0); /* from the copy in message 7 */
    assert_int_equal(dkf_fcr_counts(rt)->redundant, 1);
    dkf_fcr_free(rt);
}

/* A payload of step k pushes every step before k - DKF_FCR_WINDOW out of
 * the window (published as they are); none is refused as too far ahead. */
static void test_fcr_window_follows_arrivals(void **state)
{
    toy_t t;
    dkf_fcr_config_t c;
    dkf_fcr_t *rt;
    long k;
    (void)state;
    memset(&t, 0, sizeof t);
    c = toy_config(2 * DKF_FCR_WINDOW);
    rt = dkf_fcr_create(&c, &toy_ops, &t);
    assert_non_null(rt);
    /* node 0 alone, all steps at the same arrival time (no one given up) */
    for (k = 1; k <= 2 * DKF_FCR_WINDOW; ++k) {
        toy_pay_t p = {0, 0, 0, 0};
        dkf_fcr_msg_t m;
        p.k = k;
        memset(&m, 0, sizeof m);
        m.k = k;
        m.k_start = 1;
        m.seq = k - 1;
        m.recv_utime = T(1);
        m.pay = &p;
        dkf_fcr_receive(rt, &m, T(1));
        assert_int_equal(dkf_fcr_done_k(rt), k > DKF_FCR_WINDOW ? k - DKF_FCR_WINDOW : 0);
    }
    assert_int_equal(dkf_fcr_counts(rt)->pushed, DKF_FCR_WINDOW);
    assert_int_equal(dkf_fcr_counts(rt)->ahead, 0);
    dkf_fcr_free(rt);
}

/* Node 1 restarts at step 8 (epoch 1): the restart operation is called
 * once, before step 8; its payloads of epoch 0 for steps >= 8 are refused
 * (old epoch); a contradicting epoch is ignored. If the operation refuses,
 * the epoch is lost and the node stays masked. */
static void test_fcr_restart(void **state)
{
    toy_t t;
    dkf_fcr_t *rt;
    long k, i;
    int fail;
    (void)state;
    for (fail = 0; fail <= 1; ++fail) {
        rt = open_rt(&t);
        t.fail_restart = fail;
        for (k = 1; k <= 12; ++k)
            for (i = 0; i < L; ++i) {
                const long ep = (i == 1 && k >= 8) ? 1 : 0, ks = ep ? 8 : 1;
                send_msg(rt, i, k, ep, ks, 1, T(k), T(k));
            }
        assert_int_equal(dkf_fcr_done_k(rt), 12);
        assert_int_equal(t.restarts[1], fail ? 0 : 1);
        assert_int_equal(t.restart_k[1], fail ? 0 : 8);
        assert_int_equal(dkf_fcr_counts(rt)->restarts, fail ? 0 : 1);
        assert_int_equal(dkf_fcr_counts(rt)->lost_epochs, fail);
        assert_int_equal(t.contrib[8][1], !fail);
        assert_int_equal(t.contrib[12][1], !fail);
        /* epoch 0 at step 10: not the epoch of that step */
        send_msg(rt, 1, 10, 0, 1, 0, T(12), T(12));
        assert_int_equal(dkf_fcr_counts(rt)->old_epoch, 1);
        /* epoch 1 from another first step: contradicts */
        send_msg(rt, 1, 12, 1, 9, 0, T(12), T(12));
        assert_int_equal(dkf_fcr_counts(rt)->conflicts, 1);
        {
            dkf_fcr_epoch_t ep[4];
            /* epoch 0 from step 1 stays the assumption (not listed) */
            assert_int_equal(dkf_fcr_epochs(rt, 1, ep, 4), 1);
            assert_int_equal(ep[0].epoch, 1);
            assert_int_equal(ep[0].k_start, 8);
            assert_int_equal(ep[0].usable, !fail);
        }
        assert_int_equal(t.order_error, 0);
        dkf_fcr_free(rt);
    }
}

/* A centre that starts after the nodes: its first message is of step 6
 * (copy of 5): steps 1..4 are computed without data and recorded, not
 * published; fusion starts at 5. */
static void test_fcr_join(void **state)
{
    toy_t t;
    dkf_fcr_t *rt = open_rt(&t);
    long i;
    (void)state;
    for (i = 0; i < L; ++i) send_msg(rt, i, 6, 0, 1, 1, T(6), T(6));
    assert_int_equal(dkf_fcr_join_k(rt), 5);
    assert_int_equal(dkf_fcr_done_k(rt), 6);
    assert_int_equal(t.recorded_unpublished, 4);
    assert_int_equal(t.published, 2);
    assert_int_equal(t.degraded[5], 0);
    assert_int_equal(t.order_error, 0);
    dkf_fcr_free(rt);
}

/* After step N, node 1's payload of step N-1 is still missing (published
 * degraded at its deadline) and node 1 was heard recently: the run stays
 * RUNNING (a late payload can still revise it) until node 1 has been silent
 * for the linger time. If the payload comes in the linger, the step is
 * revised and the run ends at once. */
static void test_fcr_linger(void **state)
{
    toy_t t;
    dkf_fcr_t *rt;
    long k, i;
    int arrives;
    (void)state;
    for (arrives = 0; arrives <= 1; ++arrives) {
        rt = open_rt(&t);
        for (k = 1; k <= N; ++k)
            for (i = 0; i < L; ++i)
                if (!(i == 1 && k >= N - 1)) send_msg(rt, i, k, 0, 1, 1, T(k), T(k));
        /* node 1's last message: step N-2 at T(N-2); steps N-1, N reach the deadline */
        dkf_fcr_tick(rt, T(N) + DEADLINE);
        assert_int_equal(dkf_fcr_done_k(rt), N);
        assert_int_equal(t.degraded[N - 1], 1);
        assert_int_equal(dkf_fcr_state(rt), DKF_FCR_RUNNING);
        if (arrives) {
            send_msg(rt, 1, N, 0, 1, 1, T(N) + DEADLINE + 1, T(N) + DEADLINE + 1);
            assert_int_equal(t.degraded[N - 1], 0);
            assert_int_equal(t.degraded[N], 0);
            assert_int_equal(dkf_fcr_state(rt), DKF_FCR_DONE);
            assert_true(t.value[N] == expected(N, NULL));
        } else {
            dkf_fcr_tick(rt, T(N - 2) + LINGER - 1);
            assert_int_equal(dkf_fcr_state(rt), DKF_FCR_RUNNING);
            dkf_fcr_tick(rt, T(N - 2) + LINGER);
            assert_int_equal(dkf_fcr_state(rt), DKF_FCR_DONE);
        }
        assert_int_equal(t.states, 1);
        dkf_fcr_free(rt);
    }
}

/* Out-of-range configurations and messages are refused. */
static void test_fcr_refuses(void **state)
{
    toy_t t;
    dkf_fcr_config_t c;
    dkf_fcr_ops_t ops = toy_ops;
    dkf_fcr_t *rt;
    dkf_fcr_msg_t m;
    toy_pay_t p = {0, 1, 0, 1};
    (void)state;
    memset(&t, 0, sizeof t);
    c = toy_config(N);
    c.nodes = 0;
    assert_null(dkf_fcr_create(&c, &toy_ops, &t));
    c.nodes = DKF_FCR_MAX_NODES + 1;
    assert_null(dkf_fcr_create(&c, &toy_ops, &t));
    c.nodes = L;
    c.steps = 0;
    assert_null(dkf_fcr_create(&c, &toy_ops, &t));
    c.steps = N;
    c.deadline_us = 0;
    assert_null(dkf_fcr_create(&c, &toy_ops, &t));
    c.deadline_us = DEADLINE;
    ops.publish = NULL;
    assert_null(dkf_fcr_create(&c, &ops, &t));
    rt = dkf_fcr_create(&c, &toy_ops, &t);
    assert_non_null(rt);
    memset(&m, 0, sizeof m);
    m.k = 1;
    m.k_start = 1;
    m.pay = &p;
    m.node = L;
    assert_int_equal(dkf_fcr_receive(rt, &m, T(1)), -1);
    m.node = 0;
    m.k = N + 1;
    assert_int_equal(dkf_fcr_receive(rt, &m, T(1)), -1);
    m.k = 1;
    m.k_start = 2;
    assert_int_equal(dkf_fcr_receive(rt, &m, T(1)), -1);
    m.k_start = 1;
    m.prev = &p; /* no step 0 */
    assert_int_equal(dkf_fcr_receive(rt, &m, T(1)), -1);
    assert_int_equal(dkf_fcr_counts(rt)->received, 0);
    m.prev = NULL;
    assert_int_equal(dkf_fcr_receive(rt, &m, T(1)), 0);
    assert_int_equal(dkf_fcr_counts(rt)->received, 1);
    dkf_fcr_free(rt);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fcr_complete_in_order),
        cmocka_unit_test(test_fcr_latency_parts),
        cmocka_unit_test(test_fcr_duplicates_and_reorder),
        cmocka_unit_test(test_fcr_late_within_and_outside_window),
        cmocka_unit_test(test_fcr_silent_node),
        cmocka_unit_test(test_fcr_moved_on),
        cmocka_unit_test(test_fcr_window_follows_arrivals),
        cmocka_unit_test(test_fcr_restart),
        cmocka_unit_test(test_fcr_late_stream_bounded),
        cmocka_unit_test(test_fcr_join),
        cmocka_unit_test(test_fcr_linger),
        cmocka_unit_test(test_fcr_refuses),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
