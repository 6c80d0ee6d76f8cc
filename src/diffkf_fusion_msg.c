/*
 * The node message and the stacked (centralized) model of the distributed
 * Difference KF (dkf/diffkf_fusion.h, docs/design/diffkf-fusion.md): what a node
 * sends after its local step, and the block matrices of the model the
 * fusion centre's central filter runs on,
 *   H = [H^1; ...; H^l], D = blkdiag(D^i), R = blkdiag(R^i),
 *   B = blkdiag(B^i),    Rd = blkdiag(Rd^i)        (seed 000 (27)-(29)).
 */
#include "dkf/diffkf_fusion.h"

#include <string.h>

#include "internal.h"
#include "kernels.h"

/* ---- message ------------------------------------------------------------- */

dkf_status_t dkf_diffkf_msg_fill(dkf_diffkf_msg_t *msg, uint16_t node, const dkf_diffkf_t *f)
{
    DKF_CHECK_NULL(msg);
    DKF_CHECK_NULL(f);
    if (!f->priv.ready || !f->priv.started || f->k == 0) return DKF_ERR_STATE;
#if SIZE_MAX > UINT32_MAX
    if (f->k > (size_t)UINT32_MAX) return DKF_ERR_CAPACITY;
#endif
    memset(msg, 0, sizeof *msg);
    msg->node = node;
    msg->k = (uint32_t)f->k;
    msg->n = (uint16_t)f->n;
    dkf__copy(msg->xf, f->xf.data, f->n);
    dkf__copy(msg->xp, f->xp.data, f->n);
    return DKF_OK;
}

/* ---- stacked model ------------------------------------------------------- */

static dkf_status_t check_out(const dkf_mat_t *X, size_t rows, size_t cols)
{
    return X == NULL ? DKF_OK : dkf__check_shape(X, rows, cols);
}

#if DKF_DEBUG_CHECKS
static int overlaps_any(const dkf_mat_t *X, const dkf_mat_t *Y)
{
    return X != NULL && Y != NULL && dkf__overlap(X, Y);
}
#endif

dkf_status_t dkf_diffkf_stack_meas(dkf_mat_t *H, dkf_mat_t *D, dkf_mat_t *R,
                                   const dkf_ui_meas_t *const meas[], size_t l)
{
    size_t i, n = 0, ms = 0, ps = 0, r0 = 0, c0 = 0;
    DKF_CHECK_NULL(meas);
    if (l == 0 || l > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    for (i = 0; i < l; ++i) {
        const dkf_ui_meas_t *s = meas[i];
        DKF_CHECK_NULL(s);
        DKF_TRY(dkf__check_mat(s->H));
        DKF_TRY(dkf__check_mat(s->D));
        DKF_TRY(dkf__check_mat(s->R));
        if (i == 0) n = s->H->cols;
        if (s->H->cols != n || s->D->rows != s->H->rows ||
            s->R->rows != s->H->rows || s->R->cols != s->H->rows)
            return DKF_ERR_DIM;
        ms += s->H->rows;
        ps += s->D->cols;
    }
    if (ms > DKF_MAX_DIM || ps > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    DKF_TRY(check_out(H, ms, n));
    DKF_TRY(check_out(D, ms, ps));
    DKF_TRY(check_out(R, ms, ms));
#if DKF_DEBUG_CHECKS
    if (overlaps_any(H, D) || overlaps_any(H, R) || overlaps_any(D, R)) return DKF_ERR_ALIAS;
    for (i = 0; i < l; ++i) {
        const dkf_ui_meas_t *s = meas[i];
        if (overlaps_any(H, s->H) || overlaps_any(H, s->D) || overlaps_any(H, s->R) ||
            overlaps_any(D, s->H) || overlaps_any(D, s->D) || overlaps_any(D, s->R) ||
            overlaps_any(R, s->H) || overlaps_any(R, s->D) || overlaps_any(R, s->R))
            return DKF_ERR_ALIAS;
    }
#endif
    if (D != NULL) memset(D->data, 0, ms * ps * sizeof(dkf_real_t));
    if (R != NULL) memset(R->data, 0, ms * ms * sizeof(dkf_real_t));
    for (i = 0; i < l; ++i) {
        const dkf_ui_meas_t *s = meas[i];
        const size_t mi = s->H->rows, pi = s->D->cols;
        if (H != NULL) dkf__put_block(H->data, n, r0, 0, s->H->data, mi, n);
        if (D != NULL) dkf__put_block(D->data, ps, r0, c0, s->D->data, mi, pi);
        if (R != NULL) dkf__put_block(R->data, ms, r0, r0, s->R->data, mi, mi);
        r0 += mi;
        c0 += pi;
    }
    return DKF_OK;
}

dkf_status_t dkf_diffkf_stack_input(dkf_mat_t *B, dkf_mat_t *Rd, const dkf_mat_t *const Bi[],
                                    const dkf_mat_t *const Rdi[], size_t l)
{
    size_t i, ps = 0, c0 = 0;
    if (l == 0 || l > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    if ((B != NULL && Bi == NULL) || (Rd != NULL && Rdi == NULL)) return DKF_ERR_NULL;
    for (i = 0; i < l; ++i) {
        size_t pi = 0;
        if (B != NULL) {
            DKF_TRY(dkf__check_mat(Bi[i]));
            if (Bi[i]->rows != Bi[i]->cols) return DKF_ERR_DIM;
            pi = Bi[i]->rows;
        }
        if (Rd != NULL) {
            DKF_TRY(dkf__check_mat(Rdi[i]));
            if (Rdi[i]->rows != Rdi[i]->cols || (B != NULL && Rdi[i]->rows != pi))
                return DKF_ERR_DIM;
            pi = Rdi[i]->rows;
        }
        ps += pi;
    }
    if (B == NULL && Rd == NULL) return DKF_OK;
    if (ps > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    DKF_TRY(check_out(B, ps, ps));
    DKF_TRY(check_out(Rd, ps, ps));
#if DKF_DEBUG_CHECKS
    if (overlaps_any(B, Rd)) return DKF_ERR_ALIAS;
    for (i = 0; i < l; ++i)
        if ((B != NULL && (dkf__overlap(B, Bi[i]) || (Rd != NULL && dkf__overlap(B, Rdi[i])))) ||
            (Rd != NULL && (dkf__overlap(Rd, Rdi[i]) || (B != NULL && dkf__overlap(Rd, Bi[i])))))
            return DKF_ERR_ALIAS;
#endif
    if (B != NULL) memset(B->data, 0, ps * ps * sizeof(dkf_real_t));
    if (Rd != NULL) memset(Rd->data, 0, ps * ps * sizeof(dkf_real_t));
    for (i = 0; i < l; ++i) {
        const size_t pi = B != NULL ? Bi[i]->rows : Rdi[i]->rows;
        if (B != NULL) dkf__put_block(B->data, ps, c0, c0, Bi[i]->data, pi, pi);
        if (Rd != NULL) dkf__put_block(Rd->data, ps, c0, c0, Rdi[i]->data, pi, pi);
        c0 += pi;
    }
    return DKF_OK;
}
