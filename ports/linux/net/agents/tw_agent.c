/*
 * tw_agent.c - the seed-003 node agent of tw_agent.h: scenario binding,
 * packet codec, and the per-node round machine over dkf/tw.h's node API.
 */
#define _POSIX_C_SOURCE 200809L

#include "tw_agent.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "graph_weights.h"
#include "net.h"
#include "registry.h"
#include "util.h"

/* every error of this file: a message in err, -1 */
#define failf(err, errlen, ...) dkf_failf(err, errlen, -1, __VA_ARGS__)

/* ---- scenario ------------------------------------------------------------------- */

/* Everything that must agree between the nodes of one run: dimensions,
 * the model at every step, every sensor's H and Sw, the prior, the graph,
 * the weights, alg and eta (measurements excluded: each node reads its own). */
static int64_t model_id(const dkf_net_twa_scn_t *c)
{
    static const char *const dyn[] = {"F", "G", "Q"};
    const dkf_scenario_t *s = c->s;
    uint64_t h = DKF_FNV1A_OFFSET;
    size_t i, k, l;
    h = dkf_fnv1a_u64(h, (uint64_t)c->alg);
    h = dkf_fnv1a_u64(h, (uint64_t)c->eta);
    h = dkf_fnv1a_u64(h, (uint64_t)c->N);
    h = dkf_fnv1a_u64(h, (uint64_t)c->n);
    h = dkf_fnv1a_u64(h, (uint64_t)c->p);
    h = dkf_fnv1a_u64(h, (uint64_t)c->steps);
    for (i = 0; i < 3; ++i) {
        const dkf_scn_mat_t *M = dkf_scn_model(s, dyn[i]);
        for (k = 0; k < c->steps; ++k)
            h = dkf_fnv1a_doubles(h, dkf_scn_at(M, k), M->rows * M->cols);
    }
    for (l = 0; l < c->N; ++l) {
        const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, l, "H");
        const dkf_scn_mat_t *Sw = dkf_scn_sensor_model(s, l, "R");
        h = dkf_fnv1a_doubles(h, H->data, H->rows * H->cols);
        h = dkf_fnv1a_doubles(h, Sw->data, Sw->rows * Sw->cols);
    }
    h = dkf_fnv1a_doubles(h, dkf_scn_init(s, "x00")->data, c->n);
    h = dkf_fnv1a_doubles(h, dkf_scn_init(s, "P00")->data, c->n * c->n);
    for (i = 0; i <= c->N; ++i) h = dkf_fnv1a_u64(h, (uint64_t)c->start[i]);
    for (i = 0; i < c->g.nnz; ++i) {
        const double a = (double)c->alpha[i], w = (double)c->W[i];
        h = dkf_fnv1a_u64(h, (uint64_t)c->nbr[i]);
        h = dkf_fnv1a_doubles(h, &a, 1);
        h = dkf_fnv1a_doubles(h, &w, 1);
    }
    return (int64_t)h;
}

/* What Algorithm alg needs of the file: the registry's check of tw2 / tw3. */
static int check_file(const dkf_scenario_t *s, int alg, long eta, char *err, size_t errlen)
{
    const dkf_filter_t *f = dkf_registry_find(alg == 2 ? "tw2" : "tw3");
    dkf_run_opts_t o;
    char arg[32];
    void *area;
    int oom, rc = 0;
    if (alg != 2 && alg != 3) return failf(err, errlen, "--alg %d: expected 2 or 3", alg);
    memset(&o, 0, sizeof o);
    o.fam = area = dkf_registry_opts_new(f, &oom);
    if (oom) return failf(err, errlen, "%s: out of memory", s->file);
    snprintf(arg, sizeof arg, "%ld", eta);
    if (alg == 3 && eta >= 0) rc = dkf_registry_opt_set(f, area, "eta", arg, err, errlen);
    if (rc == DKF_EXIT_OK) rc = f->family->check(f, &o, s, err, errlen);
    free(area);
    return rc == DKF_EXIT_OK ? 0 : -1;
}

