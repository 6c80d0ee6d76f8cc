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
static int64_t model_id(const dkf_tw_scn_t *c)
{
    static const char *const dyn[] = {"A", "B", "Sv"};
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
        const dkf_scn_mat_t *Sw = dkf_scn_sensor_model(s, l, "Sw");
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
    if (alg != 2 && alg != 3) return failf(err, errlen, "--alg %d: expected 2 or 3", alg);
    memset(&o, 0, sizeof o);
    o.eta = eta;
    return f->family->check(f, &o, s, err, errlen) == DKF_EXIT_OK ? 0 : -1;
}

int dkf_tw_scn_bind(dkf_tw_scn_t *c, const dkf_scenario_t *s, int alg, long eta, char *err,
                    size_t errlen)
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
    c->p = dkf_scn_model(s, "B")->cols;
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
        dkf_tw_scn_free(c);
        return failf(err, errlen, "%s: out of memory", s->file);
    }
    c->W = c->alpha + nnz;
    st = dkf_graph_from_edges(&c->g, c->start, c->nbr, nnz, c->N, s->net->edges, c->E);
    if (st != DKF_OK) {
        dkf_tw_scn_free(c);
        return failf(err, errlen, "%s: graph.edges: %s", s->file, dkf_status_str(st));
    }
    if (dkf_graph_weights_bind(c->s, &c->g, 0, c->alpha, &c->alpha_default, err, errlen) != 0 ||
        dkf_graph_weights_bind(c->s, &c->g, 1, c->W, &c->W_default, err, errlen) != 0) {
        dkf_tw_scn_free(c);
        return -1;
    }
    c->model_id = model_id(c);
    return 0;
}

void dkf_tw_scn_free(dkf_tw_scn_t *c)
{
    free(c->start);
    free(c->nbr);
    free(c->alpha);
    c->start = c->nbr = NULL;
    c->alpha = c->W = NULL;
}

/* ---- packets -------------------------------------------------------------------- */

dkf_net_tw_expect_t dkf_tw_expect(const dkf_tw_scn_t *c, long chan_node)
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

void dkf_tw_round_shape(const dkf_tw_scn_t *c, size_t round, int *kind, size_t *len)
{
    const dkf_net_tw_expect_t ex = dkf_tw_expect(c, -1);
    dkf_net_tw_shape(&ex, round, kind, len);
}

int dkf_tw_encode(void *buf, size_t cap, size_t *len, const dkf_tw_pkt_t *p)
{
    return dkf_net_encode_tw(buf, cap, len, p);
}

dkf_net_verdict_t dkf_tw_decode(const void *buf, size_t len, const dkf_tw_scn_t *c,
                                long chan_node, dkf_tw_pkt_t *out, dkf_net_rejects_t *rej)
{
    const dkf_net_tw_expect_t ex = dkf_tw_expect(c, chan_node);
    return dkf_net_decode_tw(buf, len, &ex, out, rej);
}

void dkf_tw_chan(char *out, const char *prefix, size_t node)
{
    snprintf(out, DKF_NET_CHAN_LEN, "%s_%zu", prefix, node);
}

long dkf_tw_chan_node(const char *channel, const char *prefix)
{
    const size_t pl = strlen(prefix);
    const char *p;
    long v = 0;
    if (strncmp(channel, prefix, pl) != 0 || channel[pl] != '_') return -1;
    p = channel + pl + 1;
    if (*p == '\0') return -1;
    if (p[0] == '0' && p[1] != '\0') return -1;
    for (; *p != '\0'; ++p) {
        if (*p < '0' || *p > '9' || v > 100000000L) return -1;
        v = v * 10 + (*p - '0');
    }
    return v;
}

int dkf_tw_subscription(char *out, size_t cap, const dkf_tw_scn_t *c, const char *prefix,
                        size_t node)
{
    size_t e, used;
    int r = snprintf(out, cap, "%s_(", prefix), first = 1;
    if (r < 0 || (size_t)r >= cap) return -1;
    used = (size_t)r;
    for (e = c->start[node]; e < c->start[node + 1]; ++e) {
        if (c->nbr[e] == node) continue;
        r = snprintf(out + used, cap - used, "%s%zu", first ? "" : "|", c->nbr[e]);
        if (r < 0 || (size_t)r >= cap - used) return -1;
        used += (size_t)r;
        first = 0;
    }
    if (first) return -1; /* no neighbour: nothing to subscribe to */
    r = snprintf(out + used, cap - used, ")");
    return (r < 0 || (size_t)r >= cap - used) ? -1 : 0;
}

