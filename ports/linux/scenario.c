/*
 * scenario.c - reads the JSON scenario format (docs/scenario-format.md)
 * with jansson and normalises both accepted layouts into dkf_scenario_t.
 *
 * Parsing and validation share one rule: the first problem found is
 * reported as "FILE: KEY.PATH: problem" and everything is freed. Parsers
 * return 0 on success and -1 after recording the error.
 */
#include "scenario.h"

#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/tw.h"

#define PATH_LEN 256

typedef struct {
    const char *file;
    char *err;
    size_t errlen;
} ctx_t;

/* printf-style "FILE: PATH: problem" into the caller's buffer. */
static int fail(ctx_t *c, const char *path, const char *fmt, ...)
{
    char msg[DKF_SCN_ERR_LEN / 2];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (c->err != NULL && c->errlen > 0) {
        if (path != NULL && path[0] != '\0')
            snprintf(c->err, c->errlen, "%s: %s: %s", c->file, path, msg);
        else
            snprintf(c->err, c->errlen, "%s: %s", c->file, msg);
    }
    return -1;
}

/* Key paths longer than PATH_LEN are cut short: they only label messages. */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static void pathf(char *out, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(out, PATH_LEN, fmt, ap);
    va_end(ap);
}

static void subkey(char *out, const char *base, const char *key)
{
    if (base[0] == '\0')
        pathf(out, "%s", key);
    else
        pathf(out, "%s.%s", base, key);
}

static void subidx(char *out, const char *base, size_t i)
{
    pathf(out, "%s[%zu]", base, i);
}

static char *dupstr(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d != NULL) memcpy(d, s, n);
    return d;
}

static void *xcalloc(ctx_t *c, size_t n, size_t size)
{
    void *p = calloc(n == 0 ? 1 : n, size);
    if (p == NULL) fail(c, NULL, "out of memory");
    return p;
}

static const char *json_kind(const json_t *j)
{
    switch (json_typeof(j)) {
    case JSON_OBJECT: return "an object";
    case JSON_ARRAY: return "a list";
    case JSON_STRING: return "a string";
    case JSON_INTEGER:
    case JSON_REAL: return "a number";
    case JSON_TRUE:
    case JSON_FALSE: return "a boolean";
    case JSON_NULL: return "null";
    }
    return "?";
}

/* ---- numbers, vectors, matrices ------------------------------------------ */

/* v in the fewest significant digits (15..17) that read back as v: the
 * number as the file wrote it, for messages. */
static const char *num_str(char *buf, size_t len, double v)
{
    int prec;
    for (prec = 15; prec < 17; ++prec) {
        snprintf(buf, len, "%.*g", prec, v);
        if (strtod(buf, NULL) == v) return buf;
    }
    snprintf(buf, len, "%.17g", v);
    return buf;
}

/* An integer in lo..hi, range-checked in the double domain before any cast
 * (every long in that range converts exactly: |lo|, |hi| <= 2^53); the
 * message shows the file's value, never a converted one. */
static int get_integer(ctx_t *c, const json_t *j, const char *path, double lo, double hi,
                       long *out)
{
    double v;
    char buf[32];
    if (!json_is_number(j)) return fail(c, path, "expected an integer, got %s", json_kind(j));
    v = json_number_value(j);
    if (v != floor(v) || !(v >= lo && v <= hi)) {
        if (json_is_integer(j))
            return fail(c, path, "expected an integer in %.0f..%.0f, got %" JSON_INTEGER_FORMAT,
                        lo, hi, json_integer_value(j));
        return fail(c, path, "expected an integer in %.0f..%.0f, got %s", lo, hi,
                    num_str(buf, sizeof buf, v));
    }
    *out = (long)v;
    return 0;
}

/* ---- the one way parsed numbers are written into an array ------------------- */

/* count rows of dim doubles in one allocation; store() checks every write
 * against the shape it was allocated with. */
typedef struct {
    double *v;
    size_t count, dim;
} block_t;

static int block_alloc(ctx_t *c, block_t *b, size_t count, size_t dim, const char *path)
{
    b->v = NULL;
    b->count = count;
    b->dim = dim;
    if (dim != 0 && count > SIZE_MAX / sizeof(double) / dim)
        return fail(c, path, "%zu x %zu values are more than this machine can hold", count, dim);
    if ((b->v = xcalloc(c, count * dim, sizeof *b->v)) == NULL) return -1;
    return 0;
}

/* Row `row` of b = src[0..len-1]: refused unless row < count and len == dim. */
static int store(ctx_t *c, const char *path, const block_t *b, size_t row, const double *src,
                 size_t len)
{
    if (row >= b->count)
        return fail(c, path, "entry %zu beyond the %zu the file announced", row, b->count);
    if (len != b->dim) return fail(c, path, "expected a vector of %zu values, got %zu", b->dim, len);
    memcpy(b->v + row * b->dim, src, len * sizeof *src);
    return 0;
}

/* A non-empty list of numbers. */
static int parse_vector(ctx_t *c, const json_t *j, const char *path, size_t *len,
                        double **out)
{
    size_t i, n;
    double *v;
    char p[PATH_LEN];
    if (!json_is_array(j)) return fail(c, path, "expected a list of numbers, got %s", json_kind(j));
    n = json_array_size(j);
    if (n == 0) return fail(c, path, "expected a non-empty list of numbers, got an empty list");
    if ((v = xcalloc(c, n, sizeof *v)) == NULL) return -1;
    for (i = 0; i < n; ++i) {
        const json_t *e = json_array_get(j, i);
        if (!json_is_number(e)) {
            subidx(p, path, i);
            free(v);
            return fail(c, p, "expected a number, got %s", json_kind(e));
        }
        v[i] = json_number_value(e);
    }
    *len = n;
    *out = v;
    return 0;
}

/* A non-empty rectangular list of rows. */
static int parse_matrix(ctx_t *c, const json_t *j, const char *path, size_t *rows, size_t *cols,
                        double **out)
{
    size_t i, r;
    block_t m = {NULL, 0, 0};
    char p[PATH_LEN];
    if (!json_is_array(j) || json_array_size(j) == 0 || !json_is_array(json_array_get(j, 0)))
        return fail(c, path, "expected a matrix (non-empty list of rows), got %s",
                    !json_is_array(j)             ? json_kind(j)
                    : json_array_size(j) == 0     ? "an empty list"
                    : json_is_number(json_array_get(j, 0)) ? "a list of numbers"
                                                  : "a list of something else");
    r = json_array_size(j);
    for (i = 0; i < r; ++i) {
        double *row;
        size_t len;
        int rc;
        subidx(p, path, i);
        if (parse_vector(c, json_array_get(j, i), p, &len, &row) != 0) {
            free(m.v);
            return -1;
        }
        if (i == 0)
            rc = block_alloc(c, &m, r, len, path);
        else if (len != m.dim)
            rc = fail(c, p, "row has %zu entries, row 0 has %zu", len, m.dim);
        else
            rc = 0;
        if (rc == 0) rc = store(c, p, &m, i, row, len);
        free(row);
        if (rc != 0) {
            free(m.v);
            return -1;
        }
    }
    *rows = r;
    *cols = m.dim;
    *out = m.v;
    return 0;
}

/* Depth of the first-element chain: 1 for [1,2], 2 for [[1]], 3 for [[[1]]]. */
static int nest_depth(const json_t *j)
{
    int d = 0;
    while (json_is_array(j) && json_array_size(j) > 0) {
        ++d;
        j = json_array_get(j, 0);
    }
    return d;
}

static int shape_error(ctx_t *c, const char *path, size_t er, size_t ec, size_t r, size_t cc)
{
    if (ec == 1 && cc == 1)
        return fail(c, path, "expected a vector of %zu values, got %zu", er, r);
    return fail(c, path, "expected %zux%zu matrix, got %zux%zu", er, ec, r, cc);
}

/* ---- named matrix sets ------------------------------------------------------ */

static dkf_scn_mat_t *mats_add(ctx_t *c, dkf_scn_mats_t *set, const char *name, const char *path)
{
    dkf_scn_mat_t *items = realloc(set->items, (set->len + 1) * sizeof *items);
    dkf_scn_mat_t *m;
    if (items == NULL) {
        fail(c, NULL, "out of memory");
        return NULL;
    }
    set->items = items;
    m = &items[set->len];
    memset(m, 0, sizeof *m);
    m->name = dupstr(name);
    m->path = dupstr(path);
    if (m->name == NULL || m->path == NULL) {
        free(m->name);
        free(m->path);
        fail(c, NULL, "out of memory");
        return NULL;
    }
    set->len++;
    return m;
}

static void mats_free(dkf_scn_mats_t *set)
{
    size_t i;
    for (i = 0; i < set->len; ++i) {
        free(set->items[i].name);
        free(set->items[i].path);
        free(set->items[i].data);
    }
    free(set->items);
    set->items = NULL;
    set->len = 0;
}

static const dkf_scn_mat_t *mats_find(const dkf_scn_mats_t *set, const char *name)
{
    size_t i;
    for (i = 0; i < set->len; ++i)
        if (strcmp(set->items[i].name, name) == 0) return &set->items[i];
    return NULL;
}

/* Entry idx of m, a stack of `count` same-shape matrices: the first entry
 * fixes the shape and allocates m->data, the others must match it. */
static int stack_matrix(ctx_t *c, dkf_scn_mat_t *m, block_t *b, size_t idx, size_t count,
                        const json_t *j, const char *path)
{
    double *one;
    size_t r, cc;
    int rc = 0;
    if (parse_matrix(c, j, path, &r, &cc, &one) != 0) return -1;
    if (idx == 0) {
        m->rows = r;
        m->cols = cc;
        rc = block_alloc(c, b, count, r * cc, path);
        m->data = b->v;
    } else if (r != m->rows || cc != m->cols) {
        rc = shape_error(c, path, m->rows, m->cols, r, cc);
    }
    if (rc == 0) rc = store(c, path, b, idx, one, r * cc);
    free(one);
    return rc;
}

/* A list of same-shape matrices (per_k, or a stacked init entry). */
static int parse_matrix_list(ctx_t *c, const json_t *j, const char *path, dkf_scn_mat_t *m)
{
    size_t i, n;
    block_t b;
    char p[PATH_LEN];
    if (!json_is_array(j) || json_array_size(j) == 0)
        return fail(c, path, "expected a non-empty list of matrices, got %s", json_kind(j));
    n = json_array_size(j);
    if (n > DKF_SCN_MAX_TIMES)
        return fail(c, path, "%zu matrices, more than the %lu allowed", n, DKF_SCN_MAX_TIMES);
    for (i = 0; i < n; ++i) {
        subidx(p, path, i);
        if (stack_matrix(c, m, &b, i, n, json_array_get(j, i), p) != 0) return -1;
    }
    m->count = n;
    return 0;
}

