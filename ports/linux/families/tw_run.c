/*
 * tw_run.c - the seed-003 filters (dkf/tw.h: Talebi-Werner Algorithms 1, 2,
 * 3) over a network-layout scenario, with the whole graph simulated in
 * process by dkf_tw_net_*: the registry family "tw" (family.h), filters
 * tw1, tw2, tw3. All filtering is the library's (Algorithm 1 is
 * dkf_tw_central_step); this file converts the scenario, binds the graph
 * and weights, records, and measures.
 *
 * The graph comes from graph.edges (graph.neighbours_incl_self is
 * informational); alpha_diffusion[_sparse] and W_consensus[_sparse] from
 * the file or, when absent, the library's uniform alpha = 1/|N_l| and
 * Metropolis W (docs/design/derivation-seed003-004.md §2's defaults). Steps start at n = 1.
 *
 * Recorded per step under the vectors' names (alg2/alg3: one entry per
 * node, [N][...]):
 *   alg1: x P z phi Phi phi_post Phi_post S G
 *   alg2: x P z psi Q phi_post Phi_post S G
 *   alg3: x P z Ups vphi psi Ploc phi_post Phi_post S G
 * and, when the file has truth, metrics per step (extra keys):
 *   mse_x[i], mse_z[i]  mean over nodes of the squared error of component i
 *                       (z against z_prev: the step that takes y_n estimates
 *                       z_{n-1})
 *   nees                mean over nodes of e^T P^-1 e / n
 *   spread_x[i]         RMS over nodes of x_l,i - mean_l x_l,i
 *   range_x[i]          max over nodes of x_l,i minus the min
 * and for alg2/alg3 the gap to Algorithm 1 run alongside on the same data:
 *   gap_x, gap_z        mean over nodes of ||x_l - x_alg1||^2, ||z_l - z_alg1||^2
 *   gap_x_rel_max       max over nodes of ||x_l - x_alg1|| / ||x_alg1||
 *   gap_x_vec_rule      max over nodes of max_i |x_l,i - x_alg1,i| / max(1, max_i |x_alg1,i|)
 *                       (the golden-vector comparison rule with Alg 1 as reference)
 */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/graph.h"
#include "dkf/tw.h"
#include "family.h"
#include "graph_weights.h"
#include "status_text.h"
#include "util.h"

static const char *const alg_names[] = {"", "alg1", "alg2", "alg3"};

typedef struct {
    int alg;        /* 1, 2, 3 */
    long eta;       /* alg 3: >= 0 overrides the file's eta; -1: the file's */
    int no_nodes;   /* 1: record only the metrics, not the per-node arrays */
} tw_opts_t;

typedef struct {
    size_t N, E, steps;
    size_t eta;                   /* alg 3 */
    int W_default, alpha_default; /* 1: weights computed (not in the file) */
    double reals_per_node_step;   /* broadcast by a node per step (alg 1: sent to the centre) */
    double broadcasts_per_node_step;
    double rmse_x, rmse_z;        /* root mean over steps, nodes, components (NaN: no truth) */
    double gap_x_rel_max;         /* alg 2/3: max over steps and nodes */
    double gap_x_vec_rule;        /* alg 2/3: max over steps, nodes of the vector rule */
} tw_summary_t;

/* Everything a run owns (freed by ctx_free). */
typedef struct {
    size_t N, n, p, mmax; /* p inputs, mmax the largest sensor */
    size_t *start, *nbr;
    dkf_graph_t g;
    dkf_real_t *W, *alpha;     /* nnz each */
    dkf_tw_node_t *nodes;      /* N */
    dkf_real_t *net_mem;
    dkf_tw_net_t net;
    dkf_tw_node_t central;     /* alg 1, or the reference beside alg 2/3 */
    dkf_real_t *central_mem;
    dkf_real_t *H, *Sw, *y;    /* N * mmax * n, N * mmax^2, N * mmax */
    dkf_mat_t *mH, *mSw, *my;
    dkf_kf_meas_t *sens; /* node l: H, R; its y is my[l] */
    dkf_real_t *A, *B, *Sv, *x0, *P0; /* n^2, n p, n^2, n, n^2 */
    dkf_mat_t mA, mB, mSv, mx0, mP0;
    dkf_uif_dyn_t model;
} ctx_t;

