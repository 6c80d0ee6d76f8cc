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

#endif /* DKF_DIFFKF_FUSION_INTERNAL_H */
