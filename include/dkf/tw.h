/*
 * dkf/tw.h - Kalman filtering with unknown actuations over a sensor
 * network: seed 003 (Talebi-Werner), Algorithms 1 (centralized two-stage
 * filter), 2 (diffusion) and 3 (consensus), in the corrected form of
 * docs/design/graph-filters.md.
 *
 * Model (time k; F, G, Q may change with k, the dimensions may not):
 *   x_k     = F x_{k-1} + G d_{k-1} + w_{k-1},   w ~ (0, Q)       (1a)
 *   y_{l,k} = H_l x_k + v_{l,k},                v_l ~ (0, R_l)    (1b)
 * Library letters (dkf/ui_model.h): state n, unknown input p, node l
 * measures m_l <= m_max values; the paper writes F, G, Q, R as A, B, Sv,
 * Sw, the input d as z and the time as n. d is unknown and unmodelled (no
 * prior): the step that takes y_k estimates d_{k-1}. (x0, P0) = x_{0|0},
 * P_{0|0}; y_0 is never used.
 *
 * Every algorithm is the same LOCAL STEP run on aggregated information
 *   I = sum_j H_j^T R_j^{-1} H_j,   i = sum_j H_j^T R_j^{-1} y_j
 * (the contributions of dkf/info.h; the paper's Q and s; information form
 * (9)-(20), the sum over all nodes for Algorithm 1, over N_l for
 * Algorithm 2, an average-consensus estimate for Algorithm 3):
 *   phi- = F x,  Phi- = F P F^T + Q                           (6a)-(6b)
 *   Phi+ = (Phi-^{-1} + I)^{-1} = Psi^{-1}                    (10), (7b)
 *   phi+ = phi- + Phi+ (i - I phi-)                           (20)
 *   Gpost = (I_n - Phi+ I) G = Phi+ Phi-^{-1} G               (8a, the paper's G)
 *   S    = G^T Pi G = Gpost^T I G,  Pi = I - I Psi^{-1} I     (11)-(12)
 *   d^   = S^{-1} Gpost^T (i - I phi-)                        (18)
 *   psi  = phi+ + Gpost d^,   Ploc = Phi+ + Gpost S^{-1} Gpost^T  (8b)-(8c)
 * (8c) as corrected: the paper prints G S G^T. Then the node's estimate is
 *   Alg 1: x = psi, P = Ploc
 *   Alg 2: x_l = sum_k alpha_lk psi_k (26b), P_l = Ploc_l (26c)
 *   Alg 3: x_l = ACF{psi_k}, P_l = ACF{Ploc_k}             (34b)-(34c)
 *
 * PACKETS. Everything a node sends is a plain array of dkf_real_t:
 *   info packet (DKF_TW_PKT_LEN(n) reals) = [ i (n) | I packed ]
 *   estimate packet (same length)         = [ psi (n) | Ploc packed ]
 * "packed" = the upper triangle of a symmetric n x n matrix, row by row:
 * (0,0) (0,1) .. (0,n-1) (1,1) .. (n-1,n-1), n(n+1)/2 reals. Mixing
 * packets with dkf/graph.h is mixing the matrices (the map is linear).
 *
 * NODE API (one node, its state in caller storage):
 *   dkf_tw_node_init       (x0, P0)
 *   dkf_tw_meas_packet     its own (H, R) and y -> info packet, scaled
 *   [combine info packets: sum (Alg 1, 2) or ACF (Alg 3), dkf/graph.h]
 *   dkf_tw_node_local      local step on the combined info packet, writes
 *                          the estimate packet; nothing is committed yet
 *   [combine estimate packets: alpha-mix of psi (Alg 2), ACF (Alg 3)]
 *   dkf_tw_node_commit     x, P of the combination (NULL: the local ones)
 * A failed call of any kind leaves the node bit-identical: x, P, d, k,
 * the views of the last committed step and a pending step (a local step
 * is formed aside and replaces the pending one only once it succeeded).
 *
 * WHOLE-GRAPH SIMULATION (dkf_tw_net_*): N nodes and their packet buffers
 * in one caller array, stepping all nodes with the same primitives; a
 * step that fails at any node commits no node and leaves none pending
 * (it refuses to run, DKF_ERR_STATE, while a node has a step of its own
 * pending). It counts the reals each node broadcasts.
 *
 * PER NODE: m_l (<= the m_max the storage is sized for), H_l, R_l and y_l
 * may differ; n, p, the dynamics (F, G, Q) and, in dkf_tw_net_init, the
 * prior (x0, P0) are common.
 */
#ifndef DKF_TW_H
#define DKF_TW_H

#include <stddef.h>

#include "dkf/graph.h"
#include "dkf/kf.h"
#include "dkf/mat.h"
#include "dkf/ui_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reals of an info or estimate packet for state dimension n. */
#define DKF_TW_PKT_LEN(n) ((n) + (n) * ((n) + 1) / 2)

