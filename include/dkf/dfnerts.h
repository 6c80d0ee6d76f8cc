/*
 * dkf/dfnerts.h - the consensus network of seed 001: DF-DNERTSIF
 * (Algorithm 3, Ding-Xiao-Zhang 2014) and DF-CKF (its p = 0 case), with
 * the corrections of docs/design/nerts.md, and a consistent variant that
 * agrees on the joint information of [x; d] (docs/design/dfnerts.md).
 *
 * Every node l runs its own single-node filter (dkf/nerts.h, an
 * information kind: DKF_NERTS_DNERTSIF for the paper's DF-DNERTSIF,
 * DKF_NERTS_NERTSIF for its EKF form) on its own measurement z^l, and T_p
 * consensus rounds with its neighbours on an information pair:
 *
 *   DKF_DFNERTS_PAPER (Algorithm 3 as corrected, the vectors' algorithm):
 *     Y_l(0) = Y_pred^l,  y_l(0) = y_pred^l                   (Alg. 3, Init.)
 *     tau = 1..T_p:  Y_l <- sum_j W_lj Y_j,  y_l <- sum_j W_lj y_j   (61)
 *                    and at tau = 1 only (Remark 1):
 *                    Y_l += s I^l,  y_l += s i^l               (56)-(59)
 *     P^l = Y_l^{-1},  x^l = P^l y_l;  d^l, Pd^l, Pxd^l stay local.
 *   The next step's cubature points use [[P^l, Pxd^l], [Pdx^l, Pd^l]]: a
 *   consensus P^l beside local Pxd^l, Pd^l. That matrix can be indefinite
 *   (note section 4 item 6): the commit then fails with DKF_ERR_NOT_SPD
 *   and the node is left as it was.
 *
 *   DKF_DFNERTS_JOINT (beyond the paper): the same rounds on the joint
 *   information of X = [x; d]. With d unknown (no prior information),
 *     Y_l(0) = blkdiag(Y_pred^l, 0_p),  y_l(0) = [y_pred^l; 0_p]
 *   and the contribution of z^l, linearised as nu + C x_pred = C x + Hd d
 *   + v with v ~ (0, Rbar) (C, Hd, Rbar, nu of dkf/nerts.h), is
 *     J^l = [C Hd]^T Rbar^{-1} [C Hd],  j^l = [C Hd]^T Rbar^{-1} (nu + C x_pred).
 *   For one node this is exactly its NERTSF / DNERTSF update (the x
 *   marginal Y_pred + C^T Pi(Rbar, Hd) C is the paper's I, and the joint
 *   covariance is the filter's [[Px, Pxd], [Pdx, Pd]]), so the variant
 *   changes only what is agreed on. After the rounds
 *     P_X = Y_X^{-1},  [x; d] = P_X y_X,
 *   and Px, Pxd, Pd are blocks of one positive definite matrix: the next
 *   step's joint covariance is consistent by construction, and d^l is a
 *   network estimate (the paper's stays a one-sensor estimate). With
 *   W = 1 1^T / N, T_p >= 2 and s = N every node holds the centralised
 *   joint information filter on all sensors (input common to all).
 *
 * The scale s is a parameter of every step: s = 1 is the paper's literal
 * algorithm (at consensus it keeps 1/N of the measurement information),
 * s = N the N-scaled variant (the centralised information at consensus;
 * W doubly stochastic).
 *
 * PACKETS. A node sends one plain array of reals per round:
 *   [ y (q) | Y packed (q (q + 1) / 2) ],  q = n (PAPER) or n + p (JOINT),
 * "packed" as in dkf/tw.h (upper triangle row by row, dkf__pack_sym).
 * Mixing packets with dkf/graph.h's primitives mixes the matrices.
 *
 * NODE API (one node; it sees only its neighbours' packets):
 *   dkf_dfnerts_node_init    (kind, variant, prior)
 *   dkf_dfnerts_node_local   time update and local statistics of its z,
 *                            writes its tau = 0 packet; the step is pending
 *   dkf_dfnerts_node_mix     one round: the packets of N_l (its own
 *                            included, in the order of its weights) ->
 *                            its next packet (tau = 1 adds s * contribution)
 *   dkf_dfnerts_node_commit  the posterior from its current packet
 *   dkf_dfnerts_node_cancel  drops a pending step (node as before local)
 *   dkf_dfnerts_node_restart a new prior at step k (a node that restarts)
 *   dkf_dfnerts_node_rejoin  a new prior from a neighbour's packet
 * A failed call leaves the node bit-identical: the struct, the filter's
 * state and, while a step is pending, that step (below). Every call makes
 * all its checks before its first write; the composite ones (local over a
 * pending step, restart, rejoin) form their results aside and replace
 * the node's only once everything has passed.
 *
 * WHOLE NETWORK (dkf_dfnerts_net_*): N nodes and two packet buffers in one
 * caller array, stepped in-process with the same node calls; a step that
 * fails at any node leaves every node, and the network, as they were
 * before the step.
 *
 * PER NODE: m_l, the model (h; f and Q too, one system assumed), R, z and
 * the prior may differ; n, p, the known input u, kind, variant, s and T_p
 * are common (a packet's length depends on n and p only).
 *
 * Statuses: those of dkf/nerts.h's phases (DKF_ERR_MODEL, _NONFINITE,
 * _NOT_SPD, _RANK, _DIM), DKF_ERR_STATE out of order (mix or commit
 * without a pending step, commit before the first round), DKF_ERR_ARG (a
 * covariance kind, an unknown variant, T_p = 0 or above
 * DKF_DFNERTS_MAX_TP, a non-finite or non-positive scale),
 * DKF_ERR_WEIGHTS (W not doubly stochastic), DKF_ERR_GRAPH,
 * DKF_ERR_NOT_SPD at commit: the agreed Y (Y_X) is not SPD, or (PAPER)
 * the mixed joint covariance is not positive definite.
 */
