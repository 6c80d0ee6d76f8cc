/*
 * Communication graphs, weights and mixing (dkf/graph.h). Equation
 * numbers refer to seed 003 (Talebi-Werner) as corrected in
 * docs/design/graph-filters.md: ACF (29)-(30), diffusion weights (22).
 */
#include "dkf/graph.h"

#include "internal.h"
#include "kernels.h"

/* Binary search for j in the ascending row [lo, hi) of nbr. */
static int row_find(size_t *pos, const size_t *nbr, size_t lo, size_t hi, size_t j)
{
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (nbr[mid] == j) {
            *pos = mid;
            return 1;
        }
        if (nbr[mid] < j)
            lo = mid + 1;
        else
            hi = mid;
    }
    return 0;
}

static size_t degree(const dkf_graph_t *g, size_t i) { return g->start[i + 1] - g->start[i] - 1; }

static dkf_status_t check_graph(const dkf_graph_t *g)
{
    DKF_CHECK_NULL(g);
    DKF_CHECK_NULL(g->start);
    if (g->N == 0) return DKF_ERR_CAPACITY;
    if (g->nnz > 0) DKF_CHECK_NULL(g->nbr);
    return DKF_OK;
}

dkf_status_t dkf_graph_init(dkf_graph_t *g, size_t N, const size_t *start, const size_t *nbr)
{
    dkf_graph_t h;
    size_t i, e, pos;
    DKF_CHECK_NULL(g);
    DKF_CHECK_NULL(start);
    DKF_CHECK_NULL(nbr);
    if (N == 0) return DKF_ERR_CAPACITY;
    if (start[0] != 0) return DKF_ERR_GRAPH;
    for (i = 0; i < N; ++i) {
        int self = 0;
        if (start[i + 1] <= start[i]) return DKF_ERR_GRAPH; /* a row holds at least i */
        for (e = start[i]; e < start[i + 1]; ++e) {
            if (nbr[e] >= N) return DKF_ERR_GRAPH;
            if (e > start[i] && nbr[e] <= nbr[e - 1]) return DKF_ERR_GRAPH;
            if (nbr[e] == i) self = 1;
        }
        if (!self) return DKF_ERR_GRAPH;
    }
    /* undirected: j in N_i implies i in N_j */
    for (i = 0; i < N; ++i)
        for (e = start[i]; e < start[i + 1]; ++e)
            if (!row_find(&pos, nbr, start[nbr[e]], start[nbr[e] + 1], i)) return DKF_ERR_GRAPH;
    h.N = N;
    h.nnz = start[N];
    h.start = start;
    h.nbr = nbr;
    *g = h;
    return DKF_OK;
}

dkf_status_t dkf_graph_from_edges(dkf_graph_t *g, size_t *start, size_t *nbr, size_t nbr_cap,
                                  size_t N, const size_t *edges, size_t E)
{
    size_t e, f, i;
    DKF_CHECK_NULL(g);
    DKF_CHECK_NULL(start);
    DKF_CHECK_NULL(nbr);
    if (E > 0) DKF_CHECK_NULL(edges);
    if (N == 0) return DKF_ERR_CAPACITY;
    if (nbr_cap < N || (nbr_cap - N) / 2 < E) return DKF_ERR_CAPACITY;
    for (e = 0; e < E; ++e) {
        const size_t a = edges[2 * e], b = edges[2 * e + 1];
        if (a >= N || b >= N || a == b) return DKF_ERR_GRAPH;
        for (f = 0; f < e; ++f) {
            const size_t c = edges[2 * f], d = edges[2 * f + 1];
            if ((a == c && b == d) || (a == d && b == c)) return DKF_ERR_GRAPH;
        }
    }
    /* row lengths (self + degree) in start[i + 1], then prefix sums */
    for (i = 0; i <= N; ++i) start[i] = i == 0 ? 0 : 1;
    for (e = 0; e < E; ++e) {
        ++start[edges[2 * e] + 1];
        ++start[edges[2 * e + 1] + 1];
    }
    for (i = 0; i < N; ++i) start[i + 1] += start[i];
    /* self first, at the start of each row; then shift the offsets by one
     * so that start[i + 1] is row i's fill cursor (just past self) */
    for (i = 0; i < N; ++i) nbr[start[i]] = i;
    for (i = N; i > 0; --i) start[i] = start[i - 1] + 1;
    for (e = 0; e < E; ++e) {
        const size_t a = edges[2 * e], b = edges[2 * e + 1];
        nbr[start[a + 1]++] = b;
        nbr[start[b + 1]++] = a;
    }
    /* now start[i + 1] is the end of row i; start[0] is still 0 */
    /* insertion sort of each row: rows are short (degree) */
    for (i = 0; i < N; ++i) {
        const size_t lo = start[i], hi = start[i + 1];
        for (e = lo + 1; e < hi; ++e) {
            const size_t v = nbr[e];
            f = e;
            while (f > lo && nbr[f - 1] > v) {
                nbr[f] = nbr[f - 1];
                --f;
            }
            nbr[f] = v;
        }
    }
    g->N = N;
    g->nnz = start[N];
    g->start = start;
    g->nbr = nbr;
    return DKF_OK;
}

