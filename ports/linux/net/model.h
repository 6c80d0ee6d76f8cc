/*
 * model.h - one sensor's Difference-KF model at a time k, read from a
 * scenario (host side), and the scenario's model id.
 *
 * Node i's local filter and the fusion centre's view of sensor i both take
 * (F_k, Q_k, B^i_k, Rd^i_k) and (H^i_k, A^i_k, R^i_k) from the same file
 * through these functions, so they cannot disagree about the model.
 */
#ifndef DKF_NET_MODEL_H
#define DKF_NET_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "dkf/ui_model.h"
#include "scenario.h"

typedef struct {
    size_t n, m, p;
    dkf_real_t *buf;
    dkf_mat_t F, Q, B, Rd; /* dynamics at the k of the last dkf_net_model_dyn */
    dkf_mat_t H, A, R;     /* sensor model at the k of the last dkf_net_model_meas */
    dkf_ui_dyn_t dyn;      /* points at F, Q, B, Rd */
    dkf_ui_meas_t meas;    /* points at H, A, R */
} dkf_net_model_t;

/* Checks what the network processes need: the scenario passes
 * dkf_scn_require_ui for N steps of the Difference KF (dynamics at
 * k = 0..N, measurements at k = 1..N+1), has at most DKF_NET_MAX_NODES
 * sensors and sum m_i, sum p_i <= DKF_MAX_DIM. 0, or -1 with a
 * "FILE: KEY: problem" line in err. */
int dkf_net_check_scenario(const dkf_scenario_t *s, char *err, size_t errlen);

/* Storage for sensor i (0 or -1 if out of memory). */
int dkf_net_model_init(dkf_net_model_t *md, const dkf_scenario_t *s, size_t i);
void dkf_net_model_free(dkf_net_model_t *md);

/* Load the dynamics at k (F_k, Q_k, B^i_k, Rd^i_k) / the sensor model at k.
 * 0, or -1 if the scenario has no such k. */
int dkf_net_model_dyn(dkf_net_model_t *md, const dkf_scenario_t *s, size_t i, size_t k);
int dkf_net_model_meas(dkf_net_model_t *md, const dkf_scenario_t *s, size_t i, size_t k);

/* 64-bit FNV-1a over everything that defines the estimation problem:
 * n, number of sensors, N, F, Q, every sensor's H, A, R, B, Rd (all k),
 * x00 and the prior covariances; not the measurements or the truth, so
 * every Monte-Carlo run of one model has the same id. Values are hashed
 * by their IEEE-754 bit patterns, most significant byte first, so the id
 * does not depend on the host's byte order. */
int64_t dkf_net_model_id(const dkf_scenario_t *s);

#endif /* DKF_NET_MODEL_H */
