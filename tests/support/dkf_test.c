/* Test support. Scratch arrays of DKF_MAX_DIM^2 reals are static, not on the
 * stack: 8 MB each in a DKF_MAX_DIM = 1024 build (the tests are single-threaded). */
#include "dkf_test.h"

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

void test_rng_seed(test_rng_t *r, uint64_t seed) { r->s = seed; }

/* splitmix64: tiny, fixed-seed reproducible on every platform. */
static uint64_t rng_next(test_rng_t *r)
{
    uint64_t z = (r->s += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

double test_rng_uniform(test_rng_t *r) { return (double)(rng_next(r) >> 11) * 0x1.0p-53; }

double test_rng_normal(test_rng_t *r)
{
    double u1 = test_rng_uniform(r), u2 = test_rng_uniform(r);
    if (u1 < 1e-300) u1 = 1e-300;
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

void test_rand_gauss(test_rng_t *r, double *A, size_t rows, size_t cols)
{
    size_t i;
    for (i = 0; i < rows * cols; ++i) A[i] = test_rng_normal(r);
}

void test_rand_orthogonal(test_rng_t *r, double *Q, size_t n)
{
    size_t i, j, k, pass;
    test_rand_gauss(r, Q, n, n);
    /* columns of Q orthonormalised by modified Gram-Schmidt, twice */
    for (pass = 0; pass < 2; ++pass) {
        for (j = 0; j < n; ++j) {
            double nrm = 0.0;
            for (k = 0; k < j; ++k) {
                double d = 0.0;
                for (i = 0; i < n; ++i) d += Q[i * n + k] * Q[i * n + j];
                for (i = 0; i < n; ++i) Q[i * n + j] -= d * Q[i * n + k];
            }
            for (i = 0; i < n; ++i) nrm += Q[i * n + j] * Q[i * n + j];
            nrm = sqrt(nrm);
            for (i = 0; i < n; ++i) Q[i * n + j] /= nrm;
        }
    }
}

void test_mat_with_singular_values(test_rng_t *r, double *A, size_t rows, size_t cols,
                                   const double *s)
{
    static double U[DKF_MAX_DIM * DKF_MAX_DIM], V[DKF_MAX_DIM * DKF_MAX_DIM];
    size_t i, j, l, k = rows < cols ? rows : cols;
    test_rand_orthogonal(r, U, rows);
    test_rand_orthogonal(r, V, cols);
    for (i = 0; i < rows; ++i)
        for (j = 0; j < cols; ++j) {
            double acc = 0.0;
            for (l = 0; l < k; ++l) acc += U[i * rows + l] * s[l] * V[j * cols + l];
            A[i * cols + j] = acc;
        }
}

void test_sym_with_eigenvalues(test_rng_t *r, double *A, const double *lambda, size_t n)
{
    static double Q[DKF_MAX_DIM * DKF_MAX_DIM];
    size_t i, j, l;
    test_rand_orthogonal(r, Q, n);
    for (i = 0; i < n; ++i)
        for (j = 0; j <= i; ++j) {
            double acc = 0.0;
            for (l = 0; l < n; ++l) acc += Q[i * n + l] * lambda[l] * Q[j * n + l];
            A[i * n + j] = A[j * n + i] = acc;
        }
}

void test_rand_spd(test_rng_t *r, double *A, size_t n, double cond, double scale)
{
    double s[DKF_MAX_DIM];
    size_t i;
    for (i = 0; i < n; ++i)
        s[i] = scale * (n > 1 ? pow(cond, (double)i / (double)(n - 1)) : 1.0);
    test_sym_with_eigenvalues(r, A, s, n);
}

void test_ref_mul(double *C, const double *A, const double *B, size_t r, size_t k, size_t c)
{
    size_t i, j, l;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) {
            double acc = 0.0;
            for (l = 0; l < k; ++l) acc += A[i * k + l] * B[l * c + j];
            C[i * c + j] = acc;
        }
}

void test_ref_transpose(double *At, const double *A, size_t r, size_t c)
{
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) At[j * r + i] = A[i * c + j];
}

void test_ref_inverse(long double *Ainv, long double *W, size_t n)
{
    size_t i, j, k;
    for (i = 0; i < n * n; ++i) Ainv[i] = (i / n == i % n) ? 1.0L : 0.0L;
    for (k = 0; k < n; ++k) {
        size_t p = k;
        long double d;
        for (i = k + 1; i < n; ++i)
            if (fabsl(W[i * n + k]) > fabsl(W[p * n + k])) p = i;
        for (j = 0; j < n; ++j) {
            long double t = W[k * n + j];
            W[k * n + j] = W[p * n + j];
            W[p * n + j] = t;
            t = Ainv[k * n + j];
            Ainv[k * n + j] = Ainv[p * n + j];
            Ainv[p * n + j] = t;
        }
        d = W[k * n + k];
        assert_true(d != 0);
        for (j = 0; j < n; ++j) {
            W[k * n + j] /= d;
            Ainv[k * n + j] /= d;
        }
        for (i = 0; i < n; ++i) {
            long double f = W[i * n + k];
            if (i == k || f == 0) continue;
            for (j = 0; j < n; ++j) {
                W[i * n + j] -= f * W[k * n + j];
                Ainv[i * n + j] -= f * Ainv[k * n + j];
            }
        }
    }
}

void test_ref_inverse_double(double *Ainv, const double *A, size_t n)
{
    static long double W[DKF_MAX_DIM * DKF_MAX_DIM], X[DKF_MAX_DIM * DKF_MAX_DIM];
    size_t i;
    assert_true(n <= DKF_MAX_DIM);
    for (i = 0; i < n * n; ++i) W[i] = A[i];
    test_ref_inverse(X, W, n);
    for (i = 0; i < n * n; ++i) Ainv[i] = (double)X[i];
}

void test_to_real(dkf_real_t *dst, const double *src, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) dst[i] = (dkf_real_t)src[i];
}

