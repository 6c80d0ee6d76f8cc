/*
 * uif_run.h - the seed-004 joint state / unknown-input filters (dkf/uif.h:
 * RTSF, NRTSF-DF, NRTSF) over a steps-layout scenario (host side, used by
 * dkf-run).
 *
 * Step sequence (the vector files' convention, docs/scenario-format.md):
 *   rtsf, nrtsf_df: steps start at k = 0; (x0, P0) is the prior of x_0;
 *     step 0 has no time update (dyn = NULL), step k >= 1 uses A, G, Q of
 *     k - 1 and C, H, R, y of k.
 *   nrtsf: steps start at k = 1; (x0, P0) = x_{0|0}; no H in the file.
 * Recorded per step (the vectors' `expected` names): x_pred P_pred Rtilde d
 * Pd x Px L K M rank proj, Pxd (Pxd_extra for nrtsf, where the library's Pxd
 * is E[(x_k - x_{k|k})(d_{k-1} - d_{k-1|k})^T]); plus extra keys
 * `estimable` (per input component: 0 none, 1 partial, 2 full;
 * DKF_UIF_EST_*), `bias_risk` (0/1) and `bias_steps`.
 */
#ifndef DKF_HOST_UIF_RUN_H
#define DKF_HOST_UIF_RUN_H

#include <stddef.h>

#include <jansson.h>

#include "dkf/uif.h"
#include "scenario.h"
#include "util.h"

/* What a run measured against the file's truth (NaN where absent). */
typedef struct {
    size_t steps;
    size_t m;
    double rmse_x;               /* root mean over steps and components */
    double rmse_d[DKF_MAX_DIM];  /* per input component, vs truth d / d_prev */
    size_t est_count[DKF_MAX_DIM][3]; /* steps with estimable[i] = NONE, PARTIAL, FULL */
    size_t bias_steps;
    size_t rank_min, rank_max;
} dkf_uifrun_summary_t;

/* Name (rtsf, nrtsf_df, nrtsf) -> kind; -1 if unknown. */
int dkf_uifrun_kind(const char *name);

/* The vectors' label of a kind: "RTSF", "NRTSF_DF", "NRTSF". */
const char *dkf_uifrun_label(dkf_uif_kind_t kind);

/* Runs every step of s with filter `kind`. series: an object receiving the
 * per-step lists (NULL: record nothing). Returns DKF_EXIT_OK, or
 * DKF_EXIT_USAGE / DKF_EXIT_RUN with a one-line message in err
 * ("FILE: KEY: problem" / "FILE: step k=K: RTSF: dkf_uif_step failed: ..."). */
int dkf_uifrun(const dkf_scenario_t *s, dkf_uif_kind_t kind, json_t *series,
               dkf_uifrun_summary_t *sum, char *err, size_t errlen);

#endif /* DKF_HOST_UIF_RUN_H */
