/*
 * nerts_run.h - what the seed-001 runners share (nerts_run.c, the nerts
 * family: single-node and centralised filters; dfnerts_run.c, the
 * consensus network).
 */
#ifndef DKF_HOST_NERTS_RUN_H
#define DKF_HOST_NERTS_RUN_H

#include <jansson.h>

#include "dkf/dfnerts.h"
#include "dkf/nerts.h"
#include "family.h"

/* One step of filter f appended to series under the vector files' names
 * (`expected` of nertsif.json / dnertsif_single.json, `expected_per_node`
 * of df_dnertsif.json): x_pred P_pred z_hat nu R_tilde Pzz Pxz H M C Rbar
 * x Px d Pd Pxd; EKF kinds A, G; information kinds Y_pred y_pred Rbar_inv
 * i I Y y. */
void dkf_host_nerts_record(json_t *series, const dkf_nerts_t *f);

/* The consensus-network family (dfnerts_run.c) and its filters' data
 * (dkf_filter_t.impl): the variant, and whether the filter has no input.
 * The network node agent (net/df_agent.c) runs the same filters. */
typedef struct {
    dkf_dfnerts_variant_t variant;
    int no_input; /* 1: df_ckf (p = 0), 0: an unknown input (p >= 1) */
} dkf_df_impl_t;
extern const dkf_family_t dkf_family_dfnerts;

#endif /* DKF_HOST_NERTS_RUN_H */
