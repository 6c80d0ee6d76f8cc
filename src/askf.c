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

/* The storage: the KF's on N = n + p states, then the augmented model
 * built per step, Phi and Q^a (N x N each) and H^a (m x N). With base ==
 * NULL it only counts (DKF_ASKF_STORAGE_LEN). */
typedef struct {
    dkf_real_t *kf, *phi, *qa, *ha;
} askf_layout_t;

static size_t askf_layout(askf_layout_t *L, dkf_real_t *base, size_t N, size_t m)
{
    size_t used = 0;
    DKF_TAKE(L->kf, DKF_KF_STORAGE_LEN(N, m));
    DKF_TAKE(L->phi, N * N);
    DKF_TAKE(L->qa, N * N);
    DKF_TAKE(L->ha, m * N);
    return used;
}

/* The layout of an initialised filter (its storage starts with the KF's x). */
static askf_layout_t layout_of(const dkf_askf_t *f)
{
    askf_layout_t L;
    (void)askf_layout(&L, f->kf.x.data, f->n + f->p, f->m);
    return L;
}

dkf_status_t dkf_askf_init(dkf_askf_t *f, size_t n, size_t m, size_t p, dkf_real_t *storage,
                           size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0,
                           const dkf_mat_t *d0, const dkf_mat_t *Pd0, const dkf_mat_t *Pxd0)
{
    dkf_askf_t g;
    dkf_mat_t X0, Pa0;
    askf_layout_t L;
    size_t N;
    DKF_CHECK_NULL(f);
    DKF_CHECK_NULL(storage);
    if (n == 0 || m == 0 || p == 0 || n > DKF_MAX_DIM || m > DKF_MAX_DIM || p > DKF_MAX_DIM ||
        n + p > DKF_MAX_DIM)
        return DKF_ERR_CAPACITY;
    N = n + p;
    if (storage_len < askf_layout(&L, NULL, N, m)) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    DKF_TRY(dkf__check_input(d0, p, 1));
    DKF_TRY(dkf__check_input(Pd0, p, p));
    if (Pxd0 != NULL) DKF_TRY(dkf__check_input(Pxd0, n, p));

    memset(&g, 0, sizeof g);
    g.n = n;
    g.m = m;
    g.p = p;
    (void)askf_layout(&L, storage, N, m);
    g.priv.aug = L.phi;
    /* X0 and P^a_0 are staged in the (still unused) Q^a and Phi areas */
    dkf__view(&X0, N, 1, L.qa);
    dkf__view(&Pa0, N, N, L.phi);
    dkf__copy(X0.data, x0->data, n);
    dkf__copy(X0.data + n, d0->data, p);
    dkf__put_sym_blocks(Pa0.data, P0->data, Pxd0 != NULL ? Pxd0->data : NULL, Pd0->data, n, p);
    DKF_TRY(dkf_kf_init(&g.kf, N, m, L.kf, DKF_KF_STORAGE_LEN(N, m), &X0, &Pa0));
    g.priv.ready = 1;
    *f = g;
    return DKF_OK;
}

dkf_status_t dkf_askf_predict(dkf_askf_t *f, const dkf_ui_dyn_t *dyn)
{
    dkf_mat_t Phi, Qa;
    askf_layout_t L;
    dkf_kf_dyn_t aug; /* {Phi, Q^a} */
    size_t n, p, N;
    DKF_CHECK_NULL(f);
    if (!f->priv.ready) return DKF_ERR_STATE;
    DKF_CHECK_NULL(dyn);
    n = f->n;
    p = f->p;
    N = n + p;
    DKF_TRY(dkf__check_input(dyn->F, n, n));
    DKF_TRY(dkf__check_input(dyn->Q, n, n));
    DKF_TRY(dkf__check_input(dyn->B, p, p));
    DKF_TRY(dkf__check_input(dyn->Rd, p, p));
    L = layout_of(f);
    dkf__view(&Phi, N, N, L.phi);
    dkf__view(&Qa, N, N, L.qa);
    dkf__put_sym_blocks(Phi.data, dyn->F->data, NULL, dyn->B->data, n, p);
    dkf__put_sym_blocks(Qa.data, dyn->Q->data, NULL, dyn->Rd->data, n, p);
    aug.F = &Phi;
    aug.Q = &Qa;
    return dkf_kf_predict(&f->kf, &aug, NULL);
}

dkf_status_t dkf_askf_update(dkf_askf_t *f, const dkf_ui_meas_t *meas, const dkf_mat_t *y)
{
    dkf_mat_t Ha;
    dkf_kf_meas_t aug; /* {H^a, R} */
    size_t n, m, p, N;
    DKF_CHECK_NULL(f);
    if (!f->priv.ready) return DKF_ERR_STATE;
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
    dkf__view(&Ha, m, N, layout_of(f).ha);
    dkf__put_block(Ha.data, N, 0, 0, meas->H->data, m, n);
    dkf__put_block(Ha.data, N, 0, n, meas->D->data, m, p);
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
    if (!f->priv.ready) return DKF_ERR_STATE;
    return get_block(f, 0, f->n, x, Px);
}

dkf_status_t dkf_askf_input(const dkf_askf_t *f, dkf_mat_t *d, dkf_mat_t *Pd)
{
    DKF_CHECK_NULL(f);
    if (!f->priv.ready) return DKF_ERR_STATE;
    return get_block(f, f->n, f->p, d, Pd);
}