/* Matrices of the model and init are at most DKF_MAX_DIM x DKF_MAX_DIM. */
static int check_dims(ctx_t *c, const dkf_scn_mat_t *m)
{
    if (m->rows > DKF_MAX_DIM || m->cols > DKF_MAX_DIM)
        return fail(c, m->path, "%zux%zu: a dimension exceeds DKF_MAX_DIM = %d", m->rows,
                    m->cols, DKF_MAX_DIM);
    return 0;
}

/* A model entry: {"const": M}, {"per_k": [M_0, ...]} or a bare matrix M. */
static int parse_model_value(ctx_t *c, dkf_scn_mat_t *m, const json_t *j, const char *path)
{
    char p[PATH_LEN];
    const json_t *cst, *pk;
    if (json_is_array(j)) return parse_matrix(c, j, path, &m->rows, &m->cols, &m->data);
    cst = json_object_get(j, "const");
    pk = json_object_get(j, "per_k");
    if ((cst == NULL) == (pk == NULL))
        return fail(c, path, "expected exactly one of \"const\" and \"per_k\"");
    if (cst != NULL) {
        subkey(p, path, "const");
        return parse_matrix(c, cst, p, &m->rows, &m->cols, &m->data);
    }
    subkey(p, path, "per_k");
    return parse_matrix_list(c, pk, p, m);
}

static int parse_model_entry(ctx_t *c, dkf_scn_mats_t *set, const char *name, const json_t *j,
                             const char *path)
{
    dkf_scn_mat_t *m;
    if (json_is_string(j) || json_is_null(j)) return 0; /* notes */
    if (!json_is_object(j) && !json_is_array(j))
        return fail(c, path, "expected {\"const\": M}, {\"per_k\": [...]} or a matrix, got %s",
                    json_kind(j));
    if ((m = mats_add(c, set, name, path)) == NULL) return -1;
    if (parse_model_value(c, m, j, path) != 0) return -1;
    return check_dims(c, m);
}

/* An init entry: vector (n x 1), matrix, or list of matrices; strings skipped. */
static int parse_init_entry(ctx_t *c, dkf_scn_mats_t *set, const char *name, const json_t *j,
                            const char *path)
{
    dkf_scn_mat_t *m;
    int depth, rc;
    if (json_is_string(j) || json_is_null(j)) return 0;
    if ((m = mats_add(c, set, name, path)) == NULL) return -1;
    depth = nest_depth(j);
    if (depth <= 1) {
        m->cols = 1;
        rc = parse_vector(c, j, path, &m->rows, &m->data);
    } else if (depth == 2) {
        rc = parse_matrix(c, j, path, &m->rows, &m->cols, &m->data);
    } else {
        rc = parse_matrix_list(c, j, path, m);
    }
    return rc != 0 ? -1 : check_dims(c, m);
}

/* ---- measurements and truth -------------------------------------------------- */

/* {"k": [...], "<vkey>": [[...], ...]}: times strictly increasing. */
static int parse_series(ctx_t *c, const json_t *j, const char *path, const char *vkey,
                        size_t dim, size_t *count, long **kout, double **vout)
{
    const json_t *jk, *jv;
    size_t i, n;
    long *k;
    block_t v = {NULL, 0, 0};
    char p[PATH_LEN], pi[PATH_LEN];
    if (!json_is_object(j))
        return fail(c, path, "expected {\"k\": [...], \"%s\": [...]}, got %s", vkey,
                    json_kind(j));
    jv = json_object_get(j, vkey);
    subkey(p, path, vkey);
    if (jv == NULL) return fail(c, p, "missing key");
    if (!json_is_array(jv) || json_array_size(jv) == 0)
        return fail(c, p, "expected a non-empty list of vectors, got %s", json_kind(jv));
    n = json_array_size(jv);
    if (n > DKF_SCN_MAX_TIMES)
        return fail(c, p, "%zu entries, more than the %lu allowed", n, DKF_SCN_MAX_TIMES);
    k = xcalloc(c, n, sizeof *k);
    if (k == NULL || block_alloc(c, &v, n, dim, p) != 0) goto bad;
    for (i = 0; i < n; ++i) {
        size_t len;
        double *e;
        int rc;
        subidx(pi, p, i);
        if (parse_vector(c, json_array_get(jv, i), pi, &len, &e) != 0) goto bad;
        rc = store(c, pi, &v, i, e, len);
        free(e);
        if (rc != 0) goto bad;
    }
    jk = json_object_get(j, "k");
    subkey(p, path, "k");
    if (jk == NULL) {
        /* Only truth may omit k: it then starts at k = 0. */
        for (i = 0; i < n; ++i) k[i] = (long)i;
    } else {
        if (!json_is_array(jk) || json_array_size(jk) != n) {
            fail(c, p, "expected a list of %zu times (one per value), got %s of %zu", n,
                 json_kind(jk), json_is_array(jk) ? json_array_size(jk) : (size_t)0);
            goto bad;
        }
        for (i = 0; i < n; ++i) {
            subidx(pi, p, i);
            if (get_integer(c, json_array_get(jk, i), pi, 0.0, DKF_SCN_MAX_TIME, &k[i]) != 0)
                goto bad;
            if (i > 0 && k[i] <= k[i - 1]) {
                fail(c, pi, "times must increase strictly (%ld after %ld)", k[i], k[i - 1]);
                goto bad;
            }
        }
    }
    *count = n;
    *kout = k;
    *vout = v.v;
    return 0;
bad:
    free(k);
    free(v.v);
    return -1;
}

/* Index of time k in the strictly increasing list ks, or -1. */
static long find_time(const long *ks, size_t n, long k)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (ks[mid] == k) return (long)mid;
        if (ks[mid] < k)
            lo = mid + 1;
        else
            hi = mid;
    }
    return -1;
}

/* ---- covariances --------------------------------------------------------------- */

/* A covariance read from a file must be symmetric within rounding:
 * max |M_ij - M_ji| <= DKF_SCN_SYM_TOL eps max |M| for each entry of a
 * per_k list or init list. A symmetric matrix written out and read back is
 * exactly symmetric (the same decimal parses to the same double); a matrix
 * computed in double without symmetrizing carries a few roundings (the
 * time-varying diffkf vectors tv3, tv4: at most 0.6 eps max|M|); a typo or a
 * transposed entry is far above 8 eps. */
#define DKF_SCN_SYM_TOL 8.0

static int require_symmetric(ctx_t *c, const dkf_scenario_t *s, const dkf_scn_mat_t *m,
                             int is_list)
{
    size_t e, i, j, n, count;
    char p[PATH_LEN], va[32], vb[32];
    if (m == NULL || m->rows != m->cols) return 0; /* shapes are checked elsewhere */
    n = m->rows;
    count = m->count > 0 ? m->count : 1;
    for (e = 0; e < count; ++e) {
        const double *a = m->data + e * n * n;
        double amax = 0.0, worst = 0.0;
        size_t wi = 0, wj = 0;
        for (i = 0; i < n * n; ++i) amax = fmax(amax, fabs(a[i]));
        for (i = 0; i < n; ++i)
            for (j = i + 1; j < n; ++j)
                if (fabs(a[i * n + j] - a[j * n + i]) > worst) {
                    worst = fabs(a[i * n + j] - a[j * n + i]);
                    wi = i;
                    wj = j;
                }
        if (worst <= DKF_SCN_SYM_TOL * DBL_EPSILON * amax) continue;
        if (m->count == 0)
            pathf(p, "%s", m->path);
        else if (is_list)
            pathf(p, "%s[%zu]", m->path, e);
        else if (s->layout == DKF_SCN_LAYOUT_CANONICAL)
            pathf(p, "%s.per_k[%zu]", m->path, e);
        else
            pathf(p, "%s (entry for k = %zu)", m->path, m->k0 + e);
        return fail(c, p, "not symmetric (a covariance): entries (%zu,%zu) = %s and (%zu,%zu) "
                    "= %s differ by %.3g > %g eps max|entry| = %.3g", wi, wj,
                    num_str(va, sizeof va, a[wi * n + wj]), wj, wi,
                    num_str(vb, sizeof vb, a[wj * n + wi]), worst, DKF_SCN_SYM_TOL,
                    DKF_SCN_SYM_TOL * DBL_EPSILON * amax);
    }
    return 0;
}

/* Every covariance of the model (Q, R, Rd, Sv, Sw; each sensor's own) and of
 * init (P00, P00_local, P00_central, Pd00). */
static int check_covariances(ctx_t *c, const dkf_scenario_t *s)
{
    static const char *const model_cov[] = {"Q", "R", "Rd", "Sv", "Sw"};
    static const char *const init_cov[] = {"P00", "P00_local", "P00_central", "Pd00"};
    size_t i, l;
    for (i = 0; i < sizeof model_cov / sizeof *model_cov; ++i) {
        if (require_symmetric(c, s, mats_find(&s->model, model_cov[i]), 0) != 0) return -1;
        for (l = 0; l < s->nsensors; ++l)
            if (require_symmetric(c, s, mats_find(&s->sensors[l].mats, model_cov[i]), 0) != 0)
                return -1;
    }
    for (i = 0; i < sizeof init_cov / sizeof *init_cov; ++i)
        if (require_symmetric(c, s, mats_find(&s->init, init_cov[i]), 1) != 0) return -1;
    return 0;
}

/* ---- validation shared by both layouts ------------------------------------- */

/* Matrix `name` must exist (in set or, for sensors, the fallback) with shape r x c. */
static int require_shape(ctx_t *c, const dkf_scn_mat_t *m, const char *missing_path, size_t r,
                         size_t cc)
{
    if (m == NULL) return fail(c, missing_path, "missing key");
    if (m->rows != r || m->cols != cc) {
        char p[PATH_LEN];
        pathf(p, "%s%s", m->path, m->count > 0 ? ".per_k" : "");
        return shape_error(c, m->count > 0 ? p : m->path, r, cc, m->rows, m->cols);
    }
    return 0;
}

/* A per_k matrix must cover absolute times 0..last. */
static int require_times(ctx_t *c, const dkf_scn_mat_t *m, size_t last, const char *why)
{
    char p[PATH_LEN];
    if (m == NULL || m->count == 0 || last < m->count) return 0;
    pathf(p, "%s.per_k", m->path);
    return fail(c, p, "has %zu entries (k = 0..%zu) but %s needs k up to %zu", m->count,
                m->count - 1, why, last);
}

/* An optional init covariance: absent, or exactly one n x n matrix. */
static int require_single(ctx_t *c, const dkf_scn_mat_t *m, const char *path, size_t n)
{
    if (m == NULL) return 0;
    if (m->count != 0) return fail(c, m->path, "expected one %zux%zu matrix, got a list", n, n);
    return require_shape(c, m, path, n, n);
}

/* The key path of the times of sensor i's measurements in run r. */
static void y_path(const dkf_scenario_t *s, size_t r, size_t i, char *p)
{
    if (s->layout == DKF_SCN_LAYOUT_CASES)
        pathf(p, "cases[%zu].steps", s->case_index);
    else if (s->has_runs && s->multi)
        pathf(p, "runs[%zu].y[%zu].k", r, i);
    else if (s->has_runs)
        pathf(p, "runs[%zu].y.k", r);
    else if (s->multi)
        pathf(p, "y[%zu].k", i);
    else
        pathf(p, "y.k");
}