/* ---- the agent ------------------------------------------------------------------- */

struct dkf_tw_agent {
    const dkf_tw_scn_t *c;
    dkf_tw_agent_opts_t o;
    size_t id, row0, deg, self; /* row of id: entries row0 .. row0 + deg - 1; self = position of id */
    size_t pkt;                 /* DKF_TW_PKT_LEN(n) */
    dkf_tw_node_t nd;
    dkf_real_t *mem;            /* node storage, then the buffers below */
    dkf_real_t *rx, *nx;        /* deg x pkt: this round's / next round's packets, row order */
    dkf_real_t *cur, *prev;     /* my packet of this round / of the previous one */
    dkf_real_t *mix, *est;      /* pkt each */
    size_t cur_len, prev_len;
    unsigned char *have, *have_nx, *absent, *done, *missed; /* deg flags each */
    int64_t *heard;             /* deg: last packet of a round <= t + 1 (liveness) */
    long t, prev_t;             /* global round index (k - 1) * rounds + round; -1: none */
    long T;                     /* steps * rounds */
    size_t k;                   /* step in progress (1..steps), steps + 1 when finished */
    int state;
    int64_t round_start, last_pub, linger_start;
    /* model / sensor of the step */
    dkf_real_t *A, *B, *Sv, *H, *Sw, *y;
    dkf_mat_t mA, mB, mSv, mH, mSw, my, mx0, mP0;
    dkf_uif_dyn_t model;
    dkf_kf_meas_t sens;
    /* results */
    double *xs, *Ps, *zs;
    unsigned char *deg_step;    /* per step: degraded */
    unsigned char *miss_step;   /* steps x deg: neighbour missing in the step */
    dkf_tw_counters_t cnt;
    char err[256];
};

static void to_real(dkf_real_t *dst, const double *src, size_t n)
{
    dkf_scn_to_real(dst, src, n);
}

static int alloc_agent(dkf_tw_agent_t *a)
{
    const dkf_tw_scn_t *c = a->c;
    const size_t node_len = DKF_TW_NODE_STORAGE_LEN(c->n, c->mmax, c->p);
    const size_t nm = 2 * c->n * c->n + c->n * c->p + c->mmax * c->n + c->mmax * c->mmax +
                      c->mmax + 2 * c->n;
    a->mem = calloc(node_len + 2 * a->deg * a->pkt + 4 * a->pkt + nm, sizeof *a->mem);
    a->have = calloc(5 * a->deg + c->steps + c->steps * a->deg, 1);
    a->xs = calloc(c->steps * (c->n + c->n * c->n + c->p), sizeof *a->xs);
    a->heard = calloc(a->deg, sizeof *a->heard);
    if (a->mem == NULL || a->have == NULL || a->xs == NULL || a->heard == NULL) return -1;
    a->rx = a->mem + node_len;
    a->nx = a->rx + a->deg * a->pkt;
    a->cur = a->nx + a->deg * a->pkt;
    a->prev = a->cur + a->pkt;
    a->mix = a->prev + a->pkt;
    a->est = a->mix + a->pkt;
    a->A = a->est + a->pkt;
    a->Sv = a->A + c->n * c->n;
    a->B = a->Sv + c->n * c->n;
    a->H = a->B + c->n * c->p;
    a->Sw = a->H + c->mmax * c->n;
    a->y = a->Sw + c->mmax * c->mmax;
    a->have_nx = a->have + a->deg;
    a->absent = a->have_nx + a->deg;
    a->done = a->absent + a->deg;
    a->missed = a->done + a->deg;
    a->deg_step = a->missed + a->deg;
    a->miss_step = a->deg_step + c->steps;
    a->Ps = a->xs + c->steps * c->n;
    a->zs = a->Ps + c->steps * c->n * c->n;
    return 0;
}