int dkf_net_twa_scn_bind(dkf_net_twa_scn_t *c, const dkf_scenario_t *s, int alg, long eta,
                         char *err, size_t errlen)
{
    size_t l, nnz;
    dkf_status_t st;
    memset(c, 0, sizeof *c);
    if (check_file(s, alg, eta, err, errlen) != 0) return -1;
    c->s = s;
    c->alg = alg;
    c->N = s->net->N;
    c->E = s->net->E;
    c->n = s->n;
    c->p = dkf_scn_model(s, "G")->cols;
    c->steps = s->steps;
    c->eta = alg == 3 ? (size_t)(eta >= 0 ? eta : s->net->eta) : 0;
    c->rounds = alg == 2 ? 2 : 2 * c->eta;
    for (l = 0; l < c->N; ++l)
        if (s->sensors[l].m > c->mmax) c->mmax = s->sensors[l].m;
    nnz = DKF_GRAPH_NNZ(c->N, c->E);
    c->start = calloc(c->N + 1, sizeof *c->start);
    c->nbr = calloc(nnz, sizeof *c->nbr);
    c->alpha = calloc(2 * nnz, sizeof *c->alpha);
    if (c->start == NULL || c->nbr == NULL || c->alpha == NULL) {
        dkf_net_twa_scn_free(c);
        return failf(err, errlen, "%s: out of memory", s->file);
    }
    c->W = c->alpha + nnz;
    st = dkf_graph_from_edges(&c->g, c->start, c->nbr, nnz, c->N, s->net->edges, c->E);
    if (st != DKF_OK) {
        dkf_net_twa_scn_free(c);
        return failf(err, errlen, "%s: graph.edges: %s", s->file, dkf_status_str(st));
    }
    if (dkf_host_graph_weights_bind(c->s, &c->g, 0, c->alpha, &c->alpha_default, err, errlen) != 0 ||
        dkf_host_graph_weights_bind(c->s, &c->g, 1, c->W, &c->W_default, err, errlen) != 0) {
        dkf_net_twa_scn_free(c);
        return -1;
    }
    c->model_id = model_id(c);
    return 0;
}

void dkf_net_twa_scn_free(dkf_net_twa_scn_t *c)
{
    free(c->start);
    free(c->nbr);
    free(c->alpha);
    c->start = c->nbr = NULL;
    c->alpha = c->W = NULL;
}

/* ---- packets -------------------------------------------------------------------- */

dkf_net_tw_expect_t dkf_net_twa_expect(const dkf_net_twa_scn_t *c, long chan_node)
{
    dkf_net_tw_expect_t ex;
    ex.model_id = c->model_id;
    ex.nnodes = c->N;
    ex.node = chan_node;
    ex.steps = c->steps;
    ex.rounds = c->rounds;
    /* Alg 2: round 0 the information pair, round 1 psi (n reals); Alg 3:
     * eta rounds of information pairs, eta of estimates with covariance */
    ex.info_rounds = c->alg == 2 ? 1 : c->eta;
    ex.info_len = DKF_TW_PKT_LEN(c->n);
    ex.est_len = c->alg == 2 ? c->n : DKF_TW_PKT_LEN(c->n);
    return ex;
}

void dkf_net_twa_round_shape(const dkf_net_twa_scn_t *c, size_t round, int *kind, size_t *len)
{
    const dkf_net_tw_expect_t ex = dkf_net_twa_expect(c, -1);
    dkf_net_tw_shape(&ex, round, kind, len);
}

int dkf_net_twa_encode(void *buf, size_t cap, size_t *len, const dkf_net_tw_pkt_t *p)
{
    return dkf_net_encode_tw(buf, cap, len, p);
}

dkf_net_verdict_t dkf_net_twa_decode(const void *buf, size_t len, const dkf_net_twa_scn_t *c,
                                     long chan_node, dkf_net_tw_pkt_t *out, dkf_net_rejects_t *rej)
{
    const dkf_net_tw_expect_t ex = dkf_net_twa_expect(c, chan_node);
    return dkf_net_decode_tw(buf, len, &ex, out, rej);
}

