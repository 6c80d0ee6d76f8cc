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

/* Reals at the start of a Difference KF's storage that a step rewrites:
 * the output views and the carry (src/diffkf.c's layout up to its caches).
 * The caches follow, up to DKF_DIFFKF_STATE_LEN, and change only when
 * f->cache_gen advances, so the centre snapshots them only then.
 * dkf__diffkf_carry_len (diffkf.c) measures the layout of an initialised
 * f; test_diffkf_fusion checks that the two agree. */
#define DKF__DIFFKF_CARRY_LEN(n, p) \
    (3 * (n) + 2 * (n) * (n) + 2 * (p) + 2 * (n) * (p) + (p) * (p) /* outputs */ \
     + 3 * (p) * (p) + 2 * (n) * (p) + 2 * (p) /* carry */)
size_t dkf__diffkf_carry_len(const dkf_diffkf_t *f);

#endif /* DKF_DIFFKF_FUSION_INTERNAL_H */
