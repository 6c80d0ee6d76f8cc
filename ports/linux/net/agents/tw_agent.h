/*
 * tw_agent.h - one node of the seed-003 graph filters (dkf/tw.h,
 * Algorithms 2 and 3) as an agent that exchanges packets only with its
 * neighbours (host side; dkf-tw-node runs one over LCM, docs/guide/network.md
 * "Graph filters over LCM").
 *
 * The agent is transport-free: packets go out through a send callback
 * (which publishes on the node's own channel) and come in through
 * dkf_net_twa_receive with the sender's node id; time is passed in
 * (monotonic microseconds), so tests can drive deadlines with a fake clock.
 *
 * Measurements: each node reads its own y_{l,n} from the scenario file
 * (seed-003 steps layout); there is no measurement channel. The only
 * synchronisation is the packet exchange itself: round t of node l starts
 * when l has the round t-1 packets of every neighbour, so two neighbours
 * are never more than one round apart (a local barrier, no global one).
 *
 * Exactness: with every packet received, a node computes exactly what
 * dkf_tw_net_diffusion_step / dkf_tw_net_consensus_step compute for it:
 * the same dkf_tw_meas_packet, dkf_graph_mix over its row in row order,
 * dkf_tw_node_local, dkf_tw_node_commit (bit for bit; test_tw_agent).
 *
 * Faults: a round waits for a missing packet until round_timeout has passed
 * both since the round started and since the neighbour was last heard
 * from (the first round of step 1: start_timeout, while the processes
 * start). A neighbour that is alive but itself waiting re-publishes every
 * retry_ms, so only a silent one is given up: then it is marked absent
 * and the round completes without it:
 *   Alg 2 info sum: over the packets received (a smaller neighbourhood);
 *   Alg 2 psi mix : alpha renormalised over the packets received;
 *   Alg 3 ACF     : the node's own packet stands in for the missing one
 *                   (w_lj F_l: the row still sums to 1).
 * The step is recorded as degraded with the missing node ids. Later rounds
 * do not wait for an absent neighbour (its packet is used if it arrives
 * before the others; then it is present again, as it is when a packet of an
 * earlier round that the node can still answer shows it behind: it is
 * waited for while it catches up). Lost packets: a node that waits retry_ms
 * without completing its round re-publishes its packet (flagged
 * retransmit); a neighbour further on answers such a retransmit with its
 * packet of that round (it keeps its last 16, round_agent.c).
 * After the last step a node publishes DONE and lingers, answering
 * retransmits, until every present neighbour is DONE or round_timeout.
 */
#ifndef DKF_NET_TW_AGENT_H
#define DKF_NET_TW_AGENT_H

#include <stddef.h>
#include <stdint.h>

#include <jansson.h>

#include "codec.h" /* dkf_net_verdict_t, dkf_net_rejects_t */
#include "dkf/tw.h"
#include "round_agent.h"
#include "scenario.h"

/* Everything a node derives from the scenario (identical in every node). */
typedef struct {
    const dkf_scenario_t *s;
    int alg;                   /* 2 or 3 */
    size_t N, E, n, p, mmax, steps, eta; /* p inputs, mmax the largest m_l */
    size_t rounds;             /* exchanges per step: Alg 2: 2, Alg 3: 2 eta */
    size_t *start, *nbr;       /* the graph (dkf/graph.h CSR) */
    dkf_graph_t g;
    dkf_real_t *alpha, *W;     /* nnz each: the file's or the library defaults */
    int alpha_default, W_default;
    int64_t model_id;          /* FNV-1a of the problem, alg, eta and weights */
} dkf_net_twa_scn_t;

/* Binds the scenario for algorithm alg (2, 3); eta >= 0 overrides the
 * file's (Alg 3). 0, or -1 with "FILE: KEY: problem" in err. */
int dkf_net_twa_scn_bind(dkf_net_twa_scn_t *c, const dkf_scenario_t *s, int alg, long eta,
                         char *err, size_t errlen);
void dkf_net_twa_scn_free(dkf_net_twa_scn_t *c);

/* ---- packets (lcmtypes/tw_packet_t.lcm) ---------------------------------------- */

/* DKF_NET_TW_KIND_INFO, _EST, _DONE and the packet itself are codec.h's. */
#define DKF_NET_TWA_MAX_PKT DKF_NET_TW_MAX_LEN /* DKF_TW_PKT_LEN(DKF_NET_MAX_VEC) */
#define DKF_NET_TWA_MAX_MSG DKF_RA_MAX_MSG
#define DKF_NET_TWA_MAX_DEG DKF_RA_MAX_DEG /* |N_l| including l */

