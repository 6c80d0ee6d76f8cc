/*
 * est_nerts.h - what the seed-001 runners share (est_nerts.c, the single
 * node and centralised filters; dfnerts_run.c, the consensus network).
 */
#ifndef DKF_HOST_EST_NERTS_H
#define DKF_HOST_EST_NERTS_H

#include <jansson.h>

#include "dkf/nerts.h"

/* One step of filter f appended to series under the vector files' names
 * (`expected` of nertsif.json / dnertsif_single.json, `expected_per_node`
 * of df_dnertsif.json): x_pred P_pred z_hat nu R_tilde Pzz Pxz H M x Px d
 * Pd Pxd; EKF kinds A, G (nertsf also C); information kinds Y_pred y_pred
 * C Rbar Rbar_inv i I Y y. */
void dkf_nerts_record(json_t *series, const dkf_nerts_t *f);

#endif /* DKF_HOST_EST_NERTS_H */
