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

#endif /* DKF_DIFFKF_FUSION_INTERNAL_H */
