/*
 * Augmented-state Kalman filter (dkf/askf.h): a dkf_kf on X = [x; d] with
 *   Phi = blockdiag(F, B),  Q^a = blockdiag(Q, Rd),  H^a = [H  D].
 *
 * The augmented matrices are assembled into the filter's scratch (`aug`)
 * from the model of the step, then the KF step runs on them. Nothing but
 * the KF step writes the state, and that step is atomic, so a failed call
 * leaves the filter bit-identical. This is the baseline whose (n+p)^3 cost
 * per step the OTSKF and the Difference KF avoid: no effort is spent on
 * the block structure.
 */
#include "dkf/askf.h"

#include <string.h>

#include "internal.h"
#include "kernels.h"

/* Storage after the KF's: Phi | Q^a | H^a. */
static dkf_real_t *aug_phi(const dkf_askf_t *f) { return f->aug; }
static dkf_real_t *aug_qa(const dkf_askf_t *f)
{
    const size_t N = f->n + f->p;
    return f->aug + N * N;
}
static dkf_real_t *aug_ha(const dkf_askf_t *f)
{
    const size_t N = f->n + f->p;
    return f->aug + 2 * N * N;
}

/* Out (N x N, N = n + p) = [[X, Y], [Y^T, Z]] with X n x n, Z p x p and
 * Y n x p (Y NULL: zero blocks). */
static void assemble_blocks(dkf_real_t *Out, const dkf_real_t *X, const dkf_real_t *Y,
                            const dkf_real_t *Z, size_t n, size_t p)
{
    const size_t N = n + p;
    size_t i, j;
    for (i = 0; i < n; ++i) {
        dkf__copy(Out + i * N, X + i * n, n);
        for (j = 0; j < p; ++j) Out[i * N + n + j] = Y != NULL ? Y[i * p + j] : DKF_R(0.0);
    }
    for (i = 0; i < p; ++i) {
        for (j = 0; j < n; ++j) Out[(n + i) * N + j] = Y != NULL ? Y[j * p + i] : DKF_R(0.0);
        dkf__copy(Out + (n + i) * N + n, Z + i * p, p);
    }
}

dkf_status_t dkf_askf_init(dkf_askf_t *f, size_t n, size_t m, size_t p, dkf_real_t *storage,
                           size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0,
                           const dkf_mat_t *d0, const dkf_mat_t *Pd0, const dkf_mat_t *Pxd0)
{
    dkf_askf_t g;
    dkf_mat_t X0, Pa0;
    size_t N, kf_len;
    DKF_CHECK_NULL(f);
    DKF_CHECK_NULL(storage);
    if (n == 0 || m == 0 || p == 0 || n > DKF_MAX_DIM || m > DKF_MAX_DIM || p > DKF_MAX_DIM ||
        n + p > DKF_MAX_DIM)
        return DKF_ERR_CAPACITY;
    if (storage_len < DKF_ASKF_STORAGE_LEN(n, m, p)) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    DKF_TRY(dkf__check_input(d0, p, 1));
    DKF_TRY(dkf__check_input(Pd0, p, p));
    if (Pxd0 != NULL) DKF_TRY(dkf__check_input(Pxd0, n, p));

    memset(&g, 0, sizeof g);
    g.n = n;
    g.m = m;
    g.p = p;
    N = n + p;
    kf_len = DKF_KF_STORAGE_LEN(N, m);
    g.aug = storage + kf_len;
    /* X0 and P^a_0 are staged in the (still unused) Q^a and Phi areas */
    X0.rows = N, X0.cols = 1, X0.data = aug_qa(&g);
    Pa0.rows = N, Pa0.cols = N, Pa0.data = aug_phi(&g);
    dkf__copy(X0.data, x0->data, n);
    dkf__copy(X0.data + n, d0->data, p);
    assemble_blocks(Pa0.data, P0->data, Pxd0 != NULL ? Pxd0->data : NULL, Pd0->data, n, p);
    DKF_TRY(dkf_kf_init(&g.kf, N, m, storage, kf_len, &X0, &Pa0));
    g.ready = 1;
    *f = g;
    return DKF_OK;
}