static int validate(ctx_t *c, dkf_scenario_t *s, const char *model_path,
                    const char *sensor_fmt_path)
{
    const dkf_scn_mat_t *F = dkf_scn_model(s, "F"), *Q, *x00, *P00, *Pl, *Pc;
    size_t i, n, r;
    char p[PATH_LEN], why[64];
    long k;

    subkey(p, model_path, "F");
    if (F == NULL) return fail(c, p, "missing key");
    if (F->rows != F->cols) return fail(c, F->path, "expected a square matrix, got %zux%zu",
                                        F->rows, F->cols);
    n = s->n = F->rows;
    if (n > DKF_MAX_DIM)
        return fail(c, F->path, "state dimension %zu exceeds DKF_MAX_DIM = %d", n, DKF_MAX_DIM);
    Q = dkf_scn_model(s, "Q");
    subkey(p, model_path, "Q");
    if (require_shape(c, Q, p, n, n) != 0) return -1;
    snprintf(why, sizeof why, "steps k = 1..%zu", s->steps);
    if (require_times(c, F, s->steps - 1, why) != 0) return -1;
    if (require_times(c, Q, s->steps - 1, why) != 0) return -1;

    for (i = 0; i < s->nsensors; ++i) {
        dkf_scn_sensor_t *se = &s->sensors[i];
        const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, i, "H");
        const dkf_scn_mat_t *R = dkf_scn_sensor_model(s, i, "R");
        const dkf_scn_mat_t *A = dkf_scn_sensor_model(s, i, "A");
        char sp[PATH_LEN];
        pathf(sp, sensor_fmt_path, i);
        subkey(p, sp, "H");
        if (H == NULL) return fail(c, p, "missing key");
        if (require_shape(c, H, p, H->rows, n) != 0) return -1;
        if (se->m != 0 && se->m != H->rows)
            return fail(c, H->path, "has %zu rows but the measurements have %zu values",
                        H->rows, se->m);
        se->m = H->rows;
        if (se->m > DKF_MAX_DIM)
            return fail(c, H->path, "measurement dimension %zu exceeds DKF_MAX_DIM = %d", se->m,
                        DKF_MAX_DIM);
        subkey(p, sp, "R");
        if (require_shape(c, R, p, se->m, se->m) != 0) return -1;
        /* Unknown-input pieces are not used by kf/info; check what is unambiguous. */
        if (A != NULL && A->rows != se->m)
            return fail(c, A->path, "expected %zu rows (like H), got %zu", se->m, A->rows);
        if (A != NULL) {
            const dkf_scn_mat_t *B = dkf_scn_sensor_model(s, i, "B");
            const dkf_scn_mat_t *Rd = dkf_scn_sensor_model(s, i, "Rd");
            if (B != NULL && require_shape(c, B, B->path, A->cols, A->cols) != 0) return -1;
            if (Rd != NULL && require_shape(c, Rd, Rd->path, A->cols, A->cols) != 0) return -1;
        }
        if (require_times(c, H, s->steps, why) != 0) return -1;
        if (require_times(c, R, s->steps, why) != 0) return -1;
    }

    x00 = dkf_scn_init(s, "x00");
    if (require_shape(c, x00, "init.x00", n, 1) != 0) return -1;
    P00 = dkf_scn_init(s, "P00");
    Pl = dkf_scn_init(s, "P00_local");
    Pc = dkf_scn_init(s, "P00_central");
    if (require_single(c, P00, "init.P00", n) != 0) return -1;
    if (require_single(c, Pc, "init.P00_central", n) != 0) return -1;
    if (Pl != NULL) {
        if (require_shape(c, Pl, "init.P00_local", n, n) != 0) return -1;
        if (Pl->count != s->nsensors)
            return fail(c, Pl->path, "expected a list of %zu %zux%zu matrices (one per sensor)",
                        s->nsensors, n, n);
    }
    if (P00 == NULL && (Pc == NULL || (Pl == NULL && s->multi)))
        return fail(c, "init.P00", "missing key (needed unless init.P00_central%s are given)",
                    s->multi ? " and init.P00_local" : "");

    for (r = 0; r < s->nruns; ++r) {
        dkf_scn_select_run(s, r);
        for (i = 0; i < s->nsensors; ++i)
            for (k = 1; k <= (long)s->steps; ++k)
                if (dkf_scn_y(s, i, k) == NULL) {
                    y_path(s, r, i, p);
                    return fail(c, p, "no measurement for k = %ld (steps k = 1..%zu need one)",
                                k, s->steps);
                }
    }
    dkf_scn_select_run(s, 0);
    return check_covariances(c, s);
}

/* ---- canonical layout -------------------------------------------------------- */

static int parse_mat_object(ctx_t *c, dkf_scn_mats_t *set, const json_t *obj, const char *path,
                            const char *skip)
{
    const char *key;
    json_t *val;
    char p[PATH_LEN];
    json_object_foreach((json_t *)obj, key, val) {
        if (skip != NULL && strcmp(key, skip) == 0) continue;
        subkey(p, path, key);
        if (parse_model_entry(c, set, key, val, p) != 0) return -1;
    }
    return 0;
}

/* The number of steps N: key `N`, else the list `k` (= [1..N]), else the
 * last time every sensor has a measurement for. */
static int canonical_steps(ctx_t *c, dkf_scenario_t *s, const json_t *root)
{
    const json_t *jn = json_object_get(root, "N"), *jk = json_object_get(root, "k");
    long N = -1;
    size_t i;
    char p[PATH_LEN];
    if (jn != NULL) {
        if (get_integer(c, jn, "N", 1.0, (double)DKF_SCN_MAX_STEPS, &N) != 0) return -1;
    }
    if (jk != NULL) {
        size_t len;
        if (!json_is_array(jk) || json_array_size(jk) == 0)
            return fail(c, "k", "expected the list [1, 2, ..., N], got %s", json_kind(jk));
        len = json_array_size(jk);
        if (len > DKF_SCN_MAX_STEPS)
            return fail(c, "k", "%zu steps, more than the %lu allowed", len, DKF_SCN_MAX_STEPS);
        if (N >= 0 && (size_t)N != len)
            return fail(c, "k", "has %zu entries but N = %ld", len, N);
        for (i = 0; i < len; ++i) {
            long v;
            subidx(p, "k", i);
            if (get_integer(c, json_array_get(jk, i), p, 0.0, DKF_SCN_MAX_TIME, &v) != 0)
                return -1;
            if (v != (long)i + 1)
                return fail(c, p, "expected %zu (k lists 1..N), got %ld", i + 1, v);
        }
        N = (long)len;
    }
    if (N < 0) {
        for (i = 0; i < s->nsensors; ++i) {
            const dkf_scn_sensor_t *se = &s->sensors[i];
            long last = se->yk[se->ny - 1];
            if (N < 0 || last < N) N = last;
        }
        if (N < 1) return fail(c, "y", "no measurement at k >= 1");
        if (N > (long)DKF_SCN_MAX_STEPS)
            return fail(c, "y", "measurements up to k = %ld: more than the %lu steps allowed "
                        "(give N)", N, DKF_SCN_MAX_STEPS);
    }
    s->steps = (size_t)N;
    return 0;
}

static int parse_truth(ctx_t *c, dkf_scenario_t *s, const json_t *tj, const char *path)
{
    if (tj == NULL || !json_is_object(tj) || json_object_get(tj, "x") == NULL) return 0;
    return parse_series(c, tj, path, "x", s->n, &s->ntruth, &s->truth_k, &s->truth_x);
}

/* A sensor's y series; its dimension comes from its H (checked again later). */
static int parse_sensor_y(ctx_t *c, dkf_scenario_t *s, size_t i, const json_t *yj,
                          const char *path)
{
    dkf_scn_sensor_t *se = &s->sensors[i];
    const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, i, "H");
    const json_t *v0;
    size_t dim;
    if (H != NULL) {
        dim = H->rows;
    } else {
        /* Let validate() report the missing H; size y by its first value. */
        v0 = json_is_object(yj) ? json_object_get(yj, "values") : NULL;
        v0 = v0 != NULL ? json_array_get(v0, 0) : NULL;
        dim = v0 != NULL && json_is_array(v0) ? json_array_size(v0) : 1;
    }
    se->m = dim;
    se->ny = 0;
    se->yk = NULL;
    se->y = NULL;
    se->borrowed = 0;
    return parse_series(c, yj, path, "values", dim, &se->ny, &se->yk, &se->y);
}

/* Every sensor's y series from yj (one object, or a list with one per sensor). */
static int parse_y_all(ctx_t *c, dkf_scenario_t *s, const json_t *yj, const char *path)
{
    size_t i;
    char p[PATH_LEN];
    if (!s->multi) return parse_sensor_y(c, s, 0, yj, path);
    if (!json_is_array(yj) || json_array_size(yj) != s->nsensors)
        return fail(c, path, "expected a list of %zu measurement series (one per "
                    "model.sensors entry), got %s", s->nsensors,
                    json_is_array(yj) ? "a list of another length" : json_kind(yj));
    for (i = 0; i < s->nsensors; ++i) {
        subidx(p, path, i);
        if (parse_sensor_y(c, s, i, json_array_get(yj, i), p) != 0) return -1;
    }
    return 0;
}

/* ---- runs ------------------------------------------------------------------- */

static int alloc_runs(ctx_t *c, dkf_scenario_t *s, size_t nruns)
{
    size_t r;
    if ((s->runs = xcalloc(c, nruns, sizeof *s->runs)) == NULL) return -1;
    s->nruns = nruns;
    for (r = 0; r < nruns; ++r)
        if ((s->runs[r].y = xcalloc(c, s->nsensors, sizeof *s->runs[r].y)) == NULL) return -1;
    return 0;
}

/* Hands the sensors' freshly parsed y series to run r; the sensors keep
 * viewing them. */
static void adopt_y(dkf_scenario_t *s, size_t r)
{
    size_t i;
    for (i = 0; i < s->nsensors; ++i) {
        dkf_scn_sensor_t *se = &s->sensors[i];
        s->runs[r].y[i].n = se->ny;
        s->runs[r].y[i].k = se->yk;
        s->runs[r].y[i].v = se->y;
        se->borrowed = 1;
    }
}

static void adopt_truth(dkf_scenario_t *s, size_t r)
{
    s->runs[r].ntruth = s->ntruth;
    s->runs[r].truth_k = s->truth_k;
    s->runs[r].truth_x = s->truth_x;
    s->truth_borrowed = 1;
}

static int parse_run_truth(ctx_t *c, dkf_scenario_t *s, size_t r, const json_t *tj,
                           const char *path)
{
    s->ntruth = 0;
    s->truth_k = NULL;
    s->truth_x = NULL;
    s->truth_borrowed = 0;
    if (parse_truth(c, s, tj, path) != 0) return -1;
    adopt_truth(s, r);
    return 0;
}