dkf_tw_agent_t *dkf_tw_agent_new(const dkf_tw_scn_t *c, size_t id, const dkf_tw_agent_opts_t *o,
                                 char *err, size_t errlen)
{
    dkf_tw_agent_t *a;
    const dkf_scn_mat_t *H, *Sw;
    dkf_status_t st;
    size_t e;
    if (id >= c->N) {
        failf(err, errlen, "--id %zu: the scenario has %zu nodes", id, c->N);
        return NULL;
    }
    a = calloc(1, sizeof *a);
    if (a == NULL) return NULL;
    a->c = c;
    a->o = *o;
    a->id = id;
    a->row0 = c->start[id];
    a->deg = c->start[id + 1] - a->row0;
    if (a->deg > DKF_TW_MAX_DEG) {
        failf(err, errlen, "node %zu: %zu neighbours, at most %d supported", id, a->deg - 1,
              DKF_TW_MAX_DEG - 1);
        free(a);
        return NULL;
    }
    for (e = 0; e < a->deg; ++e)
        if (c->nbr[a->row0 + e] == id) a->self = e;
    a->pkt = DKF_TW_PKT_LEN(c->n);
    a->t = a->prev_t = -1;
    a->T = (long)(c->steps * c->rounds);
    if (alloc_agent(a) != 0) {
        dkf_tw_agent_free(a);
        failf(err, errlen, "node %zu: out of memory", id);
        return NULL;
    }
    H = dkf_scn_sensor_model(c->s, id, "H");
    Sw = dkf_scn_sensor_model(c->s, id, "Sw");
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
        dkf_tw_agent_free(a);
        return NULL;
    }
    a->model.F = &a->mA;
    a->model.G = &a->mB;
    a->model.Q = &a->mSv;
    a->sens.H = &a->mH;
    a->sens.R = &a->mSw;
    return a;
}

void dkf_tw_agent_free(dkf_tw_agent_t *a)
{
    if (a == NULL) return;
    free(a->mem);
    free(a->have);
    free(a->xs);
    free(a->heard);
    free(a);
}

static int fail_agent(dkf_tw_agent_t *a, const char *what, dkf_status_t st)
{
    snprintf(a->err, sizeof a->err, "node %zu: step n=%zu: %s failed: %s", a->id, a->k, what,
             dkf_status_str(st));
    a->state = DKF_TW_FAILED;
    return a->state;
}

/* retransmit: 0 first publication, 1 re-publication while waiting (the
 * wire flag), 2 an answer to a neighbour's re-publication (flag clear). */
static int publish(dkf_tw_agent_t *a, long t, int kind, const dkf_real_t *v, size_t len,
                   int retransmit, int64_t now)
{
    static unsigned char buf[DKF_TW_MAX_MSG];
    dkf_tw_pkt_t p;
    size_t n;
    const long R = (long)a->c->rounds;
    memset(&p, 0, sizeof p);
    p.utime = dkf_net_now_us();
    p.model_id = a->c->model_id;
    p.node = (long)a->id;
    p.k = kind == DKF_TW_KIND_DONE ? (long)a->c->steps + 1 : t / R + 1;
    p.round = kind == DKF_TW_KIND_DONE ? 0 : t % R;
    p.kind = kind;
    p.retransmit = retransmit == 1;
    p.len = len;
    if (len > 0) memcpy(p.v, v, len * sizeof *v);
    if (dkf_tw_encode(buf, sizeof buf, &n, &p) != 0 || a->o.send(a->o.user, buf, n) != 0) {
        snprintf(a->err, sizeof a->err, "node %zu: cannot publish", a->id);
        a->state = DKF_TW_FAILED;
        return -1;
    }
    ++a->cnt.sent;
    if (retransmit == 1) ++a->cnt.retransmits;
    else if (retransmit == 2) ++a->cnt.answers;
    else a->cnt.reals_sent += len; /* the filter's own traffic, first publications */
    a->last_pub = now;
    return 0;
}

