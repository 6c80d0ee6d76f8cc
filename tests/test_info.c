/*
 * Information filter and exact multi-sensor fusion (dkf/info.h): the
 * seed-001 linear golden vector, equality with the stacked-measurement KF,
 * and failure atomicity.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/info.h"
#include "dkf/kf.h"
#include "dkf_test.h"

#define N 8
#define SENSORS 4
#define MS 3

typedef struct {
    DKF_INFO_DECLARE(, f, N);
} info_box_t;

/* The file's own rule: |got - expected| <= atol + rtol * max(1, max|e|)
 * with rtol 1e-8, atol 1e-10 (double). Float: cond(Y) ~ 30 and n = 4, so an
 * inversion costs ~cond * n * eps ~ 1.4e-5 relative; the filter forgets,
 * so errors do not grow: 2e-5 (observed 8.6e-7). */
#if DKF_USE_FLOAT
#define VEC_REL 2e-5
#else
#define VEC_REL 1e-8
#endif

static void load(const json_t *node, dkf_real_t *dst, dkf_mat_t *M)
{
    double tmp[N * N];
    size_t r, c, cnt = test_json_array(node, tmp, N * N, &r, &c);
    test_to_real(dst, tmp, cnt);
    M->rows = r;
    M->cols = c;
    M->data = dst;
}

static void expect(const char *what, const dkf_real_t *got, const json_t *e)
{
    double tmp[N * N];
    size_t cnt = test_json_array(e, tmp, N * N, NULL, NULL);
    /* atol 1e-10 is below rtol * max(1, .) = 1e-8 so rtol alone decides */
    test_assert_close(what, got, tmp, cnt, VEC_REL);
}

static void test_info_matches_lif_vector(void **state)
{
    static info_box_t b;
    json_t *root = test_load_vector("infofusion/lif_central_fusion.json");
    const json_t *c = json_array_get(test_json_get(root, "cases"), 0);
    const json_t *steps = test_json_get(c, "steps");
    const json_t *Cs = test_json_get(c, "H"), *Rs = test_json_get(c, "R");
    size_t ns = json_array_size(Cs), j, s;
    dkf_real_t x0d[N], P0d[N * N], Fd[N * N], Qd[N * N], Cd[SENSORS][MS * N],
        Rd[SENSORS][MS * MS], zd[MS], id[SENSORS][N], Id[SENSORS][N * N];
    dkf_real_t work[DKF_INFO_CONTRIB_WORK(N, MS)];
    dkf_mat_t x0, P0, F, Q, C[SENSORS], R[SENSORS], z, i[SENSORS], I[SENSORS];
    (void)state;
    test_reset_worst_rel();
    assert_true(ns <= SENSORS);
    load(test_json_get(c, "x0"), x0d, &x0);
    load(test_json_get(c, "P0"), P0d, &P0);
    load(test_json_get(c, "Q"), Qd, &Q);
    for (s = 0; s < ns; ++s) {
        load(json_array_get(Cs, s), Cd[s], &C[s]);
        load(json_array_get(Rs, s), Rd[s], &R[s]);
        i[s] = (dkf_mat_t)DKF_MAT(x0.rows, 1, id[s]);
        I[s] = (dkf_mat_t)DKF_MAT(x0.rows, x0.rows, Id[s]);
    }
    assert_int_equal(dkf_info_init(&b.f, x0.rows, b.f_storage, sizeof b.f_storage / sizeof(dkf_real_t),
                                   &x0, &P0),
                     DKF_OK);
    assert_true(json_array_size(steps) == 30);
    for (j = 0; j < json_array_size(steps); ++j) {
        const json_t *st = json_array_get(steps, j), *e = test_json_get(st, "expected");
        const json_t *zs = test_json_get(st, "z");
        load(test_json_get(st, "F"), Fd, &F);
        assert_int_equal(dkf_info_predict(&b.f, &(dkf_kf_dyn_t){&F, &Q}), DKF_OK);
        expect("x_pred", b.f.x.data, test_json_get(e, "x_pred"));
        expect("P_pred", b.f.P.data, test_json_get(e, "P_pred"));
        expect("Y_pred", b.f.Y.data, test_json_get(e, "Y_pred"));
        expect("y_pred", b.f.y.data, test_json_get(e, "y_pred"));
        for (s = 0; s < ns; ++s) {
            load(json_array_get(zs, s), zd, &z);
            assert_int_equal(dkf_info_contribution(&i[s], &I[s], &(dkf_kf_meas_t){&C[s], &R[s]}, &z, work), DKF_OK);
            expect("i_j", i[s].data, json_array_get(test_json_get(e, "i"), s));
            expect("I_j", I[s].data, json_array_get(test_json_get(e, "I"), s));
        }
        assert_int_equal(dkf_info_fuse(&b.f, i, I, ns), DKF_OK);
        expect("Y", b.f.Y.data, test_json_get(e, "Y"));
        expect("y", b.f.y.data, test_json_get(e, "y"));
        expect("x", b.f.x.data, test_json_get(e, "x"));
        expect("P", b.f.P.data, test_json_get(e, "P"));
    }
    json_decref(root);
    print_message("worst relative error %.3e\n", test_worst_rel());
}