dkf_status_t dkf_graph_connected(const dkf_graph_t *g, size_t *work)
{
    size_t reached = 1, before, i, e;
    DKF_TRY(check_graph(g));
    DKF_CHECK_NULL(work);
    /* the set reached from node 0 (work[i] = 1), grown to its fixed point:
     * each O(nnz) sweep adds at least the next BFS level, so at most
     * diameter + 1 sweeps; no queue needed beyond the N marks */
    for (i = 0; i < g->N; ++i) work[i] = 0;
    work[0] = 1;
    do {
        before = reached;
        for (i = 0; i < g->N; ++i) {
            if (!work[i]) continue;
            for (e = g->start[i]; e < g->start[i + 1]; ++e)
                if (!work[g->nbr[e]]) {
                    work[g->nbr[e]] = 1;
                    ++reached;
                }
        }
    } while (reached != before);
    return reached == g->N ? DKF_OK : DKF_ERR_GRAPH;
}

dkf_status_t dkf_graph_find(size_t *pos, const dkf_graph_t *g, size_t i, size_t j)
{
    size_t p;
    DKF_CHECK_NULL(pos);
    DKF_TRY(check_graph(g));
    if (i >= g->N) return DKF_ERR_ARG;
    if (!row_find(&p, g->nbr, g->start[i], g->start[i + 1], j)) return DKF_ERR_GRAPH;
    *pos = p;
    return DKF_OK;
}

/* Off-diagonal weights from f(d_i, d_j, d_max), then w_ii = 1 - row sum. */
typedef dkf_real_t (*pair_weight_fn)(size_t di, size_t dj, size_t dmax);

static dkf_real_t metropolis_pair(size_t di, size_t dj, size_t dmax)
{
    (void)dmax;
    return DKF_R(1.0) / (dkf_real_t)(1 + (di > dj ? di : dj));
}

static dkf_real_t max_degree_pair(size_t di, size_t dj, size_t dmax)
{
    (void)di;
    (void)dj;
    return DKF_R(1.0) / (dkf_real_t)(1 + dmax);
}

static dkf_status_t symmetric_weights(dkf_real_t *w, const dkf_graph_t *g, pair_weight_fn pair)
{
    size_t i, e, dmax = 0;
    DKF_CHECK_NULL(w);
    DKF_TRY(check_graph(g));
    for (i = 0; i < g->N; ++i)
        if (degree(g, i) > dmax) dmax = degree(g, i);
    for (i = 0; i < g->N; ++i) {
        dkf_real_t sum = DKF_R(0.0);
        size_t self = g->start[i];
        for (e = g->start[i]; e < g->start[i + 1]; ++e) {
            const size_t j = g->nbr[e];
            if (j == i) {
                self = e;
                continue;
            }
            w[e] = pair(degree(g, i), degree(g, j), dmax);
            sum += w[e];
        }
        w[self] = DKF_R(1.0) - sum;
    }
    return DKF_OK;
}

