/*
 * df_agent.c - a node of seed 001's consensus network over the round
 * protocol (df_agent.h).
 */
#include "df_agent.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "graph_weights.h"
#include "nerts_run.h"
#include "nlm.h"
#include "util.h"

struct dkf_df_agent {
    const dkf_filter_t *fl;
    const dkf_scenario_t *s;
    const dkf_nlm_t *md;        /* the node's model (its Q, R) */
    dkf_ra_t *ra;
    size_t id, row0, deg, self;
    size_t n, m, p, Tp;
    dkf_real_t scale;
    size_t *start, *nbr;        /* the graph (dkf/graph.h CSR) */
    dkf_graph_t g;
    dkf_real_t *W;              /* g.nnz weights; the node's row at W + row0 */
    dkf_dfnerts_node_t nd;
    dkf_real_t *mem;            /* node storage, then Q, R, z, the prior */
    dkf_mat_t Q, R, z;
    dkf_mat_t d0, Pd0;          /* the file's input prior (a rejoin's, paper variant) */
    int64_t model_id;
    double *xs, *Ps, *ds;       /* per step: x, Px, d */
};

/* Everything the nodes of one run must agree on: filter, sizes, T_p, s,
 * the graph and W, every node's model source, Q, R and prior (the
 * measurements excluded: each node reads its own). */
static int64_t model_id(const dkf_df_agent_t *a)
{
    static const char *const init[] = {"x00", "P00", "d00", "Pd00", "Pxd00"};
    const dkf_scenario_t *s = a->s;
    uint64_t h = DKF_FNV1A_OFFSET;
    const char *c;
    size_t i, l;
    for (c = a->fl->name; *c; ++c) h = dkf_fnv1a_u64(h, (uint64_t)(unsigned char)*c);
    h = dkf_fnv1a_u64(h, s->nsensors);
    h = dkf_fnv1a_u64(h, a->n);
    h = dkf_fnv1a_u64(h, a->p);
    h = dkf_fnv1a_u64(h, s->steps);
    h = dkf_fnv1a_u64(h, a->Tp);
    {
        const double sc = s->nl->scale;
        h = dkf_fnv1a_doubles(h, &sc, 1);
    }
    for (l = 0; l < s->nsensors; ++l) {
        const dkf_nlm_t *m = s->nl->models[l];
        for (c = m->source; *c; ++c) h = dkf_fnv1a_u64(h, (uint64_t)(unsigned char)*c);
        h = dkf_fnv1a_u64(h, m->m);
        h = dkf_fnv1a_doubles(h, m->Q, a->n * a->n);
        h = dkf_fnv1a_doubles(h, m->R, m->m * m->m);
        for (i = 0; i < 5; ++i) {
            const dkf_scn_mat_t *v = dkf_scn_node_init(s, l, init[i]);
            if (v != NULL) h = dkf_fnv1a_doubles(h, v->data, v->rows * v->cols);
        }
    }
    for (i = 0; i <= a->g.N; ++i) h = dkf_fnv1a_u64(h, a->start[i]);
    for (i = 0; i < a->g.nnz; ++i) {
        const double w = (double)a->W[i];
        h = dkf_fnv1a_u64(h, a->nbr[i]);
        h = dkf_fnv1a_doubles(h, &w, 1);
    }
    return (int64_t)h;
}

/* v (rows x cols) = node id's init entry `name`, converted into *q. */
static void init_view(const dkf_df_agent_t *a, const char *name, dkf_mat_t *v, dkf_real_t **q)
{
    const dkf_scn_mat_t *m = dkf_scn_node_init(a->s, a->id, name);
    dkf_scn_to_real(*q, m->data, m->rows * m->cols);
    dkf_mat_init(v, m->rows, m->cols, *q);
    *q += m->rows * m->cols;
}

