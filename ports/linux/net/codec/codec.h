/*
 * codec.h - LCM wire messages (lcmtypes/<type>.lcm) <-> plain structs, with
 * validation of everything received (host side).
 *
 * The node message decodes into the core's dkf_diffkf_msg_t
 * (dkf/diffkf_fusion.h) plus the envelope fields the core does not need
 * (model id, sequence number, time stamps: dkf_net_meta_t). Every decoder
 * checks, in this order, and returns the first verdict that fails:
 *   MALFORMED  truncated bytes, trailing bytes, wrong type fingerprint,
 *              an array length outside the protocol's range (n, m in
 *              1..DKF_NET_MAX_VEC, nnodes in 1..DKF_NET_MAX_NODES, a status
 *              detail of 1..4096 bytes with its NUL last, a graph-filter
 *              packet of 0..DKF_NET_TW_MAX_LEN reals) or one the datagram
 *              does not hold, negative epoch, a flag (boolean) not 0/1
 *   NODE       node id outside 0..nnodes-1, or not the sender's node
 *              (ex->node: the node whose key verified the datagram, or
 *              without authentication the node its channel names)
 *   MODEL      model id differs from the receiver's scenario model
 *   DIM        n (or m) is not the receiver's dimension
 *   STEP       k outside 1..kmax; node message: also k_start outside 1..k,
 *              or a previous payload that is not of step k-1 >= k_start
 *   NONFINITE  NaN/Inf, also after conversion to dkf_real_t (float build)
 * and counts each rejection in a dkf_net_rejects_t. Outputs are written
 * only on DKF_NET_ACCEPT.
 *
 * Every decoder of network input in ports/linux (these, the graph filters'
 * packet dkf_net_decode_tw among them) runs the bytes through one checked
 * path in codec.c: the type's wire layout is checked against the
 * datagram before lcm-gen's decoder (which trusts the lengths it reads)
 * runs. tests/fuzz/fuzz_net.c fuzzes them all (docs/guide/fuzzing.md).
 */
#ifndef DKF_NET_CODEC_H
#define DKF_NET_CODEC_H

#include <stddef.h>
#include <stdint.h>

#include "chan.h"
#include "dkf/diffkf_fusion.h"
#include "dkf/tw.h"

/* Largest vector a message carries (a state n, a measurement m_i, a graph
 * node's state): the core's DKF_MAX_DIM, at most 64. A host build with a
 * large DKF_MAX_DIM for a big fusion centre (docs/decisions.md, item 23)
 * keeps the messages and their buffers the size of one node's vectors. */
#define DKF_NET_MAX_VEC (DKF_MAX_DIM < 64 ? DKF_MAX_DIM : 64)
/* Largest encoded message of any type (fused: 4 + 2n + 2n^2 doubles). */
#define DKF_NET_MAX_MSG \
    (128 + DKF_NET_MAX_NODES + 8 * (2 * DKF_NET_MAX_VEC + 2 * DKF_NET_MAX_VEC * DKF_NET_MAX_VEC))

typedef enum {
    DKF_NET_ACCEPT = 0,
    DKF_NET_REJ_MALFORMED,
    DKF_NET_REJ_NODE,
    DKF_NET_REJ_MODEL,
    DKF_NET_REJ_DIM,
    DKF_NET_REJ_STEP,
    DKF_NET_REJ_NONFINITE,
    DKF_NET_REJ_SENDER, /* the payload names another sender than the authenticated one */
    DKF_NET_NVERDICTS
} dkf_net_verdict_t;

/* "accepted", "malformed", "unknown node", ... */
const char *dkf_net_verdict_str(dkf_net_verdict_t v);

typedef struct {
    uint64_t total;
    uint64_t by[DKF_NET_NVERDICTS]; /* by[0] unused */
} dkf_net_rejects_t;

/* Counts verdict v in rej (may be NULL; ACCEPT is not counted); returns v. */
dkf_net_verdict_t dkf_net_reject(dkf_net_rejects_t *rej, dkf_net_verdict_t v);