void test_to_double(double *dst, const dkf_real_t *src, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) dst[i] = (double)src[i];
}

double test_max_abs_diff(const dkf_real_t *a, const double *b, size_t n)
{
    double m = 0.0;
    size_t i;
    for (i = 0; i < n; ++i) {
        double d = fabs((double)a[i] - b[i]);
        if (!(d <= m)) m = d; /* NaN propagates as the maximum */
    }
    return m;
}

double test_max_abs(const double *a, size_t n)
{
    double m = 0.0;
    size_t i;
    for (i = 0; i < n; ++i)
        if (fabs(a[i]) > m) m = fabs(a[i]);
    return m;
}

dkf_mat_t test_view(size_t rows, size_t cols, dkf_real_t *data)
{
    dkf_mat_t m = DKF_MAT(rows, cols, data);
    return m;
}

void test_fill(dkf_real_t *p, size_t n, dkf_real_t v)
{
    size_t i;
    for (i = 0; i < n; ++i) p[i] = v;
}

void test_assert_same_members(const void *got, const void *want, const test_member_t *m, size_t k)
{
    const unsigned char *g = (const unsigned char *)got, *w = (const unsigned char *)want;
    size_t i;
    for (i = 0; i < k; ++i)
        if (memcmp(g + m[i].offset, w + m[i].offset, m[i].size) != 0)
            fail_msg("%s changed", m[i].name);
}

double test_orth_err(const dkf_real_t *Q, size_t r, size_t k)
{
    double m = 0.0;
    size_t i, j, l;
    for (i = 0; i < k; ++i)
        for (j = 0; j < k; ++j) {
            double acc = (i == j) ? -1.0 : 0.0;
            for (l = 0; l < r; ++l) acc += (double)Q[l * k + i] * (double)Q[l * k + j];
            if (fabs(acc) > m) m = fabs(acc);
        }
    return m;
}

static double worst_rel;

double test_worst_rel(void) { return worst_rel; }
void test_reset_worst_rel(void) { worst_rel = 0.0; }

void test_assert_close(const char *what, const dkf_real_t *got, const double *expected, size_t n,
                       double rel)
{
    double scale = test_max_abs(expected, n);
    double err = test_max_abs_diff(got, expected, n);
    if (scale < 1.0) scale = 1.0;
    if (err / scale > worst_rel) worst_rel = err / scale;
    if (!(err <= rel * scale)) {
        print_error("%s: max|got - expected| = %.3e > %.3e (rel %.1e x scale %.3e)\n", what, err,
                    rel * scale, rel, scale);
        fail();
    }
}

json_t *test_load_vector(const char *rel)
{
    char path[512];
    json_error_t e;
    json_t *root;
    snprintf(path, sizeof path, "%s/%s", DKF_VECTOR_DIR, rel);
    root = json_load_file(path, 0, &e);
    if (root == NULL) {
        print_error("%s:%d: %s\n", path, e.line, e.text);
        fail();
    }
    return root;
}

