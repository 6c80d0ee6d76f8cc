/*
 * model.h - what the network processes need of a Difference-KF scenario,
 * and its model id (host side). One sensor's model at a time k is
 * the host's sensor_model.h (shared with the node role in the registry).
 */
#ifndef DKF_NET_MODEL_H
#define DKF_NET_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "scenario.h"
#include "sensor_model.h"

/* Checks what the network processes need: the scenario passes
 * dkf_scn_require_ui for N steps of the Difference KF (dynamics at
 * k = 0..N, measurements at k = 1..N+1), has at most DKF_NET_MAX_NODES
 * sensors and sum m_i, sum p_i <= DKF_MAX_DIM. 0, or -1 with a
 * "FILE: KEY: problem" line in err. */
int dkf_net_check_scenario(const dkf_scenario_t *s, char *err, size_t errlen);
/* (A weighted-fusion scenario, DKF_SCN_LAYOUT_WFCASES: the wfusion family's check,
 * and at most DKF_NET_MAX_NODES sensors; its model id hashes a tag, n, the
 * number of sensors, N, F, Q, Hs, every sensor's H, R, x00 and P00.) */

/* 64-bit FNV-1a over everything that defines the estimation problem:
 * n, number of sensors, N, F, Q, every sensor's H, A, R, B, Rd (all k),
 * x00 and the prior covariances; not the measurements or the truth, so
 * every Monte-Carlo run of one model has the same id. Values are hashed
 * by their IEEE-754 bit patterns, most significant byte first, so the id
 * does not depend on the host's byte order. */
int64_t dkf_net_model_id(const dkf_scenario_t *s);

#endif /* DKF_NET_MODEL_H */
