/*
 * Test support: a fixed-seed PRNG, random matrices built in double
 * independently of the library, and tolerance-aware comparisons.
 * Include after <cmocka.h>'s prerequisites (stdarg, stddef, setjmp).
 */
#ifndef DKF_TEST_H
#define DKF_TEST_H

#include <stddef.h>
#include <stdint.h>

#include "dkf/mat.h"

/* Unit roundoff of the library's real type, and a tolerance factor tests
 * multiply by it (so float and double runs share one justification). */
#define TEST_EPS ((double)DKF_REAL_EPSILON)

/* Directory holding the golden vectors copied into tests/vectors/. */
#ifndef DKF_VECTOR_DIR
#error "DKF_VECTOR_DIR must be defined by the build"
#endif

typedef struct {
    uint64_t s;
} test_rng_t;

void test_rng_seed(test_rng_t *r, uint64_t seed);
double test_rng_uniform(test_rng_t *r); /* in [0, 1) */
double test_rng_normal(test_rng_t *r);  /* N(0, 1) */

/* Fills A (rows x cols, row-major doubles) with N(0,1) entries. */
void test_rand_gauss(test_rng_t *r, double *A, size_t rows, size_t cols);
/* Q (n x n) random orthogonal: Gram-Schmidt (twice) on a Gaussian matrix. */
void test_rand_orthogonal(test_rng_t *r, double *Q, size_t n);
/* A = U diag(s) V^T with random orthogonal U (rows) and V (cols), k =
 * min(rows, cols) singular values s[0..k-1] as given. Exact rank control. */
void test_mat_with_singular_values(test_rng_t *r, double *A, size_t rows, size_t cols,
                                   const double *s);
/* A = Q diag(lambda) Q^T (n x n, exactly symmetric), Q random orthogonal. */
void test_sym_with_eigenvalues(test_rng_t *r, double *A, const double *lambda, size_t n);
/* Random SPD n x n with condition number cond (eigenvalues log-spaced in
 * [1, cond], scaled by `scale`). */
void test_rand_spd(test_rng_t *r, double *A, size_t n, double cond, double scale);

/* Lower L (n x n, double) with A = L L^T for the symmetric PSD A,
 * independent of the library's Cholesky; a zero pivot gives a zero column
 * (a singular Q), a negative one fails the test. */
void test_dchol(double *L, const double *A, size_t n);
/* Solves (L L^T) X = B in place for the lower n x n L of test_dchol (no
 * zero pivot) and B n x c: forward then back substitution, in double. */
void test_dchol_solve(const double *L, double *B, size_t n, size_t c);
/* x (n) = L z with z ~ N(0, I) drawn first (n normals, in order). */
void test_draw(test_rng_t *r, double *x, const double *L, size_t n);
/* e^T S^{-1} e for the SPD S (k x k, k <= DKF_MAX_DIM), in double (the
 * normalised estimation error squared of Monte-Carlo tests). */
double test_nees(const double *e, const double *S, size_t k);

/* Double-precision reference products: C = A B (A r x k, B k x c). */
/* Cholesky-Banachiewicz as written (n x n, A's lower triangle read):
 * L(i,j) = (A(i,j) - sum_{l<j} L(i,l) L(j,l)) * (1 / L(j,j)), each sum from
 * +0 in l order, L(i,i) = sqrt(A(i,i) - sum): the order the library's
 * Cholesky kernels claim, bit for bit (test_mat_chol_lu, test_kernels_wide). */
void test_textbook_chol(dkf_real_t *L, const dkf_real_t *A, size_t n);
void test_ref_mul(double *C, const double *A, const double *B, size_t r, size_t k, size_t c);
/* At (c x r) = A^T for A r x c, doubles. */
void test_ref_transpose(double *At, const double *A, size_t r, size_t c);
/* Ainv = A^{-1} (n x n) by Gauss-Jordan with partial pivoting in long
 * double: an independent reference for a nonsingular A (a zero pivot fails
 * the test). W holds A on entry and is overwritten. */
void test_ref_inverse(long double *Ainv, long double *W, size_t n);
/* The same for a double A (n <= DKF_MAX_DIM), rounded into Ainv. */
void test_ref_inverse_double(double *Ainv, const double *A, size_t n);

/* Copies between the library's real type and double. */
void test_to_real(dkf_real_t *dst, const double *src, size_t n);
void test_to_double(double *dst, const dkf_real_t *src, size_t n);