dkf_status_t dkf_graph_weights_metropolis(dkf_real_t *w, const dkf_graph_t *g)
{
    return symmetric_weights(w, g, metropolis_pair);
}

dkf_status_t dkf_graph_weights_max_degree(dkf_real_t *w, const dkf_graph_t *g)
{
    return symmetric_weights(w, g, max_degree_pair);
}

dkf_status_t dkf_graph_weights_uniform(dkf_real_t *w, const dkf_graph_t *g)
{
    size_t i, e;
    DKF_CHECK_NULL(w);
    DKF_TRY(check_graph(g));
    for (i = 0; i < g->N; ++i) {
        const dkf_real_t v = DKF_R(1.0) / (dkf_real_t)(g->start[i + 1] - g->start[i]);
        for (e = g->start[i]; e < g->start[i + 1]; ++e) w[e] = v;
    }
    return DKF_OK;
}

dkf_status_t dkf_graph_weights_from_triplets(dkf_real_t *w, const dkf_graph_t *g,
                                             const size_t *rows, const size_t *cols,
                                             const dkf_real_t *vals, size_t count)
{
    size_t t, u, pt, e;
    DKF_CHECK_NULL(w);
    DKF_TRY(check_graph(g));
    if (count > 0) {
        DKF_CHECK_NULL(rows);
        DKF_CHECK_NULL(cols);
        DKF_CHECK_NULL(vals);
    }
    for (t = 0; t < count; ++t) {
        if (rows[t] >= g->N) return DKF_ERR_GRAPH;
        if (!row_find(&pt, g->nbr, g->start[rows[t]], g->start[rows[t] + 1], cols[t]))
            return DKF_ERR_GRAPH;
    }
    if (!dkf__all_finite(vals, count)) return DKF_ERR_NONFINITE;
    /* a repeated entry is ambiguous (sum? last wins?): refuse it */
    for (t = 1; t < count; ++t)
        for (u = 0; u < t; ++u)
            if (rows[t] == rows[u] && cols[t] == cols[u]) return DKF_ERR_WEIGHTS;
    for (e = 0; e < g->nnz; ++e) w[e] = DKF_R(0.0);
    for (t = 0; t < count; ++t) {
        (void)row_find(&pt, g->nbr, g->start[rows[t]], g->start[rows[t] + 1], cols[t]);
        w[pt] = vals[t];
    }
    return DKF_OK;
}

static dkf_status_t check_rows(const dkf_graph_t *g, const dkf_real_t *w)
{
    size_t i, e;
    DKF_CHECK_NULL(w);
    DKF_TRY(check_graph(g));
    if (!dkf__all_finite(w, g->nnz)) return DKF_ERR_NONFINITE;
    for (i = 0; i < g->N; ++i) {
        const size_t k = g->start[i + 1] - g->start[i];
        dkf_real_t sum = DKF_R(0.0);
        for (e = g->start[i]; e < g->start[i + 1]; ++e) {
            if (w[e] < DKF_R(0.0)) return DKF_ERR_WEIGHTS;
            sum += w[e];
        }
        if (DKF_FABS(sum - DKF_R(1.0)) > DKF_GRAPH_SUM_TOL(k)) return DKF_ERR_WEIGHTS;
    }
    return DKF_OK;
}

dkf_status_t dkf_graph_check_row_stochastic(const dkf_graph_t *g, const dkf_real_t *w)
{
    return check_rows(g, w);
}

dkf_status_t dkf_graph_check_doubly_stochastic(const dkf_graph_t *g, const dkf_real_t *w)
{
    size_t j, e, pos;
    DKF_TRY(check_rows(g, w));
    /* column j: w_ij for i in N_j (the graph is symmetric) */
    for (j = 0; j < g->N; ++j) {
        const size_t k = g->start[j + 1] - g->start[j];
        dkf_real_t sum = DKF_R(0.0);
        for (e = g->start[j]; e < g->start[j + 1]; ++e) {
            const size_t i = g->nbr[e];
            if (!row_find(&pos, g->nbr, g->start[i], g->start[i + 1], j)) return DKF_ERR_GRAPH;
            sum += w[pos];
        }
        if (DKF_FABS(sum - DKF_R(1.0)) > DKF_GRAPH_SUM_TOL(k)) return DKF_ERR_WEIGHTS;
    }
    return DKF_OK;
}