static int load_canonical(ctx_t *c, dkf_scenario_t *s, const json_t *root)
{
    const json_t *model = json_object_get(root, "model"), *init = json_object_get(root, "init");
    const json_t *sensors, *yj, *runs;
    const char *key;
    json_t *val;
    size_t i, r, nruns = 1;
    char p[PATH_LEN];

    if (model == NULL) return fail(c, "model", "missing key");
    if (!json_is_object(model))
        return fail(c, "model", "expected an object, got %s", json_kind(model));
    if (init == NULL) return fail(c, "init", "missing key");
    if (!json_is_object(init))
        return fail(c, "init", "expected an object, got %s", json_kind(init));
    yj = json_object_get(root, "y");
    runs = json_object_get(root, "runs");
    if (runs != NULL) {
        if (yj != NULL) return fail(c, "y", "not allowed together with runs (give runs[i].y)");
        if (json_object_get(root, "truth") != NULL)
            return fail(c, "truth", "not allowed together with runs (give runs[i].truth)");
        if (!json_is_array(runs) || json_array_size(runs) == 0)
            return fail(c, "runs", "expected a non-empty list of {\"y\": ..., \"truth\": ...} "
                        "objects, got %s", json_kind(runs));
        s->has_runs = 1;
        nruns = json_array_size(runs);
        if (nruns > DKF_SCN_MAX_RUNS)
            return fail(c, "runs", "%zu runs, more than the %lu allowed", nruns,
                        DKF_SCN_MAX_RUNS);
    } else if (yj == NULL) {
        return fail(c, "y", "missing key");
    }

    sensors = json_object_get(model, "sensors");
    if (parse_mat_object(c, &s->model, model, "model", "sensors") != 0) return -1;
    if (sensors != NULL) {
        if (!json_is_array(sensors) || json_array_size(sensors) == 0)
            return fail(c, "model.sensors", "expected a non-empty list of sensor objects, got %s",
                        json_kind(sensors));
        s->multi = 1;
        s->nsensors = json_array_size(sensors);
        if (s->nsensors > DKF_SCN_MAX_SENSORS)
            return fail(c, "model.sensors", "%zu sensors, more than the %lu allowed",
                        s->nsensors, DKF_SCN_MAX_SENSORS);
    } else {
        s->nsensors = 1;
    }
    if ((s->sensors = xcalloc(c, s->nsensors, sizeof *s->sensors)) == NULL) return -1;
    for (i = 0; s->multi && i < s->nsensors; ++i) {
        const json_t *sj = json_array_get(sensors, i);
        subidx(p, "model.sensors", i);
        if (!json_is_object(sj)) return fail(c, p, "expected an object, got %s", json_kind(sj));
        if (parse_mat_object(c, &s->sensors[i].mats, sj, p, NULL) != 0) return -1;
    }

    json_object_foreach((json_t *)init, key, val) {
        subkey(p, "init", key);
        if (parse_init_entry(c, &s->init, key, val, p) != 0) return -1;
    }

    if (alloc_runs(c, s, nruns) != 0) return -1;
    for (r = 0; r < nruns; ++r) {
        const json_t *rj = runs != NULL ? json_array_get(runs, r) : root;
        char py[PATH_LEN];
        if (runs != NULL) {
            subidx(p, "runs", r);
            if (!json_is_object(rj)) return fail(c, p, "expected an object, got %s", json_kind(rj));
            subkey(py, p, "y");
            if ((yj = json_object_get(rj, "y")) == NULL) return fail(c, py, "missing key");
        } else {
            pathf(py, "y");
        }
        if (parse_y_all(c, s, yj, py) != 0) return -1;
        adopt_y(s, r);
    }
    dkf_scn_select_run(s, 0);

    if (canonical_steps(c, s, root) != 0) return -1;
    /* n comes from F; validate first so truth is sized right. */
    if (validate(c, s, "model", s->multi ? "model.sensors[%zu]" : "model") != 0) return -1;
    for (r = 0; r < nruns; ++r) {
        const json_t *rj = runs != NULL ? json_array_get(runs, r) : root;
        if (runs != NULL)
            pathf(p, "runs[%zu].truth", r);
        else
            pathf(p, "truth");
        if (parse_run_truth(c, s, r, json_object_get(rj, "truth"), p) != 0) return -1;
    }
    dkf_scn_select_run(s, 0);
    return 0;
}

/* ---- cases layout (infofusion vectors) ------------------------------------ */

static int select_case(ctx_t *c, const json_t *cases, const char *sel, size_t *idx)
{
    size_t i, n = json_array_size(cases);
    char *end;
    unsigned long v;
    if (n == 0) return fail(c, "cases", "expected a non-empty list of cases");
    if (sel == NULL) {
        *idx = 0;
        return 0;
    }
    for (i = 0; i < n; ++i) {
        const json_t *name = json_object_get(json_array_get(cases, i), "name");
        if (json_is_string(name) && strcmp(json_string_value(name), sel) == 0) {
            *idx = i;
            return 0;
        }
    }
    errno = 0;
    v = strtoul(sel, &end, 10);
    if (sel[0] >= '0' && sel[0] <= '9' && *end == '\0' && errno == 0) {
        if (v >= n) return fail(c, "cases", "case index %lu out of range (file has %zu)", v, n);
        *idx = (size_t)v;
        return 0;
    }
    return fail(c, "cases", "no case named '%s' (use a name or an index 0..%zu)", sel, n - 1);
}

/* Model matrix `name` from every step (per_k: step k gives entry k-1, the
 * matrix that propagates k-1 -> k) or from the case itself. */
static int cases_model(ctx_t *c, dkf_scenario_t *s, const json_t *cj, const json_t *steps,
                       const char *cpath, const char *name)
{
    const json_t *first = json_object_get(json_array_get(steps, 0), name);
    dkf_scn_mat_t *m;
    size_t j, N = json_array_size(steps);
    block_t b;
    char p[PATH_LEN], sp[PATH_LEN];
    if (first == NULL) {
        const json_t *v = json_object_get(cj, name);
        subkey(p, cpath, name);
        if (v == NULL) return fail(c, p, "missing key (give it in the case or in every step)");
        if ((m = mats_add(c, &s->model, name, p)) == NULL) return -1;
        if (parse_matrix(c, v, p, &m->rows, &m->cols, &m->data) != 0) return -1;
        return check_dims(c, m);
    }
    pathf(p, "%s.steps[].%s", cpath, name);
    if ((m = mats_add(c, &s->model, name, p)) == NULL) return -1;
    for (j = 0; j < N; ++j) {
        const json_t *v = json_object_get(json_array_get(steps, j), name);
        pathf(sp, "%s.steps[%zu].%s", cpath, j, name);
        if (v == NULL) return fail(c, sp, "missing key (step 0 has it, so every step needs it)");
        if (stack_matrix(c, m, &b, j, N, v, sp) != 0) return -1;
    }
    m->count = N;
    return 0;
}

/* Sensor j's matrix from the case list `list` (C or R), renamed to `as`. */
static int cases_sensor_mat(ctx_t *c, dkf_scenario_t *s, const json_t *list, const char *lpath,
                            size_t j, const char *as)
{
    dkf_scn_mat_t *m;
    char p[PATH_LEN];
    subidx(p, lpath, j);
    if ((m = mats_add(c, &s->sensors[j].mats, as, p)) == NULL) return -1;
    if (parse_matrix(c, json_array_get(list, j), p, &m->rows, &m->cols, &m->data) != 0) return -1;
    return check_dims(c, m);
}

static int cases_init(ctx_t *c, dkf_scenario_t *s, const json_t *cj, const char *cpath,
                      const char *key, const char *as)
{
    const json_t *v = json_object_get(cj, key);
    char p[PATH_LEN];
    subkey(p, cpath, key);
    if (v == NULL) return fail(c, p, "missing key");
    return parse_init_entry(c, &s->init, as, v, p);
}

static int cases_measurements(ctx_t *c, dkf_scenario_t *s, const json_t *steps,
                              const char *cpath)
{
    size_t j, i, N = json_array_size(steps);
    char p[PATH_LEN], pz[PATH_LEN];
    block_t *y = xcalloc(c, s->nsensors, sizeof *y);
    int rc = -1;
    if (y == NULL) return -1;
    for (i = 0; i < s->nsensors; ++i) {
        dkf_scn_sensor_t *se = &s->sensors[i];
        se->m = dkf_scn_sensor_model(s, i, "H")->rows;
        se->ny = N;
        se->yk = xcalloc(c, N, sizeof *se->yk);
        if (se->yk == NULL || block_alloc(c, &y[i], N, se->m, cpath) != 0) goto done;
        se->y = y[i].v;
    }
    for (j = 0; j < N; ++j) {
        const json_t *st = json_array_get(steps, j), *z;
        long k;
        pathf(p, "%s.steps[%zu]", cpath, j);
        if (!json_is_object(st)) {
            fail(c, p, "expected an object, got %s", json_kind(st));
            goto done;
        }
        subkey(pz, p, "k");
        if (json_object_get(st, "k") == NULL) {
            fail(c, pz, "missing key");
            goto done;
        }
        if (get_integer(c, json_object_get(st, "k"), pz, 0.0, DKF_SCN_MAX_TIME, &k) != 0)
            goto done;
        if (k != (long)j + 1) {
            fail(c, pz, "expected %zu (steps list k = 1..N), got %ld", j + 1, k);
            goto done;
        }
        z = json_object_get(st, "z");
        subkey(pz, p, "z");
        if (z == NULL) {
            fail(c, pz, "missing key");
            goto done;
        }
        if (!json_is_array(z) || json_array_size(z) != s->nsensors) {
            fail(c, pz, "expected a list of %zu measurements (one per sensor), got %s",
                 s->nsensors, json_kind(z));
            goto done;
        }
        for (i = 0; i < s->nsensors; ++i) {
            char pzi[PATH_LEN];
            size_t len;
            double *v;
            int st_rc;
            subidx(pzi, pz, i);
            if (parse_vector(c, json_array_get(z, i), pzi, &len, &v) != 0) goto done;
            st_rc = store(c, pzi, &y[i], j, v, len);
            free(v);
            if (st_rc != 0) goto done;
            s->sensors[i].yk[j] = k;
        }
    }
    rc = 0;
done:
    free(y);
    return rc;
}

