/*
 * scn_parse.h - the scenario reader's own toolkit (private to ports/linux/
 * scn_*.c and scenario.c; programs include scenario.h only).
 *
 * The reader is split by file layout (docs/reference/scenario-format.md):
 *   scn_values.c     numbers, vectors, matrices, named matrix sets, series
 *   scn_check.c      the checks every layout shares (shapes, times,
 *                    covariances) and the filters' pre-start queries
 *   scn_canonical.c  the canonical layout (model / init / y or runs)
 *   scn_cases.c      the cases layout (infofusion vectors)
 *   scn_steps.c      the steps layout (steps[].inputs; seed-004 vectors) and
 *                    its network form (seed-003 vectors: per-node H, Sw, y)
 *   scn_network.c    the network form's graph, weights and eta
 *   scn_nlcases.c    the nonlinear cases layout (seed-001 vectors): models
 *                    (nlm.c, nlm_builtin.c, nlm_expr.c use this toolkit
 *                    too), per-node init, z, the consensus graph
 *   scn_wfcases.c    the weighted-fusion cases layout (seed-002 vector): Phi,
 *                    Gamma Qe Gamma^T, H[i], R[i], H_signal, steps[].y
 *   scenario.c       layout dispatch, the public accessors, runs, free
 * None of them knows a filter: a layout fixes which keys a file has and
 * their shapes, nothing about what runs on it.
 *
 * Rule of every parser: the first problem found is reported as
 * "FILE: KEY.PATH: problem" (dkf_scn_fail) and -1 is returned; the caller
 * frees everything through dkf_scenario_free.
 */
#ifndef DKF_HOST_SCN_PARSE_H
#define DKF_HOST_SCN_PARSE_H

#include <stddef.h>

#include <jansson.h>

#include "scenario.h"

/* Key paths longer than this are cut short: they only label messages. */
#define DKF_SCN_PATH_LEN 256

typedef struct dkf_scn_ctx {
    const char *file;
    char *err;
    size_t errlen;
} dkf_scn_ctx_t;

/* count rows of dim doubles in one allocation; dkf_scn_store checks every
 * write against the shape it was allocated with. */
typedef struct {
    double *v;
    size_t count, dim;
} dkf_scn_block_t;

/* ---- messages and key paths (scn_values.c) ---- */
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
int dkf_scn_fail(dkf_scn_ctx_t *c, const char *path, const char *fmt, ...);
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
void dkf_scn_pathf(char *out, const char *fmt, ...);
void dkf_scn_subkey(char *out, const char *base, const char *key);
void dkf_scn_subidx(char *out, const char *base, size_t i);
char *dkf_scn_dupstr(const char *s);
void *dkf_scn_calloc(dkf_scn_ctx_t *c, size_t n, size_t size);
const char *dkf_scn_json_kind(const json_t *j);
const char *dkf_scn_num_str(char *buf, size_t len, double v);

/* ---- values (scn_values.c) ---- */
/* An integer in lo..hi, range-checked before any cast. */
int dkf_scn_get_integer(dkf_scn_ctx_t *c, const json_t *j, const char *path, double lo,
                        double hi, long *out);
int dkf_scn_block_alloc(dkf_scn_ctx_t *c, dkf_scn_block_t *b, size_t count, size_t dim,
                        const char *path);
/* Row `row` of b = src[0..len-1]: refused unless row < count and len == dim. */
int dkf_scn_store(dkf_scn_ctx_t *c, const char *path, const dkf_scn_block_t *b, size_t row,
                  const double *src, size_t len);
int dkf_scn_parse_vector(dkf_scn_ctx_t *c, const json_t *j, const char *path, size_t *len,
                         double **out);
int dkf_scn_parse_matrix(dkf_scn_ctx_t *c, const json_t *j, const char *path, size_t *rows,
                         size_t *cols, double **out);
/* Depth of the first-element chain: 1 for [1,2], 2 for [[1]], 3 for [[[1]]]. */
int dkf_scn_nest_depth(const json_t *j);
int dkf_scn_shape_error(dkf_scn_ctx_t *c, const char *path, size_t er, size_t ec, size_t r,
                        size_t cc);
dkf_scn_mat_t *dkf_scn_mats_add(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const char *name,
                                const char *path);
void dkf_scn_mats_free(dkf_scn_mats_t *set);
const dkf_scn_mat_t *dkf_scn_mats_find(const dkf_scn_mats_t *set, const char *name);
/* Entry idx of m, a stack of `count` same-shape matrices. */
int dkf_scn_stack_matrix(dkf_scn_ctx_t *c, dkf_scn_mat_t *m, dkf_scn_block_t *b, size_t idx,
                         size_t count, const json_t *j, const char *path);