/* Exact fusion: the sum of per-sensor information contributions equals the
 * Kalman update on the stacked measurement (block-diagonal R). Random
 * 6-state model, 3 sensors of dimensions 1, 2, 3 (correlated R within a
 * sensor), time-varying F, 30 steps. Tolerance: the two are algebraically
 * identical and differ only by rounding in two different inversions;
 * cond(P) stays below 1e2, so 1e-9 (the vectors' tolerance) holds with room in
 * double (observed 5e-15); in float 1e-4 ~ cond * n * eps (observed 1.8e-6). */
static void test_info_fusion_equals_stacked_kf(void **state)
{
    static info_box_t b;
    static struct {
        DKF_KF_DECLARE(, kf, N, 6);
    } k;
    const size_t n = 6, dims[3] = {1, 2, 3};
    double P0[N * N], x0[N], F[N * N], Q[N * N];
    dkf_real_t x0r[N], P0r[N * N], Fr[N * N], Qr[N * N];
    dkf_real_t Cr[3][MS * N], Rr[3][MS * MS], zr[3][MS], Hs[6 * N], Rs[6 * 6], ys[6];
    dkf_real_t id[3][N], Id[3][N * N], work[DKF_INFO_CONTRIB_WORK(N, MS)];
    dkf_mat_t X0 = DKF_MAT(6, 1, x0r), PP0 = DKF_MAT(6, 6, P0r), Fm = DKF_MAT(6, 6, Fr),
              Qm = DKF_MAT(6, 6, Qr), Hm = DKF_MAT(6, 6, Hs), Rm = DKF_MAT(6, 6, Rs),
              Ym = DKF_MAT(6, 1, ys), i[3], I[3];
    const double rel = DKF_USE_FLOAT ? 1e-4 : 1e-9;
    test_rng_t rng;
    size_t step, s, a, c;
    (void)state;
    test_reset_worst_rel();
    test_rng_seed(&rng, 7);
    test_rand_gauss(&rng, x0, n, 1);
    test_rand_spd(&rng, P0, n, 10.0, 1.0);
    test_to_real(x0r, x0, n);
    test_to_real(P0r, P0, n * n);
    assert_int_equal(dkf_info_init(&b.f, n, b.f_storage, DKF_INFO_STORAGE_LEN(N), &X0, &PP0),
                     DKF_OK);
    assert_int_equal(dkf_kf_init(&k.kf, n, 6, k.kf_storage, DKF_KF_STORAGE_LEN(N, 6), &X0, &PP0),
                     DKF_OK);
    for (step = 0; step < 30; ++step) {
        size_t row = 0;
        test_rand_orthogonal(&rng, F, n);
        for (a = 0; a < n * n; ++a) F[a] *= 0.97;
        test_rand_spd(&rng, Q, n, 4.0, 0.05);
        test_to_real(Fr, F, n * n);
        test_to_real(Qr, Q, n * n);
        memset(Rs, 0, sizeof Rs);
        for (s = 0; s < 3; ++s) {
            double C[MS * N], R[MS * MS], z[MS];
            dkf_mat_t Cm = DKF_MAT(dims[s], n, Cr[s]), Rsm = DKF_MAT(dims[s], dims[s], Rr[s]),
                      zm = DKF_MAT(dims[s], 1, zr[s]);
            test_rand_gauss(&rng, C, dims[s], n);
            test_rand_spd(&rng, R, dims[s], 5.0, 0.3);
            test_rand_gauss(&rng, z, dims[s], 1);
            test_to_real(Cr[s], C, dims[s] * n);
            test_to_real(Rr[s], R, dims[s] * dims[s]);
            test_to_real(zr[s], z, dims[s]);
            i[s] = (dkf_mat_t)DKF_MAT(n, 1, id[s]);
            I[s] = (dkf_mat_t)DKF_MAT(n, n, Id[s]);
            assert_int_equal(dkf_info_contribution(&i[s], &I[s], &(dkf_kf_meas_t){&Cm, &Rsm}, &zm, work), DKF_OK);
            /* stacked H, block-diagonal R, stacked y */
            for (a = 0; a < dims[s]; ++a) {
                for (c = 0; c < n; ++c) Hs[(row + a) * n + c] = Cr[s][a * n + c];
                for (c = 0; c < dims[s]; ++c) Rs[(row + a) * 6 + row + c] = Rr[s][a * dims[s] + c];
                ys[row + a] = zr[s][a];
            }
            row += dims[s];
        }
        assert_int_equal(dkf_info_predict(&b.f, &(dkf_kf_dyn_t){&Fm, &Qm}), DKF_OK);
        assert_int_equal(dkf_info_fuse(&b.f, i, I, 3), DKF_OK);
        assert_int_equal(dkf_kf_predict(&k.kf, &(dkf_kf_dyn_t){&Fm, &Qm}, NULL), DKF_OK);
        assert_int_equal(dkf_kf_update(&k.kf, &(dkf_kf_meas_t){&Hm, &Rm}, &Ym), DKF_OK);
        {
            double xk[N], Pk[N * N];
            test_to_double(xk, k.kf.x.data, n);
            test_to_double(Pk, k.kf.P.data, n * n);
            test_assert_close("fused x vs stacked KF", b.f.x.data, xk, n, rel);
            test_assert_close("fused P vs stacked KF", b.f.P.data, Pk, n * n, rel);
        }
    }
    print_message("worst relative error %.3e\n", test_worst_rel());
}