/* Enters round t with my packet v: early packets of t become current. */
static int enter_round(dkf_tw_agent_t *a, long t, const dkf_real_t *v, int64_t now)
{
    const size_t R = a->c->rounds;
    int kind;
    size_t len;
    dkf_tw_round_shape(a->c, (size_t)t % R, &kind, &len);
    if (a->t >= 0) {
        memcpy(a->prev, a->cur, a->cur_len * sizeof *a->cur);
        a->prev_len = a->cur_len;
        a->prev_t = a->t;
    }
    if (v != a->cur) memcpy(a->cur, v, len * sizeof *v);
    a->cur_len = len;
    a->t = t;
    memcpy(a->rx, a->nx, a->deg * a->pkt * sizeof *a->rx);
    memcpy(a->have, a->have_nx, a->deg);
    memset(a->have_nx, 0, a->deg);
    memcpy(a->rx + a->self * a->pkt, a->cur, len * sizeof *v);
    a->have[a->self] = 1;
    a->round_start = now;
    return publish(a, t, kind, a->cur, len, 0, now);
}

static void load_step(dkf_tw_agent_t *a)
{
    const dkf_tw_scn_t *c = a->c;
    const size_t k = a->k;
    to_real(a->A, dkf_scn_at(dkf_scn_model(c->s, "A"), k - 1), c->n * c->n);
    to_real(a->B, dkf_scn_at(dkf_scn_model(c->s, "B"), k - 1), c->n * c->p);
    to_real(a->Sv, dkf_scn_at(dkf_scn_model(c->s, "Sv"), k - 1), c->n * c->n);
    to_real(a->y, dkf_scn_y(c->s, a->id, (long)k), a->mH.rows);
}

static void record_step(dkf_tw_agent_t *a)
{
    const dkf_tw_scn_t *c = a->c;
    const size_t j = a->k - 1;
    size_t i;
    for (i = 0; i < c->n; ++i) a->xs[j * c->n + i] = (double)a->nd.x.data[i];
    for (i = 0; i < c->n * c->n; ++i) a->Ps[j * c->n * c->n + i] = (double)a->nd.P.data[i];
    for (i = 0; i < c->p; ++i) a->zs[j * c->p + i] = (double)a->nd.d.data[i];
    memcpy(a->miss_step + j * a->deg, a->missed, a->deg);
    for (i = 0; i < a->deg; ++i) a->deg_step[j] |= a->missed[i];
    if (a->deg_step[j]) ++a->cnt.degraded_steps;
    memset(a->missed, 0, a->deg);
}

static int finish(dkf_tw_agent_t *a, int64_t now)
{
    a->state = DKF_TW_LINGER;
    a->linger_start = now;
    a->prev_t = a->t; /* answers to retransmits of the last round */
    memcpy(a->prev, a->cur, a->cur_len * sizeof *a->cur);
    a->prev_len = a->cur_len;
    a->t = a->T;
    return publish(a, 0, DKF_TW_KIND_DONE, NULL, 0, 0, now);
}

/* Starts step a->k (or finishes): its measurement packet, then round 0;
 * with no rounds at all (Alg 3, eta = 0) the step is local. */
static int begin_step(dkf_tw_agent_t *a, int64_t now)
{
    const dkf_tw_scn_t *c = a->c;
    dkf_status_t st;
    while (a->k <= c->steps) {
        load_step(a);
        st = dkf_tw_meas_packet(a->mix, &a->nd, &a->sens, &a->my,
                                c->alg == 2 ? DKF_R(1.0) : (dkf_real_t)c->N);
        if (st != DKF_OK) return fail_agent(a, "dkf_tw_meas_packet", st);
        if (c->rounds > 0) return enter_round(a, (long)((a->k - 1) * c->rounds), a->mix, now);
        if ((st = dkf_tw_node_local(&a->nd, &a->model, a->mix, a->est)) != DKF_OK)
            return fail_agent(a, "dkf_tw_node_local", st);
        if ((st = dkf_tw_node_commit(&a->nd, a->est, a->est + c->n)) != DKF_OK)
            return fail_agent(a, "dkf_tw_node_commit", st);
        record_step(a);
        ++a->k;
    }
    return finish(a, now);
}

/* Alg 2 info sum (weights NULL) or a weighted mix of the present packets
 * (len reals each) into out. Complete rounds take the row exactly as
 * dkf_tw_net_* does; with packets missing, alpha is renormalised over the
 * present ones (Alg 2) or the own packet stands in (Alg 3, subst). */