static void ctx_free(ctx_t *c)
{
    free(c->start);
    free(c->nbr);
    free(c->W);
    free(c->alpha);
    free(c->nodes);
    free(c->net_mem);
    free(c->central_mem);
    free(c->H);
    free(c->Sw);
    free(c->y);
    free(c->mH);
    free(c->mSw);
    free(c->my);
    free(c->sens);
    free(c->A);
}

static void to_mat(dkf_mat_t *v, dkf_real_t *buf, const double *src, size_t r, size_t cc)
{
    dkf_scn_to_real(buf, src, r * cc);
    dkf_mat_init(v, r, cc, buf);
}

static int setup(ctx_t *c, const dkf_scenario_t *s, const tw_opts_t *o,
                 tw_summary_t *sum, char *err, size_t errlen)
{
    const dkf_scn_network_t *net = s->net;
    const dkf_scn_mat_t *mB = dkf_scn_model(s, "G");
    size_t l, nnz, node_len;
    dkf_status_t st;
    int rc, dflt;
    c->N = net->N;
    c->n = s->n;
    c->p = mB->cols;
    for (l = 0; l < c->N; ++l)
        if (s->sensors[l].m > c->mmax) c->mmax = s->sensors[l].m;
    nnz = DKF_GRAPH_NNZ(c->N, net->E);
    c->start = calloc(c->N + 1, sizeof *c->start);
    c->nbr = calloc(nnz, sizeof *c->nbr);
    c->W = calloc(nnz, sizeof *c->W);
    c->alpha = calloc(nnz, sizeof *c->alpha);
    c->nodes = calloc(c->N, sizeof *c->nodes);
    node_len = DKF_TW_NET_STORAGE_LEN(c->N, c->n, c->mmax, c->p);
    c->net_mem = calloc(node_len, sizeof *c->net_mem);
    c->central_mem = calloc(DKF_TW_NODE_STORAGE_LEN(c->n, c->mmax, c->p), sizeof *c->central_mem);
    c->H = calloc(c->N * c->mmax * c->n, sizeof *c->H);
    c->Sw = calloc(c->N * c->mmax * c->mmax, sizeof *c->Sw);
    c->y = calloc(c->N * c->mmax, sizeof *c->y);
    c->mH = calloc(c->N, sizeof *c->mH);
    c->mSw = calloc(c->N, sizeof *c->mSw);
    c->my = calloc(c->N, sizeof *c->my);
    c->sens = calloc(c->N, sizeof *c->sens);
    c->A = calloc(3 * c->n * c->n + c->n * c->p + c->n, sizeof *c->A);
    if (!c->start || !c->nbr || !c->W || !c->alpha || !c->nodes || !c->net_mem ||
        !c->central_mem || !c->H || !c->Sw || !c->y || !c->mH || !c->mSw || !c->my || !c->sens ||
        !c->A)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
    c->B = c->A + c->n * c->n;
    c->Sv = c->B + c->n * c->p;
    c->P0 = c->Sv + c->n * c->n;
    c->x0 = c->P0 + c->n * c->n;
    st = dkf_graph_from_edges(&c->g, c->start, c->nbr, nnz, c->N, net->edges, net->E);
    if (st != DKF_OK)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: graph.edges: not a simple undirected graph (a self loop or a "
                         "repeated edge): %s", s->file, dkf_status_str(st));
    if ((rc = dkf_host_graph_weights_bind(s, &c->g, 0, c->alpha, &dflt, err, errlen)) != 0) return rc;
    sum->alpha_default = dflt;
    if ((rc = dkf_host_graph_weights_bind(s, &c->g, 1, c->W, &dflt, err, errlen)) != 0) return rc;
    sum->W_default = dflt;
    for (l = 0; l < c->N; ++l) {
        const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, l, "H");
        const dkf_scn_mat_t *Sw = dkf_scn_sensor_model(s, l, "R");
        to_mat(&c->mH[l], c->H + l * c->mmax * c->n, dkf_scn_at(H, (size_t)s->k_first),
               H->rows, c->n);
        to_mat(&c->mSw[l], c->Sw + l * c->mmax * c->mmax, dkf_scn_at(Sw, (size_t)s->k_first),
               Sw->rows, Sw->rows);
        c->sens[l].H = &c->mH[l];
        c->sens[l].R = &c->mSw[l];
    }
    to_mat(&c->mx0, c->x0, dkf_scn_init(s, "x00")->data, c->n, 1);
    to_mat(&c->mP0, c->P0, dkf_scn_init(s, "P00")->data, c->n, c->n);
    st = dkf_tw_node_init(&c->central, c->n, c->mmax, c->p, c->central_mem,
                          DKF_TW_NODE_STORAGE_LEN(c->n, c->mmax, c->p), &c->mx0, &c->mP0);
    if (st == DKF_OK && o->alg != 1)
        st = dkf_tw_net_init(&c->net, &c->g, c->nodes, c->n, c->mmax, c->p, c->net_mem, node_len,
                             &c->mx0, &c->mP0);
    if (st != DKF_OK) {
        const char *call = o->alg == 1 ? "dkf_tw_node_init" : "dkf_tw_net_init";
        char text[DKF_STATUS_TEXT_LEN];
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: %s: %s failed: %s", s->file,
                         alg_names[o->alg], call, dkf_host_status_text(text, sizeof text, call, st));
    }
    return DKF_EXIT_OK;
}