/* What a node of scenario c expects of a packet on the channel of node
 * chan_node (-1: any). */
dkf_net_tw_expect_t dkf_net_twa_expect(const dkf_net_twa_scn_t *c, long chan_node);
/* Kind and length a packet of round r must have. */
void dkf_net_twa_round_shape(const dkf_net_twa_scn_t *c, size_t round, int *kind, size_t *len);

/* Encodes p into buf (cap bytes); *len its size. 0 or -1 (dkf_net_encode_tw). */
int dkf_net_twa_encode(void *buf, size_t cap, size_t *len, const dkf_net_tw_pkt_t *p);

/* dkf_net_decode_tw (codec.c's one checked path) with dkf_net_twa_expect(c,
 * chan_node): MALFORMED (bytes, len outside 0..DKF_NET_TWA_MAX_PKT or not what
 * the datagram holds, kind, flag), NODE (node outside 0..N-1 or != chan_node
 * when chan_node >= 0), MODEL, DIM (len not the round's), STEP (k outside
 * 1..steps, round outside 0..rounds-1 or of the other kind; DONE: k =
 * steps + 1, round 0), NONFINITE (also after conversion to dkf_real_t).
 * out is written only on DKF_NET_ACCEPT; rej (may be NULL) counts. */
dkf_net_verdict_t dkf_net_twa_decode(const void *buf, size_t len, const dkf_net_twa_scn_t *c,
                                     long chan_node, dkf_net_tw_pkt_t *out, dkf_net_rejects_t *rej);

/* "<prefix>_<node>" (out: DKF_NET_CHAN_LEN bytes); the node of such a
 * channel, or -1. */
void dkf_net_twa_chan(char *out, const char *prefix, size_t node);
long dkf_net_twa_chan_node(const char *channel, const char *prefix);
/* LCM regex of node l's neighbours' channels (self excluded), e.g.
 * "DKF_TW_(1|5)"; -1 if it does not fit in cap bytes. */
int dkf_net_twa_subscription(char *out, size_t cap, const dkf_net_twa_scn_t *c, const char *prefix,
                             size_t node);

/* ---- the agent -------------------------------------------------------------------- */

/* The rounds with the neighbours are round_agent.h's (these names are its). */
typedef dkf_ra_opts_t dkf_net_twa_opts_t;
enum {
    DKF_NET_TWA_RUNNING = DKF_RA_RUNNING,
    DKF_NET_TWA_LINGER = DKF_RA_LINGER,
    DKF_NET_TWA_FINISHED = DKF_RA_FINISHED,
    DKF_NET_TWA_FAILED = DKF_RA_FAILED
};
typedef dkf_ra_counters_t dkf_net_twa_counters_t;

typedef struct dkf_net_twa dkf_net_twa_t;

/* A new agent for node id (NULL + err on failure). */
dkf_net_twa_t *dkf_net_twa_new(const dkf_net_twa_scn_t *c, size_t id, const dkf_net_twa_opts_t *o,
                               char *err, size_t errlen);
void dkf_net_twa_free(dkf_net_twa_t *a);

/* Builds step 1's first packet and publishes it. State. */
int dkf_net_twa_start(dkf_net_twa_t *a, int64_t now_us);
/* Takes one message from the channel of node chan_node. */
dkf_net_verdict_t dkf_net_twa_receive(dkf_net_twa_t *a, long chan_node, const void *data,
                                      size_t len, int64_t now_us);
/* Completes every round it can (all present neighbours heard, or the
 * deadline passed), re-publishes when quiet, ends lingering. State. */
int dkf_net_twa_poll(dkf_net_twa_t *a, int64_t now_us);
/* Microseconds until the next thing poll would do on its own (>= 0). */
int64_t dkf_net_twa_wait_us(const dkf_net_twa_t *a, int64_t now_us);

int dkf_net_twa_state(const dkf_net_twa_t *a);
size_t dkf_net_twa_steps_done(const dkf_net_twa_t *a);
const char *dkf_net_twa_error(const dkf_net_twa_t *a);
const dkf_net_twa_counters_t *dkf_net_twa_counters(const dkf_net_twa_t *a);
/* Its rounds with the neighbours (round_agent.h). */
dkf_ra_t *dkf_net_twa_rounds(dkf_net_twa_t *a);
/* The committed node (x, P, z of the last step). */
const dkf_tw_node_t *dkf_net_twa_node(const dkf_net_twa_t *a);

/* The result document: {node, alg, eta, model_id, real, N, E, steps, n[],
 * x[], P[], z[], degraded[], missing[][], counters{...}}. */
json_t *dkf_net_twa_result(const dkf_net_twa_t *a);

#endif /* DKF_NET_TW_AGENT_H */