static dkf_status_t mix_round(dkf_tw_agent_t *a, dkf_real_t *out, size_t len,
                              const dkf_real_t *w, int subst)
{
    const dkf_real_t *in[DKF_TW_MAX_DEG];
    dkf_real_t wc[DKF_TW_MAX_DEG], sum = DKF_R(0.0);
    size_t e, cnt = 0;
    int full = 1;
    for (e = 0; e < a->deg; ++e) full &= a->have[e];
    if (full || subst) {
        for (e = 0; e < a->deg; ++e) in[e] = a->have[e] ? a->rx + e * a->pkt : a->cur;
        return dkf_graph_mix(out, len, in, w, a->deg);
    }
    for (e = 0; e < a->deg; ++e)
        if (a->have[e]) {
            in[cnt] = a->rx + e * a->pkt;
            if (w != NULL) sum += (wc[cnt] = w[e]);
            ++cnt;
        }
    for (e = 0; w != NULL && e < cnt; ++e) wc[e] /= sum;
    return dkf_graph_mix(out, len, in, w != NULL ? wc : NULL, cnt);
}

/* Round a->t is complete (or given up): mix, and go on. */
static int complete_round(dkf_tw_agent_t *a, int64_t now)
{
    const dkf_tw_scn_t *c = a->c;
    const size_t r = (size_t)a->t % c->rounds;
    const long next = a->t + 1;
    dkf_status_t st;
    if (c->alg == 2 && r == 0) { /* (24c), (25a): info sum over N_l; local step; publish psi */
        if ((st = mix_round(a, a->mix, a->pkt, NULL, 0)) != DKF_OK) return fail_agent(a, "info sum", st);
        if ((st = dkf_tw_node_local(&a->nd, &a->model, a->mix, a->est)) != DKF_OK)
            return fail_agent(a, "dkf_tw_node_local", st);
        return enter_round(a, next, a->est, now);
    }
    if (c->alg == 2) { /* (26b): x_l = sum alpha_lk psi_k */
        if ((st = mix_round(a, a->mix, c->n, c->alpha + a->row0, 0)) != DKF_OK)
            return fail_agent(a, "psi mix", st);
        if ((st = dkf_tw_node_commit(&a->nd, a->mix, NULL)) != DKF_OK)
            return fail_agent(a, "dkf_tw_node_commit", st);
    } else { /* (29)-(30): one ACF iteration */
        if ((st = mix_round(a, a->mix, a->pkt, c->W + a->row0, 1)) != DKF_OK)
            return fail_agent(a, "ACF mix", st);
        if (r + 1 == c->eta) { /* info ACF done: local step, its packet starts the second ACF */
            if ((st = dkf_tw_node_local(&a->nd, &a->model, a->mix, a->est)) != DKF_OK)
                return fail_agent(a, "dkf_tw_node_local", st);
            return enter_round(a, next, a->est, now);
        }
        if (r + 1 < c->rounds) return enter_round(a, next, a->mix, now);
        if ((st = dkf_tw_node_commit(&a->nd, a->mix, a->mix + c->n)) != DKF_OK)
            return fail_agent(a, "dkf_tw_node_commit", st);
    }
    record_step(a);
    ++a->k;
    return begin_step(a, now);
}

int dkf_tw_agent_start(dkf_tw_agent_t *a, int64_t now_us)
{
    if (a->k != 0) return a->state;
    a->k = 1;
    return begin_step(a, now_us);
}

/* Row position of node j in my row, or -1. */
static long row_pos(const dkf_tw_agent_t *a, long j)
{
    size_t e;
    for (e = 0; e < a->deg; ++e)
        if ((long)a->c->nbr[a->row0 + e] == j) return (long)e;
    return -1;
}