#ifndef DKF_DFNERTS_H
#define DKF_DFNERTS_H

#include <stddef.h>

#include "dkf/graph.h"
#include "dkf/mat.h"
#include "dkf/nerts.h"
#include "dkf/nl_model.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    DKF_DFNERTS_PAPER = 0, /* Algorithm 3: consensus on (Y, y) of x */
    DKF_DFNERTS_JOINT = 1  /* consensus on the joint information of [x; d] */
} dkf_dfnerts_variant_t;

/* Reals of a packet for an agreed vector of q reals. */
#define DKF_DFNERTS_PKT_LEN(q) ((q) + (q) * ((q) + 1) / 2)
/* The largest packet of a node with state n and input p (JOINT). */
#define DKF_DFNERTS_PKT_MAX(n, p) DKF_DFNERTS_PKT_LEN((n) + (p))

/* Largest T_p a step accepts (a T_p from a file cannot run for ever);
 * the bound of dkf/tw.h's consensus (DKF_TW_MAX_ETA, same reasoning). */
#define DKF_DFNERTS_MAX_TP 1000000u

/* Node storage: the filter's (its state first), the current packet and
 * the scaled contribution, the snapshot of the filter's state that a
 * cancel restores, and scratch (a mixed packet; the commit's and the
 * joint contribution's matrices). */
#define DKF__DFNERTS_Q(n, p) ((n) + (p))
#define DKF__DFNERTS_SCRATCH_LEN(n, m, p) \
    (DKF_DFNERTS_PKT_MAX(n, p) + 4 * DKF__DFNERTS_Q(n, p) * DKF__DFNERTS_Q(n, p) + \
     3 * DKF__DFNERTS_Q(n, p) + 2 * (m) * DKF__DFNERTS_Q(n, p) + (m) * (m) + 2 * (m))
#define DKF_DFNERTS_NODE_STORAGE_LEN(n, m, p) \
    (DKF_NERTS_STORAGE_LEN(n, m, p) + 2 * DKF_DFNERTS_PKT_MAX(n, p) + \
     DKF_NERTS_STATE_LEN(n, m, p) + DKF__DFNERTS_SCRATCH_LEN(n, m, p))
/* The first DKF_DFNERTS_NODE_STATE_LEN reals are the filter's state
 * (posterior, prediction, local statistics, Y, y: dkf/nerts.h); a failed
 * call leaves them and the struct bit-identical. */
#define DKF_DFNERTS_NODE_STATE_LEN(n, m, p) DKF_NERTS_STATE_LEN(n, m, p)
/* While a step is pending (nd->pending), the DKF_DFNERTS_NODE_PENDING_LEN
 * reals from DKF_DFNERTS_NODE_PENDING_AT on are state too: the current
 * packet, s times the contribution and the snapshot of the filter's state
 * that a cancel restores. A failed call leaves them bit-identical as well;
 * the rest of the storage is scratch. */
#define DKF_DFNERTS_NODE_PENDING_AT(n, m, p) DKF_NERTS_STORAGE_LEN(n, m, p)
#define DKF_DFNERTS_NODE_PENDING_LEN(n, m, p) \
    (2 * DKF_DFNERTS_PKT_MAX(n, p) + DKF_NERTS_STATE_LEN(n, m, p))

typedef struct {
    dkf_nerts_t f; /* the node's filter: its posterior, prediction, local views */
    dkf_dfnerts_variant_t variant;
    size_t n, m, p;
    size_t q;       /* agreed dimension: n (PAPER) or n + p (JOINT) */
    size_t pkt_len; /* DKF_DFNERTS_PKT_LEN(q) */
    size_t tau;     /* rounds mixed in the pending step (0 between steps) */
    int pending;    /* local done, not committed or cancelled */
    dkf_real_t scale;     /* s of the pending step (0 between steps) */
    const dkf_real_t *pkt; /* the node's current packet (pkt_len reals) */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_nerts_t saved; /* the filter before the pending step */
        dkf_real_t *mem;
        int ready;
    } priv;
} dkf_dfnerts_node_t;

