/*
 * scenario.h - the JSON scenario format, loaded into memory (host side).
 *
 * docs/reference/scenario-format.md is the specification; this is its reader. Three
 * layouts are accepted and normalised into one dkf_scenario_t:
 *
 *  - canonical (the diffkf golden-vector layout): top-level `model`, `init`,
 *    `y`, optional `truth`, `k`, `N`; or, for Monte-Carlo files, `runs`
 *    (a list of {y, truth}) instead of `y` and `truth`;
 *  - cases (the infofusion golden-vector layout): `cases[c]` with `x0`, `P0`,
 *    `Q`, `C[j]`, `R[j]` and `steps[]` carrying `k`, `F`, `z[j]`;
 *  - weighted-fusion cases (seed 002, s2_weighted_fusion.json): a case with
 *    Phi, Gamma, Qe, H[i], R[i], H_signal, x_hat0, P0, steps[].{t, y}
 *    (below, "Weighted-fusion cases layout");
 *  - steps (the seed-003/004 uif golden-vector layout): top-level `steps[]`
 *    with `k`/`n`, `inputs` and `truth` (see "Steps layout" below); with a
 *    `graph` key it is the network layout (seed 003: per-node H, R, y).
 *
 * The reader knows these layouts and no filter: which filter runs on a file
 * is the runner registry's business (registry.h). Its files, one per
 * layout: private/scn_parse.h; the value readers it shares with the
 * model builders (nlm.h): scn_values.h.
 *
 * Numbers stay in double here, whatever the library's real type is;
 * dkf_scn_to_real converts at the point where the core is called.
 *
 * Every error is one line, "FILE: KEY.PATH: problem", written into the
 * caller's buffer (DKF_SCN_ERR_LEN bytes is always enough to hold it).
 * Time index k is absolute: the filters start from (x00, P00) at k = 0 and
 * step k = 1..steps predicts with F_{k-1}, Q_{k-1}, updates with H_k, R_k, y_k.
 */
#ifndef DKF_HOST_SCENARIO_H
#define DKF_HOST_SCENARIO_H

#include <stddef.h>

#include <jansson.h>

#include "dkf/mat.h"
#include "scn_values.h" /* the limits, dkf_scn_mat_t, dkf_scn_mats_t */

/* eta (seed 003) is at most DKF_TW_MAX_ETA (dkf/tw.h). */

typedef enum {
    DKF_SCN_LAYOUT_CANONICAL = 0, /* model / init / y (diffkf vectors) */
    DKF_SCN_LAYOUT_CASES = 1,     /* cases[].steps[] (infofusion vectors) */
    DKF_SCN_LAYOUT_STEPS = 2,     /* steps[].inputs, one sensor (seed-004 uif vectors) */
    DKF_SCN_LAYOUT_NETWORK = 3,   /* steps[].inputs with a graph: per-node H, R, y
                                   * (seed-003 vectors); s->net holds the graph */
    DKF_SCN_LAYOUT_NLCASES = 4,   /* cases[] with a nonlinear model (built-in family or
                                   * expressions) per node (seed-001 vectors); s->nl
                                   * holds the models, s->net the graph of a network */
    DKF_SCN_LAYOUT_WFCASES = 5    /* cases[] with Phi, Gamma, Qe, H[i], R[i], H_signal
                                   * (seed-002 weighted fusion); below */
} dkf_scn_layout_t;

/* Seed-003 network data (steps layout): the graph and its weights as the
 * file gives them, checked for shape and index range only (dkf/graph.h
 * checks the rest when the filter binds them). */
typedef struct {
    size_t N;               /* nodes (= nsensors) */
    size_t E;               /* undirected edges */
    size_t *edges;          /* 2E node indices: edge e = (edges[2e], edges[2e+1]) */
    const char *W_key;      /* "W_consensus" / "W_consensus_sparse", NULL if absent */
    size_t nW;              /* triplets of W */
    size_t *W_rc;           /* 2 nW: (row, col) */
    double *W_v;            /* nW values */
    const char *alpha_key;  /* "alpha_diffusion" / "alpha_diffusion_sparse", NULL if absent */
    size_t nalpha;
    size_t *alpha_rc;
    double *alpha_v;
    long eta;               /* consensus iterations, -1 if absent */
} dkf_scn_network_t;

/* Nonlinear cases (seed-001 vectors, expression scenarios): one model
 * per node, built while loading (nlm.h: built-in family or expressions).
 * A single-node case (`model`, `init`) has nsensors = 1; a network case
 * (`node_models`, `init_per_node`, `W`, `Tp`, `scale`) one sensor per
 * node and its graph in s->net (W as triplets, eta = Tp). Each node's
 * initial estimate is in its sensor's mats as x00, P00, d00, Pd00, Pxd00
 * (dkf_scn_node_init; the d entries absent when p = 0). z_k of node i is
 * sensor i's y_k, k = 1..steps. */
