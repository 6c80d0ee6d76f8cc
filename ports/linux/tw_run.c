/*
 * tw_run.c - dkf/tw.h Algorithms 1-3 over a steps-layout scenario (see
 * tw_run.h). All filtering is the library's: the in-process simulation is
 * dkf_tw_net_*, Algorithm 1 is dkf_tw_central_step; this file converts the
 * scenario, binds the graph and weights, records, and measures.
 */
#include "tw_run.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/graph.h"
#include "dkf/tw.h"
#include "util.h"

static const char *const alg_names[] = {"", "alg1", "alg2", "alg3"};

int dkf_twrun_alg(const char *name)
{
    if (strcmp(name, "tw1") == 0) return 1;
    if (strcmp(name, "tw2") == 0) return 2;
    if (strcmp(name, "tw3") == 0) return 3;
    return 0;
}

/* Everything a run owns (freed by ctx_free). */
typedef struct {
    size_t N, n, m, pmax;
    size_t *start, *nbr;
    dkf_graph_t g;
    dkf_real_t *W, *alpha;     /* nnz each */
    dkf_tw_node_t *nodes;      /* N */
    dkf_real_t *net_mem;
    dkf_tw_net_t net;
    dkf_tw_node_t central;     /* alg 1, or the reference beside alg 2/3 */
    dkf_real_t *central_mem;
    dkf_real_t *H, *Sw, *y;    /* N * pmax * n, N * pmax^2, N * pmax */
    dkf_mat_t *mH, *mSw, *my;
    dkf_tw_sensor_t *sens;
    dkf_real_t *A, *B, *Sv, *x0, *P0; /* n^2, n m, n^2, n, n^2 */
    dkf_mat_t mA, mB, mSv, mx0, mP0;
    dkf_tw_model_t model;
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

/* The file's weights (triplets) or the library default; checked. */
static int bind_weights(ctx_t *c, const dkf_scenario_t *s, int doubly, dkf_real_t *w, int *dflt,
                        char *err, size_t errlen)
{
    const dkf_scn_network_t *net = s->net;
    const char *key = doubly ? net->W_key : net->alpha_key;
    const size_t cnt = doubly ? net->nW : net->nalpha;
    const size_t *rc = doubly ? net->W_rc : net->alpha_rc;
    const double *v = doubly ? net->W_v : net->alpha_v;
    dkf_status_t st;
    size_t t;
    *dflt = key == NULL;
    if (key == NULL) {
        st = doubly ? dkf_graph_weights_metropolis(w, &c->g) : dkf_graph_weights_uniform(w, &c->g);
        if (st != DKF_OK)
            return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: graph: default %s weights failed: %s",
                         s->file, doubly ? "Metropolis" : "uniform", dkf_status_str(st));
        return DKF_EXIT_OK;
    }
    {
        size_t *ri = malloc((cnt ? cnt : 1) * sizeof *ri), *ci = malloc((cnt ? cnt : 1) * sizeof *ci);
        dkf_real_t *vv = malloc((cnt ? cnt : 1) * sizeof *vv);
        if (ri == NULL || ci == NULL || vv == NULL) {
            free(ri), free(ci), free(vv);
            return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
        }
        for (t = 0; t < cnt; ++t) {
            size_t pos;
            ri[t] = rc[2 * t];
            ci[t] = rc[2 * t + 1];
            vv[t] = (dkf_real_t)v[t];
            if (dkf_graph_find(&pos, &c->g, ri[t], ci[t]) != DKF_OK) {
                free(ri), free(ci), free(vv);
                return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                             "%s: %s: entry (%zu, %zu) is not a link of graph.edges", s->file,
                             key, rc[2 * t], rc[2 * t + 1]);
            }
        }
        st = dkf_graph_weights_from_triplets(w, &c->g, ri, ci, vv, cnt);
        free(ri), free(ci), free(vv);
    }
    if (st == DKF_OK)
        st = doubly ? dkf_graph_check_doubly_stochastic(&c->g, w)
                    : dkf_graph_check_row_stochastic(&c->g, w);
    if (st != DKF_OK)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: %s: %s (%s)", s->file, key,
                     st == DKF_ERR_WEIGHTS ? (doubly ? "not doubly stochastic and non-negative"
                                                     : "not row-stochastic and non-negative")
                                           : "invalid weights",
                     dkf_status_str(st));
    return DKF_EXIT_OK;
}