dkf_status_t dkf_graph_mix(dkf_real_t *out, size_t len, const dkf_real_t *const in[],
                           const dkf_real_t *w, size_t count)
{
    size_t e, r;
    DKF_CHECK_NULL(out);
    DKF_CHECK_NULL(in);
    if (count == 0 || len == 0) return DKF_ERR_ARG;
    for (e = 0; e < count; ++e) {
        DKF_CHECK_NULL(in[e]);
#if DKF_DEBUG_CHECKS
        if (dkf__overlap_raw(in[e], len, out, len)) return DKF_ERR_ALIAS;
#endif
        if (!dkf__all_finite(in[e], len)) return DKF_ERR_NONFINITE;
    }
    if (w != NULL && !dkf__all_finite(w, count)) return DKF_ERR_NONFINITE;
    for (r = 0; r < len; ++r) out[r] = DKF_R(0.0);
    for (e = 0; e < count; ++e) {
        const dkf_real_t c = w != NULL ? w[e] : DKF_R(1.0);
        for (r = 0; r < len; ++r) out[r] += c * in[e][r];
    }
    return DKF_OK;
}

/* The unchecked whole-graph mix: out_i = sum_j w_ij F_j. */
static void mix_rows(dkf_real_t *out, const dkf_real_t *F, size_t len, size_t stride,
                     const dkf_graph_t *g, const dkf_real_t *w)
{
    size_t i, e, r;
    for (i = 0; i < g->N; ++i) {
        dkf_real_t *o = out + i * stride;
        for (r = 0; r < len; ++r) o[r] = DKF_R(0.0);
        for (e = g->start[i]; e < g->start[i + 1]; ++e) {
            const dkf_real_t *f = F + g->nbr[e] * stride;
            const dkf_real_t c = w != NULL ? w[e] : DKF_R(1.0);
            for (r = 0; r < len; ++r) o[r] += c * f[r];
        }
    }
}

dkf_status_t dkf_graph_mix_all(dkf_real_t *out, const dkf_real_t *F, size_t len, size_t stride,
                               const dkf_graph_t *g, const dkf_real_t *w)
{
    size_t i;
    DKF_CHECK_NULL(out);
    DKF_CHECK_NULL(F);
    DKF_TRY(check_graph(g));
    if (len == 0 || stride < len) return DKF_ERR_ARG;
#if DKF_DEBUG_CHECKS
    {
        const size_t span = (g->N - 1) * stride + len;
        if (dkf__overlap_raw(F, span, out, span)) return DKF_ERR_ALIAS;
    }
#endif
    for (i = 0; i < g->N; ++i)
        if (!dkf__all_finite(F + i * stride, len)) return DKF_ERR_NONFINITE;
    if (w != NULL && !dkf__all_finite(w, g->nnz)) return DKF_ERR_NONFINITE;
    mix_rows(out, F, len, stride, g, w);
    return DKF_OK;
}

dkf_status_t dkf_graph_acf(dkf_real_t *F, size_t len, const dkf_graph_t *g, const dkf_real_t *W,
                           size_t eta, dkf_real_t *work)
{
    size_t it;
    DKF_CHECK_NULL(F);
    DKF_CHECK_NULL(W);
    DKF_CHECK_NULL(work);
    DKF_TRY(check_graph(g));
    if (len == 0) return DKF_ERR_ARG;
#if DKF_DEBUG_CHECKS
    if (dkf__overlap_raw(F, g->N * len, work, g->N * len)) return DKF_ERR_ALIAS;
#endif
    if (!dkf__all_finite(F, g->N * len) || !dkf__all_finite(W, g->nnz)) return DKF_ERR_NONFINITE;
    /* (30): F_(eta) = (W kron I) F_(eta-1), two buffers swapped per pass */
    for (it = 0; it < eta; ++it) {
        mix_rows(work, F, len, len, g, W);
        dkf__copy(F, work, g->N * len);
    }
    return DKF_OK;
}