static void test_info_failures_leave_state_untouched(void **state)
{
    static info_box_t b;
    static dkf_real_t before[DKF_INFO_STORAGE_LEN(N)];
    static dkf_info_t fbefore;
    dkf_real_t x0d[2] = {1, -1}, P0d[4] = {1, 0.2, 0.2, 2}, Fd[4] = {1, 1, 0, 1},
               Qd[4] = {0.1, 0, 0, 0.1}, Cd[2] = {1, 0}, Rd[1] = {0.5}, zd[1] = {0.3},
               Rbad[1] = {0}, Ineg[4] = {-10, 0, 0, -10}, inan[2] = {(dkf_real_t)NAN, 0};
    dkf_real_t id[2], Id[4], work[DKF_INFO_CONTRIB_WORK(2, 1)], keep_i[2], keep_I[4];
    dkf_mat_t x0 = DKF_MAT(2, 1, x0d), P0 = DKF_MAT(2, 2, P0d), F = DKF_MAT(2, 2, Fd),
              Q = DKF_MAT(2, 2, Qd), C = DKF_MAT(1, 2, Cd), R = DKF_MAT(1, 1, Rd),
              z = DKF_MAT(1, 1, zd), Rb = DKF_MAT(1, 1, Rbad), i = DKF_MAT(2, 1, id),
              I = DKF_MAT(2, 2, Id), In = DKF_MAT(2, 2, Ineg), in = DKF_MAT(2, 1, inan);
    const size_t state_len = 2 + 4 + 2 + 4;
    (void)state;
    assert_int_equal(dkf_info_init(&b.f, 2, b.f_storage, DKF_INFO_STORAGE_LEN(2), &x0, &P0),
                     DKF_OK);
    assert_int_equal(dkf_info_predict(&b.f, &(dkf_kf_dyn_t){&F, &Q}), DKF_OK);
    assert_int_equal(dkf_info_contribution(&i, &I, &(dkf_kf_meas_t){&C, &R}, &z, work), DKF_OK);
    memcpy(keep_i, id, sizeof id);
    memcpy(keep_I, Id, sizeof Id);
    /* a singular R: contribution refused, outputs untouched */
    assert_int_equal(dkf_info_contribution(&i, &I, &(dkf_kf_meas_t){&C, &Rb}, &z, work), DKF_ERR_NOT_SPD);
    assert_memory_equal(keep_i, id, sizeof id);
    assert_memory_equal(keep_I, Id, sizeof Id);
    /* outputs aliasing inputs are refused */
    {
        dkf_mat_t z_in_i = DKF_MAT(1, 1, id);
        assert_int_equal(dkf_info_contribution(&i, &I, &(dkf_kf_meas_t){&C, &R}, &z_in_i, work), DKF_ERR_ALIAS);
    }

    fbefore = b.f;
    memcpy(before, b.f.x.data, state_len * sizeof(dkf_real_t));
    /* fusing a contribution that makes Y indefinite */
    assert_int_equal(dkf_info_fuse(&b.f, &i, &In, 1), DKF_ERR_NOT_SPD);
    assert_memory_equal(&fbefore, &b.f, sizeof fbefore);
    assert_memory_equal(before, b.f.x.data, state_len * sizeof(dkf_real_t));
    /* a NaN information vector */
    assert_int_equal(dkf_info_fuse(&b.f, &in, &I, 1), DKF_ERR_NONFINITE);
    assert_memory_equal(before, b.f.x.data, state_len * sizeof(dkf_real_t));
    /* wrong shapes */
    assert_int_equal(dkf_info_fuse(&b.f, &I, &I, 1), DKF_ERR_DIM);
    assert_int_equal(dkf_info_predict(&b.f, &(dkf_kf_dyn_t){&C, &Q}), DKF_ERR_DIM);
    assert_memory_equal(before, b.f.x.data, state_len * sizeof(dkf_real_t));
    /* a fuse with no contributions just recomputes x, P from the same Y, y */
    assert_int_equal(dkf_info_fuse(&b.f, NULL, NULL, 0), DKF_OK);
    assert_int_equal(dkf_info_fuse(&b.f, &i, &I, 1), DKF_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_info_matches_lif_vector),
        cmocka_unit_test(test_info_fusion_equals_stacked_kf),
        cmocka_unit_test(test_info_failures_leave_state_untouched),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