json_t *test_json_get(const json_t *obj, const char *key)
{
    json_t *v = json_object_get(obj, key);
    if (v == NULL) {
        print_error("missing key '%s'\n", key);
        fail();
    }
    return v;
}

void test_load_run_vector(test_run_vector_t *v, const char *rel, const char *filter)
{
    v->root = test_load_vector(rel);
    v->model = test_json_get(v->root, "model");
    v->init = test_json_get(v->root, "init");
    v->yv = test_json_get(test_json_get(v->root, "y"), "values");
    v->N = json_array_size(test_json_get(v->root, "k"));
    v->out = test_json_get(test_json_get(v->root, "outputs"), filter);
}

size_t test_json_array(const json_t *node, double *out, size_t cap, size_t *rows, size_t *cols)
{
    size_t r = 1, c = 1, i, j;
    if (json_is_number(node)) {
        assert_true(cap >= 1);
        out[0] = json_number_value(node);
    } else {
        assert_true(json_is_array(node));
        r = json_array_size(node);
        c = 1;
        if (r > 0 && json_is_array(json_array_get(node, 0))) c = json_array_size(json_array_get(node, 0));
        assert_true(r * c <= cap);
        for (i = 0; i < r; ++i) {
            const json_t *row = json_array_get(node, i);
            if (json_is_array(row)) {
                assert_int_equal(json_array_size(row), c);
                for (j = 0; j < c; ++j) {
                    assert_true(json_is_number(json_array_get(row, j)));
                    out[i * c + j] = json_number_value(json_array_get(row, j));
                }
            } else {
                assert_true(json_is_number(row) && c == 1);
                out[i] = json_number_value(row);
            }
        }
    }
    if (rows) *rows = r;
    if (cols) *cols = c;
    return r * c;
}

void test_json_mat(const json_t *node, dkf_real_t *storage, size_t cap, dkf_mat_t *M)
{
    static double tmp[DKF_MAX_DIM * DKF_MAX_DIM];
    size_t r, c, cnt;
    assert_true(cap <= DKF_MAX_DIM * DKF_MAX_DIM);
    cnt = test_json_array(node, tmp, cap, &r, &c);
    test_to_real(storage, tmp, cnt);
    M->rows = r;
    M->cols = c;
    M->data = storage;
}

const json_t *test_json_model_at(const json_t *model, const char *key, size_t k)
{
    const json_t *spec = test_json_get(model, key);
    const json_t *c = json_object_get(spec, "const");
    const json_t *m = c != NULL ? c : json_array_get(test_json_get(spec, "per_k"), k);
    assert_non_null(m);
    return m;
}

double test_rel_err(const dkf_real_t *got, const double *ref, size_t n)
{
    return test_max_abs_diff(got, ref, n) / test_max_abs(ref, n);
}

int test_psd_within(const dkf_real_t *P, size_t n, double tol)
{
    static double L[DKF_MAX_DIM * DKF_MAX_DIM];
    double tr = 0.0, d;
    size_t i, j, l;
    for (i = 0; i < n; ++i) tr += (double)P[i * n + i];
    d = tol * fabs(tr);
    for (i = 0; i < n; ++i) {
        if (!((double)P[i * n + i] >= -d)) return 0;
        for (j = 0; j <= i; ++j) {
            double s = (double)P[i * n + j] + (i == j ? d : 0.0);
            for (l = 0; l < j; ++l) s -= L[i * n + l] * L[j * n + l];
            if (i == j) {
                if (!(s > 0.0)) return 0;
                L[i * n + i] = sqrt(s);
            } else {
                L[i * n + j] = s / L[j * n + j];
            }
        }
    }
    return 1;
}

void test_assert_below(const char *what, double e, double bound)
{
    if (!(e <= bound)) {
        print_error("%s: %.3e > %.3e\n", what, e, bound);
        fail();
    }
}

const json_t *test_json_case(const json_t *root, const char *name)
{
    const json_t *cases = test_json_get(root, "cases");
    size_t i;
    for (i = 0; i < json_array_size(cases); ++i) {
        const json_t *c = json_array_get(cases, i);
        const char *nm = json_string_value(test_json_get(c, "name"));
        if (nm != NULL && strcmp(nm, name) == 0) return c;
    }
    print_error("no case %s\n", name);
    fail();
    return NULL;
}

