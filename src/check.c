/* Argument checks shared by every module (see internal.h). */
#include <stdint.h>

#include "internal.h"

dkf_status_t dkf__check_input(const dkf_mat_t *m, size_t rows, size_t cols)
{
    DKF_TRY(dkf__check_shape(m, rows, cols));
    return dkf__all_finite(m->data, rows * cols) ? DKF_OK : DKF_ERR_NONFINITE;
}

/* Pointers into different objects cannot be compared portably with <, so
 * compare their integer images (exact on every flat-memory target). */
int dkf__overlap_raw(const dkf_real_t *a, size_t na, const dkf_real_t *b, size_t nb)
{
    uintptr_t a0 = (uintptr_t)a;
    uintptr_t a1 = a0 + na * sizeof(dkf_real_t);
    uintptr_t b0 = (uintptr_t)b;
    uintptr_t b1 = b0 + nb * sizeof(dkf_real_t);
    return a0 < b1 && b0 < a1;
}

int dkf__overlap_buf(const dkf_mat_t *m, const dkf_real_t *p, size_t len)
{
    return dkf__overlap_raw(m->data, m->rows * m->cols, p, len);
}

int dkf__overlap(const dkf_mat_t *a, const dkf_mat_t *b)
{
    return dkf__overlap_buf(a, b->data, b->rows * b->cols);
}

int dkf__all_finite(const dkf_real_t *p, size_t n)
{
    /* x - x is 0 for every finite x and NaN for Inf or NaN, and NaN
     * propagates through the sum: one compare at the end instead of a
     * classification per element. */
    dkf_real_t acc = DKF_R(0.0);
    size_t i;
    for (i = 0; i < n; ++i) acc += p[i] - p[i];
    return acc == acc;
}

void dkf__ckpt_put_k(dkf_real_t *d, size_t k)
{
    size_t i;
    for (i = 0; i < DKF__CKPT_K_LEN; ++i, k = (k >> 8) >> 8) d[i] = (dkf_real_t)(k & 0xFFFFu);
}

dkf_status_t dkf__ckpt_get_k(const dkf_real_t *d, size_t *k)
{
    size_t i, v = 0, digit = 0;
    for (i = DKF__CKPT_K_LEN; i-- > 0;) {
        if (!dkf__ckpt_int(d[i], 0xFFFFu, &digit)) return DKF_ERR_ARG;
#if SIZE_MAX <= 0xFFFFFFFFu
        if (i >= 2 && digit != 0) return DKF_ERR_CAPACITY;
#endif
        v = ((v << 8) << 8) + digit;
    }
    *k = v;
    return DKF_OK;
}

int dkf__ckpt_int(dkf_real_t x, size_t hi, size_t *v)
{
    if (!(x >= DKF_R(0.0) && x <= (dkf_real_t)hi) || x != (dkf_real_t)(size_t)x) return 0;
    *v = (size_t)x;
    return 1;
}
