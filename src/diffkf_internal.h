/*
 * src/diffkf_internal.h - what the Difference KF (diffkf.c) gives its
 * fusion centre (diffkf_fusion*.c) beyond dkf/diffkf.h: the size of a
 * filter's carry, its model memo's key, and a gain told that the model is
 * the memo's. Owned by diffkf.c; included by it and by the centre. Not
 * installed.
 */
#ifndef DKF_DIFFKF_INTERNAL_H
#define DKF_DIFFKF_INTERNAL_H

#include "dkf/diffkf.h"

/* DKF__DIFFKF_CARRY_LEN (dkf/diffkf.h) measured on the layout of an
 * initialised f; test_kernels_wide checks that the two agree. */
size_t dkf__diffkf_carry_len(const dkf_diffkf_t *f);

/* The measurement and input matrices of f's model memo (the model-only
 * block's key), H, D, R, B, Rd; 0 (pointers unset) if there is none. */
int dkf__diffkf_memo(const dkf_diffkf_t *f, const dkf_real_t **H, const dkf_real_t **D,
                     const dkf_real_t **R, const dkf_real_t **B, const dkf_real_t **Rd);

/* dkf_diffkf_gain_masked, told by the caller (memo_same = 1) that
 * dyn->B, dyn->Rd and meas_next's H, D, R are bitwise the memo's
 * (dkf__diffkf_memo): the memo test then compares F, Q and the carried
 * products only, which saves O(m^2 + p^2) per gain on a stacked model that
 * the caller compared in O(N). memo_same = 0 is dkf_diffkf_gain_masked. */
dkf_status_t dkf__diffkf_gain_masked_memo(dkf_diffkf_t *f, const dkf_ui_dyn_t *dyn,
                                          const dkf_ui_meas_t *meas_next, const unsigned char *rows,
                                          int memo_same);

#endif /* DKF_DIFFKF_INTERNAL_H */