/* `name` and `name_storage`, storage class sc: the form of DKF_KF_DECLARE. */
#define DKF_DFNERTS_NODE_DECLARE(sc, name, n, m, p) \
    sc dkf_real_t name##_storage[DKF_DFNERTS_NODE_STORAGE_LEN(n, m, p)]; \
    sc dkf_dfnerts_node_t name

/* Binds the node to storage and initialises its filter (dkf_nerts_init:
 * kind DKF_NERTS_NERTSIF or DKF_NERTS_DNERTSIF, else DKF_ERR_ARG; prior
 * x0, P0, d0, Pd0, Pxd0, NULL for the input with p = 0). */
dkf_status_t dkf_dfnerts_node_init(dkf_dfnerts_node_t *nd, dkf_nerts_kind_t kind,
                                   dkf_dfnerts_variant_t variant, size_t n, size_t m, size_t p,
                                   dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                                   const dkf_mat_t *P0, const dkf_mat_t *d0,
                                   const dkf_mat_t *Pd0, const dkf_mat_t *Pxd0);

/* Time update (u_prev, Q) and local statistics of z (u, R) with the
 * node's model (dkf_nerts_predict, dkf_nerts_local), then the tau = 0
 * packet (also to pkt, pkt_len reals, if not NULL) and s times the
 * contribution for tau = 1. Over a pending step: the new step starts from
 * the posterior before it (as after a cancel) and replaces it on success;
 * a failure leaves it pending, as it was. */
dkf_status_t dkf_dfnerts_node_local(dkf_dfnerts_node_t *nd, const dkf_nl_model_t *model,
                                    const dkf_real_t *u_prev, const dkf_mat_t *Q,
                                    const dkf_real_t *u, const dkf_mat_t *R, const dkf_mat_t *z,
                                    dkf_real_t scale, dkf_real_t *pkt);

/* One consensus round: the node's next packet is sum_e w[e] in[e] over
 * the count packets of its neighbourhood (its own nd->pkt among them, in
 * the order of w: its row of the graph's weights), plus s times its
 * contribution in the first round; copied to out (pkt_len reals) if not
 * NULL. in[] may point at nd->pkt. */
dkf_status_t dkf_dfnerts_node_mix(dkf_dfnerts_node_t *nd, const dkf_real_t *const in[],
                                  const dkf_real_t *w, size_t count, dkf_real_t *out);

/* Commits the pending step from the node's current packet (after at
 * least one round): PAPER dkf_nerts_commit_info (Px = Y^{-1}, x = Px y,
 * the local d, Pd, Pxd); JOINT P_X = Y_X^{-1}, [x; d] = P_X y_X and Px,
 * Pxd, Pd its blocks (the filter's Y, y: Px^{-1}, Px^{-1} x). */
dkf_status_t dkf_dfnerts_node_commit(dkf_dfnerts_node_t *nd);

/* Drops a pending step: the filter is as before dkf_dfnerts_node_local.
 * DKF_ERR_STATE without one. */
dkf_status_t dkf_dfnerts_node_cancel(dkf_dfnerts_node_t *nd);

/* A new prior mid-run (a node that restarts and rejoins): the posterior
 * at step k is x0, P0, d0, Pd0, Pxd0 (as for init, with its statuses);
 * the next local is the step k -> k + 1. The prior is checked completely
 * (its joint covariance's definiteness last) before anything is written:
 * a refused prior leaves the node, and a pending step, as they were; a
 * new prior drops a pending step. */
dkf_status_t dkf_dfnerts_node_restart(dkf_dfnerts_node_t *nd, size_t k, const dkf_mat_t *x0,
                                      const dkf_mat_t *P0, const dkf_mat_t *d0,
                                      const dkf_mat_t *Pd0, const dkf_mat_t *Pxd0);

/* A node that joins a running network, with its prior taken from a
 * neighbour's packet `pkt` (pkt_len reals, e.g. of the last round of step
 * k): P = Y^{-1}, X = P y of the packet's information pair. PAPER: the
 * posterior at step k is x = X, Px = P, and the input's d0, Pd0 (p > 0:
 * the caller's, e.g. the file's prior; Pxd = 0); JOINT: x, d, Px, Pxd, Pd
 * are X's and P's blocks (d0, Pd0 ignored, may be NULL). Then as
 * dkf_dfnerts_node_restart(k). Checks, in order: DKF_ERR_NULL (pkt; PAPER
 * with p > 0: d0, Pd0), DKF_ERR_NONFINITE (the packet, or P, X
 * overflowing), DKF_ERR_NOT_SPD (the packet's Y), then restart's on the
 * prior (PAPER: the caller's d0, Pd0, e.g. DKF_ERR_NOT_SPD for an
 * indefinite Pd0). Every check comes before the first write: a failure
 * leaves the node, and a pending step, bit-identical. */