static int setup(ctx_t *c, const dkf_scenario_t *s, const dkf_twrun_opts_t *o,
                 dkf_twrun_summary_t *sum, char *err, size_t errlen)
{
    const dkf_scn_network_t *net = s->net;
    const dkf_scn_mat_t *mB = dkf_scn_model(s, "B");
    size_t l, nnz, node_len;
    dkf_status_t st;
    int rc, dflt;
    c->N = net->N;
    c->n = s->n;
    c->m = mB->cols;
    for (l = 0; l < c->N; ++l)
        if (s->sensors[l].m > c->pmax) c->pmax = s->sensors[l].m;
    nnz = DKF_GRAPH_NNZ(c->N, net->E);
    c->start = calloc(c->N + 1, sizeof *c->start);
    c->nbr = calloc(nnz, sizeof *c->nbr);
    c->W = calloc(nnz, sizeof *c->W);
    c->alpha = calloc(nnz, sizeof *c->alpha);
    c->nodes = calloc(c->N, sizeof *c->nodes);
    node_len = DKF_TW_NET_STORAGE_LEN(c->N, c->n, c->m, c->pmax);
    c->net_mem = calloc(node_len, sizeof *c->net_mem);
    c->central_mem = calloc(DKF_TW_NODE_STORAGE_LEN(c->n, c->m, c->pmax), sizeof *c->central_mem);
    c->H = calloc(c->N * c->pmax * c->n, sizeof *c->H);
    c->Sw = calloc(c->N * c->pmax * c->pmax, sizeof *c->Sw);
    c->y = calloc(c->N * c->pmax, sizeof *c->y);
    c->mH = calloc(c->N, sizeof *c->mH);
    c->mSw = calloc(c->N, sizeof *c->mSw);
    c->my = calloc(c->N, sizeof *c->my);
    c->sens = calloc(c->N, sizeof *c->sens);
    c->A = calloc(3 * c->n * c->n + c->n * c->m + c->n, sizeof *c->A);
    if (!c->start || !c->nbr || !c->W || !c->alpha || !c->nodes || !c->net_mem ||
        !c->central_mem || !c->H || !c->Sw || !c->y || !c->mH || !c->mSw || !c->my || !c->sens ||
        !c->A)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
    c->B = c->A + c->n * c->n;
    c->Sv = c->B + c->n * c->m;
    c->P0 = c->Sv + c->n * c->n;
    c->x0 = c->P0 + c->n * c->n;
    st = dkf_graph_from_edges(&c->g, c->start, c->nbr, nnz, c->N, net->edges, net->E);
    if (st != DKF_OK)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                     "%s: graph.edges: not a simple undirected graph (a self loop or a repeated "
                     "edge): %s", s->file, dkf_status_str(st));
    if ((rc = bind_weights(c, s, 0, c->alpha, &dflt, err, errlen)) != 0) return rc;
    sum->alpha_default = dflt;
    if ((rc = bind_weights(c, s, 1, c->W, &dflt, err, errlen)) != 0) return rc;
    sum->W_default = dflt;
    for (l = 0; l < c->N; ++l) {
        const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, l, "H");
        const dkf_scn_mat_t *Sw = dkf_scn_sensor_model(s, l, "Sw");
        to_mat(&c->mH[l], c->H + l * c->pmax * c->n, dkf_scn_at(H, (size_t)s->k_first),
               H->rows, c->n);
        to_mat(&c->mSw[l], c->Sw + l * c->pmax * c->pmax, dkf_scn_at(Sw, (size_t)s->k_first),
               Sw->rows, Sw->rows);
        c->sens[l].H = &c->mH[l];
        c->sens[l].Sw = &c->mSw[l];
        c->sens[l].y = &c->my[l];
    }
    to_mat(&c->mx0, c->x0, dkf_scn_init(s, "x00")->data, c->n, 1);
    to_mat(&c->mP0, c->P0, dkf_scn_init(s, "P00")->data, c->n, c->n);
    st = dkf_tw_node_init(&c->central, c->n, c->m, c->pmax, c->central_mem,
                          DKF_TW_NODE_STORAGE_LEN(c->n, c->m, c->pmax), &c->mx0, &c->mP0);
    if (st == DKF_OK && o->alg != 1)
        st = dkf_tw_net_init(&c->net, &c->g, c->nodes, c->n, c->m, c->pmax, c->net_mem, node_len,
                             &c->mx0, &c->mP0);
    if (st != DKF_OK)
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: %s: %s failed: %s (%d)", s->file,
                     alg_names[o->alg], o->alg == 1 ? "dkf_tw_node_init" : "dkf_tw_net_init",
                     dkf_status_str(st), (int)st);
    return DKF_EXIT_OK;
}

