/*
 * src/diffkf_fusion_internal.h - what the fusion centre's source files
 * (diffkf_fusion.c, diffkf_fusion_ckpt.c) share. Not installed.
 */
#ifndef DKF_DIFFKF_FUSION_INTERNAL_H
#define DKF_DIFFKF_FUSION_INTERNAL_H

#include "dkf/diffkf_fusion.h"

/* After a successful call the snapshot structs equal the replicas, so a
 * later failed call (snapshot, fail, restore) leaves the node array
 * bit-identical, not just the replicas. */
void dkf__fc_refresh_saved(dkf_diffkf_fc_t *fc);

/* (diffkf.c) DKF__DIFFKF_CARRY_LEN (dkf/diffkf.h) measured on the layout
 * of an initialised f; test_kernels_wide checks that the two agree. */
size_t dkf__diffkf_carry_len(const dkf_diffkf_t *f);

/* (diffkf.c) The measurement and input matrices of f's model memo (the
 * model-only block's key), H, D, R, B, Rd; 0 (pointers unset) if there is
 * none. */
int dkf__diffkf_memo(const dkf_diffkf_t *f, const dkf_real_t **H, const dkf_real_t **D,
                     const dkf_real_t **R, const dkf_real_t **B, const dkf_real_t **Rd);

#endif /* DKF_DIFFKF_FUSION_INTERNAL_H */