void dkf_net_twa_chan(char *out, const char *prefix, size_t node)
{
    dkf_ra_chan(out, prefix, node);
}
long dkf_net_twa_chan_node(const char *channel, const char *prefix)
{
    return dkf_ra_chan_node(channel, prefix);
}
int dkf_net_twa_subscription(char *out, size_t cap, const dkf_net_twa_scn_t *c, const char *prefix,
                             size_t node)
{
    return dkf_ra_subscription(out, cap, prefix, c->nbr + c->start[node],
                               c->start[node + 1] - c->start[node], node);
}

/* ---- the agent: the filter's side of round_agent.h ------------------------------ */

struct dkf_net_twa {
    const dkf_net_twa_scn_t *c;
    dkf_ra_t *ra;               /* the rounds with the neighbours */
    size_t id, row0, deg, self; /* row of id: entries row0 .. row0 + deg - 1; self = position of id */
    size_t pkt;                 /* DKF_TW_PKT_LEN(n) */
    dkf_tw_node_t nd;
    dkf_real_t *mem;            /* node storage, then the buffers below */
    dkf_real_t *mix, *est;      /* pkt each */
    /* model / sensor of the step */
    dkf_real_t *A, *B, *Sv, *H, *Sw, *y;
    dkf_mat_t mA, mB, mSv, mH, mSw, my, mx0, mP0;
    dkf_uif_dyn_t model;
    dkf_kf_meas_t sens;
    /* results */
    double *xs, *Ps, *zs;
    char err[256];
};

static void to_real(dkf_real_t *dst, const double *src, size_t n)
{
    dkf_scn_to_real(dst, src, n);
}

static int alloc_agent(dkf_net_twa_t *a)
{
    const dkf_net_twa_scn_t *c = a->c;
    const size_t node_len = DKF_TW_NODE_STORAGE_LEN(c->n, c->mmax, c->p);
    const size_t nm = 2 * c->n * c->n + c->n * c->p + c->mmax * c->n + c->mmax * c->mmax +
                      c->mmax + 2 * c->n;
    a->mem = calloc(node_len + 2 * a->pkt + nm, sizeof *a->mem);
    a->xs = calloc(c->steps * (c->n + c->n * c->n + c->p), sizeof *a->xs);
    if (a->mem == NULL || a->xs == NULL) return -1;
    a->mix = a->mem + node_len;
    a->est = a->mix + a->pkt;
    a->A = a->est + a->pkt;
    a->Sv = a->A + c->n * c->n;
    a->B = a->Sv + c->n * c->n;
    a->H = a->B + c->n * c->p;
    a->Sw = a->H + c->mmax * c->n;
    a->y = a->Sw + c->mmax * c->mmax;
    a->Ps = a->xs + c->steps * c->n;
    a->zs = a->Ps + c->steps * c->n * c->n;
    return 0;
}

static int fail_step(char *err, size_t errlen, const dkf_net_twa_t *a, size_t k,
                     const char *what, dkf_status_t st)
{
    snprintf(err, errlen, "node %zu: step n=%zu: %s failed: %s", a->id, k, what,
             dkf_status_str(st));
    return -1;
}

static void load_step(dkf_net_twa_t *a, size_t k)
{
    const dkf_net_twa_scn_t *c = a->c;
    to_real(a->A, dkf_scn_at(dkf_scn_model(c->s, "F"), k - 1), c->n * c->n);
    to_real(a->B, dkf_scn_at(dkf_scn_model(c->s, "G"), k - 1), c->n * c->p);
    to_real(a->Sv, dkf_scn_at(dkf_scn_model(c->s, "Q"), k - 1), c->n * c->n);
    to_real(a->y, dkf_scn_y(c->s, a->id, (long)k), a->mH.rows);
}

/* The committed step k's x, P, z (the result document). */
static int record_step(dkf_net_twa_t *a, size_t k)
{
    const dkf_net_twa_scn_t *c = a->c;
    const size_t j = k - 1;
    size_t i;
    for (i = 0; i < c->n; ++i) a->xs[j * c->n + i] = (double)a->nd.x.data[i];
    for (i = 0; i < c->n * c->n; ++i) a->Ps[j * c->n * c->n + i] = (double)a->nd.P.data[i];
    for (i = 0; i < c->p; ++i) a->zs[j * c->p + i] = (double)a->nd.d.data[i];
    return 1;
}

