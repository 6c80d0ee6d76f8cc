/*
 * Seed 001's single-node nonlinear unknown-input filters (dkf/nerts.h).
 * Stub: every call returns DKF_ERR_STATE until the implementation lands.
 */
#include "dkf/nerts.h"

dkf_status_t dkf_nerts_init(dkf_nerts_t *f, dkf_nerts_kind_t kind, size_t n, size_t m, size_t p,
                            dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                            const dkf_mat_t *P0, const dkf_mat_t *d0, const dkf_mat_t *Pd0,
                            const dkf_mat_t *Pxd0)
{
    (void)f, (void)kind, (void)n, (void)m, (void)p, (void)storage, (void)storage_len;
    (void)x0, (void)P0, (void)d0, (void)Pd0, (void)Pxd0;
    return DKF_ERR_STATE;
}

dkf_status_t dkf_nerts_predict(dkf_nerts_t *f, const dkf_nl_model_t *model, const dkf_real_t *u,
                               const dkf_mat_t *Q)
{
    (void)f, (void)model, (void)u, (void)Q;
    return DKF_ERR_STATE;
}

dkf_status_t dkf_nerts_local(dkf_nerts_t *f, const dkf_nl_model_t *model, const dkf_real_t *u,
                             const dkf_mat_t *R, const dkf_mat_t *z)
{
    (void)f, (void)model, (void)u, (void)R, (void)z;
    return DKF_ERR_STATE;
}

dkf_status_t dkf_nerts_update(dkf_nerts_t *f)
{
    (void)f;
    return DKF_ERR_STATE;
}

dkf_status_t dkf_nerts_commit_info(dkf_nerts_t *f, const dkf_mat_t *Y, const dkf_mat_t *y)
{
    (void)f, (void)Y, (void)y;
    return DKF_ERR_STATE;
}

dkf_status_t dkf_nerts_step(dkf_nerts_t *f, const dkf_nl_model_t *model, const dkf_real_t *u_prev,
                            const dkf_mat_t *Q, const dkf_real_t *u, const dkf_mat_t *R,
                            const dkf_mat_t *z)
{
    (void)f, (void)model, (void)u_prev, (void)Q, (void)u, (void)R, (void)z;
    return DKF_ERR_STATE;
}

dkf_status_t dkf_nerts_stack(dkf_nl_model_t *out, dkf_nerts_stack_t *st,
                             const dkf_nl_model_t *sensors, size_t count)
{
    (void)out, (void)st, (void)sensors, (void)count;
    return DKF_ERR_STATE;
}