static int load_cases(ctx_t *c, dkf_scenario_t *s, const json_t *root, const char *sel)
{
    const json_t *cases = json_object_get(root, "cases"), *cj, *steps, *C, *R, *name;
    size_t i;
    char cpath[PATH_LEN], p[PATH_LEN], pr[PATH_LEN];

    if (!json_is_array(cases)) return fail(c, "cases", "expected a list, got %s", json_kind(cases));
    if (select_case(c, cases, sel, &s->case_index) != 0) return -1;
    subidx(cpath, "cases", s->case_index);
    cj = json_array_get(cases, s->case_index);
    if (!json_is_object(cj)) return fail(c, cpath, "expected an object, got %s", json_kind(cj));
    name = json_object_get(cj, "name");
    s->case_name = dupstr(json_is_string(name) ? json_string_value(name) : "");
    s->layout = DKF_SCN_LAYOUT_CASES;
    s->multi = 1;

    steps = json_object_get(cj, "steps");
    subkey(p, cpath, "steps");
    if (steps == NULL) return fail(c, p, "missing key");
    if (!json_is_array(steps) || json_array_size(steps) == 0)
        return fail(c, p, "expected a non-empty list of steps, got %s", json_kind(steps));
    s->steps = json_array_size(steps);
    if (s->steps > DKF_SCN_MAX_STEPS)
        return fail(c, p, "%zu steps, more than the %lu allowed", s->steps, DKF_SCN_MAX_STEPS);
    if (!json_is_object(json_array_get(steps, 0)))
        return fail(c, p, "expected a list of step objects");
    if (cases_model(c, s, cj, steps, cpath, "F") != 0) return -1;
    if (cases_model(c, s, cj, steps, cpath, "Q") != 0) return -1;

    C = json_object_get(cj, "C");
    R = json_object_get(cj, "R");
    subkey(p, cpath, "C");
    subkey(pr, cpath, "R");
    if (C == NULL) return fail(c, p, "missing key");
    if (R == NULL) return fail(c, pr, "missing key");
    if (!json_is_array(C) || json_array_size(C) == 0)
        return fail(c, p, "expected a non-empty list of sensor matrices, got %s", json_kind(C));
    s->nsensors = json_array_size(C);
    if (s->nsensors > DKF_SCN_MAX_SENSORS)
        return fail(c, p, "%zu sensors, more than the %lu allowed", s->nsensors,
                    DKF_SCN_MAX_SENSORS);
    if (!json_is_array(R) || json_array_size(R) != s->nsensors)
        return fail(c, pr, "expected a list of %zu matrices (one per C), got %s", s->nsensors,
                    json_kind(R));
    if ((s->sensors = xcalloc(c, s->nsensors, sizeof *s->sensors)) == NULL) return -1;
    for (i = 0; i < s->nsensors; ++i) {
        if (cases_sensor_mat(c, s, C, p, i, "H") != 0) return -1;
        if (cases_sensor_mat(c, s, R, pr, i, "R") != 0) return -1;
    }
    if (cases_init(c, s, cj, cpath, "x0", "x00") != 0) return -1;
    if (cases_init(c, s, cj, cpath, "P0", "P00") != 0) return -1;
    if (cases_measurements(c, s, steps, cpath) != 0) return -1;
    if (alloc_runs(c, s, 1) != 0) return -1;
    adopt_y(s, 0);
    pathf(p, "%s.C[%%zu]", cpath);
    if (validate(c, s, cpath, p) != 0) return -1;
    subkey(p, cpath, "truth");
    if (parse_run_truth(c, s, 0, json_object_get(cj, "truth"), p) != 0) return -1;
    dkf_scn_select_run(s, 0);
    return 0;
}

/* ---- steps layout (seed-003/004 vectors) ------------------------------------- */

#define STEPS_MAX_KEYS 32

/* Step j's absolute time: key `k` (seed 004) or `n` (seed 003). */
static int steps_time(ctx_t *c, const json_t *st, size_t j, long *k)
{
    const json_t *jk = json_object_get(st, "k");
    const char *key = "k";
    char p[PATH_LEN], pk[PATH_LEN];
    subidx(p, "steps", j);
    if (!json_is_object(st)) return fail(c, p, "expected an object, got %s", json_kind(st));
    if (jk == NULL) {
        jk = json_object_get(st, "n");
        key = "n";
    }
    if (jk == NULL) return fail(c, p, "missing key k (or n): the step's time");
    subkey(pk, p, key);
    return get_integer(c, jk, pk, 0.0, DKF_SCN_MAX_TIME, k);
}

/* `inputs` of step j: an object with at least y. */
static int steps_inputs_of(ctx_t *c, const json_t *st, size_t j, const json_t **in)
{
    char p[PATH_LEN];
    pathf(p, "steps[%zu].inputs", j);
    *in = json_object_get(st, "inputs");
    if (*in == NULL) return fail(c, p, "missing key");
    if (!json_is_object(*in)) return fail(c, p, "expected an object, got %s", json_kind(*in));
    return 0;
}

/* Per-step matrix `key` of the inputs (`<M>` at k, `<M>_prev` at k - 1)
 * into model <M>, per_k from k0. Steps that need it: all, or k >= 1. */
static int steps_matrix(ctx_t *c, dkf_scenario_t *s, const json_t *steps, const char *key)
{
    size_t len = strlen(key), N = json_array_size(steps), j, first = N;
    block_t b;
    int prev = len > 5 && strcmp(key + len - 5, "_prev") == 0;
    char name[64], p[PATH_LEN];
    dkf_scn_mat_t *m;
    snprintf(name, sizeof name, "%.*s", (int)(prev ? len - 5 : len), key);
    for (j = 0; j < N; ++j) {
        const json_t *v = json_object_get(json_object_get(json_array_get(steps, j), "inputs"), key);
        const long k = s->k_first + (long)j;
        pathf(p, "steps[%zu].inputs.%s", j, key);
        if (prev && k == 0) {
            if (v != NULL) return fail(c, p, "no dynamics lead to k = 0 (the first step has none)");
            continue;
        }
        if (v == NULL)
            return fail(c, p, "missing key (another step has it, so every step%s needs it)",
                        prev ? " with k >= 1" : "");
        if (nest_depth(v) > 2)
            return fail(c, p, "expected a matrix, got a list of matrices (only seed-003 H and Sw "
                        "are per node)");
        if (first == N) first = j;
    }
    if (mats_find(&s->model, name) != NULL) {
        pathf(p, "steps[%zu].inputs.%s", first, key);
        return fail(c, p, "also given as model.%s or as another step input (give one)", name);
    }
    pathf(p, "steps[%zu].inputs.%s", first, key);
    if ((m = mats_add(c, &s->model, name, p)) == NULL) return -1;
    for (j = first; j < N; ++j) {
        pathf(p, "steps[%zu].inputs.%s", j, key);
        if (stack_matrix(c, m, &b, j - first, N - first,
                         json_object_get(json_object_get(json_array_get(steps, j), "inputs"), key),
                         p) != 0)
            return -1;
    }
    m->count = N - first;
    m->k0 = (size_t)(s->k_first + (long)first - (prev ? 1 : 0));
    return check_dims(c, m);
}

/* Seed 003's per-node H or Sw given per step: steps[j].inputs.<key> is a
 * list of one matrix per node, node l's <key> at the step's time (a per_k
 * list of sensor l from k_first). Shapes may not change between steps. */
static int steps_node_series(ctx_t *c, dkf_scenario_t *s, const json_t *steps, const char *key)
{
    size_t N = json_array_size(steps), L = s->nsensors, j, l;
    block_t *b;
    char p[PATH_LEN], pl[PATH_LEN];
    int rc = -1;
    for (l = 0; l < L; ++l)
        if (mats_find(&s->sensors[l].mats, key) != NULL) {
            pathf(p, "steps[0].inputs.%s", key);
            return fail(c, p, "also given as model.%s (give one)", key);
        }
    if ((b = xcalloc(c, L, sizeof *b)) == NULL) return -1;
    for (l = 0; l < L; ++l) {
        dkf_scn_mat_t *m;
        pathf(pl, "steps[0].inputs.%s[%zu]", key, l);
        if ((m = mats_add(c, &s->sensors[l].mats, key, pl)) == NULL) goto done;
        m->count = N;
        m->k0 = (size_t)s->k_first;
    }
    for (j = 0; j < N; ++j) {
        const json_t *v = json_object_get(json_object_get(json_array_get(steps, j), "inputs"), key);
        pathf(p, "steps[%zu].inputs.%s", j, key);
        if (v == NULL) {
            fail(c, p, "missing key (another step has it, so every step needs it)");
            goto done;
        }
        if (!json_is_array(v) || nest_depth(v) != 3 || json_array_size(v) != L) {
            fail(c, p, "expected a list of %zu matrices (one per node), got %s", L,
                 json_is_array(v) ? "a list of another shape" : json_kind(v));
            goto done;
        }
        for (l = 0; l < L; ++l) {
            dkf_scn_mat_t *m = &s->sensors[l].mats.items[s->sensors[l].mats.len - 1];
            subidx(pl, p, l);
            if (stack_matrix(c, m, &b[l], j, N, json_array_get(v, l), pl) != 0) goto done;
            if (j == 0 && check_dims(c, m) != 0) goto done;
        }
    }
    rc = 0;
done:
    free(b);
    return rc;
}

/* Every per-step matrix input (the union of the steps' input keys but y). */
static int steps_matrices(ctx_t *c, dkf_scenario_t *s, const json_t *steps)
{
    const char *keys[STEPS_MAX_KEYS];
    size_t nkeys = 0, j, i;
    for (j = 0; j < json_array_size(steps); ++j) {
        const json_t *in = json_object_get(json_array_get(steps, j), "inputs");
        const char *key;
        json_t *val;
        json_object_foreach((json_t *)in, key, val) {
            if (strcmp(key, "y") == 0 || json_is_string(val) || json_is_null(val)) continue;
            for (i = 0; i < nkeys && strcmp(keys[i], key) != 0; ++i) continue;
            if (i < nkeys) continue;
            if (nkeys == STEPS_MAX_KEYS) {
                char p[PATH_LEN];
                pathf(p, "steps[%zu].inputs.%s", j, key);
                return fail(c, p, "more than %d different per-step inputs", STEPS_MAX_KEYS);
            }
            keys[nkeys++] = key;
        }
    }
    for (i = 0; i < nkeys; ++i) {
        const int node_key = s->family == DKF_SCN_FAMILY_TW &&
                             (strcmp(keys[i], "H") == 0 || strcmp(keys[i], "Sw") == 0);
        if ((node_key ? steps_node_series(c, s, steps, keys[i])
                      : steps_matrix(c, s, steps, keys[i])) != 0)
            return -1;
    }
    return 0;
}

/* A list of N same-shape matrices (model.H / model.Sw of seed 003): sensor
 * l's matrix `name`. */
static int steps_node_matrices(ctx_t *c, dkf_scenario_t *s, const json_t *model,
                               const char *name)
{
    const json_t *v = json_object_get(model, name);
    size_t l;
    char p[PATH_LEN], pl[PATH_LEN];
    subkey(p, "model", name);
    if (v == NULL) return fail(c, p, "missing key (a list of one matrix per node)");
    if (!json_is_array(v) || nest_depth(v) != 3 || json_array_size(v) != s->nsensors)
        return fail(c, p, "expected a list of %zu matrices (one per node of graph), got %s",
                    s->nsensors, json_is_array(v) ? "a list of another shape" : json_kind(v));
    for (l = 0; l < s->nsensors; ++l) {
        dkf_scn_mat_t *m;
        subidx(pl, p, l);
        if ((m = mats_add(c, &s->sensors[l].mats, name, pl)) == NULL) return -1;
        if (parse_matrix(c, json_array_get(v, l), pl, &m->rows, &m->cols, &m->data) != 0)
            return -1;
        if (check_dims(c, m) != 0) return -1;
    }
    return 0;
}