struct dkf_nlm;
typedef struct {
    size_t p;                /* unknown input (every node) */
    struct dkf_nlm **models; /* nsensors models */
    int network;             /* 1: node_models / W layout */
    double scale;            /* consensus scale s (1 if the file has none) */
    int has_scale;
} dkf_scn_nl_t;

/* Consensus iterations a file may ask for (Tp). */
#define DKF_SCN_MAX_TP 100000L

/* One sensor's measurement series: y at absolute times k[0..n-1]. */
typedef struct {
    size_t n;
    long *k;   /* strictly increasing */
    double *v; /* n * m */
} dkf_scn_yseries_t;

/* One Monte-Carlo run: every sensor's measurements and (optionally) the
 * true state. A file without `runs` has exactly one run (its y, truth). */
typedef struct {
    dkf_scn_yseries_t *y; /* nsensors series */
    size_t ntruth;
    long *truth_k;
    double *truth_x;      /* ntruth * n */
} dkf_scn_run_t;

typedef struct {
    size_t m;            /* measurement dimension (rows of H) */
    dkf_scn_mats_t mats; /* this sensor's own matrices (H, R, D, B, Rd, ...) */
    /* the selected run's measurements (views into runs[run].y[i] once loaded) */
    size_t ny;           /* measurements y at absolute times yk[0..ny-1] */
    long *yk;            /* strictly increasing */
    double *y;           /* ny * m */
    int borrowed;        /* 1: yk, y belong to a run (not freed with the sensor) */
} dkf_scn_sensor_t;

typedef struct {
    char *file;               /* path as given to dkf_scenario_load */
    dkf_scn_layout_t layout;
    char *case_name;          /* cases layout: the selected case's name, else NULL */
    size_t case_index;
    size_t n;                 /* state dimension (rows of F) */
    size_t steps;             /* N: filters run k = 1..N */
    int multi;                /* 1: several-sensor layout (model.sensors or cases) */
    size_t nsensors;          /* 1 for a single-sensor scenario */
    dkf_scn_sensor_t *sensors;
    dkf_scn_mats_t model;     /* F, Q and (single sensor) H, R, D, B, Rd, ... */
    dkf_scn_mats_t init;      /* x00, P00, P00_local, P00_central, d00, Pd00, ... */
    /* the selected run's truth x at absolute times truth_k (0 if none) */
    size_t ntruth;
    long *truth_k;
    double *truth_x;          /* ntruth * n */
    int truth_borrowed;       /* 1: truth_k, truth_x belong to a run */
    size_t nruns;             /* >= 1; > 1 or has_runs: the file has a `runs` list */
    int has_runs;
    dkf_scn_run_t *runs;
    size_t run;               /* the selected run (dkf_scn_select_run) */
    json_t *root;             /* the parsed document (read-only), for keys not modelled;
                               * a canonical file's y, runs and truth, read into the
                               * runs, are dropped from it (their memory reused) */
    /* steps layout and its network form (seed-004/003 vectors), below */
    long k_first;             /* the first step's absolute k (1 for the other layouts) */
    dkf_scn_network_t *net;   /* network layout: graph and weights; NULL otherwise */
    size_t ntruth_u;          /* true unknown input at the steps' times truth_u_k */
    long *truth_u_k;
    double *truth_u;          /* ntruth_u * m_u */
    size_t m_u;
    char truth_u_key[16];     /* its key in steps[].truth: d, d_prev or z_prev */
    dkf_scn_nl_t *nl;         /* nonlinear cases layout: the models; NULL otherwise */
    char notice[DKF_SCN_ERR_LEN]; /* "" or the one-line deprecation notice of old letters
                                   * (dkf_scenario_load prints it on stderr) */
} dkf_scenario_t;

/* Steps and network layouts (docs/reference/scenario-format.md, "Steps layout"): a
 * top-level `steps` list of {k or n, inputs: {y, ...}, truth, expected},
 * normalised as
 *   init.x0, init.P0          -> init x00, P00
 *   model.<M> (bare matrix)   -> model <M> (constant)
 *   steps[j].inputs.<M>       -> model <M> per_k, entry at k = steps[j].k
 *   steps[j].inputs.<M>_prev  -> model <M> per_k, entry at k - 1
 *   steps[j].inputs.y         -> sensor 0's y_k (seed 004) / node l's y (seed 003)
 *   model.H[l], model.R[l]    -> sensor l's H, R (seed 003)
 *   steps[j].truth.x          -> truth x_k; truth.d / d_prev / z_prev -> truth_u
 * Steps run k = k_first .. k_first + steps - 1 (k_first = steps[0].k, 0 or 1);
 * `expected` is ignored. */