/* Graph, W, the node's storage and its filter from the file's prior. */
static int bind(dkf_df_agent_t *a, dkf_dfnerts_variant_t variant, char *err, size_t errlen)
{
    const dkf_scenario_t *s = a->s;
    const size_t N = s->nsensors, n = a->n, m = a->m, p = a->p;
    const size_t nnz = DKF_GRAPH_NNZ(N, s->net->E);
    const size_t len = DKF_DFNERTS_NODE_STORAGE_LEN(n, m, p);
    dkf_mat_t x0, P0, Pxd0;
    dkf_real_t *q;
    dkf_status_t st;
    int dflt;
    size_t e;
    a->start = calloc(N + 1, sizeof *a->start);
    a->nbr = calloc(nnz, sizeof *a->nbr);
    a->W = calloc(nnz, sizeof *a->W);
    a->mem = calloc(len + n * n + m * m + m + n + n * n + p + p * p + n * p, sizeof *a->mem);
    a->xs = calloc(s->steps * (n + n * n + p) + 1, sizeof *a->xs);
    if (!a->start || !a->nbr || !a->W || !a->mem || !a->xs)
        return dkf_failf(err, errlen, -1, "%s: node %zu: out of memory", s->file, a->id);
    a->Ps = a->xs + s->steps * n;
    a->ds = a->Ps + s->steps * n * n;
    st = dkf_graph_from_edges(&a->g, a->start, a->nbr, nnz, N, s->net->edges, s->net->E);
    if (st != DKF_OK)
        return dkf_failf(err, errlen, -1, "%s: cases[%zu].edges: %s", s->file, s->case_index,
                         dkf_status_str(st));
    if (dkf_host_graph_weights_bind(s, &a->g, 1, a->W, &dflt, err, errlen) != DKF_EXIT_OK) return -1;
    a->row0 = a->start[a->id];
    a->deg = a->start[a->id + 1] - a->row0;
    for (e = 0; e < a->deg; ++e)
        if (a->nbr[a->row0 + e] == a->id) a->self = e;
    q = a->mem + len;
    dkf_scn_to_real(q, a->md->Q, n * n);
    dkf_mat_init(&a->Q, n, n, q);
    q += n * n;
    dkf_scn_to_real(q, a->md->R, m * m);
    dkf_mat_init(&a->R, m, m, q);
    q += m * m;
    dkf_mat_init(&a->z, m, 1, q);
    q += m;
    init_view(a, "x00", &x0, &q);
    init_view(a, "P00", &P0, &q);
    if (p > 0) {
        init_view(a, "d00", &a->d0, &q);
        init_view(a, "Pd00", &a->Pd0, &q);
        init_view(a, "Pxd00", &Pxd0, &q);
    }
    st = dkf_dfnerts_node_init(&a->nd, DKF_NERTS_DNERTSIF, variant, n, m, p, a->mem, len, &x0,
                               &P0, p > 0 ? &a->d0 : NULL, p > 0 ? &a->Pd0 : NULL,
                               p > 0 ? &Pxd0 : NULL);
    if (st != DKF_OK)
        return dkf_failf(err, errlen, -1, "%s: node %zu: dkf_dfnerts_node_init failed: %s (%d)",
                         s->file, a->id, dkf_status_str(st), (int)st);
    return 0;
}

static int fail_step(char *err, size_t errlen, const dkf_df_agent_t *a, size_t k,
                     const char *what, dkf_status_t st)
{
    snprintf(err, errlen, "node %zu: step k=%zu: %s failed: %s (%d)", a->id, k, what,
             dkf_status_str(st), (int)st);
    return -1;
}

/* Step k: the node's time update and local statistics; round 0's packet. */
static int df_begin_step(void *filter, size_t k, dkf_real_t *pkt, char *err, size_t errlen)
{
    dkf_df_agent_t *a = filter;
    dkf_status_t st;
    dkf_scn_to_real(a->z.data, dkf_scn_y(a->s, a->id, (long)k), a->m);
    st = dkf_dfnerts_node_local(&a->nd, &a->md->model, NULL, &a->Q, NULL, &a->R, &a->z, a->scale,
                                pkt);
    return st == DKF_OK ? 0 : fail_step(err, errlen, a, k, "dkf_dfnerts_node_local", st);
}

