/*
 * wfn_model.h - the seed-002 model as the weighted-fusion network reads it
 * (host side): the shared dynamics {F, Q}, every sensor's {H_i, R_i}, the
 * signal row Hs and the common prior (x00, P00), at a time k, as the
 * dkf_kf_dyn_t / dkf_kf_meas_t that dkf/wfusion.h takes.
 *
 * The wfusion family's node role (est_wfusion_node.c) and the weighted
 * fusion centre (net/wfusion_centre.c) both load the model through these
 * functions, so a node and the centre cannot read the file differently.
 * Keys (any layout whose reader provides them: dkf_scn_model "F", "Q",
 * "Hs"; dkf_scn_sensor_model "H", "R"; dkf_scn_init "x00", "P00"); the
 * time convention of scenario.h: step k predicts with F_{k-1}, Q_{k-1}
 * and updates with H_k, R_k, y_k.
 */
#ifndef DKF_HOST_WFN_MODEL_H
#define DKF_HOST_WFN_MODEL_H

#include <stddef.h>

#include "dkf/kf.h"
#include "scenario.h"

typedef struct {
    size_t n, l;          /* state, sensors */
    size_t *m;            /* l measurement dimensions */
    dkf_real_t *buf;
    dkf_mat_t F, Q;       /* F_{k-1}, Q_{k-1} of the last dkf_wfn_model_at */
    dkf_mat_t Hs;         /* 1 x n signal row (constant) */
    dkf_mat_t x0, P0;     /* common prior x(0|0), P(0|0) */
    dkf_mat_t *H, *R;     /* l sensors' H_k, R_k */
    dkf_kf_dyn_t dyn;     /* points at F, Q */
    dkf_kf_meas_t *meas;  /* l, point at H[i], R[i] */
} dkf_wfn_model_t;

/* Checks that s has what the weighted-fusion network needs (F, Q n x n at
 * k = 0..N-1; Hs 1 x n; every sensor's H (m_i x n), R (m_i x m_i) at
 * k = 1..N; x00, P00; y of every sensor at k = 1..N; n l + n <=
 * DKF_MAX_DIM). 0, or -1 with a "FILE: KEY: problem" line in err. */
int dkf_wfn_check(const dkf_scenario_t *s, char *err, size_t errlen);

/* Storage and the constant parts (Hs, x0, P0). 0, or -1 (out of memory or
 * a key missing: run dkf_wfn_check first). */
int dkf_wfn_model_init(dkf_wfn_model_t *md, const dkf_scenario_t *s);
void dkf_wfn_model_free(dkf_wfn_model_t *md);

/* Loads the model of step k >= 1 (F_{k-1}, Q_{k-1}, every H_k, R_k).
 * 0, or -1 if the scenario has no such k. */
int dkf_wfn_model_at(dkf_wfn_model_t *md, const dkf_scenario_t *s, size_t k);

/* 1 if s is a weighted-fusion scenario (a signal row "Hs" and no sensor
 * with an unknown-input matrix "A"), else 0: the network programs pick the
 * node check, the model id and the fusion centre by it. */
int dkf_wfn_is_wfusion(const dkf_scenario_t *s);

#endif /* DKF_HOST_WFN_MODEL_H */