/* Reals of node storage for state n, input p, measurements up to m_max. */
#define DKF_TW_NODE_STORAGE_LEN(n, m, p) \
    ((n) + (n) * (n) /* x, P */ \
     + 3 * ((p) + 4 * (n) + 4 * (n) * (n) + (p) * (p) + (n) * (p)) \
     /* d + views: committed, pending, the next pending (a local step's) */ \
     + 3 * (n) * (n) + 3 * (n) * (p) + 2 * (p) * (p) + (n) /* local-step scratch */ \
     + (m) * (m) + (m) * (n) + (m) /* info-packet scratch */ \
     + 2 * DKF_TW_PKT_LEN(n)) /* packet being built, the central sum */

/* The first DKF_TW_NODE_STATE_LEN(n, p) reals of node storage hold x, P, d
 * and the views of the last committed step, and the next
 * DKF_TW_NODE_STATE_LEN(n, p) - n - n^2 the pending step (state while
 * nd->pending): a failed call leaves them and the struct bit-identical.
 * The rest is scratch. */
#define DKF_TW_NODE_STATE_LEN(n, p) \
    ((n) + (n) * (n) + (p) + 4 * (n) + 4 * (n) * (n) + (p) * (p) + (n) * (p))

/* The model: dkf_uif_dyn_t {F, G, Q} of time k - 1 (dkf/ui_model.h; Q
 * symmetric PSD, may be singular) and, per node, dkf_kf_meas_t {H, R}
 * (dkf/kf.h; H m_l x n, R m_l x m_l SPD) with its y (m_l x 1) as a
 * separate argument. */

typedef struct {
    size_t n, m_max, p;
    size_t k; /* committed steps: x is x_{k|k} */
    /* estimate */
    dkf_mat_t x; /* x^_{l,k}, n x 1 */
    dkf_mat_t P; /* P_{l,k}, n x n */
    dkf_mat_t d; /* d^_{l,k}: the estimate of d_{k-1}, p x 1 */
    /* the last committed step, for inspection and tests */
    dkf_mat_t phi, Phi;           /* phi_{k|k-1}, Phi_{k|k-1} */
    dkf_mat_t I, i;               /* the info used (paper: Q_l / Upsilon_l, s_l / varphi_l) */
    dkf_mat_t phi_post, Phi_post; /* phi_{k|k}, Phi_{k|k} */
    dkf_mat_t S, Gpost;           /* S_k (p x p), Gpost_k (n x p; paper: G_n) */
    dkf_mat_t psi, Ploc;          /* phi+ + Gpost d^, Phi+ + Gpost S^{-1} Gpost^T (local) */
    int pending; /* dkf_tw_node_local succeeded, commit not yet called */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *mem; /* pending step and scratch */
        int ready;
    } priv;
} dkf_tw_node_t;

/* `name` and `name_storage`, storage class sc (static, extern or empty):
 * the form of DKF_KF_DECLARE (dkf/kf.h). */
#define DKF_TW_NODE_DECLARE(sc, name, n, m, p) \
    sc dkf_real_t name##_storage[DKF_TW_NODE_STORAGE_LEN(n, m, p)]; \
    sc dkf_tw_node_t name

/* Binds the node to storage; x = x0, P = P0 (SPD), d = 0, k = 0.
 * DKF_ERR_RANK if p > n (S = G^T Pi G cannot be invertible then). */
dkf_status_t dkf_tw_node_init(dkf_tw_node_t *nd, size_t n, size_t m_max, size_t p,
                              dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                              const dkf_mat_t *P0);

/* The node's info packet: pkt = scale * [H^T R^{-1} y | packed H^T R^{-1} H]
 * (17), (21) for its measurement y (m x 1) with the model meas; scale 1
 * for Algorithms 1-2, |N| for the ACF inputs of Algorithm 3 (32c), (33a).
 * Uses the node's scratch only. DKF_ERR_CAPACITY if m > m_max,
 * DKF_ERR_NOT_SPD if R is not SPD. */
dkf_status_t dkf_tw_meas_packet(dkf_real_t *pkt, dkf_tw_node_t *nd, const dkf_kf_meas_t *meas,
                                const dkf_mat_t *y, dkf_real_t scale);

/* The local step on an info packet (see the top of this file). Writes the
 * estimate packet [psi | packed Ploc] to est (may be NULL) and keeps the
 * step pending, in place of a step pending before (which a failure
 * leaves pending). DKF_ERR_NOT_SPD if Phi- or Psi is not SPD, DKF_ERR_RANK if
 * S is not numerically positive definite (rank(H G) < p over the nodes
 * the info came from), DKF_ERR_NONFINITE. */
dkf_status_t dkf_tw_node_local(dkf_tw_node_t *nd, const dkf_uif_dyn_t *dyn, const dkf_real_t *info,
                               dkf_real_t *est);

/* Commits the pending step with x (n reals) and packed P (n(n+1)/2 reals);
 * NULL takes the local psi / Ploc. d and the views take the pending step's
 * values; k advances. DKF_ERR_STATE without a pending step,
 * DKF_ERR_NOT_SPD if P is not SPD, DKF_ERR_NONFINITE. */