/* Step k: its measurement packet is round 0's; with no rounds at all (Alg
 * 3, eta = 0) the step is local. */
static int tw_begin_step(void *filter, size_t k, dkf_real_t *pkt, char *err, size_t errlen)
{
    dkf_net_twa_t *a = filter;
    const dkf_net_twa_scn_t *c = a->c;
    dkf_status_t st;
    load_step(a, k);
    st = dkf_tw_meas_packet(a->mix, &a->nd, &a->sens, &a->my,
                            c->alg == 2 ? DKF_R(1.0) : (dkf_real_t)c->N);
    if (st != DKF_OK) return fail_step(err, errlen, a, k, "dkf_tw_meas_packet", st);
    if (c->rounds > 0) {
        memcpy(pkt, a->mix, a->pkt * sizeof *pkt);
        return 0;
    }
    if ((st = dkf_tw_node_local(&a->nd, &a->model, a->mix, a->est)) != DKF_OK)
        return fail_step(err, errlen, a, k, "dkf_tw_node_local", st);
    if ((st = dkf_tw_node_commit(&a->nd, a->est, a->est + c->n)) != DKF_OK)
        return fail_step(err, errlen, a, k, "dkf_tw_node_commit", st);
    return record_step(a, k);
}

/* Alg 2 info sum (weights NULL) or a weighted mix of the present packets
 * (len reals each) into out. Complete rounds take the row exactly as
 * dkf_tw_net_* does; with packets missing, alpha is renormalised over the
 * present ones (Alg 2) or the own packet stands in (Alg 3, subst). */
static dkf_status_t mix_round(const dkf_net_twa_t *a, const dkf_real_t *rx, size_t stride,
                              const unsigned char *have, dkf_real_t *out, size_t len,
                              const dkf_real_t *w, int subst)
{
    const dkf_real_t *in[DKF_NET_TWA_MAX_DEG];
    const dkf_real_t *own = rx + a->self * stride;
    dkf_real_t wc[DKF_NET_TWA_MAX_DEG], sum = DKF_R(0.0);
    size_t e, cnt = 0;
    int full = 1;
    for (e = 0; e < a->deg; ++e) full &= have[e];
    if (full || subst) {
        for (e = 0; e < a->deg; ++e) in[e] = have[e] ? rx + e * stride : own;
        return dkf_graph_mix(out, len, in, w, a->deg);
    }
    for (e = 0; e < a->deg; ++e)
        if (have[e]) {
            in[cnt] = rx + e * stride;
            if (w != NULL) sum += (wc[cnt] = w[e]);
            ++cnt;
        }
    for (e = 0; w != NULL && e < cnt; ++e) wc[e] /= sum;
    return dkf_graph_mix(out, len, in, w != NULL ? wc : NULL, cnt);
}

/* Round r of step k is complete (or given up): mix, and go on. */
static int tw_complete_round(void *filter, size_t k, size_t r, const dkf_real_t *rx,
                             size_t stride, const unsigned char *have, dkf_real_t *next,
                             char *err, size_t errlen)
{
    dkf_net_twa_t *a = filter;
    const dkf_net_twa_scn_t *c = a->c;
    dkf_status_t st;
    if (c->alg == 2 && r == 0) { /* (24c), (25a): info sum over N_l; local step; publish psi */
        if ((st = mix_round(a, rx, stride, have, a->mix, a->pkt, NULL, 0)) != DKF_OK)
            return fail_step(err, errlen, a, k, "info sum", st);
        if ((st = dkf_tw_node_local(&a->nd, &a->model, a->mix, a->est)) != DKF_OK)
            return fail_step(err, errlen, a, k, "dkf_tw_node_local", st);
        memcpy(next, a->est, c->n * sizeof *next);
        return 0;
    }
    if (c->alg == 2) { /* (26b): x_l = sum alpha_lk psi_k */
        if ((st = mix_round(a, rx, stride, have, a->mix, c->n, c->alpha + a->row0, 0)) != DKF_OK)
            return fail_step(err, errlen, a, k, "psi mix", st);
        if ((st = dkf_tw_node_commit(&a->nd, a->mix, NULL)) != DKF_OK)
            return fail_step(err, errlen, a, k, "dkf_tw_node_commit", st);
        return record_step(a, k);
    }
    /* (29)-(30): one ACF iteration */
    if ((st = mix_round(a, rx, stride, have, a->mix, a->pkt, c->W + a->row0, 1)) != DKF_OK)
        return fail_step(err, errlen, a, k, "ACF mix", st);
    if (r + 1 == c->eta) { /* info ACF done: local step, its packet starts the second ACF */
        if ((st = dkf_tw_node_local(&a->nd, &a->model, a->mix, a->est)) != DKF_OK)
            return fail_step(err, errlen, a, k, "dkf_tw_node_local", st);
        memcpy(next, a->est, a->pkt * sizeof *next);
        return 0;
    }
    if (r + 1 < c->rounds) {
        memcpy(next, a->mix, a->pkt * sizeof *next);
        return 0;
    }
    if ((st = dkf_tw_node_commit(&a->nd, a->mix, a->mix + c->n)) != DKF_OK)
        return fail_step(err, errlen, a, k, "dkf_tw_node_commit", st);
    return record_step(a, k);
}