/* The constant model: bare matrices (or const/per_k objects); seed 003's
 * per-node H, Sw go to the sensors. */
static int steps_model(ctx_t *c, dkf_scenario_t *s, const json_t *model)
{
    const char *key;
    json_t *val;
    char p[PATH_LEN];
    json_object_foreach((json_t *)model, key, val) {
        if (s->family == DKF_SCN_FAMILY_TW && (strcmp(key, "H") == 0 || strcmp(key, "Sw") == 0))
            continue;
        subkey(p, "model", key);
        if (json_is_array(val) && nest_depth(val) > 2)
            return fail(c, p, "expected a matrix, got a list of matrices");
        if (parse_model_entry(c, &s->model, key, val, p) != 0) return -1;
    }
    if (s->family == DKF_SCN_FAMILY_TW) {
        /* per node, in model or (time varying) in every step's inputs */
        if (json_object_get(model, "H") != NULL && steps_node_matrices(c, s, model, "H") != 0)
            return -1;
        if (json_object_get(model, "Sw") != NULL && steps_node_matrices(c, s, model, "Sw") != 0)
            return -1;
    }
    return 0;
}

/* The length of sensor i's y: the rows of its C (seed 004) or H (seed 003)
 * if given, else what the first step's y has (steps_validate then reports
 * the missing matrix); every step's y is checked against it. */
static size_t steps_y_dim(const dkf_scenario_t *s, size_t i, const json_t *y0)
{
    const int tw = s->family == DKF_SCN_FAMILY_TW;
    const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, i, tw ? "H" : "C");
    const json_t *yi = tw ? json_array_get(y0, i) : y0;
    if (H != NULL) return H->rows;
    return json_is_array(yi) && json_array_size(yi) > 0 ? json_array_size(yi) : 1;
}

/* y of every step into the sensors' series (seed 004: one vector; seed
 * 003: a list with one vector per node). */
static int steps_measurements(ctx_t *c, dkf_scenario_t *s, const json_t *steps)
{
    size_t N = json_array_size(steps), j, i;
    const int tw = s->family == DKF_SCN_FAMILY_TW;
    const json_t *y0 = json_object_get(json_object_get(json_array_get(steps, 0), "inputs"), "y");
    char p[PATH_LEN], pi[PATH_LEN];
    block_t *yb = xcalloc(c, s->nsensors, sizeof *yb);
    int rc = -1;
    if (yb == NULL) return -1;
    for (i = 0; i < s->nsensors; ++i) {
        dkf_scn_sensor_t *se = &s->sensors[i];
        se->m = steps_y_dim(s, i, y0);
        se->ny = N;
        se->yk = xcalloc(c, N, sizeof *se->yk);
        if (se->yk == NULL || block_alloc(c, &yb[i], N, se->m, "steps") != 0) goto done;
        se->y = yb[i].v;
    }
    for (j = 0; j < N; ++j) {
        const json_t *y = json_object_get(json_object_get(json_array_get(steps, j), "inputs"), "y");
        pathf(p, "steps[%zu].inputs.y", j);
        if (y == NULL) {
            fail(c, p, "missing key");
            goto done;
        }
        if (tw && (!json_is_array(y) || json_array_size(y) != s->nsensors || nest_depth(y) != 2)) {
            fail(c, p, "expected a list of %zu measurement vectors (one per node), got %s",
                 s->nsensors, json_is_array(y) ? "a list of another shape" : json_kind(y));
            goto done;
        }
        for (i = 0; i < s->nsensors; ++i) {
            size_t len;
            double *v;
            int st;
            if (tw)
                subidx(pi, p, i);
            else
                pathf(pi, "%s", p);
            if (parse_vector(c, tw ? json_array_get(y, i) : y, pi, &len, &v) != 0) goto done;
            if (len != yb[i].dim)
                st = fail(c, pi, "expected a vector of %zu values (the rows of %s), got %zu",
                          yb[i].dim, tw ? "H" : "C", len);
            else
                st = store(c, pi, &yb[i], j, v, len);
            free(v);
            if (st != 0) goto done;
            s->sensors[i].yk[j] = s->k_first + (long)j;
        }
    }
    rc = 0;
done:
    free(yb);
    return rc;
}

/* truth.x (n) and the true input truth.d / d_prev / z_prev (m), all or none. */
static int steps_truth(ctx_t *c, dkf_scenario_t *s, const json_t *steps, size_t m)
{
    static const char *const ukeys[] = {"d", "d_prev", "z_prev"};
    const json_t *t0 = json_object_get(json_array_get(steps, 0), "truth");
    size_t N = json_array_size(steps), j, i;
    const char *ukey = NULL;
    block_t tb[2] = {{NULL, 0, 0}, {NULL, 0, 0}};
    char p[PATH_LEN];
    if (!json_is_object(t0)) return 0;
    for (i = 0; i < 3 && ukey == NULL; ++i)
        if (json_object_get(t0, ukeys[i]) != NULL) ukey = ukeys[i];
    if (json_object_get(t0, "x") != NULL) {
        s->truth_k = xcalloc(c, N, sizeof *s->truth_k);
        if (s->truth_k == NULL || block_alloc(c, &tb[0], N, s->n, "steps[0].truth.x") != 0)
            return -1;
        s->truth_x = tb[0].v;
        s->ntruth = N;
    }
    if (ukey != NULL) {
        snprintf(s->truth_u_key, sizeof s->truth_u_key, "%s", ukey);
        s->truth_u_k = xcalloc(c, N, sizeof *s->truth_u_k);
        if (s->truth_u_k == NULL || block_alloc(c, &tb[1], N, m, "steps[0].truth") != 0)
            return -1;
        s->truth_u = tb[1].v;
        s->ntruth_u = N;
        s->m_u = m;
    }
    for (j = 0; j < N; ++j) {
        const json_t *t = json_object_get(json_array_get(steps, j), "truth");
        for (i = 0; i < 2; ++i) {
            const char *key = i == 0 ? "x" : ukey;
            long *kd = i == 0 ? s->truth_k : s->truth_u_k;
            size_t len;
            double *v;
            int rc;
            if (tb[i].v == NULL) continue;
            pathf(p, "steps[%zu].truth.%s", j, key);
            if (json_object_get(t, key) == NULL)
                return fail(c, p, "missing key (steps[0] has it, so every step needs it)");
            if (parse_vector(c, json_object_get(t, key), p, &len, &v) != 0) return -1;
            rc = store(c, p, &tb[i], j, v, len);
            free(v);
            if (rc != 0) return -1;
            kd[j] = s->k_first + (long)j;
        }
    }
    return 0;
}

/* Weights `key` (dense N x N, nonzeros kept) or `key`_sparse ([[i, j, v], ...]). */
static int steps_weights(ctx_t *c, dkf_scenario_t *s, const json_t *root, const char *key,
                         const char **which, size_t *count, size_t **rc, double **v)
{
    char skey[64], p[PATH_LEN];
    const json_t *dense = json_object_get(root, key), *sparse;
    size_t N = s->nsensors, i, j, n = 0;
    snprintf(skey, sizeof skey, "%s_sparse", key);
    sparse = json_object_get(root, skey);
    *which = NULL;
    *count = 0;
    if (dense == NULL && sparse == NULL) return 0;
    if (dense != NULL && sparse != NULL) return fail(c, skey, "not allowed together with %s", key);
    if (dense != NULL) {
        double *M;
        size_t r, cc;
        if (parse_matrix(c, dense, key, &r, &cc, &M) != 0) return -1;
        if (r != N || cc != N) {
            free(M);
            return shape_error(c, key, N, N, r, cc);
        }
        for (i = 0; i < N * N; ++i) n += M[i] != 0.0;
        *rc = xcalloc(c, 2 * n, sizeof **rc);
        *v = xcalloc(c, n, sizeof **v);
        if (*rc == NULL || *v == NULL) {
            free(M);
            return -1;
        }
        n = 0;
        for (i = 0; i < N; ++i)
            for (j = 0; j < N; ++j)
                if (M[i * N + j] != 0.0) {
                    (*rc)[2 * n] = i;
                    (*rc)[2 * n + 1] = j;
                    (*v)[n++] = M[i * N + j];
                }
        free(M);
        *which = key;
        *count = n;
        return 0;
    }
    if (!json_is_array(sparse) || json_array_size(sparse) == 0)
        return fail(c, skey, "expected a non-empty list of [i, j, value] triplets, got %s",
                    json_kind(sparse));
    n = json_array_size(sparse);
    *rc = xcalloc(c, 2 * n, sizeof **rc);
    *v = xcalloc(c, n, sizeof **v);
    if (*rc == NULL || *v == NULL) return -1;
    for (i = 0; i < n; ++i) {
        const json_t *t = json_array_get(sparse, i);
        long a, b;
        subidx(p, skey, i);
        if (!json_is_array(t) || json_array_size(t) != 3)
            return fail(c, p, "expected a triplet [i, j, value], got %s", json_kind(t));
        if (get_integer(c, json_array_get(t, 0), p, -DKF_SCN_MAX_TIME, DKF_SCN_MAX_TIME, &a) != 0)
            return -1;
        if (get_integer(c, json_array_get(t, 1), p, -DKF_SCN_MAX_TIME, DKF_SCN_MAX_TIME, &b) != 0)
            return -1;
        if (a < 0 || b < 0 || (size_t)a >= N || (size_t)b >= N)
            return fail(c, p, "node index out of range 0..%zu", N - 1);
        if (!json_is_number(json_array_get(t, 2)))
            return fail(c, p, "expected a number as the value, got %s",
                        json_kind(json_array_get(t, 2)));
        (*rc)[2 * i] = (size_t)a;
        (*rc)[2 * i + 1] = (size_t)b;
        (*v)[i] = json_number_value(json_array_get(t, 2));
    }
    *which = strcmp(key, "W_consensus") == 0 ? "W_consensus_sparse" : "alpha_diffusion_sparse";
    *count = n;
    return 0;
}

