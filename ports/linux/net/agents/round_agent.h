/*
 * round_agent.h - the neighbour-round protocol of one node of a graph
 * filter (host side, transport-free): the part of a graph node that is not
 * the filter. The seed-003 agents (tw_agent.h) are its first user.
 *
 * A step k = 1..steps is `rounds` exchanges with the neighbours. In round
 * r the node publishes one packet and waits for the packet of round r of
 * every neighbour, then hands them to the filter, which gives the packet of
 * round r + 1 or commits the step. Rounds are numbered globally,
 * t = (k - 1) rounds + r, and carried on the wire as (k, round) in
 * lcmtypes/tw_packet_t.lcm, whose shapes (kind and length per round) the
 * filter states in a dkf_net_tw_expect_t.
 *
 * The protocol (what tw_agent.h's top comment describes in full): a round
 * waits for a missing packet until a timeout has passed both since the
 * round started and since that neighbour was last heard from (the first
 * round: the start timeout); then the neighbour is marked absent and the
 * round completes without it (have[e] = 0), the step is recorded degraded
 * and later rounds do not wait for it until it is heard again: a packet of
 * this round or the next, or one of an earlier round that the node can
 * still answer (below; a neighbour that joined or fell behind, which then
 * is waited for while it catches up). A node that waits retry_us without
 * completing its round re-publishes its packet (flagged retransmit); a
 * neighbour further on answers with its packet of that round (it keeps its
 * last 16). After the last step a node publishes DONE and lingers,
 * answering retransmits, until every present neighbour is DONE or the round
 * timeout has passed. Time is passed in (monotonic microseconds), so tests
 * drive the deadlines with a fake clock.
 */
#ifndef DKF_NET_ROUND_AGENT_H
#define DKF_NET_ROUND_AGENT_H

#include <stddef.h>
#include <stdint.h>

#include <jansson.h>

#include "codec.h" /* dkf_net_tw_expect_t, dkf_net_verdict_t, dkf_net_rejects_t */

/* Publishes one encoded packet on the node's own channel: 0 or -1. */
typedef int (*dkf_ra_send_fn)(void *user, const void *data, size_t len);

typedef struct {
    dkf_ra_send_fn send;
    void *user;               /* passed to send unchanged */
    int64_t round_timeout_us; /* > 0 */
    int64_t start_timeout_us; /* first round of step 1; > 0 */
    int64_t retry_us;         /* quiet period before a re-publication; > 0 */
} dkf_ra_opts_t;

enum {
    DKF_RA_RUNNING = 0,
    DKF_RA_LINGER = 1,
    DKF_RA_FINISHED = 2,
    DKF_RA_FAILED = 3,
    DKF_RA_JOINING = 4 /* dkf_ra_join: waiting for a neighbour's last round of a step */
};

typedef struct {
    /* sent: every publication; reals_sent: the reals of first publications
     * only (the filter's traffic, DONE has none); retransmits, answers: loss
     * recovery (above) */
    unsigned long sent, reals_sent, retransmits, answers, received, duplicates, stale, ahead,
        absent_marks, degraded_steps;
    dkf_net_rejects_t rej;
} dkf_ra_counters_t;

/* The filter's side. Each returns 0 (go on), 1 (the step is complete and
 * committed) or -1 (failed: a one-line message in err; the agent stops). */
typedef struct {
    /* Step k (1..steps) begins: its round-0 packet into pkt (the round's
     * length), or return 1 when the step needs no exchange (rounds = 0). */
    int (*begin_step)(void *filter, size_t k, dkf_real_t *pkt, char *err, size_t errlen);
    /* Round r of step k is complete or given up: the packet of row position
     * e is at rx + e * stride when have[e] (the node's own, at its own row
     * position, always). Writes round r + 1's packet into next and returns
     * 0, or commits the step and returns 1 (r = rounds - 1). */
    int (*complete_round)(void *filter, size_t k, size_t r, const dkf_real_t *rx, size_t stride,
                          const unsigned char *have, dkf_real_t *next, char *err, size_t errlen);
    /* A node that joins a running network (optional; NULL: it cannot): the
     * neighbour's packet `pkt` of the last round of step k (k < steps)
     * gives the node a new prior for the end of step k; then step k + 1
     * begins as in begin_step (its round-0 packet into next). 0 or -1. */
    int (*rejoin)(void *filter, size_t k, const dkf_real_t *pkt, dkf_real_t *next, char *err,
                  size_t errlen);
} dkf_ra_ops_t;