/* (no rejoin: a seed-003 node restarted mid-run is not supported) */
static const dkf_ra_ops_t tw_ops = {tw_begin_step, tw_complete_round, NULL};

dkf_net_twa_t *dkf_net_twa_new(const dkf_net_twa_scn_t *c, size_t id, const dkf_net_twa_opts_t *o,
                               char *err, size_t errlen)
{
    dkf_net_twa_t *a;
    const dkf_scn_mat_t *H, *Sw;
    dkf_ra_config_t rc;
    dkf_status_t st;
    size_t e;
    if (id >= c->N) {
        failf(err, errlen, "--id %zu: the scenario has %zu nodes", id, c->N);
        return NULL;
    }
    a = calloc(1, sizeof *a);
    if (a == NULL) return NULL;
    a->c = c;
    a->id = id;
    a->row0 = c->start[id];
    a->deg = c->start[id + 1] - a->row0;
    for (e = 0; e < a->deg; ++e)
        if (c->nbr[a->row0 + e] == id) a->self = e;
    a->pkt = DKF_TW_PKT_LEN(c->n);
    rc.ops = &tw_ops;
    rc.filter = a;
    rc.id = id;
    rc.row = c->nbr + a->row0;
    rc.deg = a->deg;
    rc.ex = dkf_net_twa_expect(c, -1);
    if ((a->ra = dkf_ra_new(&rc, o, err, errlen)) == NULL) {
        dkf_net_twa_free(a);
        return NULL;
    }
    if (alloc_agent(a) != 0) {
        dkf_net_twa_free(a);
        failf(err, errlen, "node %zu: out of memory", id);
        return NULL;
    }
    H = dkf_scn_sensor_model(c->s, id, "H");
    Sw = dkf_scn_sensor_model(c->s, id, "R");
    to_real(a->H, H->data, H->rows * c->n);
    to_real(a->Sw, Sw->data, Sw->rows * Sw->rows);
    dkf_mat_init(&a->mH, H->rows, c->n, a->H);
    dkf_mat_init(&a->mSw, Sw->rows, Sw->rows, a->Sw);
    dkf_mat_init(&a->mA, c->n, c->n, a->A);
    dkf_mat_init(&a->mB, c->n, c->p, a->B);
    dkf_mat_init(&a->mSv, c->n, c->n, a->Sv);
    dkf_mat_init(&a->my, H->rows, 1, a->y);
    /* x0, P0 through the scratch of the step model (A, Sv) before the first step */
    to_real(a->B, dkf_scn_init(c->s, "x00")->data, c->n);
    to_real(a->A, dkf_scn_init(c->s, "P00")->data, c->n * c->n);
    dkf_mat_init(&a->mx0, c->n, 1, a->B);
    dkf_mat_init(&a->mP0, c->n, c->n, a->A);
    st = dkf_tw_node_init(&a->nd, c->n, c->mmax, c->p, a->mem,
                          DKF_TW_NODE_STORAGE_LEN(c->n, c->mmax, c->p), &a->mx0, &a->mP0);
    if (st != DKF_OK) {
        failf(err, errlen, "node %zu: dkf_tw_node_init: %s", id, dkf_status_str(st));
        dkf_net_twa_free(a);
        return NULL;
    }
    a->model.F = &a->mA;
    a->model.G = &a->mB;
    a->model.Q = &a->mSv;
    a->sens.H = &a->mH;
    a->sens.R = &a->mSw;
    return a;
}