dkf_status_t dkf_askf_predict(dkf_askf_t *f, const dkf_ui_dyn_t *dyn)
{
    dkf_mat_t Phi, Qa;
    dkf_kf_dyn_t aug; /* {Phi, Q^a} */
    size_t n, p, N;
    DKF_CHECK_NULL(f);
    if (!f->ready) return DKF_ERR_STATE;
    DKF_CHECK_NULL(dyn);
    n = f->n;
    p = f->p;
    N = n + p;
    DKF_TRY(dkf__check_input(dyn->F, n, n));
    DKF_TRY(dkf__check_input(dyn->Q, n, n));
    DKF_TRY(dkf__check_input(dyn->B, p, p));
    DKF_TRY(dkf__check_input(dyn->Rd, p, p));
    Phi.rows = Phi.cols = N, Phi.data = aug_phi(f);
    Qa.rows = Qa.cols = N, Qa.data = aug_qa(f);
    assemble_blocks(Phi.data, dyn->F->data, NULL, dyn->B->data, n, p);
    assemble_blocks(Qa.data, dyn->Q->data, NULL, dyn->Rd->data, n, p);
    aug.F = &Phi;
    aug.Q = &Qa;
    return dkf_kf_predict(&f->kf, &aug, NULL);
}

dkf_status_t dkf_askf_update(dkf_askf_t *f, const dkf_ui_meas_t *meas, const dkf_mat_t *y)
{
    dkf_mat_t Ha;
    dkf_kf_meas_t aug; /* {H^a, R} */
    size_t n, m, p, N, i;
    DKF_CHECK_NULL(f);
    if (!f->ready) return DKF_ERR_STATE;
    DKF_CHECK_NULL(meas);
    n = f->n;
    m = f->m;
    p = f->p;
    N = n + p;
    DKF_TRY(dkf__check_input(meas->H, m, n));
    DKF_TRY(dkf__check_input(meas->D, m, p));
    DKF_TRY(dkf__check_input(meas->R, m, m));
    DKF_TRY(dkf__check_input(y, m, 1));
    /* H^a = [H  D] */
    Ha.rows = m, Ha.cols = N, Ha.data = aug_ha(f);
    for (i = 0; i < m; ++i) {
        dkf__copy(Ha.data + i * N, meas->H->data + i * n, n);
        dkf__copy(Ha.data + i * N + n, meas->D->data + i * p, p);
    }
    aug.H = &Ha;
    aug.R = meas->R;
    return dkf_kf_update(&f->kf, &aug, y);
}

/* v (may be NULL) = view of `len` entries of X from `off`; Pb (may be
 * NULL) = the len x len diagonal block of P^a from (off, off). */
static dkf_status_t get_block(const dkf_askf_t *f, size_t off, size_t len, dkf_mat_t *v,
                              dkf_mat_t *Pb)
{
    const size_t N = f->n + f->p;
    size_t i;
    if (Pb != NULL) {
        DKF_TRY(dkf__check_shape(Pb, len, len));
        DKF_CHECK_NO_ALIAS(Pb, &f->kf.P);
        for (i = 0; i < len; ++i)
            dkf__copy(Pb->data + i * len, f->kf.P.data + (off + i) * N + off, len);
    }
    if (v != NULL) v->rows = len, v->cols = 1, v->data = f->kf.x.data + off;
    return DKF_OK;
}

dkf_status_t dkf_askf_state(const dkf_askf_t *f, dkf_mat_t *x, dkf_mat_t *Px)
{
    DKF_CHECK_NULL(f);
    if (!f->ready) return DKF_ERR_STATE;
    return get_block(f, 0, f->n, x, Px);
}

dkf_status_t dkf_askf_input(const dkf_askf_t *f, dkf_mat_t *d, dkf_mat_t *Pd)
{
    DKF_CHECK_NULL(f);
    if (!f->ready) return DKF_ERR_STATE;
    return get_block(f, f->n, f->p, d, Pd);
}