/* Weighted-fusion cases layout (seed 002, docs/reference/scenario-format.md,
 * "Weighted-fusion cases"; scn_wfcases.c), normalised as
 *   Phi                 -> model F (constant)
 *   Gamma, Qe           -> model Gamma, Qe, and model Q = Gamma Qe Gamma^T
 *   H_signal (1 x n)    -> model Hs
 *   H[i], R[i]          -> sensor i's H (m_i x n), R (m_i x m_i, SPD)
 *   x_hat0, P0          -> init x00, P00
 *   steps[t-1].y[i]     -> sensor i's y_t, t = 1..N (steps[t-1].t = t)
 *   x_true[k] (k=0..N)  -> truth x_k (optional)
 * `expected` (optional) and steady_state are left in s->root. */

/* Loads and validates a scenario. case_sel selects a case of the cases
 * layout by name or decimal index (NULL: case 0); it is an error for a
 * canonical file. Returns NULL and fills err on any problem. A file in
 * the old letters (docs/reference/scenario-format.md, "Letters") is read as the
 * library's letters, and s->notice is printed on stderr (one line). */
dkf_scenario_t *dkf_scenario_load(const char *path, const char *case_sel, char *err,
                                  size_t errlen);
/* The same from len bytes at buf (need not be NUL-terminated; e.g. a fuzz
 * input); name labels the messages and becomes s->file. Prints nothing
 * (the notice stays in s->notice). */
dkf_scenario_t *dkf_scenario_load_buffer(const char *buf, size_t len, const char *name,
                                         const char *case_sel, char *err, size_t errlen);
void dkf_scenario_free(dkf_scenario_t *s);

/* Matrix `name` of the global model, of sensor i (falling back to the
 * global model, so a single-sensor file's H is every sensor's H), or of
 * `init`. NULL if absent. */
const dkf_scn_mat_t *dkf_scn_model(const dkf_scenario_t *s, const char *name);
const dkf_scn_mat_t *dkf_scn_sensor_model(const dkf_scenario_t *s, size_t i, const char *name);
const dkf_scn_mat_t *dkf_scn_init(const dkf_scenario_t *s, const char *name);

/* The matrix valid at absolute time k (per_k), the constant one, or entry k
 * of a list. NULL if k is outside a per_k / list range. */
const double *dkf_scn_at(const dkf_scn_mat_t *m, size_t k);

/* Node i's initial-estimate entry `name` (its sensor's mats, else the
 * file's init). NULL if absent. */
const dkf_scn_mat_t *dkf_scn_node_init(const dkf_scenario_t *s, size_t i, const char *name);

/* Initial covariance for the filter of sensor i alone (P00_local[i], else
 * P00) or for a filter using every sensor (P00_central, else P00). Never
 * NULL for a loaded scenario (the loader checks). */
const double *dkf_scn_P00_local(const dkf_scenario_t *s, size_t i);
const double *dkf_scn_P00_central(const dkf_scenario_t *s);

/* y_k of sensor i (m values), NULL if the sensor has no measurement at k. */
const double *dkf_scn_y(const dkf_scenario_t *s, size_t i, long k);
/* True state x_k (n values), NULL if absent. */
const double *dkf_scn_truth(const dkf_scenario_t *s, long k);

/* Makes run r (0..nruns-1) the one dkf_scn_y and dkf_scn_truth read. */
void dkf_scn_select_run(dkf_scenario_t *s, size_t r);

/* Checks what the unknown-input filters (DKF, ASKF, OTSKF) need beyond the
 * loader's own checks: every sensor has D (m x p, p <= m), B and Rd (p x p);
 * per_k lists of F, Q, B, Rd cover k = 0..last_dyn and of H, R, D cover
 * k = 1..last_meas; every run has y at k = 1..last_meas; with need_d0,
 * init.d00 (p) and init.Pd00 (p x p) exist (single sensor). `who` names
 * the filter in messages. Returns 0, or -1 with a "FILE: KEY: problem"
 * line in err. */
int dkf_scn_require_ui(const dkf_scenario_t *s, size_t last_dyn, size_t last_meas, int need_d0,
                       const char *who, char *err, size_t errlen);

/* True unknown input recorded with step k (m_u values), NULL if absent. */
const double *dkf_scn_truth_u(const dkf_scenario_t *s, long k);

/* Checks that every run has truth x at k = 1..N (Monte-Carlo error mode). */
int dkf_scn_require_truth(const dkf_scenario_t *s, char *err, size_t errlen);

/* dst[0..n-1] = src converted to the library's real type. */
void dkf_scn_to_real(dkf_real_t *dst, const double *src, size_t n);

#endif /* DKF_HOST_SCENARIO_H */