/* Matrices of the model and init are at most DKF_MAX_DIM x DKF_MAX_DIM. */
int dkf_scn_check_dims(dkf_scn_ctx_t *c, const dkf_scn_mat_t *m);
/* A model entry ({"const": M}, {"per_k": [...]}, a bare matrix; strings
 * skipped) / an init entry (vector, matrix or list of matrices). */
int dkf_scn_parse_model_entry(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const char *name,
                              const json_t *j, const char *path);
int dkf_scn_parse_init_entry(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const char *name,
                             const json_t *j, const char *path);
/* {"k": [...], "<vkey>": [[...], ...]}: times strictly increasing. */
int dkf_scn_parse_series(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *vkey,
                         size_t dim, size_t *count, long **kout, double **vout);
/* Index of time k in the strictly increasing list ks, or -1. */
long dkf_scn_find_time(const long *ks, size_t n, long k);

/* ---- checks every layout shares (scn_check.c) ---- */
/* The n x n covariance a (read from the file at path) symmetric within
 * rounding (8 eps max|a|, docs/reference/scenario-format.md "Limits and checks"). */
int dkf_scn_check_symmetric(dkf_scn_ctx_t *c, const char *path, const double *a, size_t n);
int dkf_scn_check_covariances(dkf_scn_ctx_t *c, const dkf_scenario_t *s);
int dkf_scn_require_shape(dkf_scn_ctx_t *c, const dkf_scn_mat_t *m, const char *missing_path,
                          size_t r, size_t cc);
int dkf_scn_require_times(dkf_scn_ctx_t *c, const dkf_scn_mat_t *m, size_t last,
                          const char *why);
int dkf_scn_require_single(dkf_scn_ctx_t *c, const dkf_scn_mat_t *m, const char *path, size_t n);
void dkf_scn_y_path(const dkf_scenario_t *s, size_t r, size_t i, char *p);
/* The canonical and cases layouts' model, init and y (sets s->n). */
int dkf_scn_validate(dkf_scn_ctx_t *c, dkf_scenario_t *s, const char *model_path,
                     const char *sensor_fmt_path);

/* ---- runs (scenario.c) ---- */
int dkf_scn_alloc_runs(dkf_scn_ctx_t *c, dkf_scenario_t *s, size_t nruns);
/* Hands the sensors' freshly parsed y series / the truth to run r. */
void dkf_scn_adopt_y(dkf_scenario_t *s, size_t r);
void dkf_scn_adopt_truth(dkf_scenario_t *s, size_t r);
int dkf_scn_parse_run_truth(dkf_scn_ctx_t *c, dkf_scenario_t *s, size_t r, const json_t *tj,
                            const char *path);

/* ---- the layouts ---- */
int dkf_scn_load_canonical(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *root);
int dkf_scn_load_cases(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *root,
                       const char *sel);
int dkf_scn_load_steps(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *root);
/* The cases layouts' measurements (scn_cases.c): every sensor's y series
 * of N steps (each sensor's m set) into blocks y[0..nsensors-1], and
 * steps[j] of the case at cpath checked (an object whose time key tkey,
 * "k" or "t", is j + 1): its data key dkey ("z", "y") with that key's path
 * in pd, or NULL after the message (every cases layout's step list). */
int dkf_scn_cases_alloc_y(dkf_scn_ctx_t *c, dkf_scenario_t *s, size_t N, dkf_scn_block_t *y,
                          const char *cpath);
const json_t *dkf_scn_cases_step(dkf_scn_ctx_t *c, const json_t *steps, size_t j,
                                 const char *cpath, const char *tkey, const char *dkey, char *pd);
/* Case cj (at cpath) of a cases file whose case has `model` or
 * `node_models` (the nonlinear cases layout). */
int dkf_scn_load_nlcases(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj,
                         const char *cpath);
/* 1 if case cj has the weighted-fusion keys Phi, Gamma, Qe and H_signal
 * (seed 002); case cj at cpath of such a file (scn_wfcases.c). */
int dkf_scn_is_wfcase(const json_t *cj);
int dkf_scn_load_wfcases(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj,
                         const char *cpath);
/* The undirected edges [[i, j], ...] at path into net (net->N set; `who`
 * names what sized N in messages) / the weights obj[key] (dense N x N,
 * nonzeros kept) or obj[key_sparse] ([[i, j, v], ...]) as triplets
 * (which: the key found, NULL if neither; base: obj's key path). */
int dkf_scn_parse_edges(dkf_scn_ctx_t *c, dkf_scn_network_t *net, const json_t *edges,
                        const char *path, const char *who);
int dkf_scn_parse_weights(dkf_scn_ctx_t *c, size_t N, const json_t *obj, const char *base,
                          const char *key, const char **which, size_t *count, size_t **rc,
                          double **v);
/* graph.edges, the weights, eta of a network-form steps file. */
int dkf_scn_load_network(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *root);

#endif /* DKF_HOST_SCN_PARSE_H */
