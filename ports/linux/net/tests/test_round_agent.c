/*
 * The neighbour-round protocol (round_agent.h) with a filter of its own,
 * not the seed-003 one (test_tw_agent covers that): three nodes on a path
 * 0 - 1 - 2 average their neighbours' values, three rounds per step, the
 * step's value carried into the next step. Driven in one process by an
 * in-memory delivery to the neighbours and a fake clock:
 *   - every round's value equals the same averages computed here directly
 *     (bit for bit: the same sums in the same row order);
 *   - the counters add up (one first publication per round and node);
 *   - a node that never starts: after the start timeout its neighbour
 *     completes the round without it (have[e] = 0), every step of that
 *     neighbour is degraded with the node missing, and it finishes;
 *   - a node that joins late from a backlog of its receive queue (held
 *     deliveries, read at once): it joins from the newest last round of a
 *     step in the backlog, while its neighbour, which gave it up, is
 *     already further on. The neighbour hears it again behind itself,
 *     waits for it while it catches up through the neighbour's answers,
 *     and takes its packets in every later step (none of them degraded).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "ra_bus.h"
#include "round_agent.h"

#define NN 3
#define STEPS 4
#define ROUNDS 3

static const size_t rows[NN][NN] = {{0, 1}, {0, 1, 2}, {1, 2}};
static const size_t degs[NN] = {2, 3, 2};

typedef struct {
    size_t id, self;
    dkf_real_t v;              /* the value carried from step to step */
    dkf_real_t seen[STEPS * ROUNDS];
    unsigned char full[STEPS * ROUNDS];
} avg_t;

static int avg_begin(void *filter, size_t k, dkf_real_t *pkt, char *err, size_t errlen)
{
    avg_t *f = filter;
    (void)k, (void)err, (void)errlen;
    pkt[0] = f->v;
    return 0;
}

static int avg_complete(void *filter, size_t k, size_t r, const dkf_real_t *rx, size_t stride,
                        const unsigned char *have, dkf_real_t *next, char *err, size_t errlen)
{
    avg_t *f = filter;
    dkf_real_t sum = DKF_R(0.0);
    size_t e, cnt = 0;
    (void)err, (void)errlen;
    assert_true(have[f->self]);
    for (e = 0; e < degs[f->id]; ++e)
        if (have[e]) {
            sum += rx[e * stride];
            ++cnt;
        }
    f->v = sum / (dkf_real_t)cnt;
    f->seen[(k - 1) * ROUNDS + r] = f->v;
    f->full[(k - 1) * ROUNDS + r] = cnt == degs[f->id];
    if (r + 1 < ROUNDS) {
        next[0] = f->v;
        return 0;
    }
    return 1;
}

/* Joining after step k: the neighbour's value of its last round is the prior. */
static int avg_rejoin(void *filter, size_t k, const dkf_real_t *pkt, dkf_real_t *next, char *err,
                      size_t errlen)
{
    avg_t *f = filter;
    (void)k;
    f->v = pkt[0];
    return avg_begin(filter, k + 1, next, err, errlen);
}

static const dkf_ra_ops_t avg_ops = {avg_begin, avg_complete, avg_rejoin};

static ra_bus_t bus;

static dkf_ra_t *make(size_t id, avg_t *f)
{
    dkf_ra_config_t c;
    dkf_ra_opts_t o;
    char err[128];
    dkf_ra_t *a;
    size_t e;
    memset(f, 0, sizeof *f);
    f->id = id;
    f->v = (dkf_real_t)(id + 1) * DKF_R(0.7);
    for (e = 0; e < degs[id]; ++e)
        if (rows[id][e] == id) f->self = e;
    memset(&c, 0, sizeof c);
    c.ops = &avg_ops;
    c.filter = f;
    c.id = id;
    c.row = rows[id];
    c.deg = degs[id];
    c.ex.model_id = 77;
    c.ex.nnodes = NN;
    c.ex.node = -1;
    c.ex.steps = STEPS;
    c.ex.rounds = ROUNDS;
    c.ex.info_rounds = ROUNDS;
    c.ex.info_len = 1;
    c.ex.est_len = 1;
    bus.N = NN;
    bus.row[id] = rows[id];
    bus.deg[id] = degs[id];
    o = ra_bus_opts(&bus, id, 1000, 5000, 100);
    a = dkf_ra_new(&c, &o, err, sizeof err);
    if (a == NULL) fail_msg("%s", err);
    bus.agent[id] = a;
    return a;
}

