/*
 * fuzz_core_wfusion - seed 002's weighted fusion (dkf/wfusion.h): a fusion
 * of 1-3 sensors (state n <= 4, measurements m_i <= 3) started from a
 * byte-edited prior, then up to 24 operations: a step of every local
 * filter and of the cross covariances (with or without the measurements),
 * the switch to the steady state, scalar and matrix fusion over a
 * byte-chosen set of present sensors (and byte-edited estimates), on
 * byte-edited F, Q, H_i, R_i, y_i (fuzz_core.h), and a restore of a saved
 * checkpoint with a byte-chosen element edited or one real short
 * (fz_ckpt_restore_len). Property: a failed call
 * leaves the structs, every node's DKF_WFUSION_LOCAL_STATE_LEN reals and
 * the fusion's joint covariance and results byte-identical; after a
 * successful one they are finite and the joint covariance is exactly
 * symmetric (unless the prior was not, or an edited checkpoint was
 * restored).
 */
#include "dkf/wfusion.h"
#include "fuzz_core.h"

#define NMAX 4
#define LMAX 3
#define MMAX 3

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    DKF_WFUSION_DECLARE(static, fu, NMAX, LMAX, MMAX);
    static fz_snap_t snap;
    static fz_mat_t x0, P0, Hs, F, Q, H[LMAX], R[LMAX], y[LMAX], xe[LMAX];
    fz_mat_t *const init_m[] = {&x0, &P0, &Hs}, *const dyn_m[] = {&F, &Q};
    fz_mat_t *meas_m[3 * LMAX], *est_m[LMAX];
    dkf_kf_meas_t meas[LMAX];
    dkf_mat_t yv[LMAX];
    const dkf_mat_t *xs[LMAX];
    fz_t z = {data, size, 0};
    size_t n, l, m[LMAX], i, op, N, own;
    int sym; /* 0 for a prior not exactly symmetric, or once a restore took an
                edited checkpoint (any finite values) */
    dkf_status_t s;
    n = fz_dim(&z, NMAX);
    l = fz_dim(&z, LMAX);
    for (i = 0; i < l; ++i) m[i] = fz_dim(&z, MMAX);
    fz_set(&x0, n, 1, DKF_R(0.5), DKF_R(0.5));
    fz_set(&P0, n, n, DKF_R(1.0), DKF_R(0.1));
    fz_set(&Hs, 1, n, DKF_R(1.0), DKF_R(0.0));
    fz_edit(&z, init_m, 3);
    /* init copies P0 into every block of Pj: a prior that is not exactly
     * symmetric (an edit, or -0 against +0) makes no symmetric Pj */
    sym = P0.v.data == NULL || fz_is_symmetric(P0.v.data, P0.v.rows);
    memset(&fu, 0, sizeof fu);
    fz_regions_clear(&snap);
    fz_region(&snap, &fu, sizeof fu);
    fz_region(&snap, fu_nodes, sizeof fu_nodes);
    fz_take(&snap);
    s = dkf_wfusion_init(&fu, n, l, m, fu_nodes, fu_storage, dkf_wfusion_storage_len(n, l, m),
                         &Hs.v, &x0.v, &P0.v);
    if (!fz_after(&snap, s)) return 0;
    N = n * l;
    own = N * N + n + l * l + l + n * N + n + n * n; /* Pj, Hs, PS, w, A, xf, Pf */
    for (i = 0; i < l; ++i)
        fz_region(&snap, fu_nodes[i].x.data, DKF_WFUSION_LOCAL_STATE_LEN(n, m[i]) * sizeof(dkf_real_t));
    fz_region(&snap, fu.Pj.data, own * sizeof(dkf_real_t));
    for (i = 0; i < l; ++i) {
        meas_m[3 * i] = &H[i];
        meas_m[3 * i + 1] = &R[i];
        meas_m[3 * i + 2] = &y[i];
        est_m[i] = &xe[i];
    }
    for (op = 0; op < 24 && fz_more(&z); ++op) {
        const uint8_t code = fz_byte(&z);
        if (code % 4 <= 1) {
            /* one step: code % 4 == 1 without measurements (a centre) */
            fz_set(&F, n, n, DKF_R(0.9), DKF_R(0.05));
            fz_set(&Q, n, n, DKF_R(0.1), DKF_R(0.0));
            for (i = 0; i < l; ++i) {
                fz_set(&H[i], m[i], n, DKF_R(1.0), DKF_R(0.0));
                fz_set(&R[i], m[i], m[i], DKF_R(0.5), DKF_R(0.0));
                fz_set(&y[i], m[i], 1, DKF_R(0.3), DKF_R(0.3));
                meas[i].H = &H[i].v;
                meas[i].R = &R[i].v;
            }
            fz_edit(&z, dyn_m, 2);
            fz_edit(&z, meas_m, 3 * l);
            for (i = 0; i < l; ++i) yv[i] = y[i].v;
            fz_take(&snap);
            s = dkf_wfusion_step(&fu, &(dkf_kf_dyn_t){&F.v, &Q.v}, meas, code % 4 == 1 ? NULL : yv);
        } else if (code % 4 == 2 && (code & 4)) {
            fz_set(&F, n, n, DKF_R(0.9), DKF_R(0.05));
            fz_set(&Q, n, n, DKF_R(0.1), DKF_R(0.0));
            for (i = 0; i < l; ++i) {
                fz_set(&H[i], m[i], n, DKF_R(1.0), DKF_R(0.0));
                fz_set(&R[i], m[i], m[i], DKF_R(0.5), DKF_R(0.0));
                meas[i].H = &H[i].v;
                meas[i].R = &R[i].v;
            }
            fz_edit(&z, dyn_m, 2);
            fz_edit(&z, meas_m, 3 * l);
            fz_take(&snap);
            s = dkf_wfusion_steady(&fu, &(dkf_kf_dyn_t){&F.v, &Q.v}, meas);
        } else if (code % 4 == 3 && (code & 64)) {
            static dkf_real_t ck[DKF_WFUSION_STORAGE_LEN(NMAX, LMAX, MMAX)];
            const size_t cl = dkf_wfusion_checkpoint_len(&fu);
            size_t rl;
            FZ_CHECK(cl > 0 && cl <= sizeof ck / sizeof ck[0]);
            FZ_CHECK(dkf_wfusion_save(&fu, ck, cl) == DKF_OK);
            rl = fz_ckpt_restore_len(&z, code, ck, cl, &sym);
            fz_take(&snap);
            s = dkf_wfusion_restore(&fu, ck, rl);
        } else {
            /* a fusion over the sensors of a byte's mask, on the nodes' own
             * estimates (code & 8) or byte-edited ones */
            const uint8_t mask = fz_byte(&z);
            for (i = 0; i < l; ++i) fz_set(&xe[i], n, 1, DKF_R(0.1), DKF_R(0.2));
            fz_edit(&z, est_m, l);
            for (i = 0; i < l; ++i)
                xs[i] = (mask >> i) & 1 ? NULL : (code & 8) ? &fu_nodes[i].x : &xe[i].v;
            fz_take(&snap);
            s = (code & 16) ? dkf_wfusion_fuse_matrix(&fu, mask == 0xff ? NULL : xs)
                            : dkf_wfusion_fuse_scalar(&fu, mask == 0xff ? NULL : xs);
        }
        if (fz_after(&snap, s)) {
            for (i = 0; i < l; ++i)
                fz_finite(fu_nodes[i].x.data, DKF_WFUSION_LOCAL_STATE_LEN(n, m[i]));
            fz_finite(fu.Pj.data, own);
            fz_symmetric(fu.Pj.data, N, sym);
        }
    }
    return 0;
}