dkf_status_t dkf_tw_node_commit(dkf_tw_node_t *nd, const dkf_real_t *x, const dkf_real_t *Ppacked);

/* ---- Algorithm 1 ----------------------------------------------------------- */

/* One step of the centralized filter (6a)-(8c) with the N sensors of the
 * whole network (sensor l: model meas[l], measurement y[l]): sums their
 * info packets (the fusion centre's job), runs the local step and commits
 * it (a step pending before is superseded; a failure, of the commit's SPD
 * check of Ploc too, leaves the node as it was); nd's m_max must cover
 * every sensor. */
dkf_status_t dkf_tw_central_step(dkf_tw_node_t *nd, const dkf_uif_dyn_t *dyn,
                                 const dkf_kf_meas_t meas[], const dkf_mat_t y[], size_t N);

/* ---- in-process whole-graph simulation (Algorithms 2 and 3) ----------------- */

/* Storage of dkf_tw_net_init: N nodes plus three packet buffers per node. */
#define DKF_TW_NET_STORAGE_LEN(N, n, m, p) \
    ((N) * (DKF_TW_NODE_STORAGE_LEN(n, m, p) + 3 * DKF_TW_PKT_LEN(n)))

typedef struct {
    const dkf_graph_t *g;
    size_t N, n, p;
    dkf_tw_node_t *nodes; /* caller array of N nodes */
    /* communication counters, summed over nodes and steps; per node per
     * step = reals_sent / (N * steps) */
    unsigned long reals_sent;
    unsigned long broadcasts;
    size_t steps;
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *out; /* N x PKT: the packet each node broadcasts */
        dkf_real_t *mix; /* N x PKT: what each node combined */
        dkf_real_t *tmp; /* N x PKT: ACF double buffer */
    } priv;
} dkf_tw_net_t;

/* Declares a network `name`, its node array `name_nodes` (N) and storage
 * `name_storage` (DKF_TW_NET_STORAGE_LEN(N, n, m, p) reals), all with the
 * storage class sc: the form of DKF_KF_DECLARE (dkf/kf.h). */
#define DKF_TW_NET_DECLARE(sc, name, N, n, m, p) \
    sc dkf_real_t name##_storage[DKF_TW_NET_STORAGE_LEN(N, n, m, p)]; \
    sc dkf_tw_node_t name##_nodes[N]; \
    sc dkf_tw_net_t name

/* Binds the simulation to the graph g (checked: DKF_ERR_GRAPH), the array
 * nodes[0..g->N-1] and storage, and initialises every node with (x0, P0). */
dkf_status_t dkf_tw_net_init(dkf_tw_net_t *net, const dkf_graph_t *g, dkf_tw_node_t *nodes,
                             size_t n, size_t m_max, size_t p, dkf_real_t *storage,
                             size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0);

/* Algorithm 2 (24a)-(26c): each node broadcasts its info packet (PKT
 * reals), sums those of N_l, runs the local step, broadcasts psi (n reals)
 * and takes x_l = sum_k alpha_lk psi_k; P_l stays local. alpha: weights
 * on the graph, row-stochastic and >= 0 (else DKF_ERR_WEIGHTS).
 * meas[l] and y[l] are node l's measurement model and measurement. */
dkf_status_t dkf_tw_net_diffusion_step(dkf_tw_net_t *net, const dkf_real_t *alpha,
                                       const dkf_uif_dyn_t *dyn, const dkf_kf_meas_t meas[],
                                       const dkf_mat_t y[]);

/* Largest eta dkf_tw_net_consensus_step accepts. A step costs 2 eta mixes of
 * every packet, so this bounds its time (an eta from a file or the network
 * cannot run for ever). On a connected graph the ACF error shrinks like
 * |lambda_2(W)|^eta, so 10^6 iterations reach double rounding (ln 1e16 = 37)
 * for any spectral gap 1 - |lambda_2| above 4e-5; a 300-node path with
 * Metropolis weights, about the worst case a network of that size can be,
 * has pi^2 / (3 * 300^2) = 3.7e-5. The vectors use eta = 10. */
#define DKF_TW_MAX_ETA 1000000u

/* Algorithm 3 (31)-(34c): ACF over eta iterations with W (doubly
 * stochastic, >= 0, else DKF_ERR_WEIGHTS) of the |N|-scaled info packets
 * (I and i, the paper's Upsilon and varphi, together: eta broadcasts of PKT reals), local step,
 * ACF of the estimate packets [psi | Ploc] (eta more broadcasts). Every
 * ACF restarts from the step's fresh inputs. DKF_ERR_ARG if eta >
 * DKF_TW_MAX_ETA (nothing changes). */
dkf_status_t dkf_tw_net_consensus_step(dkf_tw_net_t *net, const dkf_real_t *W, size_t eta,
                                       const dkf_uif_dyn_t *dyn, const dkf_kf_meas_t meas[],
                                       const dkf_mat_t y[]);

#ifdef __cplusplus
}
#endif

#endif /* DKF_TW_H */
