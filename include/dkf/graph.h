/*
 * dkf/graph.h - communication graphs, combination weights and the
 * neighbour-mixing primitives of diffusion and consensus filters.
 *
 * A graph is data in caller storage: compressed adjacency lists (CSR).
 * Row i lists the neighbourhood N_i of node i INCLUDING i itself (the
 * convention of seed 003, Talebi-Werner), ascending:
 *     nbr[start[i]], ..., nbr[start[i+1] - 1],     nnz = start[N].
 * Undirected graphs only: j in N_i iff i in N_j. Weights (a consensus
 * matrix W or diffusion coefficients alpha) are nnz reals parallel to
 * nbr: w[e] is the weight node i gives to node nbr[e], e in row i. Entries
 * outside the graph are zero by construction, so a weight matrix can
 * never use a link that does not exist.
 *
 * Mixing is the only operation on neighbour data:
 *     out_i = sum_{j in N_i} w_ij F_j
 * for a packet F_j of `len` reals. dkf_graph_mix is what ONE node does
 * with the packets it received from its neighbours (caller-owned buffers,
 * passed as pointers in the order of its row); dkf_graph_mix_all and
 * dkf_graph_acf do the same for every node of an in-process simulation.
 * Average consensus (seed 003 eqs (29)-(30)) is eta repetitions of the
 * mix with a doubly stochastic W; diffusion (eq. (26b)) is one mix with a
 * row-stochastic alpha.
 *
 * PER NODE: the neighbourhood, its weights and what a packet holds may
 * differ; the packet length `len` is common to every node of one mix.
 *
 * docs/design/graph-filters.md has the conditions, statuses and examples.
 */
#ifndef DKF_GRAPH_H
#define DKF_GRAPH_H

#include <stddef.h>

#include "dkf/config.h"
#include "dkf/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    size_t N;            /* nodes, numbered 0 .. N-1 */
    size_t nnz;          /* start[N]: entries of all rows, self included */
    const size_t *start; /* N + 1 row offsets, start[0] = 0 */
    const size_t *nbr;   /* nnz neighbour indices, rows ascending, i in row i */
} dkf_graph_t;

/* nbr entries of a graph with N nodes and E undirected edges (no loops). */
#define DKF_GRAPH_NNZ(N, E) ((N) + 2 * (E))

/* Binds g to existing adjacency lists after checking them: DKF_ERR_CAPACITY
 * for N = 0; DKF_ERR_GRAPH when start is not non-decreasing from 0, an
 * index is >= N, a row is not strictly ascending (duplicates), a row lacks
 * its own node, or the lists are not symmetric. O(nnz log deg). */
dkf_status_t dkf_graph_init(dkf_graph_t *g, size_t N, const size_t *start, const size_t *nbr);

/* Builds adjacency lists from E undirected edges given as pairs
 * edges[2e], edges[2e+1] (either orientation), into start (N + 1 entries)
 * and nbr (nbr_cap entries, DKF_GRAPH_NNZ(N, E) needed, else
 * DKF_ERR_CAPACITY), and binds g. DKF_ERR_GRAPH for an index >= N, a self
 * loop or a repeated edge; checked before anything is written (the
 * repeated-edge check is O(E^2): a set-up cost). */
dkf_status_t dkf_graph_from_edges(dkf_graph_t *g, size_t *start, size_t *nbr, size_t nbr_cap,
                                  size_t N, const size_t *edges, size_t E);

/* DKF_OK if g is connected, DKF_ERR_GRAPH if not (consensus then cannot
 * reach the network average). work: N entries. */
dkf_status_t dkf_graph_connected(const dkf_graph_t *g, size_t *work);

/* *pos = the entry of j in row i (w[*pos] is w_ij); DKF_ERR_GRAPH if j is
 * not in N_i, DKF_ERR_ARG if i >= N. */
dkf_status_t dkf_graph_find(size_t *pos, const dkf_graph_t *g, size_t i, size_t j);

/* ---- weights (nnz reals parallel to g->nbr) ------------------------------ */

