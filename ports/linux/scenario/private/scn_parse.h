/*
 * scn_parse.h - the scenario reader's own toolkit (private to the
 * scenario layer, ports/linux/scenario; programs include scenario.h only).
 *
 * The reader is split by file layout (docs/reference/scenario-format.md):
 *   (json/scn_values.c, below this layer: numbers, vectors, matrices,
 *   named matrix sets, series, shared with the model builders of nlm/)
 *   scn_letters.c    the old letters renamed (the keys: json/scn_keys.c)
 *   scn_check.c      the checks every layout shares (shapes, times,
 *                    covariances) and the filters' pre-start queries
 *   scn_canonical.c  the canonical layout (model / init / y or runs)
 *   scn_cases.c      the cases layout (infofusion vectors), and the steps,
 *                    measurements and truth every cases layout reads alike
 *   scn_steps.c      the steps layout (steps[].inputs; seed-004 vectors) and
 *                    its network form (seed-003 vectors: per-node H, Sw, y)
 *   scn_network.c    the network form's graph, weights and eta
 *   scn_nlcases.c    the nonlinear cases layout (seed-001 vectors): models
 *                    (nlm.h), per-node init, z, the consensus graph
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
#include "scn_values.h"

/* ---- letters (scn_letters.c) ---- */
/* The old letters of root's matrices (layout: CANONICAL, CASES, STEPS or
 * NETWORK; the others have none) renamed in place to the library's, with
 * a one-line notice naming them into notice (unchanged if the file has
 * none); -1 if the file mixes the two. docs/reference/scenario-format.md, "Letters". */
int dkf_scn_letters(dkf_scn_ctx_t *c, json_t *root, dkf_scn_layout_t layout, char *notice,
                    size_t len);

/* ---- checks every layout shares (scn_check.c) ---- */
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
/* ---- what every cases layout shares (scn_cases.c) ---- */
/* Case cj's steps (at cpath.steps): a non-empty list of at most
 * DKF_SCN_MAX_STEPS (s->steps set), or NULL after the message. */
const json_t *dkf_scn_cases_steps(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj,
                                  const char *cpath);
/* How a cases layout's steps carry the measurements. */
typedef struct {
    const char *tkey;          /* the time key, "k" or "t": steps[j] has j + 1 */
    const char *dkey;          /* the data key, "z" or "y" */
    const char *const *known;  /* every key a step may have (NULL-terminated) */
    const char *per;           /* the data is a list of one vector per sensor, named in
                                * messages "one per PER" ("sensor, as H"); NULL: the
                                * one sensor's vector */
    const char *len_of;        /* what sets sensor i's m, named in messages ("the rows
                                * of H", with per then "the rows of H[i]") */
} dkf_scn_case_steps_t;
/* Every sensor's y series from steps (each sensor's m set): sensor i's y at
 * k = j + 1 from steps[j] of the case at cpath, read as how says. Refused:
 * "PATH.steps[j].DKEY: expected a list of L measurements (one per PER),
 * got ..." and "PATH.steps[j].DKEY[i]: expected a vector of M values
 * (LEN_OF[i]), got ..." (with the time key's and the vectors' own). */
int dkf_scn_cases_measurements(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *steps,
                               const char *cpath, const dkf_scn_case_steps_t *how);
/* A truth series at path: a non-empty list of vectors of dim values (a
 * number stands for a vector of one; len_of names what sets dim) into a
 * fresh series at k = k0, k0 + 1, ... */
int dkf_scn_cases_truth(dkf_scn_ctx_t *c, const json_t *list, const char *path, size_t dim,
                        const char *len_of, long k0, size_t *count, long **kout, double **vout);
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