/* The model and measurements of step k (absolute time n = k). */
static void load_step(ctx_t *c, const dkf_scenario_t *s, long k)
{
    size_t l;
    to_mat(&c->mA, c->A, dkf_scn_at(dkf_scn_model(s, "F"), (size_t)(k - 1)), c->n, c->n);
    to_mat(&c->mB, c->B, dkf_scn_at(dkf_scn_model(s, "G"), (size_t)(k - 1)), c->n, c->p);
    to_mat(&c->mSv, c->Sv, dkf_scn_at(dkf_scn_model(s, "Q"), (size_t)(k - 1)), c->n, c->n);
    c->model.F = &c->mA;
    c->model.G = &c->mB;
    c->model.Q = &c->mSv;
    for (l = 0; l < c->N; ++l) {
        const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, l, "H");
        const dkf_scn_mat_t *Sw = dkf_scn_sensor_model(s, l, "R");
        /* per node H_l, Sw_l of time k (constant, or given per step) */
        to_mat(&c->mH[l], c->H + l * c->mmax * c->n, dkf_scn_at(H, (size_t)k), H->rows, c->n);
        to_mat(&c->mSw[l], c->Sw + l * c->mmax * c->mmax, dkf_scn_at(Sw, (size_t)k), Sw->rows,
               Sw->rows);
        to_mat(&c->my[l], c->y + l * c->mmax, dkf_scn_y(s, l, k), s->sensors[l].m, 1);
    }
}

/* ---- recording ------------------------------------------------------------------ */

static json_t *mat_json(const dkf_mat_t *A)
{
    return dkf_json_from_mat(A, A->cols == 1);
}

typedef struct {
    const char *key;
    size_t off;
} field_t;

/* JSON keys: the paper's names (z = d, G = Gpost, Q / Ups = I, vphi = i) */
#define F(key, member) {key, offsetof(dkf_tw_node_t, member)}
static const field_t fields1[] = {F("x", x), F("P", P), F("z", d), F("phi", phi), F("Phi", Phi),
                                  F("phi_post", phi_post), F("Phi_post", Phi_post), F("S", S),
                                  F("G", Gpost)};
static const field_t fields2[] = {F("x", x), F("P", P), F("z", d), F("psi", psi), F("Q", I),
                                  F("phi_post", phi_post), F("Phi_post", Phi_post), F("S", S),
                                  F("G", Gpost)};
static const field_t fields3[] = {F("x", x), F("P", P), F("z", d), F("Ups", I), F("vphi", i),
                                  F("psi", psi), F("Ploc", Ploc), F("phi_post", phi_post),
                                  F("Phi_post", Phi_post), F("S", S), F("G", Gpost)};
#undef F

static const dkf_mat_t *field(const dkf_tw_node_t *nd, size_t off)
{
    return (const dkf_mat_t *)(const void *)((const char *)nd + off);
}

static void record_nodes(json_t *series, int alg, const dkf_tw_node_t *nodes, size_t count)
{
    const field_t *fs = alg == 1 ? fields1 : alg == 2 ? fields2 : fields3;
    const size_t nf = alg == 1   ? sizeof fields1 / sizeof fields1[0]
                      : alg == 2 ? sizeof fields2 / sizeof fields2[0]
                                 : sizeof fields3 / sizeof fields3[0];
    size_t i, l;
    for (i = 0; i < nf; ++i) {
        if (alg == 1) {
            dkf_json_append(series, fs[i].key, mat_json(field(&nodes[0], fs[i].off)));
            continue;
        }
        {
            json_t *all = json_array();
            for (l = 0; l < count; ++l)
                json_array_append_new(all, mat_json(field(&nodes[l], fs[i].off)));
            dkf_json_append(series, fs[i].key, all);
        }
    }
}

