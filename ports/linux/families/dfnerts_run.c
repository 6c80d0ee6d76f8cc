/*
 * dfnerts_run.c - seed 001's consensus network (dkf/dfnerts.h) over a
 * network case of the nonlinear cases layout (scn_nlcases.c:
 * node_models, init_per_node, W, Tp, scale), the whole graph in process:
 * the registry family "dfnerts", filters
 *
 *   df_dnertsif        DF-DNERTSIF, Algorithm 3 as corrected (PAPER): every
 *                      node's cubature step, Tp rounds on (Y, y), the
 *                      file's scale s (1 literal, N the N-scaled variant)
 *   df_ckf             DF-CKF, the same with p = 0 (s1_ckf models)
 *   df_dnertsif_joint  beyond the paper (JOINT): the rounds on the joint
 *                      information of [x; d], so every node's joint
 *                      covariance is consistent (docs/design/dfnerts.md)
 *
 * The graph is the case's `edges`, or the links of W's nonzero entries; W
 * is checked doubly stochastic on it (graph_weights.h). Recorded per step,
 * per node, the vector's `expected_per_node` names (nerts_run.h): under
 * outputs.<LABEL>, every key a list over steps of a list over nodes, so
 * tools/dkf_compare.py compares it with cases[c].steps[*].expected_per_node[*].
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/dfnerts.h"
#include "family.h"
#include "graph_weights.h"
#include "nerts_run.h"
#include "nlm.h"
#include "status_text.h"
#include "util.h"

typedef struct {
    const dkf_filter_t *fl;
    const dkf_scenario_t *s;
    dkf_df_impl_t impl;
    size_t N, n, p;              /* nodes, state, input */
    size_t *m;                   /* m_l: node l's measurements (its model's g) */
    size_t *start, *nbr;         /* the graph's CSR lists */
    dkf_graph_t g;
    dkf_real_t *W;               /* g.nnz weights */
    dkf_dfnerts_node_t *nodes;
    dkf_dfnerts_net_t net;
    dkf_real_t *mem;             /* dkf_dfnerts_net_storage_len */
    dkf_nl_model_t *models;
    dkf_mat_t *Q, *R, *z;        /* per node */
    dkf_mat_t *x0, *P0, *d0, *Pd0, *Pxd0;
    dkf_real_t *buf;             /* the matrices' data */
    json_t *series;              /* NULL: record nothing */
    double sx, sd, spread;       /* squared errors (node mean), largest node spread */
    size_t nx, nd;
} df_runner_t;

static int df_check(const dkf_filter_t *fl, const dkf_run_opts_t *o, const dkf_scenario_t *s,
                    char *err, size_t errlen)
{
    const dkf_df_impl_t *im = fl->impl;
    (void)o;
    if (s->layout != DKF_SCN_LAYOUT_NLCASES || s->nl == NULL || !s->nl->network)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: cases: filter %s needs a network case of a nonlinear model "
                         "(`node_models`, `init_per_node`, `W`, `Tp`: docs/reference/scenario-format.md, "
                         "\"Nonlinear cases\")", s->file, fl->name);
    if (im->no_input && s->nl->p != 0)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: cases[%zu].init_per_node[0].d0: filter %s has no unknown input "
                         "(d0 = []), the case has p = %zu: use df_dnertsif", s->file,
                         s->case_index, fl->name, s->nl->p);
    if (!im->no_input && s->nl->p == 0)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: cases[%zu].init_per_node[0].d0: filter %s estimates an unknown "
                         "input, the case has none (d0 = []): use df_ckf", s->file,
                         s->case_index, fl->name);
    if ((unsigned long)s->net->eta > DKF_DFNERTS_MAX_TP)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: cases[%zu].Tp: at most %u", s->file,
                         s->case_index, DKF_DFNERTS_MAX_TP);
    return DKF_EXIT_OK;
}

static void df_destroy(dkf_runner_t *r)
{
    df_runner_t *u = (df_runner_t *)(void *)r;
    if (u == NULL) return;
    free(u->start);
    free(u->nbr);
    free(u->m);
    free(u->W);
    free(u->nodes);
    free(u->mem);
    free(u->models);
    free(u->Q);
    free(u->buf);
    json_decref(u->series);
    free(u);
}

