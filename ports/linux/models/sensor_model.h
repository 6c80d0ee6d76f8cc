/*
 * sensor_model.h - one sensor's Difference-KF model at a time k, read from
 * a scenario (host side).
 *
 * Node i's local filter (the dkf family's node role, est_diffkf_node.c)
 * and the fusion centre's view of sensor i (net/fusion.c) both take
 * (F_k, Q_k, B^i_k, Rd^i_k) and (H^i_k, D^i_k, R^i_k) from the same file
 * through these functions, so they cannot disagree about the model.
 */
#ifndef DKF_HOST_SENSOR_MODEL_H
#define DKF_HOST_SENSOR_MODEL_H

#include <stddef.h>

#include "dkf/ui_model.h"
#include "scenario.h"

typedef struct {
    size_t n, m, p;
    dkf_real_t *buf;
    dkf_mat_t F, Q, B, Rd; /* dynamics at the k of the last dkf_sensor_model_dyn */
    dkf_mat_t H, D, R;     /* sensor model at the k of the last dkf_sensor_model_meas */
    dkf_ui_dyn_t dyn;      /* points at F, Q, B, Rd */
    dkf_ui_meas_t meas;    /* points at H, D, R */
} dkf_sensor_model_t;

/* Storage for sensor i of s (0, or -1 if out of memory). */
int dkf_sensor_model_init(dkf_sensor_model_t *md, const dkf_scenario_t *s, size_t i);
void dkf_sensor_model_free(dkf_sensor_model_t *md);

/* Load the dynamics at k (F_k, Q_k, B^i_k, Rd^i_k) / the sensor model at k.
 * 0, or -1 if the scenario has no such k. */
int dkf_sensor_model_dyn(dkf_sensor_model_t *md, const dkf_scenario_t *s, size_t i, size_t k);
int dkf_sensor_model_meas(dkf_sensor_model_t *md, const dkf_scenario_t *s, size_t i, size_t k);

#endif /* DKF_HOST_SENSOR_MODEL_H */