/* ---- metrics ---------------------------------------------------------------------- */

/* e^T P^-1 e by a double Cholesky of P (n <= DKF_MAX_DIM); NaN if P is not PD. */
static double nees(const dkf_tw_node_t *nd, const double *xt)
{
    const size_t n = nd->n;
    double *Pd = malloc(2 * n * n * sizeof *Pd), *L = Pd + n * n, v, q = 0;
    size_t i, k;
    if (Pd == NULL) return NAN;
    for (i = 0; i < n * n; ++i) Pd[i] = (double)nd->P.data[i];
    if (dkf_chol_double(Pd, n, L, NULL) < n) {
        free(Pd);
        return NAN;
    }
    for (i = 0; i < n; ++i) { /* L v = e, v over the rows of Pd (done with) */
        double sm = (double)nd->x.data[i] - xt[i];
        for (k = 0; k < i; ++k) sm -= L[i * n + k] * Pd[k];
        v = sm / L[i * n + i];
        Pd[i] = v;
        q += v * v;
    }
    free(Pd);
    return q;
}

typedef struct {
    double sx, sz, gap_rel_max, gap_vec_max;
    size_t nx, nz;
} acc_t;

static void metrics(json_t *series, const dkf_scenario_t *s, long k, int alg,
                    const dkf_tw_node_t *nodes, size_t count, const dkf_tw_node_t *ref,
                    acc_t *acc)
{
    const double *xt = dkf_scn_truth(s, k), *zt = dkf_scn_truth_u(s, k);
    const size_t n = nodes[0].n, p = nodes[0].p;
    double mx[DKF_MAX_DIM] = {0}, mz[DKF_MAX_DIM] = {0}, mean[DKF_MAX_DIM] = {0};
    double lo[DKF_MAX_DIM], hi[DKF_MAX_DIM];
    double sp[DKF_MAX_DIM] = {0}, ne = 0, gx = 0, gz = 0, grel = 0, nref = 0, ginf = 0,
           xinf = 1;
    size_t l, i;
    if (xt != NULL) {
        for (l = 0; l < count; ++l) {
            for (i = 0; i < n; ++i) {
                const double e = (double)nodes[l].x.data[i] - xt[i];
                mx[i] += e * e / (double)count;
                mean[i] += (double)nodes[l].x.data[i] / (double)count;
            }
            ne += nees(&nodes[l], xt) / (double)(count * n);
        }
        for (i = 0; i < n; ++i) lo[i] = hi[i] = (double)nodes[0].x.data[i];
        for (l = 0; l < count; ++l)
            for (i = 0; i < n; ++i) {
                const double v = (double)nodes[l].x.data[i], d = v - mean[i];
                sp[i] += d * d / (double)count;
                if (v < lo[i]) lo[i] = v;
                if (v > hi[i]) hi[i] = v;
            }
        for (i = 0; i < n; ++i) {
            sp[i] = sqrt(sp[i]);
            acc->sx += mx[i];
        }
        acc->nx += n;
        if (series != NULL) {
            dkf_json_append(series, "mse_x", dkf_json_doubles(mx, n, 0));
            dkf_json_append(series, "nees", json_real(ne));
            dkf_json_append(series, "spread_x", dkf_json_doubles(sp, n, 0));
            for (i = 0; i < n; ++i) hi[i] -= lo[i];
            dkf_json_append(series, "range_x", dkf_json_doubles(hi, n, 0));
        }
    }
    if (zt != NULL && s->m_u == p) {
        for (l = 0; l < count; ++l)
            for (i = 0; i < p; ++i) {
                const double e = (double)nodes[l].d.data[i] - zt[i];
                mz[i] += e * e / (double)count;
            }
        for (i = 0; i < p; ++i) acc->sz += mz[i];
        acc->nz += p;
        if (series != NULL) dkf_json_append(series, "mse_z", dkf_json_doubles(mz, p, 0));
    }
    if (alg == 1 || ref == NULL) return;
    for (i = 0; i < n; ++i) {
        nref += (double)ref->x.data[i] * (double)ref->x.data[i];
        if (fabs((double)ref->x.data[i]) > xinf) xinf = fabs((double)ref->x.data[i]);
    }
    nref = sqrt(nref);
    for (l = 0; l < count; ++l) {
        double dx = 0, dz = 0;
        for (i = 0; i < n; ++i) {
            const double d = (double)nodes[l].x.data[i] - (double)ref->x.data[i];
            dx += d * d;
            if (fabs(d) / xinf > ginf) ginf = fabs(d) / xinf;
        }
        for (i = 0; i < p; ++i) {
            const double d = (double)nodes[l].d.data[i] - (double)ref->d.data[i];
            dz += d * d;
        }
        gx += dx / (double)count;
        gz += dz / (double)count;
        if (nref > 0 && sqrt(dx) / nref > grel) grel = sqrt(dx) / nref;
    }
    if (grel > acc->gap_rel_max) acc->gap_rel_max = grel;
    if (ginf > acc->gap_vec_max) acc->gap_vec_max = ginf;
    if (series != NULL) {
        dkf_json_append(series, "gap_x", json_real(gx));
        dkf_json_append(series, "gap_z", json_real(gz));
        dkf_json_append(series, "gap_x_rel_max", json_real(grel));
        dkf_json_append(series, "gap_x_vec_rule", json_real(ginf));
    }
}