/* graph.edges, the weights, eta (seed 003). */
static int steps_network(ctx_t *c, dkf_scenario_t *s, const json_t *root)
{
    const json_t *graph = json_object_get(root, "graph"), *edges, *eta;
    dkf_scn_network_t *net;
    size_t e, N = s->nsensors;
    char p[PATH_LEN];
    if ((net = s->net = xcalloc(c, 1, sizeof *net)) == NULL) return -1;
    net->N = N;
    net->eta = -1;
    if (!json_is_object(graph)) return fail(c, "graph", "expected an object, got %s", json_kind(graph));
    edges = json_object_get(graph, "edges");
    if (edges == NULL) return fail(c, "graph.edges", "missing key");
    if (!json_is_array(edges))
        return fail(c, "graph.edges", "expected a list of [i, j] pairs, got %s", json_kind(edges));
    net->E = json_array_size(edges);
    if (net->E > N * (N - 1) / 2)
        return fail(c, "graph.edges", "%zu edges, more than a simple graph on %zu nodes has",
                    net->E, N);
    if ((net->edges = xcalloc(c, 2 * net->E, sizeof *net->edges)) == NULL) return -1;
    for (e = 0; e < net->E; ++e) {
        const json_t *pr = json_array_get(edges, e);
        size_t i;
        subidx(p, "graph.edges", e);
        if (!json_is_array(pr) || json_array_size(pr) != 2)
            return fail(c, p, "expected a pair [i, j], got %s", json_kind(pr));
        for (i = 0; i < 2; ++i) {
            long v;
            if (get_integer(c, json_array_get(pr, i), p, -DKF_SCN_MAX_TIME, DKF_SCN_MAX_TIME, &v)
                != 0)
                return -1;
            if (v < 0 || (size_t)v >= N)
                return fail(c, p, "node index %ld out of range 0..%zu (model.H has %zu nodes)", v,
                            N - 1, N);
            net->edges[2 * e + i] = (size_t)v;
        }
    }
    if (steps_weights(c, s, root, "W_consensus", &net->W_key, &net->nW, &net->W_rc, &net->W_v) != 0)
        return -1;
    if (steps_weights(c, s, root, "alpha_diffusion", &net->alpha_key, &net->nalpha,
                      &net->alpha_rc, &net->alpha_v) != 0)
        return -1;
    eta = json_object_get(root, "eta");
    if (eta != NULL) {
        if (get_integer(c, eta, "eta", 0.0, (double)DKF_TW_MAX_ETA, &net->eta) != 0) return -1;
    }
    return 0;
}

/* Model matrix `name` must exist with shape r x cc (0: any) and cover
 * absolute times k = from..to; returns it through out. */
static int steps_require(ctx_t *c, const dkf_scenario_t *s, size_t sensor, const char *name,
                         size_t r, size_t cc, long from, long to, const dkf_scn_mat_t **out)
{
    const dkf_scn_mat_t *m = dkf_scn_sensor_model(s, sensor, name);
    char p[PATH_LEN];
    long k;
    subkey(p, "model", name);
    if (m == NULL) return fail(c, p, "missing key");
    if ((r != 0 && m->rows != r) || (cc != 0 && m->cols != cc))
        return shape_error(c, m->path, r != 0 ? r : m->rows, cc != 0 ? cc : m->cols, m->rows,
                           m->cols);
    for (k = from; k <= to; ++k)
        if (dkf_scn_at(m, (size_t)k) == NULL)
            return fail(c, m->path, "no value for k = %ld (steps k = %ld..%ld need %s_%ld)", k,
                        s->k_first, s->k_first + (long)s->steps - 1, name, k);
    if (m->rows > DKF_MAX_DIM || m->cols > DKF_MAX_DIM)
        return fail(c, m->path, "dimension %zu exceeds DKF_MAX_DIM = %d",
                    m->rows > m->cols ? m->rows : m->cols, DKF_MAX_DIM);
    if (out != NULL) *out = m;
    return 0;
}

/* Shapes and time coverage of a steps-layout model; sets n. Dynamics are
 * needed at k - 1 for every step k >= 1, the measurement model at every k. */
static int steps_validate(ctx_t *c, dkf_scenario_t *s, size_t *m_out)
{
    const long klast = s->k_first + (long)s->steps - 1, kd0 = s->k_first > 0 ? s->k_first - 1 : 0;
    const long kd1 = klast - 1;
    const dkf_scn_mat_t *A, *G, *C, *H;
    size_t n, m, p, l;
    const int tw = s->family == DKF_SCN_FAMILY_TW;
    if (steps_require(c, s, 0, "A", 0, 0, kd0, kd1, &A) != 0) return -1;
    if (A->rows != A->cols)
        return fail(c, A->path, "expected a square matrix, got %zux%zu", A->rows, A->cols);
    n = s->n = A->rows;
    if (steps_require(c, s, 0, tw ? "B" : "G", n, 0, kd0, kd1, &G) != 0) return -1;
    m = *m_out = G->cols;
    if (steps_require(c, s, 0, tw ? "Sv" : "Q", n, n, kd0, kd1, NULL) != 0) return -1;
    if (!tw) {
        if (steps_require(c, s, 0, "C", 0, n, s->k_first, klast, &C) != 0) return -1;
        p = C->rows;
        if (steps_require(c, s, 0, "R", p, p, s->k_first, klast, NULL) != 0) return -1;
        H = dkf_scn_model(s, "H");
        if (H != NULL && steps_require(c, s, 0, "H", p, m, s->k_first, klast, NULL) != 0)
            return -1;
        if (s->sensors[0].m != p)
            return fail(c, "steps[0].inputs.y", "expected a vector of %zu values (the rows of C), "
                        "got %zu", p, s->sensors[0].m);
        return 0;
    }
    for (l = 0; l < s->nsensors; ++l) {
        const dkf_scn_mat_t *Hl = dkf_scn_sensor_model(s, l, "H"), *Sw;
        if (Hl == NULL)
            return fail(c, "model.H", "missing key (seed-003 files give one H per node, in "
                        "model or in every step's inputs)");
        if (Hl->cols != n) return shape_error(c, Hl->path, Hl->rows, n, Hl->rows, Hl->cols);
        if (Hl->rows > DKF_MAX_DIM)
            return fail(c, Hl->path, "dimension %zu exceeds DKF_MAX_DIM = %d", Hl->rows,
                        DKF_MAX_DIM);
        Sw = dkf_scn_sensor_model(s, l, "Sw");
        if (Sw == NULL)
            return fail(c, "model.Sw", "missing key (one Sw per node, in model or in every "
                        "step's inputs)");
        if (Sw->rows != Hl->rows || Sw->cols != Hl->rows)
            return shape_error(c, Sw->path, Hl->rows, Hl->rows, Sw->rows, Sw->cols);
        if (s->sensors[l].m != Hl->rows) {
            char p2[PATH_LEN];
            pathf(p2, "steps[0].inputs.y[%zu]", l);
            return fail(c, p2, "expected a vector of %zu values (the rows of model.H[%zu]), got %zu",
                        Hl->rows, l, s->sensors[l].m);
        }
    }
    return 0;
}

static int load_steps(ctx_t *c, dkf_scenario_t *s, const json_t *root)
{
    const json_t *steps = json_object_get(root, "steps"), *model = json_object_get(root, "model");
    const json_t *init = json_object_get(root, "init"), *in;
    size_t j, N, m = 0;
    long k;
    s->layout = DKF_SCN_LAYOUT_STEPS;
    if (!json_is_array(steps) || json_array_size(steps) == 0)
        return fail(c, "steps", "expected a non-empty list of step objects, got %s",
                    json_kind(steps));
    N = s->steps = json_array_size(steps);
    if (N > DKF_SCN_MAX_STEPS)
        return fail(c, "steps", "%zu steps, more than the %lu allowed", N, DKF_SCN_MAX_STEPS);
    for (j = 0; j < N; ++j) {
        char p[PATH_LEN];
        if (steps_time(c, json_array_get(steps, j), j, &k) != 0) return -1;
        if (steps_inputs_of(c, json_array_get(steps, j), j, &in) != 0) return -1;
        if (j == 0) {
            if (k != 0 && k != 1)
                return fail(c, "steps[0]", "the first step's time must be 0 or 1, got %ld", k);
            s->k_first = k;
        } else if (k != s->k_first + (long)j) {
            pathf(p, "steps[%zu]", j);
            return fail(c, p, "time %ld, expected %ld (steps are consecutive)", k,
                        s->k_first + (long)j);
        }
    }
    /* a time-varying file may give every matrix per step: no model, or null */
    if (json_is_null(model)) model = NULL;
    if (model != NULL && !json_is_object(model))
        return fail(c, "model", "expected an object, got %s", json_kind(model));
    if (init == NULL) return fail(c, "init", "missing key");
    if (!json_is_object(init)) return fail(c, "init", "expected an object, got %s", json_kind(init));
    if (json_object_get(root, "graph") != NULL) {
        const json_t *H = json_object_get(model, "H");
        const char *hkey = "model.H";
        s->family = DKF_SCN_FAMILY_TW;
        s->multi = 1;
        if (H == NULL) {
            H = json_object_get(json_object_get(json_array_get(steps, 0), "inputs"), "H");
            hkey = "steps[0].inputs.H";
        }
        if (H == NULL)
            return fail(c, "model.H", "missing key (seed-003 files give one H per node, in "
                        "model or in every step's inputs)");
        if (!json_is_array(H) || json_array_size(H) == 0)
            return fail(c, hkey, "expected a list of matrices (one per node)");
        s->nsensors = json_array_size(H);
        if (s->nsensors > DKF_SCN_MAX_SENSORS)
            return fail(c, hkey, "%zu nodes, more than the %lu allowed", s->nsensors,
                        DKF_SCN_MAX_SENSORS);
    } else {
        s->family = DKF_SCN_FAMILY_UIF;
        s->nsensors = 1;
    }
    if ((s->sensors = xcalloc(c, s->nsensors, sizeof *s->sensors)) == NULL) return -1;
    if (steps_model(c, s, model) != 0) return -1;
    if (steps_matrices(c, s, steps) != 0) return -1;
    {
        const char *key;
        json_t *val;
        char p[PATH_LEN];
        json_object_foreach((json_t *)init, key, val) {
            const char *as = strcmp(key, "x0") == 0 ? "x00" : strcmp(key, "P0") == 0 ? "P00" : key;
            subkey(p, "init", key);
            if (parse_init_entry(c, &s->init, as, val, p) != 0) return -1;
        }
    }
    if (steps_measurements(c, s, steps) != 0) return -1;
    if (steps_validate(c, s, &m) != 0) return -1;
    if (require_shape(c, dkf_scn_init(s, "x00"), "init.x0", s->n, 1) != 0) return -1;
    if (require_shape(c, dkf_scn_init(s, "P00"), "init.P0", s->n, s->n) != 0) return -1;
    if (require_single(c, dkf_scn_init(s, "P00"), "init.P0", s->n) != 0) return -1;
    if (check_covariances(c, s) != 0) return -1;
    if (s->family == DKF_SCN_FAMILY_TW && steps_network(c, s, root) != 0) return -1;
    if (alloc_runs(c, s, 1) != 0) return -1;
    adopt_y(s, 0);
    if (steps_truth(c, s, steps, m) != 0) return -1;
    adopt_truth(s, 0);
    dkf_scn_select_run(s, 0);
    return 0;
}

/* ---- public API ---------------------------------------------------------------- */