/* v = the node-l init entry `name` (r x c) converted into *q (advanced). */
static void init_mat(const dkf_scenario_t *s, size_t l, const char *name, dkf_mat_t *v,
                     dkf_real_t **q)
{
    const dkf_scn_mat_t *m = dkf_scn_node_init(s, l, name);
    dkf_scn_to_real(*q, m->data, m->rows * m->cols);
    dkf_mat_init(v, m->rows, m->cols, *q);
    *q += m->rows * m->cols;
}

static void to_mat(dkf_mat_t *v, const double *src, size_t r, size_t c, dkf_real_t **q)
{
    dkf_scn_to_real(*q, src, r * c);
    dkf_mat_init(v, r, c, *q);
    *q += r * c;
}

/* Graph, weights and every node's matrices; DKF_EXIT_OK or an exit status. */
static int bind_data(df_runner_t *u, char *err, size_t errlen)
{
    const dkf_scenario_t *s = u->s;
    const dkf_scn_network_t *net = s->net;
    const size_t N = u->N, n = u->n, p = u->p, nnz = DKF_GRAPH_NNZ(N, net->E);
    size_t l, per = 0, total;
    dkf_real_t *q;
    dkf_status_t st;
    int dflt, rc;
    u->m = calloc(N, sizeof *u->m);
    if (u->m == NULL) return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
    for (l = 0; l < N; ++l) {
        const size_t ml = u->m[l] = s->nl->models[l]->m;
        per += n * n + ml * ml + ml;
    }
    total = per + N * (n + n * n + p + p * p + n * p);
    u->start = calloc(N + 1, sizeof *u->start);
    u->nbr = calloc(nnz, sizeof *u->nbr);
    u->W = calloc(nnz, sizeof *u->W);
    u->models = calloc(N, sizeof *u->models);
    u->Q = calloc(8 * N, sizeof *u->Q);
    u->buf = calloc(total, sizeof *u->buf);
    if (!u->start || !u->nbr || !u->W || !u->models || !u->Q || !u->buf)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
    u->R = u->Q + N;
    u->z = u->R + N;
    u->x0 = u->z + N;
    u->P0 = u->x0 + N;
    u->d0 = u->P0 + N;
    u->Pd0 = u->d0 + N;
    u->Pxd0 = u->Pd0 + N;
    st = dkf_graph_from_edges(&u->g, u->start, u->nbr, nnz, N, net->edges, net->E);
    if (st != DKF_OK)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: cases[%zu].edges: not a simple undirected graph (a self loop or a "
                         "repeated edge): %s", s->file, s->case_index, dkf_status_str(st));
    if ((rc = dkf_host_graph_weights_bind(s, &u->g, 1, u->W, &dflt, err, errlen)) != 0) return rc;
    q = u->buf;
    for (l = 0; l < N; ++l) {
        const dkf_nlm_t *m = s->nl->models[l];
        u->models[l] = m->model;
        to_mat(&u->Q[l], m->Q, n, n, &q);
        to_mat(&u->R[l], m->R, m->m, m->m, &q);
        dkf_mat_init(&u->z[l], m->m, 1, q);
        q += m->m;
        init_mat(s, l, "x00", &u->x0[l], &q);
        init_mat(s, l, "P00", &u->P0[l], &q);
        if (p > 0) {
            init_mat(s, l, "d00", &u->d0[l], &q);
            init_mat(s, l, "Pd00", &u->Pd0[l], &q);
            init_mat(s, l, "Pxd00", &u->Pxd0[l], &q);
        }
    }
    return DKF_EXIT_OK;
}