/* Round r: the row's mix (the own packet for a missing neighbour); the
 * last round commits and records the step. */
static int df_complete_round(void *filter, size_t k, size_t r, const dkf_real_t *rx,
                             size_t stride, const unsigned char *have, dkf_real_t *next,
                             char *err, size_t errlen)
{
    dkf_df_agent_t *a = filter;
    const dkf_real_t *in[DKF_RA_MAX_DEG];
    const size_t n = a->n, p = a->p, j = k - 1;
    dkf_status_t st;
    size_t e;
    for (e = 0; e < a->deg; ++e) in[e] = rx + (have[e] ? e : a->self) * stride;
    st = dkf_dfnerts_node_mix(&a->nd, in, a->W + a->row0, a->deg, next);
    if (st != DKF_OK) return fail_step(err, errlen, a, k, "dkf_dfnerts_node_mix", st);
    if (r + 1 < a->Tp) return 0;
    if ((st = dkf_dfnerts_node_commit(&a->nd)) != DKF_OK)
        return fail_step(err, errlen, a, k, "dkf_dfnerts_node_commit", st);
    for (e = 0; e < n; ++e) a->xs[j * n + e] = (double)a->nd.f.x.data[e];
    for (e = 0; e < n * n; ++e) a->Ps[j * n * n + e] = (double)a->nd.f.Px.data[e];
    for (e = 0; e < p; ++e) a->ds[j * p + e] = (double)a->nd.f.d.data[e];
    return 1;
}

/* Joining after step k: the prior from the neighbour's last-round packet
 * (its information after T_p - 1 mixes; the input's prior from the file
 * for the paper's variant), then step k + 1. */
static int df_rejoin(void *filter, size_t k, const dkf_real_t *pkt, dkf_real_t *next, char *err,
                     size_t errlen)
{
    dkf_df_agent_t *a = filter;
    dkf_status_t st = dkf_dfnerts_node_rejoin(&a->nd, k, pkt, a->p > 0 ? &a->d0 : NULL,
                                              a->p > 0 ? &a->Pd0 : NULL);
    if (st != DKF_OK) return fail_step(err, errlen, a, k + 1, "dkf_dfnerts_node_rejoin", st);
    return df_begin_step(filter, k + 1, next, err, errlen);
}

static const dkf_ra_ops_t df_ops = {df_begin_step, df_complete_round, df_rejoin};