/* What a receiver expects. */
typedef struct {
    int64_t model_id;
    size_t nnodes;     /* node ids 0..nnodes-1 */
    long node;         /* the channel's node, or -1 for any */
    size_t n;          /* state dimension */
    const size_t *m;   /* measurement dimension per node (measurements only) */
    long kmax;         /* largest acceptable k */
} dkf_net_expect_t;

/* Envelope of a message: what the core message does not carry. */
typedef struct {
    int64_t utime;      /* publication time, us since the epoch */
    int64_t model_id;
    int64_t seq;
    int64_t meas_utime; /* node message: utime of the measurement that completed the step */
    long epoch;         /* node message: restart counter of the local filter (>= 0) */
    long k_start;       /* node message: first step of this epoch (1 <= k_start <= k) */
    int has_prev;       /* node message: the payload of step k-1 rides along */
} dkf_net_meta_t;

/* One sensor's measurement, as host doubles. */
typedef struct {
    dkf_net_meta_t meta; /* meas_utime unused */
    size_t node;
    long k;
    size_t m;
    double y[DKF_NET_MAX_VEC];
} dkf_net_meas_t;

/* The simulated truth. */
typedef struct {
    dkf_net_meta_t meta;
    long k;
    size_t n;
    double x[DKF_NET_MAX_VEC];
} dkf_net_truth_t;

/* A fused estimate (host doubles; matrices row-major n x n). */
typedef struct {
    dkf_net_meta_t meta; /* meas_utime unused */
    long k;
    int degraded;        /* 0 complete (centralized), 1 some nodes' rows missing */
    long revision;       /* 0 first publication, r > 0 r-th recomputation */
    size_t nnodes;
    unsigned char contributed[DKF_NET_MAX_NODES];
    int64_t meas_utime_first, meas_utime_last, msg_utime_last;
    size_t n;
    double xf[DKF_NET_MAX_VEC], xp[DKF_NET_MAX_VEC];
    double Pf[DKF_NET_MAX_VEC * DKF_NET_MAX_VEC], Pp[DKF_NET_MAX_VEC * DKF_NET_MAX_VEC];
} dkf_net_fused_t;

/* Process status / heartbeat (lcmtypes/status_t.lcm; role: chan.h). */
enum { DKF_NET_STARTING = 0, DKF_NET_RUNNING = 1, DKF_NET_DONE = 2, DKF_NET_FAILED = 3 };
typedef struct {
    int64_t utime, model_id;
    int role, id, state;
    long k;
    int64_t sent, received, rejected, missed;
    char detail[160];
} dkf_net_status_t;

/* Copies what a node message holds: node, k, n and the first n values of
 * xf and xp (n capped at DKF_MAX_DIM); the rest of dst is left as it was.
 * In a build with a large DKF_MAX_DIM the struct is 16 KiB, its used part a
 * few cache lines. */
void dkf_net_copy_node_msg(dkf_diffkf_msg_t *dst, const dkf_diffkf_msg_t *src);
/* The same as fc_runtime.h's copy operation (user unused): the centres
 * whose payload is a node message store only its used part. */
void dkf_net_copy_node_payload(void *user, void *dst, const void *src);

/* Encoders: write the message into buf (cap bytes), *len = its size.
 * 0, or -1 if it does not fit or a dimension is out of range. */
/* Node message: msg is step k; prev (used iff meta->has_prev; then
 * prev->k == k-1 and prev->n == msg->n) the node's previous step. */
int dkf_net_encode_node_msg(void *buf, size_t cap, size_t *len, const dkf_diffkf_msg_t *msg,
                            const dkf_diffkf_msg_t *prev, const dkf_net_meta_t *meta);
int dkf_net_encode_meas(void *buf, size_t cap, size_t *len, const dkf_net_meas_t *meas);
int dkf_net_encode_truth(void *buf, size_t cap, size_t *len, const dkf_net_truth_t *t);
int dkf_net_encode_fused(void *buf, size_t cap, size_t *len, const dkf_net_fused_t *f);
int dkf_net_encode_status(void *buf, size_t cap, size_t *len, const dkf_net_status_t *st);

/* Decoders (see the top of this file). rej may be NULL. */
/* Node message: prev (may be NULL) receives the previous payload when
 * meta->has_prev (untouched otherwise). */