static void test_averages_bit_for_bit(void **state)
{
    avg_t f[NN];
    dkf_ra_t *a[NN];
    dkf_real_t v[NN], w[NN];
    size_t i, e, t;
    (void)state;
    memset(&bus, 0, sizeof bus);
    for (i = 0; i < NN; ++i) a[i] = make(i, &f[i]);
    for (i = 0; i < NN; ++i) v[i] = f[i].v;
    for (i = 0; i < NN; ++i) assert_int_equal(dkf_ra_start(a[i], 0), DKF_RA_RUNNING);
    ra_bus_run(&bus, 0, 10, 1000000);
    assert_int_equal(bus.rejected, 0);
    for (t = 0; t < STEPS * ROUNDS; ++t) {
        for (i = 0; i < NN; ++i) {
            dkf_real_t sum = DKF_R(0.0);
            for (e = 0; e < degs[i]; ++e) sum += v[rows[i][e]];
            w[i] = sum / (dkf_real_t)degs[i];
        }
        for (i = 0; i < NN; ++i) {
            v[i] = w[i];
            assert_true(f[i].seen[t] == v[i]);
            assert_true(f[i].full[t]);
        }
    }
    for (i = 0; i < NN; ++i) {
        const dkf_ra_counters_t *c = dkf_ra_counters(a[i]);
        assert_int_equal(dkf_ra_state(a[i]), DKF_RA_FINISHED);
        assert_int_equal(dkf_ra_steps_done(a[i]), STEPS);
        assert_int_equal(c->reals_sent, STEPS * ROUNDS);
        assert_int_equal(c->degraded_steps, 0);
        assert_int_equal(c->rej.total, 0);
        assert_false(dkf_ra_step_degraded(a[i], 1));
        dkf_ra_free(a[i]);
    }
}

static void test_silent_node_degrades_its_neighbour(void **state)
{
    avg_t f[NN];
    dkf_ra_t *a[NN];
    size_t j;
    int64_t end;
    (void)state;
    memset(&bus, 0, sizeof bus);
    a[0] = make(0, &f[0]);
    a[1] = make(1, &f[1]);
    a[2] = NULL; /* node 2 never starts */
    bus.N = NN;
    bus.row[2] = rows[2];
    bus.deg[2] = degs[2];
    assert_int_equal(dkf_ra_start(a[0], 0), DKF_RA_RUNNING);
    assert_int_equal(dkf_ra_start(a[1], 0), DKF_RA_RUNNING);
    end = ra_bus_run(&bus, 0, 10, 1000000);
    assert_true(end >= 5000); /* the first round waited for the start timeout */
    assert_int_equal(dkf_ra_state(a[0]), DKF_RA_FINISHED);
    assert_int_equal(dkf_ra_state(a[1]), DKF_RA_FINISHED);
    assert_int_equal(dkf_ra_counters(a[1])->degraded_steps, STEPS);
    assert_int_equal(dkf_ra_counters(a[1])->absent_marks, 1); /* marked once, not per round */
    assert_int_equal(dkf_ra_counters(a[0])->degraded_steps, 0);
    for (j = 1; j <= STEPS; ++j) {
        assert_true(dkf_ra_step_degraded(a[1], j));
        assert_true(dkf_ra_step_missing(a[1], j, 2));  /* row position of node 2 */
        assert_false(dkf_ra_step_missing(a[1], j, 0));
    }
    /* node 1's first round averaged over {0, 1} only */
    {
        dkf_real_t sum = DKF_R(0.0);
        sum += (dkf_real_t)1 * DKF_R(0.7);
        sum += (dkf_real_t)2 * DKF_R(0.7);
        assert_true(f[1].seen[0] == sum / DKF_R(2.0));
        assert_false(f[1].full[0]);
    }
    dkf_ra_free(a[0]);
    dkf_ra_free(a[1]);
}

/* Nodes 0 and 1 start and node 2 joins, its deliveries held back until
 * node 1 has entered `rounds` rounds (its first publications count them);
 * then node 2 reads the backlog at once, and all run to the end. Node 1's
 * round at the release. */