dkf_df_agent_t *dkf_df_agent_new(const dkf_filter_t *f, const dkf_scenario_t *s, size_t id,
                                 const dkf_ra_opts_t *o, char *err, size_t errlen)
{
    dkf_df_agent_t *a;
    dkf_run_opts_t ro;
    dkf_ra_config_t rc;
    memset(&ro, 0, sizeof ro);
    if (f->family != &dkf_family_dfnerts) {
        snprintf(err, errlen, "--filter %s: not a consensus-network filter (df_dnertsif, df_ckf, "
                 "df_dnertsif_joint)", f->name);
        return NULL;
    }
    if (f->family->check(f, &ro, s, err, errlen) != DKF_EXIT_OK) return NULL;
    if (id >= s->nsensors) {
        snprintf(err, errlen, "--id %zu: the scenario has %zu nodes", id, s->nsensors);
        return NULL;
    }
    if (s->net->eta < 1) {
        snprintf(err, errlen, "%s: cases[%zu].Tp: at least 1 round", s->file, s->case_index);
        return NULL;
    }
    if ((a = calloc(1, sizeof *a)) == NULL) {
        snprintf(err, errlen, "node %zu: out of memory", id);
        return NULL;
    }
    a->fl = f;
    a->s = s;
    a->id = id;
    a->md = s->nl->models[id];
    a->n = s->n;
    a->m = a->md->m;
    a->p = s->nl->p;
    a->Tp = (size_t)s->net->eta;
    a->scale = (dkf_real_t)s->nl->scale;
    if (bind(a, ((const dkf_df_impl_t *)f->impl)->variant, err, errlen) != 0) {
        dkf_df_agent_free(a);
        return NULL;
    }
    a->model_id = model_id(a);
    memset(&rc, 0, sizeof rc);
    rc.ops = &df_ops;
    rc.filter = a;
    rc.id = id;
    rc.row = a->nbr + a->row0;
    rc.deg = a->deg;
    rc.ex.model_id = a->model_id;
    rc.ex.nnodes = s->nsensors;
    rc.ex.node = -1;
    rc.ex.steps = s->steps;
    rc.ex.rounds = a->Tp;
    rc.ex.info_rounds = a->Tp;
    rc.ex.info_len = a->nd.pkt_len;
    rc.ex.est_len = 0;
    if ((a->ra = dkf_ra_new(&rc, o, err, errlen)) == NULL) {
        dkf_df_agent_free(a);
        return NULL;
    }
    return a;
}

void dkf_df_agent_free(dkf_df_agent_t *a)
{
    if (a == NULL) return;
    dkf_ra_free(a->ra);
    free(a->start);
    free(a->nbr);
    free(a->W);
    free(a->mem);
    free(a->xs);
    free(a);
}

dkf_ra_t *dkf_df_agent_rounds(dkf_df_agent_t *a) { return a->ra; }
const dkf_dfnerts_node_t *dkf_df_agent_node(const dkf_df_agent_t *a) { return &a->nd; }
int64_t dkf_df_agent_model_id(const dkf_df_agent_t *a) { return a->model_id; }

json_t *dkf_df_agent_result(const dkf_df_agent_t *a)
{
    const size_t done = dkf_ra_steps_done(a->ra), n = a->n, p = a->p;
    json_t *d = json_object(), *ks = json_array(), *xs = json_array(), *Ps = json_array(),
           *ds = json_array();
    size_t j;
    char id[32];
    snprintf(id, sizeof id, "%016llx", (unsigned long long)(uint64_t)a->model_id);
    json_object_set_new(d, "node", json_integer((json_int_t)a->id));
    json_object_set_new(d, "filter", json_string(a->fl->name));
    json_object_set_new(d, "model_id", json_string(id));
    json_object_set_new(d, "real", json_string(sizeof(dkf_real_t) == sizeof(double) ? "double"
                                                                                  : "float"));
    json_object_set_new(d, "N", json_integer((json_int_t)a->s->nsensors));
    json_object_set_new(d, "steps", json_integer((json_int_t)a->s->steps));
    json_object_set_new(d, "Tp", json_integer((json_int_t)a->Tp));
    json_object_set_new(d, "first_step", json_integer((json_int_t)dkf_ra_first_step(a->ra)));
    json_object_set_new(d, "scale", json_real(a->s->nl->scale));
    const size_t first = dkf_ra_first_step(a->ra);
    for (j = first > 0 ? first - 1 : done; j < done; ++j) {
        json_array_append_new(ks, json_integer((json_int_t)j + 1));
        json_array_append_new(xs, dkf_json_doubles(a->xs + j * n, n, 0));
        json_array_append_new(Ps, dkf_json_doubles(a->Ps + j * n * n, n, n));
        json_array_append_new(ds, dkf_json_doubles(a->ds + j * p, p, 0));
    }
    json_object_set_new(d, "k", ks);
    json_object_set_new(d, "x", xs);
    json_object_set_new(d, "Px", Ps);
    json_object_set_new(d, "d", ds);
    dkf_ra_result_json(a->ra, done, d);
    return d;
}