/* ---- the run ---------------------------------------------------------------------- */

static int check_file(const dkf_scenario_t *s, const tw_opts_t *o, char *err,
                      size_t errlen, size_t *eta)
{
    const char *who = o->alg == 1 ? "tw1" : o->alg == 2 ? "tw2" : "tw3";
    if (s->layout != DKF_SCN_LAYOUT_STEPS && s->layout != DKF_SCN_LAYOUT_NETWORK)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: steps: missing key (filter %s reads the seed-003 steps layout)",
                         s->file, who);
    if (s->layout != DKF_SCN_LAYOUT_NETWORK || s->net == NULL)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: graph: missing key (filter %s needs a seed-003 network file)",
                         s->file, who);
    if (s->k_first != 1)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: steps[0].n: filter %s starts at n = 1 ((x0, P0) = x_{0|0}, y_0 "
                         "unused), got %ld", s->file, who, s->k_first);
    *eta = 0;
    if (o->alg == 3) {
        if (o->eta >= 0)
            *eta = (size_t)o->eta;
        else if (s->net->eta >= 0)
            *eta = (size_t)s->net->eta;
        else
            return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                             "%s: eta: missing key (filter tw3 needs eta or --eta N)", s->file);
    }
    return DKF_EXIT_OK;
}

/* A running filter: the graph and nodes (ctx_t), what it records and
 * measures. */
typedef struct {
    const dkf_filter_t *fl;
    const dkf_scenario_t *s;
    tw_opts_t o;
    size_t eta;
    ctx_t c;
    acc_t acc;
    tw_summary_t sum;  /* the weights' origin (setup); the rest: tw_finish */
    json_t *series;    /* NULL: record nothing */
} tw_runner_t;

/* ---- the options: --eta (tw3), --metrics-only (tw1-3) ---- */

#define TW_OPT_ETA 1u
#define TW_OPT_METRICS 2u

typedef struct {
    long eta;         /* --eta, -1 if not given */
    int metrics_only; /* --metrics-only */
} tw_cli_t;

static const tw_cli_t tw_defaults = {-1, 0};

static void cli_init(void *area)
{
    memcpy(area, &tw_defaults, sizeof tw_defaults);
}

static int cli_parse(void *area, const dkf_run_opt_t *opt, const char *arg, char *err,
                     size_t errlen)
{
    tw_cli_t *c = area;
    char *end;
    if (opt->bit == TW_OPT_METRICS) {
        c->metrics_only = 1;
        return DKF_EXIT_OK;
    }
    errno = 0;
    c->eta = strtol(arg, &end, 10);
    if (end == arg || *end != '\0' || errno != 0 || c->eta < 0 ||
        (unsigned long)c->eta > DKF_TW_MAX_ETA)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "--eta %s: expected an integer >= 0 (at most %u)", arg, DKF_TW_MAX_ETA);
    return DKF_EXIT_OK;
}