dkf_net_verdict_t dkf_net_decode_node_msg(const void *buf, size_t len,
                                          const dkf_net_expect_t *ex, dkf_diffkf_msg_t *msg,
                                          dkf_diffkf_msg_t *prev, dkf_net_meta_t *meta,
                                          dkf_net_rejects_t *rej);
dkf_net_verdict_t dkf_net_decode_meas(const void *buf, size_t len, const dkf_net_expect_t *ex,
                                      dkf_net_meas_t *meas, dkf_net_rejects_t *rej);
/* Truth: MODEL, DIM, STEP (0..kmax), NONFINITE; nnodes, node, m unused. */
dkf_net_verdict_t dkf_net_decode_truth(const void *buf, size_t len, const dkf_net_expect_t *ex,
                                       dkf_net_truth_t *t, dkf_net_rejects_t *rej);
/* Fused: nnodes must equal ex->nnodes (else NODE); status must be valid (else MALFORMED). */
dkf_net_verdict_t dkf_net_decode_fused(const void *buf, size_t len, const dkf_net_expect_t *ex,
                                       dkf_net_fused_t *f, dkf_net_rejects_t *rej);
/* Status: MALFORMED (any model), then SENDER: from is known (chan.h) and
 * the payload's role and id are not its role and id (a node: its node id;
 * the simulator, the fusion centre: -1). from NULL or unknown: any role. */
dkf_net_verdict_t dkf_net_decode_status(const void *buf, size_t len, const dkf_net_from_t *from,
                                        dkf_net_status_t *st, dkf_net_rejects_t *rej);

/* A graph-filter packet (lcmtypes/tw_packet_t.lcm; tw_agent.h is its user):
 * kind INFO (Algorithm 2 round 0 / Algorithm 3 rounds < eta: the
 * information pair), EST (an estimate) or DONE (the node's last step is
 * over; no reals). */
enum { DKF_NET_TW_KIND_INFO = 0, DKF_NET_TW_KIND_EST = 1, DKF_NET_TW_KIND_DONE = 2 };
#define DKF_NET_TW_MAX_LEN DKF_TW_PKT_LEN(DKF_NET_MAX_VEC)
typedef struct {
    int64_t utime, model_id;
    long node, k, round;
    int kind, retransmit; /* retransmit 0/1 */
    size_t len;           /* reals in v, <= DKF_NET_TW_MAX_LEN */
    dkf_real_t v[DKF_NET_TW_MAX_LEN];
} dkf_net_tw_pkt_t;

/* What a graph-filter receiver expects (dkf_net_twa_expect fills it from the
 * scenario): rounds 0..info_rounds-1 of a step are INFO packets of
 * info_len reals, the rest up to rounds-1 EST packets of est_len. */
typedef struct {
    int64_t model_id;
    size_t nnodes;       /* node ids 0..nnodes-1 */
    long node;           /* the channel's node, or -1 for any */
    size_t steps;        /* k in 1..steps (DONE: steps + 1, round 0) */
    size_t rounds, info_rounds, info_len, est_len;
} dkf_net_tw_expect_t;

/* Kind and length a packet of round r must have. */
void dkf_net_tw_shape(const dkf_net_tw_expect_t *ex, size_t round, int *kind, size_t *len);
/* 0, or -1 if len is too large or the packet does not fit in cap bytes. */
int dkf_net_encode_tw(void *buf, size_t cap, size_t *len, const dkf_net_tw_pkt_t *p);
/* In codec.h's order: MALFORMED (the wire layout, kind outside 0..2, a
 * flag not 0/1), NODE (outside 0..nnodes-1 or not ex->node when >= 0),
 * MODEL, DIM (len not the round's; DONE: not 0), STEP (k outside 1..steps,
 * round outside 0..rounds-1 or of the other kind; DONE: k != steps + 1 or
 * round != 0), NONFINITE (also after conversion to dkf_real_t). */
dkf_net_verdict_t dkf_net_decode_tw(const void *buf, size_t len, const dkf_net_tw_expect_t *ex,
                                    dkf_net_tw_pkt_t *out, dkf_net_rejects_t *rej);

#endif /* DKF_NET_CODEC_H */