/* Metropolis-Hastings: w_ij = 1 / (1 + max(d_i, d_j)) for j != i,
 * w_ii = 1 - sum of the others, d = degree without self. Symmetric,
 * doubly stochastic, non-negative on any graph. */
dkf_status_t dkf_graph_weights_metropolis(dkf_real_t *w, const dkf_graph_t *g);
/* Max-degree: w_ij = 1 / (1 + d_max) for j != i, w_ii = 1 - d_i / (1 + d_max).
 * Symmetric, doubly stochastic, non-negative. */
dkf_status_t dkf_graph_weights_max_degree(dkf_real_t *w, const dkf_graph_t *g);
/* Uniform: w_ij = 1 / |N_i| for every j in N_i (the paper's diffusion
 * alpha). Row-stochastic; doubly stochastic only on regular graphs. */
dkf_status_t dkf_graph_weights_uniform(dkf_real_t *w, const dkf_graph_t *g);
/* Sparse triplets (rows[t], cols[t], vals[t]), t < count, into w; entries
 * not listed are 0. DKF_ERR_GRAPH if a triplet is not on the graph (no
 * such link, or an index >= N), DKF_ERR_WEIGHTS if an entry is given
 * twice, DKF_ERR_NONFINITE for a non-finite value. */
dkf_status_t dkf_graph_weights_from_triplets(dkf_real_t *w, const dkf_graph_t *g,
                                             const size_t *rows, const size_t *cols,
                                             const dkf_real_t *vals, size_t count);

/* Tolerance of the stochasticity checks for a row of k entries: sums must
 * be within 4 k eps of 1 (weights rounded to the real type, then summed). */
#define DKF_GRAPH_SUM_TOL(k) (DKF_R(4.0) * (dkf_real_t)(k) * DKF_REAL_EPSILON)

/* DKF_OK if every w >= 0 and every row sum is 1 (alpha of eq. (22));
 * DKF_ERR_WEIGHTS otherwise, DKF_ERR_NONFINITE for NaN/inf. */
dkf_status_t dkf_graph_check_row_stochastic(const dkf_graph_t *g, const dkf_real_t *w);
/* DKF_OK if every w >= 0 and every row AND column sum is 1 (W of Remark 1;
 * then W^eta -> 1 1^T / N on a connected graph with a positive diagonal
 * somewhere or a non-bipartite graph); DKF_ERR_WEIGHTS otherwise. */
dkf_status_t dkf_graph_check_doubly_stochastic(const dkf_graph_t *g, const dkf_real_t *w);

/* ---- mixing ---------------------------------------------------------------- */

/* One node: out = sum_{e < count} w[e] in[e], each in[e] and out `len`
 * reals; w == NULL means all weights 1 (a plain sum). The caller passes
 * its row of weights and the received packets in the same order.
 * DKF_ERR_NONFINITE if an input or weight is not finite, DKF_ERR_ALIAS if
 * out overlaps an input (debug checks); count >= 1. */
dkf_status_t dkf_graph_mix(dkf_real_t *out, size_t len, const dkf_real_t *const in[],
                           const dkf_real_t *w, size_t count);

/* Every node: out_i = sum_{j in N_i} w_ij F_j, where node i's packet is the
 * `len` reals at F + i * stride (likewise out); w == NULL means weights 1.
 * out must not overlap F. DKF_ERR_NONFINITE for non-finite F or w. */
dkf_status_t dkf_graph_mix_all(dkf_real_t *out, const dkf_real_t *F, size_t len, size_t stride,
                               const dkf_graph_t *g, const dkf_real_t *w);

/* Average-consensus filter, eqs (29)-(30): eta iterations of F <- W F, in
 * place (packets of len reals, stride len). work: N * len reals. eta = 0
 * leaves F unchanged. W is not checked here (see
 * dkf_graph_check_doubly_stochastic). */
dkf_status_t dkf_graph_acf(dkf_real_t *F, size_t len, const dkf_graph_t *g, const dkf_real_t *W,
                           size_t eta, dkf_real_t *work);

#ifdef __cplusplus
}
#endif

#endif /* DKF_GRAPH_H */