static unsigned long late_join(avg_t *f, dkf_ra_t **a, unsigned long rounds)
{
    int64_t now = 0;
    size_t i;
    unsigned long r1;
    memset(&bus, 0, sizeof bus);
    for (i = 0; i < NN; ++i) a[i] = make(i, &f[i]);
    bus.hold[2] = 1; /* node 2 does not read its queue yet */
    assert_int_equal(dkf_ra_start(a[0], 0), DKF_RA_RUNNING);
    assert_int_equal(dkf_ra_start(a[1], 0), DKF_RA_RUNNING);
    assert_int_equal(dkf_ra_join(a[2], 0), DKF_RA_JOINING);
    /* nodes 0 and 1 give node 2 up after the start timeout and run on */
    while (dkf_ra_counters(a[1])->reals_sent < rounds && now < 1000000)
        now = ra_bus_run(&bus, now, 10, now + 10);
    r1 = dkf_ra_counters(a[1])->reals_sent - 1;
    assert_int_equal(dkf_ra_counters(a[1])->absent_marks, 1);
    ra_bus_release(&bus, 2);
    ra_bus_run(&bus, now, 10, now + 1000000);
    for (i = 0; i < NN; ++i) {
        if (dkf_ra_state(a[i]) != DKF_RA_FINISHED)
            fail_msg("node %zu: state %d after %zu steps", i, dkf_ra_state(a[i]),
                     dkf_ra_steps_done(a[i]));
        assert_int_equal(dkf_ra_steps_done(a[i]), STEPS);
    }
    return r1;
}

/* After late_join: node 2 joined in step `first`, and caught up through
 * node 1's answers while node 1 waited for it: node 2 took node 1's packet
 * in every round it ran; node 1 went without node 2's until some round of
 * step `first` at the latest, then took them all (no later step degraded,
 * no round timed out on node 2 again). */
static void check_caught_up(const avg_t *f, dkf_ra_t **a, size_t first)
{
    size_t i, j, t;
    assert_int_equal(dkf_ra_first_step(a[2]), first);
    for (j = 1; j < first; ++j) assert_true(dkf_ra_step_degraded(a[1], j));
    for (j = first + 1; j <= STEPS; ++j) assert_false(dkf_ra_step_degraded(a[1], j));
    for (t = 0; t < (first - 1) * ROUNDS; ++t) assert_false(f[1].full[t]);
    for (t = 0; t + 1 < STEPS * ROUNDS; ++t)
        if (f[1].full[t]) assert_true(f[1].full[t + 1]);
    for (t = (first - 1) * ROUNDS; t < STEPS * ROUNDS; ++t) assert_true(f[2].full[t]);
    assert_int_equal(dkf_ra_counters(a[1])->absent_marks, 1);
    assert_true(dkf_ra_counters(a[1])->answers > 0);
    assert_int_equal(dkf_ra_counters(a[2])->degraded_steps, 0);
    assert_int_equal(dkf_ra_counters(a[2])->absent_marks, 0);
    for (i = 0; i < NN; ++i) dkf_ra_free(a[i]);
}

/* Node 1 is in step 2 when node 2 reads its backlog, so node 2 joins from
 * step 1's last round, at least a round behind node 1, which had given it
 * up and must wait for it again (not waited for, node 2 would stay behind
 * for good and node 1 be degraded in every step). */
static void test_joiner_behind_is_waited_for(void **state)
{
    avg_t f[NN];
    dkf_ra_t *a[NN];
    unsigned long r1;
    (void)state;
    r1 = late_join(f, a, ROUNDS + 2);
    assert_true(r1 >= ROUNDS + 1 && r1 + 1 < 2 * ROUNDS); /* step 2's last round not sent */
    assert_true(dkf_ra_step_degraded(a[1], 2)); /* node 1 had left the join round */
    assert_false(f[1].full[ROUNDS]);
    check_caught_up(f, a, 2);
}

/* Node 1 has sent step 2's last round as well when node 2 reads its
 * backlog: node 2 joins from that one, the newest, not from step 1's. */
static void test_joiner_takes_the_newest_last_round(void **state)
{
    avg_t f[NN];
    dkf_ra_t *a[NN];
    unsigned long r1;
    (void)state;
    r1 = late_join(f, a, 2 * ROUNDS + 1);
    assert_true(r1 >= 2 * ROUNDS && r1 + 1 < 3 * ROUNDS); /* step 3's last round not sent */
    check_caught_up(f, a, 3);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_averages_bit_for_bit),
        cmocka_unit_test(test_silent_node_degrades_its_neighbour),
        cmocka_unit_test(test_joiner_behind_is_waited_for),
        cmocka_unit_test(test_joiner_takes_the_newest_last_round),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