/* The model and measurements of step k (absolute time n = k). */
static void load_step(ctx_t *c, const dkf_scenario_t *s, long k)
{
    size_t l;
    to_mat(&c->mA, c->A, dkf_scn_at(dkf_scn_model(s, "A"), (size_t)(k - 1)), c->n, c->n);
    to_mat(&c->mB, c->B, dkf_scn_at(dkf_scn_model(s, "B"), (size_t)(k - 1)), c->n, c->m);
    to_mat(&c->mSv, c->Sv, dkf_scn_at(dkf_scn_model(s, "Sv"), (size_t)(k - 1)), c->n, c->n);
    c->model.A = &c->mA;
    c->model.B = &c->mB;
    c->model.Sv = &c->mSv;
    for (l = 0; l < c->N; ++l) {
        const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, l, "H");
        const dkf_scn_mat_t *Sw = dkf_scn_sensor_model(s, l, "Sw");
        /* per node H_l, Sw_l of time k (constant, or given per step) */
        to_mat(&c->mH[l], c->H + l * c->pmax * c->n, dkf_scn_at(H, (size_t)k), H->rows, c->n);
        to_mat(&c->mSw[l], c->Sw + l * c->pmax * c->pmax, dkf_scn_at(Sw, (size_t)k), Sw->rows,
               Sw->rows);
        to_mat(&c->my[l], c->y + l * c->pmax, dkf_scn_y(s, l, k), s->sensors[l].m, 1);
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

#define F(key, member) {key, offsetof(dkf_tw_node_t, member)}
static const field_t fields1[] = {F("x", x), F("P", P), F("z", z), F("phi", phi), F("Phi", Phi),
                                  F("phi_post", phi_post), F("Phi_post", Phi_post), F("S", S),
                                  F("G", G)};
static const field_t fields2[] = {F("x", x), F("P", P), F("z", z), F("psi", psi), F("Q", Q),
                                  F("phi_post", phi_post), F("Phi_post", Phi_post), F("S", S),
                                  F("G", G)};
static const field_t fields3[] = {F("x", x), F("P", P), F("z", z), F("Ups", Q), F("vphi", s),
                                  F("psi", psi), F("Ploc", Ploc), F("phi_post", phi_post),
                                  F("Phi_post", Phi_post), F("S", S), F("G", G)};
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
    double L[DKF_MAX_DIM * DKF_MAX_DIM], v[DKF_MAX_DIM], q = 0;
    const size_t n = nd->n;
    size_t i, j, k;
    for (i = 0; i < n; ++i) {
        for (j = 0; j <= i; ++j) {
            double sm = (double)nd->P.data[i * n + j];
            for (k = 0; k < j; ++k) sm -= L[i * n + k] * L[j * n + k];
            if (i == j) {
                if (!(sm > 0)) return NAN;
                L[i * n + i] = sqrt(sm);
            } else {
                L[i * n + j] = sm / L[j * n + j];
            }
        }
    }
    for (i = 0; i < n; ++i) { /* L v = e */
        double sm = (double)nd->x.data[i] - xt[i];
        for (k = 0; k < i; ++k) sm -= L[i * n + k] * v[k];
        v[i] = sm / L[i * n + i];
        q += v[i] * v[i];
    }
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
    const size_t n = nodes[0].n, m = nodes[0].m;
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
    if (zt != NULL && s->m_u == m) {
        for (l = 0; l < count; ++l)
            for (i = 0; i < m; ++i) {
                const double e = (double)nodes[l].z.data[i] - zt[i];
                mz[i] += e * e / (double)count;
            }
        for (i = 0; i < m; ++i) acc->sz += mz[i];
        acc->nz += m;
        if (series != NULL) dkf_json_append(series, "mse_z", dkf_json_doubles(mz, m, 0));
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
        for (i = 0; i < m; ++i) {
            const double d = (double)nodes[l].z.data[i] - (double)ref->z.data[i];
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

static int check_file(const dkf_scenario_t *s, const dkf_twrun_opts_t *o, char *err,
                      size_t errlen, size_t *eta)
{
    const char *who = o->alg == 1 ? "tw1" : o->alg == 2 ? "tw2" : "tw3";
    if (s->layout != DKF_SCN_LAYOUT_STEPS && s->layout != DKF_SCN_LAYOUT_NETWORK)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                     "%s: steps: missing key (filter %s reads the seed-003 steps layout)", s->file,
                     who);
    if (s->layout != DKF_SCN_LAYOUT_NETWORK || s->net == NULL)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                     "%s: graph: missing key (filter %s needs a seed-003 network file)", s->file,
                     who);
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

int dkf_twrun(const dkf_scenario_t *s, const dkf_twrun_opts_t *o, json_t *series,
              dkf_twrun_summary_t *sum, char *err, size_t errlen)
{
    ctx_t c;
    acc_t acc;
    size_t eta;
    long k;
    int rc;
    memset(sum, 0, sizeof *sum);
    memset(&acc, 0, sizeof acc);
    if ((rc = check_file(s, o, err, errlen, &eta)) != DKF_EXIT_OK) return rc;
    memset(&c, 0, sizeof c);
    rc = setup(&c, s, o, sum, err, errlen);
    for (k = s->k_first; rc == DKF_EXIT_OK && k < s->k_first + (long)s->steps; ++k) {
        dkf_status_t st;
        const char *what;
        load_step(&c, s, k);
        what = "dkf_tw_central_step";
        st = dkf_tw_central_step(&c.central, &c.model, c.sens, c.N);
        if (st == DKF_OK && o->alg == 2) {
            what = "dkf_tw_net_diffusion_step";
            st = dkf_tw_net_diffusion_step(&c.net, c.alpha, &c.model, c.sens);
        } else if (st == DKF_OK && o->alg == 3) {
            what = "dkf_tw_net_consensus_step";
            st = dkf_tw_net_consensus_step(&c.net, c.W, eta, &c.model, c.sens);
        }
        if (st != DKF_OK) {
            rc = dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: step n=%ld: %s: %s failed: %s (%d)",
                       s->file, k, alg_names[o->alg], what, dkf_status_str(st), (int)st);
            break;
        }
        if (series != NULL && !o->no_nodes)
            record_nodes(series, o->alg, o->alg == 1 ? &c.central : c.nodes,
                         o->alg == 1 ? 1 : c.N);
        metrics(series, s, k, o->alg, o->alg == 1 ? &c.central : c.nodes, o->alg == 1 ? 1 : c.N,
                &c.central, &acc);
    }
    if (rc == DKF_EXIT_OK) {
        sum->N = c.N;
        sum->E = s->net->E;
        sum->steps = s->steps;
        sum->eta = eta;
        if (o->alg == 1) {
            /* every node sends its info packet [H^T Sw^-1 y | packed H^T Sw^-1 H] to the
             * centre once per step */
            sum->reals_per_node_step = (double)DKF_TW_PKT_LEN(c.n);
            sum->broadcasts_per_node_step = 1;
        } else {
            sum->reals_per_node_step = (double)c.net.reals_sent / (double)(c.N * c.net.steps);
            sum->broadcasts_per_node_step =
                (double)c.net.broadcasts / (double)(c.N * c.net.steps);
        }
        sum->rmse_x = acc.nx > 0 ? sqrt(acc.sx / (double)acc.nx) : NAN;
        sum->rmse_z = acc.nz > 0 ? sqrt(acc.sz / (double)acc.nz) : NAN;
        sum->gap_x_rel_max = o->alg == 1 ? 0 : acc.gap_rel_max;
        sum->gap_x_vec_rule = o->alg == 1 ? 0 : acc.gap_vec_max;
    }
    ctx_free(&c);
    return rc;
}
