/*
 * src/internal.h - checks shared by the dkf sources. Not installed.
 */
#ifndef DKF_INTERNAL_H
#define DKF_INTERNAL_H

#include <math.h>
#include <stddef.h>

#include "dkf/mat.h"

/* DKF__UNLIKELY(c): c, with the hint that it is rarely true (GCC, Clang):
 * the error exits of a step. Without it GCC's static estimate lets the
 * frequency of the code after a dozen checks fall so low that it treats
 * the end of a step as cold and stops unrolling its loops. */
#if defined(__GNUC__)
#define DKF__UNLIKELY(c) __builtin_expect(!!(c), 0)
#else
#define DKF__UNLIKELY(c) (c)
#endif

/* Returns from the calling function with `s` unless it is DKF_OK. */
#define DKF_TRY(expr) \
    do { \
        dkf_status_t dkf_try_s_ = (expr); \
        if (DKF__UNLIKELY(dkf_try_s_ != DKF_OK)) return dkf_try_s_; \
    } while (0)

#if DKF_DEBUG_CHECKS
#define DKF_CHECK_NULL(p) \
    do { \
        if ((p) == NULL) return DKF_ERR_NULL; \
    } while (0)
#define DKF_CHECK_NO_ALIAS(a, b) \
    do { \
        if (dkf__overlap((a), (b))) return DKF_ERR_ALIAS; \
    } while (0)
/* For routines that accept output == input: the identical buffer is fine,
 * any other overlap would read elements already overwritten. */
#define DKF_CHECK_SAME_OR_DISJOINT(a, b) \
    do { \
        if ((a)->data != (b)->data && dkf__overlap((a), (b))) return DKF_ERR_ALIAS; \
    } while (0)
/* Workspace (len reals at p) must not overlap matrix m. */
#define DKF_CHECK_NO_ALIAS_BUF(m, p, len) \
    do { \
        if (dkf__overlap_buf((m), (p), (len))) return DKF_ERR_ALIAS; \
    } while (0)
#else
#define DKF_CHECK_NULL(p) ((void)0)
#define DKF_CHECK_NO_ALIAS(a, b) ((void)0)
#define DKF_CHECK_SAME_OR_DISJOINT(a, b) ((void)0)
#define DKF_CHECK_NO_ALIAS_BUF(m, p, len) ((void)0)
#endif

/* Carves `count` reals for `ptr` out of caller storage: ptr = base + used,
 * used += count. With base == NULL it only counts, so one layout function
 * both sizes a filter's storage (for its exact *_STORAGE_LEN check) and maps
 * it. Expects `base` (dkf_real_t *) and `used` (size_t) in scope. */
#define DKF_TAKE(ptr, count) \
    do { \
        (ptr) = base != NULL ? base + used : NULL; \
        used += (count); \
    } while (0)

/* Points the view v at r x c reals at data (a region of a layout). */
static inline void dkf__view(dkf_mat_t *v, size_t r, size_t c, dkf_real_t *data)
{
    v->rows = r;
    v->cols = c;
    v->data = data;
}

/* Checkpoint headers (dkf_diffkf_save, dkf_diffkf_fc_save) are small
 * integers stored as reals, each below 2^16 and so exact in any real
 * type. A time index k takes DKF__CKPT_K_LEN of them: its 16-bit digits,
 * least significant first. */
#define DKF__CKPT_K_LEN 4
void dkf__ckpt_put_k(dkf_real_t *d, size_t k);
/* The k that dkf__ckpt_put_k wrote at d: DKF_ERR_ARG if a digit is not an
 * integer in [0, 2^16), DKF_ERR_CAPACITY if k does not fit in size_t. */
dkf_status_t dkf__ckpt_get_k(const dkf_real_t *d, size_t *k);
/* 1 if x is an integer in [0, hi] (hi < 2^16), then stored in *v. */
int dkf__ckpt_int(dkf_real_t x, size_t hi, size_t *v);
/* 1 if x is the integer v (v < 2^16). */
static inline int dkf__ckpt_is(dkf_real_t x, size_t v)
{
    size_t got = 0;
    return dkf__ckpt_int(x, v, &got) && got == v;
}

/* DKF_ERR_NULL for a NULL view or data pointer, DKF_ERR_CAPACITY for a
 * dimension of 0 or above DKF_MAX_DIM. Inline: every step of every filter
 * runs a few of these, and a call costs as much as the test. */
static inline dkf_status_t dkf__check_mat(const dkf_mat_t *m)
{
    if (m == NULL || m->data == NULL) return DKF_ERR_NULL;
    if (m->rows == 0 || m->cols == 0 || m->rows > DKF_MAX_DIM || m->cols > DKF_MAX_DIM)
        return DKF_ERR_CAPACITY;
    return DKF_OK;
}

/* dkf__check_mat plus an exact shape. */
static inline dkf_status_t dkf__check_shape(const dkf_mat_t *m, size_t rows, size_t cols)
{
    DKF_TRY(dkf__check_mat(m));
    return (m->rows == rows && m->cols == cols) ? DKF_OK : DKF_ERR_DIM;
}

/* dkf__check_shape plus finiteness of every element (DKF_ERR_NONFINITE):
 * the check every filter applies to each model input at its boundary. */
dkf_status_t dkf__check_input(const dkf_mat_t *m, size_t rows, size_t cols);
/* 1 if the storage of a and b overlaps (any element shared). */
int dkf__overlap(const dkf_mat_t *a, const dkf_mat_t *b);
/* 1 if the na reals at a overlap the nb reals at b. */
int dkf__overlap_raw(const dkf_real_t *a, size_t na, const dkf_real_t *b, size_t nb);
/* 1 if the storage of m overlaps the len reals at p. */
int dkf__overlap_buf(const dkf_mat_t *m, const dkf_real_t *p, size_t len);
/* 1 if all n reals at p are finite. */
int dkf__all_finite(const dkf_real_t *p, size_t n);

#endif /* DKF_INTERNAL_H */