static const dkf_run_opt_t tw_cli_opts[] = {
    {"eta", 1, TW_OPT_ETA,
     "--eta N          tw3: consensus iterations per ACF (overrides the file's eta)"},
    {"metrics-only", 0, TW_OPT_METRICS,
     "--metrics-only   tw1-3: record only the per-step metrics (errors against the\n"
     "                       truth, gap to Algorithm 1), not the per-node arrays"},
};

static const dkf_run_optset_t tw_options = {
    tw_cli_opts, sizeof tw_cli_opts / sizeof tw_cli_opts[0], sizeof(tw_cli_t), cli_init,
    cli_parse,
};

static tw_opts_t tw_opts(const dkf_filter_t *fl, const dkf_run_opts_t *o)
{
    const tw_cli_t *c = o->fam != NULL ? (const tw_cli_t *)o->fam : &tw_defaults;
    tw_opts_t t;
    t.alg = *(const int *)fl->impl;
    t.eta = c->eta;
    t.no_nodes = c->metrics_only;
    return t;
}

static int tw_check(const dkf_filter_t *fl, const dkf_run_opts_t *o, const dkf_scenario_t *s,
                    char *err, size_t errlen)
{
    const tw_opts_t t = tw_opts(fl, o);
    size_t eta;
    return check_file(s, &t, err, errlen, &eta);
}

static void tw_destroy(dkf_runner_t *r)
{
    tw_runner_t *t = (tw_runner_t *)(void *)r;
    if (t == NULL) return;
    ctx_free(&t->c);
    json_decref(t->series);
    free(t);
}

static dkf_runner_t *tw_create(const dkf_filter_t *fl, const dkf_run_opts_t *o,
                               const dkf_scenario_t *s, char *err, size_t errlen, int *rc)
{
    tw_runner_t *t = dkf_runner_calloc(sizeof *t, s, err, errlen, rc);
    if (t == NULL) return NULL;
    t->fl = fl;
    t->s = s;
    t->o = tw_opts(fl, o);
    t->series = o->record ? json_object() : NULL;
    *rc = check_file(s, &t->o, err, errlen, &t->eta);
    if (*rc == DKF_EXIT_OK && o->record && t->series == NULL)
        *rc = dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
    if (*rc == DKF_EXIT_OK) *rc = setup(&t->c, s, &t->o, &t->sum, err, errlen);
    if (*rc != DKF_EXIT_OK) {
        tw_destroy((dkf_runner_t *)(void *)t);
        return NULL;
    }
    return (dkf_runner_t *)(void *)t;
}

static int tw_step(dkf_runner_t *r, long k, char *err, size_t errlen)
{
    tw_runner_t *t = (tw_runner_t *)(void *)r;
    ctx_t *c = &t->c;
    const int alg = t->o.alg;
    dkf_status_t st;
    const char *what;
    load_step(c, t->s, k);
    what = "dkf_tw_central_step";
    st = dkf_tw_central_step(&c->central, &c->model, c->sens, c->my, c->N);
    if (st == DKF_OK && alg == 2) {
        what = "dkf_tw_net_diffusion_step";
        st = dkf_tw_net_diffusion_step(&c->net, c->alpha, &c->model, c->sens, c->my);
    } else if (st == DKF_OK && alg == 3) {
        what = "dkf_tw_net_consensus_step";
        st = dkf_tw_net_consensus_step(&c->net, c->W, t->eta, &c->model, c->sens, c->my);
    }
    if (st != DKF_OK) {
        char text[DKF_STATUS_TEXT_LEN];
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: step n=%ld: %s: %s failed: %s",
                         t->s->file, k, alg_names[alg], what,
                         dkf_host_status_text(text, sizeof text, what, st));
    }
    if (t->series != NULL && !t->o.no_nodes)
        record_nodes(t->series, alg, alg == 1 ? &c->central : c->nodes, alg == 1 ? 1 : c->N);
    metrics(t->series, t->s, k, alg, alg == 1 ? &c->central : c->nodes, alg == 1 ? 1 : c->N,
            &c->central, &t->acc);
    return DKF_EXIT_OK;
}