dkf_net_verdict_t dkf_tw_agent_receive(dkf_tw_agent_t *a, long chan_node, const void *data,
                                       size_t len, int64_t now_us)
{
    static dkf_tw_pkt_t p;
    dkf_net_verdict_t v;
    long e, t;
    v = dkf_tw_decode(data, len, a->c, chan_node, &p, &a->cnt.rej);
    if (v != DKF_NET_ACCEPT) return v;
    e = row_pos(a, p.node);
    if (e < 0 || (size_t)e == a->self) { /* not a neighbour (a subscription filters these) */
        ++a->cnt.rej.total;
        ++a->cnt.rej.by[DKF_NET_REJ_NODE];
        return DKF_NET_REJ_NODE;
    }
    ++a->cnt.received;
    if (p.kind == DKF_TW_KIND_DONE || (p.k - 1) * (long)a->c->rounds + p.round <= a->t + 1)
        a->heard[e] = now_us; /* alive, and not gone past us */
    if (p.kind == DKF_TW_KIND_DONE) {
        a->done[e] = 1;
        return v;
    }
    t = (p.k - 1) * (long)a->c->rounds + p.round;
    if (t == a->t && a->state == DKF_TW_RUNNING) {
        if (a->have[e]) ++a->cnt.duplicates;
        memcpy(a->rx + (size_t)e * a->pkt, p.v, p.len * sizeof p.v[0]);
        a->have[e] = 1;
        a->absent[e] = 0;
    } else if (t == a->t + 1 && a->state == DKF_TW_RUNNING) {
        memcpy(a->nx + (size_t)e * a->pkt, p.v, p.len * sizeof p.v[0]);
        a->have_nx[e] = 1;
        a->absent[e] = 0;
    } else if (t < a->t) {
        int kind;
        size_t plen;
        ++a->cnt.stale;
        /* the neighbour still waits in the round I left: it may lack mine */
        if (p.retransmit && t == a->prev_t) {
            dkf_tw_round_shape(a->c, (size_t)t % a->c->rounds, &kind, &plen);
            (void)publish(a, t, kind, a->prev, a->prev_len, 2, now_us);
        }
    } else {
        ++a->cnt.ahead;
    }
    return v;
}

static int round_ready(const dkf_tw_agent_t *a)
{
    size_t e;
    for (e = 0; e < a->deg; ++e)
        if (!a->have[e] && !a->absent[e]) return 0;
    return 1;
}

/* When the round may complete without the packets still missing: a
 * neighbour is given up only after a full timeout of silence, counted from
 * the round's start or from its last packet (a neighbour that is itself
 * waiting re-publishes, so it is never given up while it lives). */
static int64_t deadline(const dkf_tw_agent_t *a)
{
    const int64_t d = a->t == 0 ? a->o.start_timeout_us : a->o.round_timeout_us;
    int64_t last = a->round_start;
    size_t e;
    for (e = 0; e < a->deg; ++e)
        if (!a->have[e] && !a->absent[e] && a->heard[e] > last) last = a->heard[e];
    return last + d;
}

static int linger_over(const dkf_tw_agent_t *a, int64_t now)
{
    size_t e;
    if (now - a->linger_start >= a->o.round_timeout_us) return 1;
    for (e = 0; e < a->deg; ++e)
        if (e != a->self && !a->done[e] && !a->absent[e]) return 0;
    return 1;
}

int dkf_tw_agent_poll(dkf_tw_agent_t *a, int64_t now_us)
{
    size_t e;
    while (a->state == DKF_TW_RUNNING) {
        if (!round_ready(a)) {
            if (now_us < deadline(a)) break;
            for (e = 0; e < a->deg; ++e)
                if (!a->have[e] && !a->absent[e]) {
                    a->absent[e] = 1;
                    a->missed[e] = 1;
                    ++a->cnt.absent_marks;
                }
        }
        for (e = 0; e < a->deg; ++e) a->missed[e] |= (unsigned char)!a->have[e];
        complete_round(a, now_us);
    }
    if (a->state == DKF_TW_RUNNING && now_us - a->last_pub >= a->o.retry_us) {
        int kind;
        size_t len;
        dkf_tw_round_shape(a->c, (size_t)a->t % a->c->rounds, &kind, &len);
        publish(a, a->t, kind, a->cur, a->cur_len, 1, now_us);
    }
    if (a->state == DKF_TW_LINGER) {
        if (linger_over(a, now_us))
            a->state = DKF_TW_FINISHED;
        else if (now_us - a->last_pub >= a->o.retry_us)
            publish(a, 0, DKF_TW_KIND_DONE, NULL, 0, 1, now_us);
    }
    return a->state;
}