void dkf_net_twa_free(dkf_net_twa_t *a)
{
    if (a == NULL) return;
    dkf_ra_free(a->ra);
    free(a->mem);
    free(a->xs);
    free(a);
}

int dkf_net_twa_start(dkf_net_twa_t *a, int64_t now_us) { return dkf_ra_start(a->ra, now_us); }
dkf_net_verdict_t dkf_net_twa_receive(dkf_net_twa_t *a, long chan_node, const void *data,
                                      size_t len, int64_t now_us)
{
    return dkf_ra_receive(a->ra, chan_node, data, len, now_us);
}
int dkf_net_twa_poll(dkf_net_twa_t *a, int64_t now_us) { return dkf_ra_poll(a->ra, now_us); }
int64_t dkf_net_twa_wait_us(const dkf_net_twa_t *a, int64_t now_us)
{
    return dkf_ra_wait_us(a->ra, now_us);
}
int dkf_net_twa_state(const dkf_net_twa_t *a) { return dkf_ra_state(a->ra); }
size_t dkf_net_twa_steps_done(const dkf_net_twa_t *a) { return a->nd.k; }
const char *dkf_net_twa_error(const dkf_net_twa_t *a) { return dkf_ra_error(a->ra); }
const dkf_net_twa_counters_t *dkf_net_twa_counters(const dkf_net_twa_t *a)
{
    return dkf_ra_counters(a->ra);
}
const dkf_tw_node_t *dkf_net_twa_node(const dkf_net_twa_t *a) { return &a->nd; }
dkf_ra_t *dkf_net_twa_rounds(dkf_net_twa_t *a) { return a->ra; }

/* ---- result --------------------------------------------------------------------- */

json_t *dkf_net_twa_result(const dkf_net_twa_t *a)
{
    const dkf_net_twa_scn_t *c = a->c;
    const size_t done = a->nd.k;
    json_t *d = json_object(), *ks = json_array(), *xs = json_array(), *Ps = json_array(),
           *zs = json_array();
    size_t j;
    char id[32];
    snprintf(id, sizeof id, "%016llx", (unsigned long long)(uint64_t)c->model_id);
    json_object_set_new(d, "node", json_integer((json_int_t)a->id));
    json_object_set_new(d, "alg", json_integer(c->alg));
    json_object_set_new(d, "eta", json_integer((json_int_t)c->eta));
    json_object_set_new(d, "model_id", json_string(id));
    json_object_set_new(d, "real", json_string(sizeof(dkf_real_t) == sizeof(double) ? "double" : "float"));
    json_object_set_new(d, "N", json_integer((json_int_t)c->N));
    json_object_set_new(d, "E", json_integer((json_int_t)c->E));
    json_object_set_new(d, "steps", json_integer((json_int_t)c->steps));
    json_object_set_new(d, "rounds_per_step", json_integer((json_int_t)c->rounds));
    for (j = 0; j < done; ++j) {
        json_array_append_new(ks, json_integer((json_int_t)j + 1));
        json_array_append_new(xs, dkf_json_doubles(a->xs + j * c->n, c->n, 0));
        json_array_append_new(Ps, dkf_json_doubles(a->Ps + j * c->n * c->n, c->n, c->n));
        json_array_append_new(zs, dkf_json_doubles(a->zs + j * c->p, c->p, 0));
    }
    json_object_set_new(d, "n", ks);
    json_object_set_new(d, "x", xs);
    json_object_set_new(d, "P", Ps);
    json_object_set_new(d, "z", zs);
    dkf_ra_result_json(a->ra, done, d);
    return d;
}