static dkf_runner_t *df_create(const dkf_filter_t *fl, const dkf_run_opts_t *o,
                               const dkf_scenario_t *s, char *err, size_t errlen, int *rc)
{
    df_runner_t *u = dkf_runner_calloc(sizeof *u, s, err, errlen, rc);
    size_t len;
    dkf_status_t st;
    if (u == NULL) return NULL;
    u->fl = fl;
    u->s = s;
    u->impl = *(const dkf_df_impl_t *)fl->impl;
    u->N = s->nsensors;
    u->n = s->n;
    u->p = s->nl->p;
    if ((*rc = bind_data(u, err, errlen)) != DKF_EXIT_OK) {
        df_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    len = dkf_dfnerts_net_storage_len(u->N, u->n, u->m, u->p);
    u->nodes = calloc(u->N, sizeof *u->nodes);
    u->mem = calloc(len, sizeof *u->mem);
    u->series = o->record ? json_object() : NULL;
    if (u->nodes == NULL || u->mem == NULL || (o->record && u->series == NULL)) {
        *rc = dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
        df_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    st = dkf_dfnerts_net_init(&u->net, &u->g, u->nodes, DKF_NERTS_DNERTSIF, u->impl.variant,
                              u->n, u->m, u->p, u->mem, len, u->x0, u->P0,
                              u->p > 0 ? u->d0 : NULL, u->p > 0 ? u->Pd0 : NULL,
                              u->p > 0 ? u->Pxd0 : NULL);
    if (st != DKF_OK) {
        char text[DKF_STATUS_TEXT_LEN];
        *rc = dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: cases[%zu]: %s: dkf_dfnerts_net_init "
                        "failed: %s", s->file, s->case_index, fl->label,
                        dkf_host_status_text(text, sizeof text, "dkf_dfnerts_net_init", st));
        df_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    *rc = DKF_EXIT_OK;
    return (dkf_runner_t *)(void *)u;
}

/* One step of every node into series: key -> [.., [node 0, node 1, ...]]. */
static void record_nodes(json_t *series, const df_runner_t *u)
{
    json_t *step = json_object();
    const char *key;
    json_t *val;
    size_t l;
    for (l = 0; l < u->N; ++l) {
        json_t *one = json_object();
        dkf_host_nerts_record(one, &u->nodes[l].f);
        json_object_foreach(one, key, val) {
            json_t *all = json_object_get(step, key);
            if (all == NULL) {
                all = json_array();
                json_object_set_new(step, key, all);
            }
            json_array_append(all, json_array_get(val, 0));
        }
        json_decref(one);
    }
    json_object_foreach(step, key, val) dkf_json_append(series, key, json_incref(val));
    json_decref(step);
}

static void errors_against_truth(df_runner_t *u, long k)
{
    const double *xt = dkf_scn_truth(u->s, k), *dt = dkf_scn_truth_u(u->s, k);
    size_t i, l;
    for (i = 0; i < u->n; ++i) {
        double lo = INFINITY, hi = -INFINITY;
        for (l = 0; l < u->N; ++l) {
            const double v = (double)u->nodes[l].f.x.data[i];
            lo = fmin(lo, v);
            hi = fmax(hi, v);
            if (xt != NULL) u->sx += (v - xt[i]) * (v - xt[i]) / (double)u->N;
        }
        u->spread = fmax(u->spread, hi - lo);
    }
    if (xt != NULL) u->nx++;
    if (dt != NULL && u->s->m_u == u->p && u->p > 0) {
        for (l = 0; l < u->N; ++l)
            for (i = 0; i < u->p; ++i) {
                const double e = (double)u->nodes[l].f.d.data[i] - dt[i];
                u->sd += e * e / (double)u->N;
            }
        u->nd++;
    }
}

static int df_step(dkf_runner_t *r, long k, char *err, size_t errlen)
{
    df_runner_t *u = (df_runner_t *)(void *)r;
    const dkf_scenario_t *s = u->s;
    dkf_status_t st;
    size_t l;
    for (l = 0; l < u->N; ++l)
        dkf_scn_to_real(u->z[l].data, dkf_scn_y(s, l, k), s->sensors[l].m);
    st = dkf_dfnerts_net_step(&u->net, u->models, NULL, u->Q, NULL, u->R, u->z, u->W,
                              (size_t)s->net->eta, (dkf_real_t)s->nl->scale);
    if (st != DKF_OK) {
        const char *why = "";
        char text[DKF_STATUS_TEXT_LEN];
        for (l = 0; l < u->N && why[0] == '\0'; ++l) why = dkf_nlm_failure(s->nl->models[l]);
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: cases[%zu] step k=%ld: %s: "
                         "dkf_dfnerts_net_step failed: %s%s%s", s->file, s->case_index, k,
                         u->fl->label, dkf_host_status_text(text, sizeof text, "dkf_dfnerts_net_step",
                                                       st),
                         why[0] != '\0' ? "; " : "", why);
    }
    if (u->series != NULL) record_nodes(u->series, u);
    errors_against_truth(u, k);
    return DKF_EXIT_OK;
}

static void df_record(dkf_runner_t *r, dkf_out_t *out)
{
    const df_runner_t *u = (const df_runner_t *)(const void *)r;
    dkf_out_outputs(out, u->fl->label, u->series);
}

static void df_record_end(const dkf_runner_t *r, dkf_out_t *out)
{
    const df_runner_t *u = (const df_runner_t *)(const void *)r;
    dkf_out_value(out, "communication",
                        json_pack("{s:I, s:I, s:I, s:I}", "reals_sent",
                                  (json_int_t)u->net.reals_sent, "broadcasts",
                                  (json_int_t)u->net.broadcasts, "N", (json_int_t)u->N, "edges",
                                  (json_int_t)u->s->net->E));
}

static void df_summary(const dkf_runner_t *r, FILE *out)
{
    const df_runner_t *u = (const df_runner_t *)(const void *)r;
    const dkf_scenario_t *s = u->s;
    fprintf(out, "scenario %s, case %s: %zu steps, %zu nodes (%zu links), n = %zu, p = %zu, "
            "Tp = %ld, scale %g; filter %s (%s)\n", s->file,
            s->case_name != NULL ? s->case_name : "", s->steps, u->N, s->net->E, u->n, u->p,
            s->net->eta, s->nl->scale, u->fl->name, DKF_USE_FLOAT ? "float" : "double");
    if (u->nx > 0)
        fprintf(out, "  RMSE(x) %.6g (mean over the nodes) over %zu steps\n",
                sqrt(u->sx / (double)(u->nx * u->n)), u->nx);
    else
        fprintf(out, "  RMSE(x) (no truth)\n");
    if (u->nd > 0)
        fprintf(out, "  RMSE(d) %.6g vs truth %s\n", sqrt(u->sd / (double)(u->nd * u->p)),
                s->truth_u_key);
    fprintf(out, "  largest spread of a state component across the nodes %.3g; %lu reals sent "
            "in %lu broadcasts\n", u->spread, u->net.reals_sent, u->net.broadcasts);
}

/* ---- the registry family ---- */

static const dkf_df_impl_t impls[] = {
    {DKF_DFNERTS_PAPER, 0}, {DKF_DFNERTS_PAPER, 1}, {DKF_DFNERTS_JOINT, 0},
};
static const dkf_filter_t filters[] = {
    {"df_dnertsif", "DF_DNERTSIF",
     "seed 001: DF-DNERTSIF (Algorithm 3), every node's cubature\n"
     "                           step and Tp consensus rounds on (Y, y), the case's scale;\n"
     "                           whole network in process (dkf/dfnerts.h)",
     0, &dkf_family_dfnerts, &impls[0]},
    {"df_ckf", "DF_CKF",
     "seed 001: DF-CKF, the same without unknown input (p = 0)",
     0, &dkf_family_dfnerts, &impls[1]},
    {"df_dnertsif_joint", "DF_DNERTSIF_JOINT",
     "beyond seed 001: consensus on the joint information of\n"
     "                           [x; d] (a consistent joint covariance at every node)",
     0, &dkf_family_dfnerts, &impls[2]},
};
const dkf_family_t dkf_family_dfnerts = {
    .name = "dfnerts",
    .filters = filters,
    .nfilters = sizeof filters / sizeof filters[0],
    .layouts = 1u << DKF_SCN_LAYOUT_NLCASES,
    .check = df_check,
    .create = df_create,
    .step = df_step,
    .record = df_record,
    .record_end = df_record_end,
    .errors = NULL,
    .summary = df_summary,
    .destroy = df_destroy,
};