/* The scenario of a parsed document (takes the reference to root). */
static dkf_scenario_t *load_root(ctx_t *c, json_t *root, const json_error_t *je,
                                 const char *case_sel)
{
    dkf_scenario_t *s;
    int rc;
    if (root == NULL) {
        if (je->line <= 0)
            fail(c, NULL, "cannot read: %s", je->text);
        else
            fail(c, NULL, "invalid JSON at line %d, column %d: %s", je->line, je->column, je->text);
        return NULL;
    }
    if (!json_is_object(root)) {
        fail(c, NULL, "expected a JSON object at the top level, got %s", json_kind(root));
        json_decref(root);
        return NULL;
    }
    s = calloc(1, sizeof *s);
    if (s == NULL || (s->file = dupstr(c->file)) == NULL) {
        free(s);
        json_decref(root);
        fail(c, NULL, "out of memory");
        return NULL;
    }
    s->root = root;
    s->k_first = 1;
    if (json_object_get(root, "cases") != NULL) {
        rc = load_cases(c, s, root, case_sel);
    } else if (case_sel != NULL) {
        rc = fail(c, "cases", "--case given but the file has no cases (%s layout)",
                  json_object_get(root, "steps") != NULL ? "steps" : "canonical");
    } else if (json_object_get(root, "steps") != NULL && json_object_get(root, "y") == NULL &&
               json_object_get(root, "runs") == NULL) {
        rc = load_steps(c, s, root);
    } else {
        rc = load_canonical(c, s, root);
    }
    if (rc != 0) {
        dkf_scenario_free(s);
        return NULL;
    }
    return s;
}

static void ctx_init(ctx_t *c, const char *file, char *err, size_t errlen)
{
    c->file = file != NULL ? file : "(null)";
    c->err = err;
    c->errlen = errlen;
    if (err != NULL && errlen > 0) err[0] = '\0';
}

dkf_scenario_t *dkf_scenario_load(const char *path, const char *case_sel, char *err,
                                  size_t errlen)
{
    ctx_t c;
    json_error_t je;
    ctx_init(&c, path, err, errlen);
    if (path == NULL) {
        fail(&c, NULL, "no scenario file given");
        return NULL;
    }
    return load_root(&c, json_load_file(path, JSON_REJECT_DUPLICATES, &je), &je, case_sel);
}

dkf_scenario_t *dkf_scenario_load_buffer(const char *buf, size_t len, const char *name,
                                         const char *case_sel, char *err, size_t errlen)
{
    ctx_t c;
    json_error_t je;
    ctx_init(&c, name, err, errlen);
    if (buf == NULL) {
        fail(&c, NULL, "no scenario buffer given");
        return NULL;
    }
    return load_root(&c, json_loadb(buf, len, JSON_REJECT_DUPLICATES, &je), &je, case_sel);
}

void dkf_scenario_free(dkf_scenario_t *s)
{
    size_t i, r;
    if (s == NULL) return;
    for (i = 0; s->sensors != NULL && i < s->nsensors; ++i) {
        mats_free(&s->sensors[i].mats);
        if (!s->sensors[i].borrowed) {
            free(s->sensors[i].yk);
            free(s->sensors[i].y);
        }
    }
    for (r = 0; s->runs != NULL && r < s->nruns; ++r) {
        for (i = 0; s->runs[r].y != NULL && i < s->nsensors; ++i) {
            free(s->runs[r].y[i].k);
            free(s->runs[r].y[i].v);
        }
        free(s->runs[r].y);
        free(s->runs[r].truth_k);
        free(s->runs[r].truth_x);
    }
    free(s->runs);
    free(s->sensors);
    mats_free(&s->model);
    mats_free(&s->init);
    if (!s->truth_borrowed) {
        free(s->truth_k);
        free(s->truth_x);
    }
    free(s->case_name);
    free(s->file);
    if (s->net != NULL) {
        free(s->net->edges);
        free(s->net->W_rc);
        free(s->net->W_v);
        free(s->net->alpha_rc);
        free(s->net->alpha_v);
        free(s->net);
    }
    free(s->truth_u_k);
    free(s->truth_u);
    json_decref(s->root);
    free(s);
}

const dkf_scn_mat_t *dkf_scn_model(const dkf_scenario_t *s, const char *name)
{
    return mats_find(&s->model, name);
}

const dkf_scn_mat_t *dkf_scn_sensor_model(const dkf_scenario_t *s, size_t i, const char *name)
{
    const dkf_scn_mat_t *m = NULL;
    if (i < s->nsensors) m = mats_find(&s->sensors[i].mats, name);
    return m != NULL ? m : mats_find(&s->model, name);
}

const dkf_scn_mat_t *dkf_scn_init(const dkf_scenario_t *s, const char *name)
{
    return mats_find(&s->init, name);
}

const double *dkf_scn_at(const dkf_scn_mat_t *m, size_t k)
{
    if (m == NULL) return NULL;
    if (m->count == 0) return m->data;
    if (k < m->k0 || k - m->k0 >= m->count) return NULL;
    return m->data + (k - m->k0) * m->rows * m->cols;
}

const double *dkf_scn_P00_local(const dkf_scenario_t *s, size_t i)
{
    const dkf_scn_mat_t *Pl = dkf_scn_init(s, "P00_local");
    if (Pl != NULL) return dkf_scn_at(Pl, i);
    return dkf_scn_at(dkf_scn_init(s, "P00"), 0);
}

const double *dkf_scn_P00_central(const dkf_scenario_t *s)
{
    const dkf_scn_mat_t *Pc = dkf_scn_init(s, "P00_central");
    return dkf_scn_at(Pc != NULL ? Pc : dkf_scn_init(s, "P00"), 0);
}

const double *dkf_scn_y(const dkf_scenario_t *s, size_t i, long k)
{
    long j;
    if (i >= s->nsensors) return NULL;
    j = find_time(s->sensors[i].yk, s->sensors[i].ny, k);
    return j < 0 ? NULL : s->sensors[i].y + (size_t)j * s->sensors[i].m;
}

const double *dkf_scn_truth(const dkf_scenario_t *s, long k)
{
    long j = find_time(s->truth_k, s->ntruth, k);
    return j < 0 ? NULL : s->truth_x + (size_t)j * s->n;
}

const double *dkf_scn_truth_u(const dkf_scenario_t *s, long k)
{
    long j = find_time(s->truth_u_k, s->ntruth_u, k);
    return j < 0 ? NULL : s->truth_u + (size_t)j * s->m_u;
}

void dkf_scn_to_real(dkf_real_t *dst, const double *src, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) dst[i] = (dkf_real_t)src[i];
}

void dkf_scn_select_run(dkf_scenario_t *s, size_t r)
{
    size_t i;
    if (s->runs == NULL || r >= s->nruns) return;
    s->run = r;
    for (i = 0; i < s->nsensors; ++i) {
        s->sensors[i].ny = s->runs[r].y[i].n;
        s->sensors[i].yk = s->runs[r].y[i].k;
        s->sensors[i].y = s->runs[r].y[i].v;
        s->sensors[i].borrowed = 1;
    }
    s->ntruth = s->runs[r].ntruth;
    s->truth_k = s->runs[r].truth_k;
    s->truth_x = s->runs[r].truth_x;
    s->truth_borrowed = 1;
}

/* ---- checks of the unknown-input filters ------------------------------------ */

/* The key path of sensor i's matrix `name` when it is missing. */
static void sensor_key(const dkf_scenario_t *s, size_t i, const char *name, char *p)
{
    if (s->layout == DKF_SCN_LAYOUT_CASES)
        pathf(p, "cases[%zu].%s[%zu]", s->case_index, name, i);
    else if (s->multi)
        pathf(p, "model.sensors[%zu].%s", i, name);
    else
        pathf(p, "model.%s", name);
}

int dkf_scn_require_ui(const dkf_scenario_t *s, size_t last_dyn, size_t last_meas, int need_d0,
                       const char *who, char *err, size_t errlen)
{
    ctx_t c;
    size_t i, r, j, p = 0;
    char path[PATH_LEN], why[96];
    static const char *const dyn_names[] = {"B", "Rd"};
    static const char *const meas_names[] = {"H", "R", "A"};
    dkf_scenario_t *sm = (dkf_scenario_t *)s; /* run selection only; restored below */
    size_t run0 = s->run;
    c.file = s->file;
    c.err = err;
    c.errlen = errlen;
    snprintf(why, sizeof why, "filter %s", who);
    if (require_times(&c, dkf_scn_model(s, "F"), last_dyn, why) != 0) return -1;
    if (require_times(&c, dkf_scn_model(s, "Q"), last_dyn, why) != 0) return -1;
    for (i = 0; i < s->nsensors; ++i) {
        const dkf_scn_mat_t *A = dkf_scn_sensor_model(s, i, "A");
        sensor_key(s, i, "A", path);
        if (A == NULL) return fail(&c, path, "missing key (filter %s needs A, B, Rd)", who);
        p = A->cols;
        if (p > s->sensors[i].m)
            return fail(&c, A->path, "has %zu columns but %zu rows: A must have full column "
                        "rank (p <= m)", p, s->sensors[i].m);
        for (j = 0; j < 2; ++j) {
            const dkf_scn_mat_t *M = dkf_scn_sensor_model(s, i, dyn_names[j]);
            sensor_key(s, i, dyn_names[j], path);
            if (M == NULL)
                return fail(&c, path, "missing key (filter %s needs A, B, Rd)", who);
            if (require_shape(&c, M, path, p, p) != 0) return -1;
            if (require_times(&c, M, last_dyn, why) != 0) return -1;
        }
        for (j = 0; j < 3; ++j)
            if (require_times(&c, dkf_scn_sensor_model(s, i, meas_names[j]), last_meas, why)
                != 0)
                return -1;
    }
    for (r = 0; r < s->nruns; ++r) {
        dkf_scn_select_run(sm, r);
        for (i = 0; i < s->nsensors; ++i)
            if (dkf_scn_y(s, i, (long)last_meas) == NULL) {
                y_path(s, r, i, path);
                dkf_scn_select_run(sm, run0);
                return fail(&c, path, "no measurement for k = %zu (filter %s needs y_1..y_%zu)",
                            last_meas, who, last_meas);
            }
    }
    dkf_scn_select_run(sm, run0);
    if (need_d0) {
        const dkf_scn_mat_t *d00 = dkf_scn_init(s, "d00"), *Pd00 = dkf_scn_init(s, "Pd00");
        if (d00 == NULL) return fail(&c, "init.d00", "missing key (filter %s needs it)", who);
        if (require_shape(&c, d00, "init.d00", p, 1) != 0) return -1;
        if (Pd00 == NULL) return fail(&c, "init.Pd00", "missing key (filter %s needs it)", who);
        if (require_single(&c, Pd00, "init.Pd00", p) != 0) return -1;
    }
    return 0;
}

int dkf_scn_require_truth(const dkf_scenario_t *s, char *err, size_t errlen)
{
    ctx_t c;
    size_t r;
    long k;
    char path[PATH_LEN];
    c.file = s->file;
    c.err = err;
    c.errlen = errlen;
    for (r = 0; r < s->nruns; ++r) {
        const dkf_scn_run_t *run = &s->runs[r];
        for (k = 1; k <= (long)s->steps; ++k)
            if (find_time(run->truth_k, run->ntruth, k) < 0) {
                if (s->has_runs)
                    pathf(path, "runs[%zu].truth", r);
                else
                    pathf(path, "truth");
                return fail(&c, path, "no true state x for k = %ld (the error mode needs "
                            "x_1..x_%zu)", k, s->steps);
            }
    }
    return 0;
}