void test_note_rel_err(double *worst, const json_t *ref, const dkf_real_t *got, size_t len)
{
    static double r[DKF_MAX_DIM * DKF_MAX_DIM];
    double e;
    assert_true(len <= DKF_MAX_DIM * DKF_MAX_DIM);
    assert_int_equal(test_json_array(ref, r, DKF_MAX_DIM * DKF_MAX_DIM, NULL, NULL), len);
    e = test_rel_err(got, r, len);
    if (!(e <= *worst)) *worst = e;
}

/* obj[key] as a size, 0 if obj has no key. */
static size_t size_or_0(const json_t *obj, const char *key)
{
    return json_object_get(obj, key) != NULL ? test_json_size(obj, key) : 0;
}

void test_stress_cases(const char *rel, const char *const names[], size_t k,
                       void (*run)(const test_stress_case_t *sc, size_t i))
{
    static test_stress_case_t sc;
    json_t *root = test_load_vector(rel);
    size_t i;
    for (i = 0; i < k; ++i) {
        sc.name = names[i];
        sc.node = test_json_case(root, names[i]);
        sc.steps = test_json_get(sc.node, "steps");
        sc.n = test_json_size(sc.node, "n");
        sc.m = size_or_0(sc.node, "m");
        sc.p = size_or_0(sc.node, "p");
        test_json_mat(test_json_get(sc.node, "x0"), sc.x0, TEST_UI_CAP, &sc.mx0);
        test_json_mat(test_json_get(sc.node, "P0"), sc.P0, TEST_UI_CAP * TEST_UI_CAP, &sc.mP0);
        run(&sc, i);
    }
    json_decref(root);
}

void test_note_rel_errs(double *worst, const json_t *st, const test_out_t *out, size_t k)
{
    size_t i;
    for (i = 0; i < k; ++i)
        test_note_rel_err(&worst[i], test_json_get(st, out[i].key), out[i].got, out[i].len);
}

void test_assert_stress_bounds(const char *who, const char *const what[], const double *worst,
                               size_t k, const double *ext, const double *seen)
{
    char msg[96];
    size_t i;
    for (i = 0; i < k; ++i) {
        if (ext != NULL && ext[i] > 0) {
            snprintf(msg, sizeof msg, "%s %s external", who, what[i]);
            test_assert_below(msg, worst[i], ext[i]);
        }
        if (seen != NULL && seen[i] >= 0) {
            snprintf(msg, sizeof msg, "%s %s regression", who, what[i]);
            test_assert_below(msg, worst[i], 4 * seen[i]);
        }
    }
}

void test_stress_verdict(const char *who, size_t steps, const char *const what[],
                         const double *worst, size_t k, double rk2, double ext,
                         const double *seen)
{
    char line[256];
    double ev[8];
    size_t i, used;
    assert_true(k <= 8);
    used = (size_t)snprintf(line, sizeof line, "%s (%zu steps): worst rel error", who, steps);
    for (i = 0; i < k; ++i) {
        if (used < sizeof line)
            used += (size_t)snprintf(line + used, sizeof line - used, " %s %.3e", what[i],
                                     worst[i]);
        ev[i] = ext < 1 ? ext : 0;
    }
    print_message("%s (rho cond^2 %.3g, bound %.3e)\n", line, rk2, ext);
    test_assert_stress_bounds(who, what, worst, k, ev, seen);
}

void test_dchol(double *L, const double *A, size_t n)
{
    size_t i, j, k;
    memset(L, 0, n * n * sizeof *L);
    for (j = 0; j < n; ++j) {
        double s = A[j * n + j];
        for (k = 0; k < j; ++k) s -= L[j * n + k] * L[j * n + k];
        assert_true(s >= 0.0);
        L[j * n + j] = sqrt(s);
        for (i = j + 1; i < n; ++i) {
            double t = A[i * n + j];
            for (k = 0; k < j; ++k) t -= L[i * n + k] * L[j * n + k];
            L[i * n + j] = s > 0.0 ? t / L[j * n + j] : 0.0;
        }
    }
}

void test_dchol_solve(const double *L, double *B, size_t n, size_t c)
{
    size_t i, j, l;
    for (j = 0; j < c; ++j) {
        for (i = 0; i < n; ++i) {
            double s = B[i * c + j];
            for (l = 0; l < i; ++l) s -= L[i * n + l] * B[l * c + j];
            B[i * c + j] = s / L[i * n + i];
        }
        for (i = n; i-- > 0;) {
            double s = B[i * c + j];
            for (l = i + 1; l < n; ++l) s -= L[l * n + i] * B[l * c + j];
            B[i * c + j] = s / L[i * n + i];
        }
    }
}