/* max |a - b| over n entries (a, b in the library type / double). */
double test_max_abs_diff(const dkf_real_t *a, const double *b, size_t n);
double test_max_abs(const double *a, size_t n);

/* Asserts max|got - expected| <= rel * max(1, max|expected|), naming
 * `what` in the failure message. */
void test_assert_close(const char *what, const dkf_real_t *got, const double *expected, size_t n,
                       double rel);
/* A view as an expression (DKF_MAT is an initializer only). */
dkf_mat_t test_view(size_t rows, size_t cols, dkf_real_t *data);
/* p[0..n-1] = v (a sentinel before a call that must not write). */
void test_fill(dkf_real_t *p, size_t n, dkf_real_t v);
/* max |Q^T Q - I| for the r x k Q, in double. */
double test_orth_err(const dkf_real_t *Q, size_t r, size_t k);

/* A member of a struct of buffers (TEST_MEMBER), for test_assert_same_members. */
typedef struct {
    const char *name;
    size_t offset, size;
} test_member_t;
#define TEST_MEMBER(type, member) {#member, offsetof(type, member), sizeof(((type *)0)->member)}
/* Fails the test, naming the member, unless each of the k members m[] of
 * *got is bit-identical to that of *want. */
void test_assert_same_members(const void *got, const void *want, const test_member_t *m, size_t k);

/* Asserts `call` returns `st` and leaves the n reals at `out` bit-identical;
 * `snap` is caller scratch of at least n reals. */
#define TEST_FAILS_UNTOUCHED(snap, st, call, out, n) \
    do { \
        memcpy((snap), (out), (n) * sizeof(dkf_real_t)); \
        assert_int_equal((call), (st)); \
        assert_memory_equal((snap), (out), (n) * sizeof(dkf_real_t)); \
    } while (0)

/* Largest max|got - expected| / max(1, max|expected|) seen by
 * test_assert_close since the last reset: tests print it so the log shows
 * the margin under each tolerance. */
double test_worst_rel(void);
void test_reset_worst_rel(void);

/* max|got - ref| / max|ref| over n entries (relative to the reference's
 * own scale, not max(1, .): for covariances far below 1). */
double test_rel_err(const dkf_real_t *got, const double *ref, size_t n);
/* Whether the symmetric n x n P satisfies lambda_min(P) >= -tol |tr(P)|
 * and min P(i,i) >= -tol |tr(P)|, by a double-precision Cholesky of
 * P + tol |tr(P)| I written here (independent of the library's). */
int test_psd_within(const dkf_real_t *P, size_t n, double tol);
/* Fails the test (naming `what`) unless e <= bound. */
void test_assert_below(const char *what, double e, double bound);

/* ---- golden vectors (jansson) ------------------------------------------ */
#include <jansson.h>

/* Loads DKF_VECTOR_DIR "/" rel; fails the test if it cannot. */
json_t *test_load_vector(const char *rel);
/* Reads a JSON number, list (n x 1) or list of lists (r x c) into out
 * (cap doubles); fails the test on a malformed node. Returns the count. */
size_t test_json_array(const json_t *node, double *out, size_t cap, size_t *rows, size_t *cols);
/* Reads a matrix node into storage (cap reals, library type) and points M
 * at it with the node's shape. */
void test_json_mat(const json_t *node, dkf_real_t *storage, size_t cap, dkf_mat_t *M);
/* The model matrix `key` of a vector file at absolute time k: the node of
 * {"const": M} or of {"per_k": [M_0, M_1, ...]}[k]. */
const json_t *test_json_model_at(const json_t *model, const char *key, size_t k);
/* Every number of a JSON number or nested list into out (cap doubles, row
 * major); fails the test on anything else or more than cap. The count. */
size_t test_json_flatten(const json_t *node, double *out, size_t cap);
/* The integer obj[key] as a size (test_json_get: the key must be there). */
size_t test_json_size(const json_t *obj, const char *key);
/* json_object_get that fails the test when the key is missing. */
json_t *test_json_get(const json_t *obj, const char *key);
/* A filter's run in a vector file of tests/vectors/diffkf/: the root (the
 * caller's to json_decref), its "model", "init" and y "values", the
 * number N of steps (the length of "k") and outputs[filter]. */