int64_t dkf_tw_agent_wait_us(const dkf_tw_agent_t *a, int64_t now_us)
{
    int64_t w = a->last_pub + a->o.retry_us - now_us;
    if (a->state == DKF_TW_RUNNING && deadline(a) - now_us < w) w = deadline(a) - now_us;
    if (a->state == DKF_TW_LINGER && a->linger_start + a->o.round_timeout_us - now_us < w)
        w = a->linger_start + a->o.round_timeout_us - now_us;
    return w < 0 ? 0 : w;
}

int dkf_tw_agent_state(const dkf_tw_agent_t *a) { return a->state; }
size_t dkf_tw_agent_steps_done(const dkf_tw_agent_t *a) { return a->nd.k; }
const char *dkf_tw_agent_error(const dkf_tw_agent_t *a) { return a->err; }
const dkf_tw_counters_t *dkf_tw_agent_counters(const dkf_tw_agent_t *a) { return &a->cnt; }
const dkf_tw_node_t *dkf_tw_agent_node(const dkf_tw_agent_t *a) { return &a->nd; }

/* ---- result --------------------------------------------------------------------- */

static json_t *counters(const dkf_tw_agent_t *a)
{
    const dkf_tw_counters_t *c = &a->cnt;
    json_t *o = json_object(), *by = json_object();
    int v;
    json_object_set_new(o, "sent", json_integer((json_int_t)c->sent));
    json_object_set_new(o, "reals_sent", json_integer((json_int_t)c->reals_sent));
    json_object_set_new(o, "retransmits", json_integer((json_int_t)c->retransmits));
    json_object_set_new(o, "answers", json_integer((json_int_t)c->answers));
    json_object_set_new(o, "received", json_integer((json_int_t)c->received));
    json_object_set_new(o, "duplicates", json_integer((json_int_t)c->duplicates));
    json_object_set_new(o, "stale", json_integer((json_int_t)c->stale));
    json_object_set_new(o, "ahead", json_integer((json_int_t)c->ahead));
    json_object_set_new(o, "absent_marks", json_integer((json_int_t)c->absent_marks));
    json_object_set_new(o, "degraded_steps", json_integer((json_int_t)c->degraded_steps));
    json_object_set_new(o, "rejected", json_integer((json_int_t)c->rej.total));
    for (v = 1; v < DKF_NET_NVERDICTS; ++v)
        json_object_set_new(by, dkf_net_verdict_str((dkf_net_verdict_t)v),
                            json_integer((json_int_t)c->rej.by[v]));
    json_object_set_new(o, "rejected_by_reason", by);
    return o;
}

json_t *dkf_tw_agent_result(const dkf_tw_agent_t *a)
{
    const dkf_tw_scn_t *c = a->c;
    const size_t done = a->nd.k;
    json_t *d = json_object(), *ks = json_array(), *xs = json_array(), *Ps = json_array(),
           *zs = json_array(), *dg = json_array(), *ms = json_array(), *nb = json_array();
    size_t j, e;
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
    for (e = 0; e < a->deg; ++e)
        if (e != a->self) json_array_append_new(nb, json_integer((json_int_t)c->nbr[a->row0 + e]));
    json_object_set_new(d, "neighbours", nb);
    for (j = 0; j < done; ++j) {
        json_t *miss = json_array();
        json_array_append_new(ks, json_integer((json_int_t)j + 1));
        json_array_append_new(xs, dkf_json_doubles(a->xs + j * c->n, c->n, 0));
        json_array_append_new(Ps, dkf_json_doubles(a->Ps + j * c->n * c->n, c->n, c->n));
        json_array_append_new(zs, dkf_json_doubles(a->zs + j * c->p, c->p, 0));
        json_array_append_new(dg, json_boolean(a->deg_step[j]));
        for (e = 0; e < a->deg; ++e)
            if (a->miss_step[j * a->deg + e])
                json_array_append_new(miss, json_integer((json_int_t)c->nbr[a->row0 + e]));
        json_array_append_new(ms, miss);
    }
    json_object_set_new(d, "n", ks);
    json_object_set_new(d, "x", xs);
    json_object_set_new(d, "P", Ps);
    json_object_set_new(d, "z", zs);
    json_object_set_new(d, "degraded", dg);
    json_object_set_new(d, "missing", ms);
    json_object_set_new(d, "counters", counters(a));
    return d;
}