dkf_status_t dkf_dfnerts_node_rejoin(dkf_dfnerts_node_t *nd, size_t k, const dkf_real_t *pkt,
                                     const dkf_mat_t *d0, const dkf_mat_t *Pd0);

/* ---- in-process whole network ------------------------------------------- */

/* An upper bound of dkf_dfnerts_net_storage_len for N nodes that measure
 * at most m_max values each (exact when every node has m_max). */
#define DKF_DFNERTS_NET_STORAGE_LEN(N, n, m_max, p) \
    ((N) * (DKF_DFNERTS_NODE_STORAGE_LEN(n, m_max, p) + 2 * DKF_DFNERTS_PKT_MAX(n, p)))

typedef struct {
    const dkf_graph_t *g;
    size_t N, n, p;
    size_t m_max;              /* the largest m_l (node l's is nodes[l].m) */
    dkf_dfnerts_node_t *nodes; /* caller array of N nodes */
    /* communication, summed over nodes and steps */
    unsigned long reals_sent;
    unsigned long broadcasts;
    size_t steps;
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *cur, *nxt; /* N x DKF_DFNERTS_PKT_MAX: the packets of a round */
    } priv;
} dkf_dfnerts_net_t;

/* `name`, its node array `name_nodes` and `name_storage` (nodes of up to
 * m_max measurements), storage class sc. */
#define DKF_DFNERTS_NET_DECLARE(sc, name, N, n, m_max, p) \
    sc dkf_real_t name##_storage[DKF_DFNERTS_NET_STORAGE_LEN(N, n, m_max, p)]; \
    sc dkf_dfnerts_node_t name##_nodes[N]; \
    sc dkf_dfnerts_net_t name

/* Exact reals of storage for N nodes, node l measuring m[l] values: the
 * nodes' DKF_DFNERTS_NODE_STORAGE_LEN(n, m[l], p) one after another, then
 * the two packet buffers. 0 for N = 0, a NULL m or a dimension out of
 * range (an m[l] of 0 or above DKF_MAX_DIM, n + p above it). */
size_t dkf_dfnerts_net_storage_len(size_t N, size_t n, const size_t m[], size_t p);

/* Binds the network to the graph g (checked: DKF_ERR_GRAPH), nodes[0 ..
 * g->N - 1] and storage (dkf_dfnerts_net_storage_len(g->N, n, m, p) reals,
 * else DKF_ERR_CAPACITY), and initialises node l for m[l] measurements
 * with its prior x0[l], P0[l], d0[l], Pd0[l], Pxd0[l] (the last three NULL
 * when p = 0). The dimensions (DKF_ERR_CAPACITY; DKF_ERR_RANK for an m[l]
 * < p), the storage and every node's prior are checked before any node
 * is touched: a failure leaves net and the nodes as they were. */
dkf_status_t dkf_dfnerts_net_init(dkf_dfnerts_net_t *net, const dkf_graph_t *g,
                                  dkf_dfnerts_node_t *nodes, dkf_nerts_kind_t kind,
                                  dkf_dfnerts_variant_t variant, size_t n, const size_t m[],
                                  size_t p, dkf_real_t *storage, size_t storage_len,
                                  const dkf_mat_t x0[], const dkf_mat_t P0[], const dkf_mat_t d0[],
                                  const dkf_mat_t Pd0[], const dkf_mat_t Pxd0[]);

/* One step of every node: local with models[l], Q[l], R[l], z[l] (node
 * l's m_l: models[l].m, R[l] m_l x m_l and z[l] m_l x 1, else
 * DKF_ERR_DIM; u_prev, u shared, NULL when q = 0), Tp rounds with W (nnz
 * weights parallel to g->nbr, doubly stochastic, >= 0), commit. Tp in
 * [1, DKF_DFNERTS_MAX_TP]. DKF_ERR_STATE, before anything, while a node
 * has a step of its own pending (node calls on the network's nodes: a
 * failed step could not give it back). */
dkf_status_t dkf_dfnerts_net_step(dkf_dfnerts_net_t *net, const dkf_nl_model_t models[],
                                  const dkf_real_t *u_prev, const dkf_mat_t Q[],
                                  const dkf_real_t *u, const dkf_mat_t R[], const dkf_mat_t z[],
                                  const dkf_real_t *W, size_t Tp, dkf_real_t scale);

#ifdef __cplusplus
}
#endif

#endif /* DKF_DFNERTS_H */