typedef struct {
    json_t *root;
    const json_t *model, *init, *yv, *out;
    size_t N;
} test_run_vector_t;
void test_load_run_vector(test_run_vector_t *v, const char *rel, const char *filter);

/* ---- one step of an unknown-input model (dkf/ui_model.h) from a vector -- */
#include "dkf/ui_model.h"

#define TEST_UI_CAP 9 /* largest n, m, n + p of the tests' models */
typedef struct {
    dkf_real_t F[TEST_UI_CAP * TEST_UI_CAP], Q[TEST_UI_CAP * TEST_UI_CAP],
        B[TEST_UI_CAP * TEST_UI_CAP], Rd[TEST_UI_CAP * TEST_UI_CAP], H[TEST_UI_CAP * TEST_UI_CAP],
        A[TEST_UI_CAP * TEST_UI_CAP], R[TEST_UI_CAP * TEST_UI_CAP], y[TEST_UI_CAP];
    dkf_mat_t Fm, Qm, Bm, Rdm, Hm, Am, Rm, ym;
    dkf_ui_dyn_t dyn;   /* F, Q, B, Rd (when loaded with the dynamics) */
    dkf_ui_meas_t meas; /* H, D = A, R */
} test_ui_step_t;
/* The measurement part (H, A, R, y) of the step node st, and the dynamics
 * (F, Q, B, Rd) if with_dyn. */
void test_load_ui_step(test_ui_step_t *s, const json_t *st, int with_dyn);
/* dyn and meas pointed at the step's matrices. */
void test_ui_bind(test_ui_step_t *s);
/* F, Q of the model `dynamics` and H, A, R, B, Rd of the model `sensor`
 * (test_json_model_at) at absolute k, bound; y untouched. */
void test_ui_model_at(test_ui_step_t *s, const json_t *dynamics, const json_t *sensor, size_t k);
/* The element of root's "cases" array whose "name" is `name` (fails the
 * test if none). */
const json_t *test_json_case(const json_t *root, const char *name);
/* Stress tests (tests/vectors/stress/): *worst = max(*worst,
 * test_rel_err(got, ref)) with the reference node ref of len numbers
 * (fails the test on another count). */
void test_note_rel_err(double *worst, const json_t *ref, const dkf_real_t *got, size_t len);
/* One output of a stress test's step: the len reals at got against the
 * step node's `key`. */
typedef struct {
    const char *key;
    const dkf_real_t *got;
    size_t len;
} test_out_t;
/* test_note_rel_err(&worst[i], st's out[i].key, out[i].got, out[i].len)
 * for each of the k outputs. */
void test_note_rel_errs(double *worst, const json_t *st, const test_out_t *out, size_t k);
/* A case of a stress vector file: its node and steps, the sizes its "n",
 * "m" and "p" give (0 where absent; each file says what they mean), and its
 * prior "x0", "P0" (n <= TEST_UI_CAP) with views on them. */
typedef struct {
    const json_t *node, *steps;
    const char *name;
    size_t n, m, p;
    dkf_real_t x0[TEST_UI_CAP], P0[TEST_UI_CAP * TEST_UI_CAP];
    dkf_mat_t mx0, mP0;
} test_stress_case_t;
/* Loads the vector file rel and calls run(case, i) on its cases names[i],
 * i = 0..k-1, in order. */
void test_stress_cases(const char *rel, const char *const names[], size_t k,
                       void (*run)(const test_stress_case_t *sc, size_t i));
/* For each of the k outputs what[i]: worst[i] <= ext[i] ("external",
 * skipped if ext is NULL or ext[i] <= 0) and worst[i] <= 4 seen[i]
 * ("regression": 4x the worst observed; skipped if seen is NULL or
 * seen[i] < 0). Failures name who and what[i]. */
void test_assert_stress_bounds(const char *who, const char *const what[], const double *worst,
                               size_t k, const double *ext, const double *seen);
/* The verdict on stress case `who` after `steps` steps: prints the worst
 * error of each output what[i] with rk2 (the case's largest rho cond^2)
 * and the external bound ext, then test_assert_stress_bounds with ext for
 * every output (skipped when ext >= 1: vacuous, as in float) and seen.
 * k <= 8. */
void test_stress_verdict(const char *who, size_t steps, const char *const what[],
                         const double *worst, size_t k, double rk2, double ext,
                         const double *seen);

#endif /* DKF_TEST_H */