void test_draw(test_rng_t *r, double *x, const double *L, size_t n)
{
    double z[DKF_MAX_DIM];
    size_t i, j;
    assert_true(n <= DKF_MAX_DIM);
    for (i = 0; i < n; ++i) z[i] = test_rng_normal(r);
    for (i = 0; i < n; ++i) {
        x[i] = 0.0;
        for (j = 0; j <= i; ++j) x[i] += L[i * n + j] * z[j];
    }
}

double test_nees(const double *e, const double *S, size_t k)
{
    static double L[DKF_MAX_DIM * DKF_MAX_DIM];
    double w[DKF_MAX_DIM], s = 0.0;
    size_t i, j;
    assert_true(k <= DKF_MAX_DIM);
    test_dchol(L, S, k);
    for (i = 0; i < k; ++i) {
        double t = e[i];
        for (j = 0; j < i; ++j) t -= L[i * k + j] * w[j];
        w[i] = t / L[i * k + i];
        s += w[i] * w[i];
    }
    return s;
}

void test_textbook_chol(dkf_real_t *L, const dkf_real_t *A, size_t n)
{
    size_t i, j, l;
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) {
            dkf_real_t s = DKF_R(0.0);
            if (j > i) {
                L[i * n + j] = DKF_R(0.0);
                continue;
            }
            for (l = 0; l < j; ++l) s += L[i * n + l] * L[j * n + l];
            L[i * n + j] = j < i ? (A[i * n + j] - s) * (DKF_R(1.0) / L[j * n + j])
                                 : DKF_SQRT(A[i * n + i] - s);
        }
}

void test_load_ui_step(test_ui_step_t *s, const json_t *st, int with_dyn)
{
    const size_t sq = TEST_UI_CAP * TEST_UI_CAP;
    if (with_dyn) {
        test_json_mat(test_json_get(st, "F"), s->F, sq, &s->Fm);
        test_json_mat(test_json_get(st, "Q"), s->Q, sq, &s->Qm);
        test_json_mat(test_json_get(st, "B"), s->B, sq, &s->Bm);
        test_json_mat(test_json_get(st, "Rd"), s->Rd, sq, &s->Rdm);
    }
    test_json_mat(test_json_get(st, "H"), s->H, sq, &s->Hm);
    test_json_mat(test_json_get(st, "A"), s->A, sq, &s->Am);
    test_json_mat(test_json_get(st, "R"), s->R, sq, &s->Rm);
    test_json_mat(test_json_get(st, "y"), s->y, TEST_UI_CAP, &s->ym);
    test_ui_bind(s);
}

void test_ui_bind(test_ui_step_t *s)
{
    s->dyn.F = &s->Fm, s->dyn.Q = &s->Qm, s->dyn.B = &s->Bm, s->dyn.Rd = &s->Rdm;
    s->meas.H = &s->Hm, s->meas.D = &s->Am, s->meas.R = &s->Rm;
}

void test_ui_model_at(test_ui_step_t *s, const json_t *dynamics, const json_t *sensor, size_t k)
{
    const size_t sq = TEST_UI_CAP * TEST_UI_CAP;
    test_json_mat(test_json_model_at(dynamics, "F", k), s->F, sq, &s->Fm);
    test_json_mat(test_json_model_at(dynamics, "Q", k), s->Q, sq, &s->Qm);
    test_json_mat(test_json_model_at(sensor, "H", k), s->H, sq, &s->Hm);
    test_json_mat(test_json_model_at(sensor, "D", k), s->A, sq, &s->Am);
    test_json_mat(test_json_model_at(sensor, "R", k), s->R, sq, &s->Rm);
    test_json_mat(test_json_model_at(sensor, "B", k), s->B, sq, &s->Bm);
    test_json_mat(test_json_model_at(sensor, "Rd", k), s->Rd, sq, &s->Rdm);
    test_ui_bind(s);
}

size_t test_json_flatten(const json_t *node, double *out, size_t cap)
{
    size_t i, k = 0;
    if (json_is_number(node)) {
        assert_true(cap >= 1);
        out[0] = json_number_value(node);
        return 1;
    }
    assert_true(json_is_array(node));
    for (i = 0; i < json_array_size(node); ++i)
        k += test_json_flatten(json_array_get(node, i), out + k, cap - k);
    return k;
}

size_t test_json_size(const json_t *obj, const char *key)
{
    return (size_t)json_integer_value(test_json_get(obj, key));
}
