/*
 * wf_model.h - the seed-002 model of a weighted-fusion scenario
 * (DKF_SCN_LAYOUT_WFCASES, scn_wfcases.c) in the library's real type,
 * ready for dkf/wfusion.h: the dynamics {F, Q}, one {H_i, R_i} per sensor,
 * the signal row Hs, the common prior (x0, P0), and a buffer for one
 * step's measurements. The wfusion family (wfusion_run.c) and the network
 * processes (node, fusion centre) read the file through it, so they cannot
 * read it differently.
 *
 *   dkf_wf_model_t mdl;
 *   if (dkf_wf_model_load(s, &mdl, err, errlen) != 0) ... (DKF_EXIT_USAGE)
 *   dkf_wfusion_init(&fu, mdl.n, mdl.l, mdl.m, nodes, storage, len, &mdl.Hs, &mdl.x0, &mdl.P0);
 *   for (t = 1..s->steps) {
 *       dkf_wf_model_y(&mdl, s, t);           y_i(t) into mdl.y[i]
 *       dkf_wfusion_step(&fu, &mdl.dyn, mdl.meas, mdl.y);
 *   }
 *   dkf_wf_model_free(&mdl);
 */
#ifndef DKF_HOST_WF_MODEL_H
#define DKF_HOST_WF_MODEL_H

#include <stddef.h>

#include "dkf/kf.h"
#include "dkf/mat.h"
#include "scenario.h"

typedef struct {
    size_t n;            /* state dimension */
    size_t l;            /* sensors */
    size_t *m;           /* l measurement dimensions (rows of H_i) */
    size_t m_max;        /* max m[i] */
    dkf_mat_t F, Q;      /* Phi and Gamma Qe Gamma^T, n x n */
    dkf_mat_t Hs;        /* the signal row H_signal, 1 x n */
    dkf_mat_t x0, P0;    /* the common prior x_hat0 (n x 1), P0 (n x n) */
    dkf_mat_t *H, *R;    /* l views: H_i (m_i x n), R_i (m_i x m_i) */
    dkf_kf_dyn_t dyn;    /* {&F, &Q} */
    dkf_kf_meas_t *meas; /* l: {&H[i], &R[i]} */
    dkf_mat_t *y;        /* l views (m_i x 1) filled by dkf_wf_model_y */
    dkf_real_t *data;    /* one allocation behind every view above */
} dkf_wf_model_t;

/* The model of s (a weighted-fusion scenario, as loaded and checked by the
 * reader) into mdl, converted to dkf_real_t. Returns 0, or -1 with a
 * one-line "FILE: KEY: problem" in err (s of another layout, out of
 * memory); mdl is then zeroed and needs no free. */
int dkf_wf_model_load(const dkf_scenario_t *s, dkf_wf_model_t *mdl, char *err, size_t errlen);

/* mdl->y[i] = sensor i's y at time t (1..s->steps). Returns 0, or -1 if a
 * sensor has no measurement at t (mdl->y then partly written). */
int dkf_wf_model_y(dkf_wf_model_t *mdl, const dkf_scenario_t *s, long t);

void dkf_wf_model_free(dkf_wf_model_t *mdl);

#endif /* DKF_HOST_WF_MODEL_H */