typedef struct {
    const dkf_ra_ops_t *ops;
    void *filter;          /* passed to the ops unchanged */
    size_t id;             /* this node */
    const size_t *row;     /* its graph row: node ids, itself included (dkf/graph.h CSR) */
    size_t deg;            /* entries of row, at most DKF_RA_MAX_DEG */
    dkf_net_tw_expect_t ex; /* model id, nnodes, steps, rounds, each round's shape */
} dkf_ra_config_t;

#define DKF_RA_MAX_DEG 256 /* |N_l| including l */
#define DKF_RA_MAX_MSG (64 + 8 * DKF_NET_TW_MAX_LEN)

typedef struct dkf_ra dkf_ra_t;

/* A new agent (nothing published yet); NULL + err. cfg->row must outlive it. */
dkf_ra_t *dkf_ra_new(const dkf_ra_config_t *cfg, const dkf_ra_opts_t *o, char *err,
                     size_t errlen);
void dkf_ra_free(dkf_ra_t *a);

/* Begins step 1 and publishes its first packet. State. */
int dkf_ra_start(dkf_ra_t *a, int64_t now_us);
/* Instead of dkf_ra_start, for a node (re)started while its neighbours
 * run: publishes nothing until it receives a neighbour's packet of the last
 * round of some step k < steps; then the next dkf_ra_poll joins from the
 * newest such packet received by then (the largest k: a backlog read at
 * once does not start the node from an old step): ops->rejoin takes its
 * prior from it and the node runs from step k + 1 (its neighbours, which
 * had given it up, take its packets again from that round on; one already
 * further on waits for it while it catches up). DKF_RA_JOINING, or
 * DKF_RA_FAILED if the ops have no rejoin. */
int dkf_ra_join(dkf_ra_t *a, int64_t now_us);
/* Takes one message from the channel of node chan_node (-1: any). */
dkf_net_verdict_t dkf_ra_receive(dkf_ra_t *a, long chan_node, const void *data, size_t len,
                                 int64_t now_us);
/* Completes every round it can, re-publishes when quiet, ends lingering. State. */
int dkf_ra_poll(dkf_ra_t *a, int64_t now_us);
/* Microseconds until the next thing poll would do on its own (>= 0). */
int64_t dkf_ra_wait_us(const dkf_ra_t *a, int64_t now_us);

/* "<prefix>_<node>" (out: DKF_NET_CHAN_LEN bytes): node `node`'s channel,
 * where it publishes every packet; the node of such a channel, or -1. */
void dkf_ra_chan(char *out, const char *prefix, size_t node);
long dkf_ra_chan_node(const char *channel, const char *prefix);
/* LCM regex of the channels of the row's nodes other than self, e.g.
 * "DKF_TW_(1|5)"; -1 if there is none or it does not fit in cap bytes. */
int dkf_ra_subscription(char *out, size_t cap, const char *prefix, const size_t *row, size_t deg,
                        size_t self);

/* Agent a's graph row (node ids, itself included; *deg entries). */
const size_t *dkf_ra_row(const dkf_ra_t *a, size_t *deg);

/* dkf_ra_subscription of agent a's own row. */
int dkf_ra_neighbours_regex(const dkf_ra_t *a, const char *prefix, char *out, size_t cap);

int dkf_ra_state(const dkf_ra_t *a);
const char *dkf_ra_error(const dkf_ra_t *a);
const dkf_ra_counters_t *dkf_ra_counters(const dkf_ra_t *a);
/* Into a node's result document: "neighbours" (the row without the node),
 * per step 1..steps "degraded" (bool) and "missing" (node ids), and
 * "counters" {sent, reals_sent, ..., rejected, rejected_by_reason}. */
void dkf_ra_result_json(const dkf_ra_t *a, size_t steps, json_t *doc);
/* Steps completed so far; of step j (1-based, <= that): degraded, and
 * whether row position e was missing in it. */
size_t dkf_ra_steps_done(const dkf_ra_t *a);
/* The first step the node ran (1, or its join step k + 1; 0 while joining). */
size_t dkf_ra_first_step(const dkf_ra_t *a);
int dkf_ra_step_degraded(const dkf_ra_t *a, size_t j);
int dkf_ra_step_missing(const dkf_ra_t *a, size_t j, size_t e);

#endif /* DKF_NET_ROUND_AGENT_H */