/* The run's totals (after its steps). */
static tw_summary_t tw_finish(const tw_runner_t *t)
{
    const ctx_t *c = &t->c;
    tw_summary_t sum = t->sum;
    sum.N = c->N;
    sum.E = t->s->net->E;
    sum.steps = t->s->steps;
    sum.eta = t->eta;
    if (t->o.alg == 1) {
        /* every node sends its info packet [H^T Sw^-1 y | packed H^T Sw^-1 H] to the
         * centre once per step */
        sum.reals_per_node_step = (double)DKF_TW_PKT_LEN(c->n);
        sum.broadcasts_per_node_step = 1;
    } else {
        sum.reals_per_node_step = (double)c->net.reals_sent / (double)(c->N * c->net.steps);
        sum.broadcasts_per_node_step = (double)c->net.broadcasts / (double)(c->N * c->net.steps);
    }
    sum.rmse_x = t->acc.nx > 0 ? sqrt(t->acc.sx / (double)t->acc.nx) : NAN;
    sum.rmse_z = t->acc.nz > 0 ? sqrt(t->acc.sz / (double)t->acc.nz) : NAN;
    sum.gap_x_rel_max = t->o.alg == 1 ? 0 : t->acc.gap_rel_max;
    sum.gap_x_vec_rule = t->o.alg == 1 ? 0 : t->acc.gap_vec_max;
    return sum;
}

static void tw_record(dkf_runner_t *r, dkf_out_t *out)
{
    const tw_runner_t *t = (const tw_runner_t *)(const void *)r;
    dkf_out_outputs(out, t->fl->label, t->series);
}

static void tw_record_end(const dkf_runner_t *r, dkf_out_t *out)
{
    const tw_runner_t *t = (const tw_runner_t *)(const void *)r;
    const tw_summary_t sum = tw_finish(t);
    if (t->o.alg == 3) dkf_out_value(out, "eta", json_integer((json_int_t)sum.eta));
    dkf_out_value(out, "communication",
                        json_pack("{s:f, s:f, s:i, s:i}", "reals_per_node_step",
                                  sum.reals_per_node_step, "messages_per_node_step",
                                  sum.broadcasts_per_node_step, "N", (json_int_t)sum.N, "edges",
                                  (json_int_t)sum.E));
}

static void tw_summary(const dkf_runner_t *r, FILE *out)
{
    const tw_runner_t *t = (const tw_runner_t *)(const void *)r;
    const tw_summary_t sum = tw_finish(t);
    fprintf(out, "scenario %s: %zu steps, %zu nodes, %zu edges, n = %zu; filter %s (%s)",
            t->s->file, sum.steps, sum.N, sum.E, t->s->n, t->fl->name,
            DKF_USE_FLOAT ? "float" : "double");
    if (t->o.alg == 3) fprintf(out, ", eta = %zu", sum.eta);
    fprintf(out, "\n  weights: alpha %s, W %s\n",
            sum.alpha_default ? "uniform (computed)" : "from file",
            sum.W_default ? "Metropolis (computed)" : "from file");
    fprintf(out, "  RMSE x %.6g, z %.6g (over steps, nodes, components)\n", sum.rmse_x,
            sum.rmse_z);
    fprintf(out, "  reals sent per node per step %.6g (%.6g messages)\n",
            sum.reals_per_node_step, sum.broadcasts_per_node_step);
    if (t->o.alg != 1)
        fprintf(out, "  gap to Algorithm 1 (max over steps, nodes): ||dx||/||x1|| %.6g, "
                "max|dx|/max(1, max|x1|) %.6g\n", sum.gap_x_rel_max, sum.gap_x_vec_rule);
}

/* ---- the registry family ---- */

extern const dkf_family_t dkf_family_tw;
static const int algs[] = {1, 2, 3};
static const dkf_filter_t filters[] = {
    {"tw1", "alg1",
     "seed 003: Algorithm 1, centralized filter with unknown\n"
     "                           actuations (dkf/tw.h) over every node",
     TW_OPT_METRICS, &dkf_family_tw, &algs[0]},
    {"tw2", "alg2", "seed 003: Algorithm 2, diffusion, whole graph in process",
     TW_OPT_METRICS, &dkf_family_tw, &algs[1]},
    {"tw3", "alg3",
     "seed 003: Algorithm 3, consensus (eta ACF iterations:\n"
     "                           the file's eta or --eta N), whole graph in process",
     TW_OPT_METRICS | TW_OPT_ETA, &dkf_family_tw, &algs[2]},
};
const dkf_family_t dkf_family_tw = {
    "tw", filters, sizeof filters / sizeof filters[0], 1u << DKF_SCN_LAYOUT_NETWORK,
    tw_check, tw_create, tw_step, tw_record, tw_record_end, NULL, tw_summary, tw_destroy, NULL, &tw_options,
};
