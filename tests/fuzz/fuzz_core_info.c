/*
 * fuzz_core_info - the information filter (dkf/info.h): init, then up to
 * 24 predicts, contributions and fusions of 0-2 contributions, on
 * byte-edited inputs (fuzz_core.h). Property: a failed call leaves the
 * struct and DKF_INFO_STATE_LEN reals of storage (a failed contribution:
 * its outputs i, I) byte-identical; after a successful one x, P, y, Y are
 * finite and Y is exactly symmetric.
 */
#include "dkf/info.h"
#include "fuzz_core.h"

#define NMAX 5
#define MMAX 4

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static dkf_real_t st[DKF_INFO_STORAGE_LEN(NMAX)];
    static dkf_real_t work[DKF_INFO_CONTRIB_WORK(NMAX + 1, MMAX + 1)];
    static fz_snap_t snap, out;
    static fz_mat_t x0, P0, F, Q, C, R, zm, ci[2], cI[2];
    fz_mat_t *const init_m[] = {&x0, &P0}, *const pred_m[] = {&F, &Q},
                    *const con_m[] = {&C, &R, &zm}, *const fuse_m[] = {&ci[0], &ci[1], &cI[0], &cI[1]};
    fz_t z = {data, size, 0};
    dkf_info_t f;
    dkf_status_t s;
    size_t n, op, j;
    n = fz_dim(&z, NMAX);
    memset(&f, 0, sizeof f);
    fz_set(&x0, n, 1, DKF_R(0.5), DKF_R(0.5));
    fz_set(&P0, n, n, DKF_R(1.0), DKF_R(0.1));
    fz_edit(&z, init_m, 2);
    /* a non-symmetric prior is accepted (one triangle is read): then no
     * symmetry is promised */
    const int sym = P0.v.data == NULL || fz_is_symmetric(P0.v.data, P0.v.rows);
    fz_regions_clear(&snap);
    fz_region(&snap, &f, sizeof f);
    fz_take(&snap);
    s = dkf_info_init(&f, n, st, DKF_INFO_STORAGE_LEN(n), &x0.v, &P0.v);
    if (!fz_after(&snap, s)) return 0;
    fz_region(&snap, st, DKF_INFO_STATE_LEN(n) * sizeof(dkf_real_t));
    for (j = 0; j < 2; ++j) {
        fz_set(&ci[j], n, 1, DKF_R(0.0), DKF_R(0.1));
        fz_set(&cI[j], n, n, DKF_R(1.0), DKF_R(0.0));
    }
    for (op = 0; op < 24 && fz_more(&z); ++op) {
        const uint8_t code = fz_byte(&z);
        if (code % 3 == 0) {
            fz_set(&F, n, n, DKF_R(1.0), DKF_R(0.05));
            fz_set(&Q, n, n, DKF_R(0.1), DKF_R(0.0));
            fz_edit(&z, pred_m, 2);
            fz_take(&snap);
            s = dkf_info_predict(&f, &(dkf_kf_dyn_t){&F.v, &Q.v});
        } else if (code % 3 == 1) {
            /* a sensor's contribution into slot j (touches no filter) */
            const size_t m = fz_dim(&z, MMAX);
            j = (code >> 2) & 1;
            fz_set(&C, m, n, DKF_R(1.0), DKF_R(0.0));
            fz_set(&R, m, m, DKF_R(0.5), DKF_R(0.0));
            fz_set(&zm, m, 1, DKF_R(0.2), DKF_R(0.2));
            fz_edit(&z, con_m, 3);
            fz_regions_clear(&out);
            fz_region(&out, ci[j].d, sizeof ci[j].d);
            fz_region(&out, cI[j].d, sizeof cI[j].d);
            fz_take(&out);
            s = dkf_info_contribution(&ci[j].v, &cI[j].v, &(dkf_kf_meas_t){&C.v, &R.v}, &zm.v, work);
            if (fz_after(&out, s)) {
                fz_finite(ci[j].d, n);
                fz_finite(cI[j].d, n * n);
                fz_symmetric(cI[j].d, n, 1);
            }
            continue;
        } else {
            const dkf_mat_t iv[2] = {ci[0].v, ci[1].v}, Iv[2] = {cI[0].v, cI[1].v};
            fz_edit(&z, fuse_m, 4);
            fz_take(&snap);
            s = dkf_info_fuse(&f, iv, Iv, (size_t)(code >> 2) % 3);
            for (j = 0; j < 2; ++j) {
                fz_set(&ci[j], n, 1, DKF_R(0.0), DKF_R(0.1));
                fz_set(&cI[j], n, n, DKF_R(1.0), DKF_R(0.0));
            }
        }
        if (fz_after(&snap, s)) {
            fz_finite(st, DKF_INFO_STATE_LEN(n));
            fz_symmetric(f.Y.data, n, sym);
        }
    }
    return 0;
}
