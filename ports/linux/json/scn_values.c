/*
 * scn_values.c - the scenario reader's values: numbers (integers checked
 * before any cast), vectors, matrices, named matrix sets, measurement
 * series, symmetric covariances (scn_values.h). Every scenario layout and
 * every model builder reads its values through these.
 */
#include "scn_values.h"
#include "util.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* printf-style "FILE: PATH: problem" into the caller's buffer. */
int dkf_scn_fail(dkf_scn_ctx_t *c, const char *path, const char *fmt, ...)
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

/* Key paths longer than DKF_SCN_PATH_LEN are cut short: they only label messages. */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
void dkf_scn_pathf(char *out, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(out, DKF_SCN_PATH_LEN, fmt, ap);
    va_end(ap);
}

void dkf_scn_subkey(char *out, const char *base, const char *key)
{
    if (base[0] == '\0')
        dkf_scn_pathf(out, "%s", key);
    else
        dkf_scn_pathf(out, "%s.%s", base, key);
}

void dkf_scn_subidx(char *out, const char *base, size_t i)
{
    dkf_scn_pathf(out, "%s[%zu]", base, i);
}

char *dkf_scn_dupstr(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d != NULL) memcpy(d, s, n);
    return d;
}

void *dkf_scn_calloc(dkf_scn_ctx_t *c, size_t n, size_t size)
{
    void *p = calloc(n == 0 ? 1 : n, size);
    if (p == NULL) dkf_scn_fail(c, NULL, "out of memory");
    return p;
}

const char *dkf_scn_json_kind(const json_t *j)
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

/* v in the fewest significant digits (15..17) that read back as v: the
 * number as the file wrote it, for messages. */
const char *dkf_scn_num_str(char *buf, size_t len, double v)
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
int dkf_scn_get_integer(dkf_scn_ctx_t *c, const json_t *j, const char *path, double lo, double hi,
                        long *out)
{
    double v;
    char buf[32];
    if (!json_is_number(j))
        return dkf_scn_fail(c, path, "expected an integer, got %s", dkf_scn_json_kind(j));
    v = json_number_value(j);
    if (v != floor(v) || !(v >= lo && v <= hi)) {
        if (json_is_integer(j))
            return dkf_scn_fail(c, path,
                                "expected an integer in %.0f..%.0f, got %" JSON_INTEGER_FORMAT,
                                lo, hi, json_integer_value(j));
        return dkf_scn_fail(c, path, "expected an integer in %.0f..%.0f, got %s", lo, hi,
                            dkf_scn_num_str(buf, sizeof buf, v));
    }
    *out = (long)v;
    return 0;
}

int dkf_scn_block_alloc(dkf_scn_ctx_t *c, dkf_scn_block_t *b, size_t count, size_t dim,
                        const char *path)
{
    b->v = NULL;
    b->count = count;
    b->dim = dim;
    if (dim != 0 && count > SIZE_MAX / sizeof(double) / dim)
        return dkf_scn_fail(c, path, "%zu x %zu values are more than this machine can hold", count,
                            dim);
    if ((b->v = dkf_scn_calloc(c, count * dim, sizeof *b->v)) == NULL) return -1;
    return 0;
}

/* Row `row` of b = src[0..len-1]: refused unless row < count and len == dim. */
int dkf_scn_store(dkf_scn_ctx_t *c, const char *path, const dkf_scn_block_t *b, size_t row,
                  const double *src,
                  size_t len)
{
    if (row >= b->count)
        return dkf_scn_fail(c, path, "entry %zu beyond the %zu the file announced", row, b->count);
    if (len != b->dim)
        return dkf_scn_fail(c, path, "expected a vector of %zu values, got %zu", b->dim, len);
    memcpy(b->v + row * b->dim, src, len * sizeof *src);
    return 0;
}

/* A non-empty list of at most max entries: its length into *n. */
int dkf_scn_list_len(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *what,
                     const char *unit, unsigned long max, size_t *n)
{
    if (j == NULL) return dkf_scn_fail(c, path, "missing key");
    if (!json_is_array(j) || json_array_size(j) == 0)
        return dkf_scn_fail(c, path, "expected a non-empty list of %s, got %s", what,
                            json_is_array(j) ? "an empty list" : dkf_scn_json_kind(j));
    if (json_array_size(j) > max)
        return dkf_scn_fail(c, path, "%zu %s, more than the %lu allowed", json_array_size(j),
                            unit, max);
    *n = json_array_size(j);
    return 0;
}

/* Row `row` of b = the vector j: its length is b->dim, which len_of names. */
int dkf_scn_store_vector(dkf_scn_ctx_t *c, const json_t *j, const char *path,
                         const dkf_scn_block_t *b, size_t row, const char *len_of)
{
    double *v;
    size_t len;
    int rc;
    if (dkf_scn_parse_vector(c, j, path, &len, &v) != 0) return -1;
    if (len_of != NULL && len != b->dim)
        rc = dkf_scn_fail(c, path, "expected a vector of %zu values (%s), got %zu", b->dim,
                          len_of, len);
    else
        rc = dkf_scn_store(c, path, b, row, v, len);
    free(v);
    return rc;
}

/* A non-empty list of numbers. */
int dkf_scn_parse_vector(dkf_scn_ctx_t *c, const json_t *j, const char *path, size_t *len,
                         double **out)
{
    size_t i, n;
    double *v;
    char p[DKF_SCN_PATH_LEN];
    if (!json_is_array(j))
        return dkf_scn_fail(c, path, "expected a list of numbers, got %s", dkf_scn_json_kind(j));
    n = json_array_size(j);
    if (n == 0)
        return dkf_scn_fail(c, path, "expected a non-empty list of numbers, got an empty list");
    if ((v = dkf_scn_calloc(c, n, sizeof *v)) == NULL) return -1;
    for (i = 0; i < n; ++i) {
        const json_t *e = json_array_get(j, i);
        if (!json_is_number(e)) {
            dkf_scn_subidx(p, path, i);
            free(v);
            return dkf_scn_fail(c, p, "expected a number, got %s", dkf_scn_json_kind(e));
        }
        v[i] = json_number_value(e);
    }
    *len = n;
    *out = v;
    return 0;
}

/* A non-empty rectangular list of rows. */
int dkf_scn_parse_matrix(dkf_scn_ctx_t *c, const json_t *j, const char *path, size_t *rows,
                         size_t *cols,
                         double **out)
{
    size_t i, r;
    dkf_scn_block_t m = {NULL, 0, 0};
    char p[DKF_SCN_PATH_LEN];
    if (!json_is_array(j) || json_array_size(j) == 0 || !json_is_array(json_array_get(j, 0)))
        return dkf_scn_fail(c, path, "expected a matrix (non-empty list of rows), got %s",
                            !json_is_array(j)             ? dkf_scn_json_kind(j)
                            : json_array_size(j) == 0     ? "an empty list"
                            : json_is_number(json_array_get(j, 0)) ? "a list of numbers"
                                                  : "a list of something else");
    r = json_array_size(j);
    for (i = 0; i < r; ++i) {
        double *row;
        size_t len;
        int rc;
        dkf_scn_subidx(p, path, i);
        if (dkf_scn_parse_vector(c, json_array_get(j, i), p, &len, &row) != 0) {
            free(m.v);
            return -1;
        }
        if (i == 0)
            rc = dkf_scn_block_alloc(c, &m, r, len, path);
        else if (len != m.dim)
            rc = dkf_scn_fail(c, p, "row has %zu entries, row 0 has %zu", len, m.dim);
        else
            rc = 0;
        if (rc == 0) rc = dkf_scn_store(c, p, &m, i, row, len);
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
int dkf_scn_nest_depth(const json_t *j)
{
    int d = 0;
    while (json_is_array(j) && json_array_size(j) > 0) {
        ++d;
        j = json_array_get(j, 0);
    }
    return d;
}

int dkf_scn_shape_error(dkf_scn_ctx_t *c, const char *path, size_t er, size_t ec, size_t r,
                        size_t cc)
{
    if (ec == 1 && cc == 1)
        return dkf_scn_fail(c, path, "expected a vector of %zu values, got %zu", er, r);
    return dkf_scn_fail(c, path, "expected %zux%zu matrix, got %zux%zu", er, ec, r, cc);
}

dkf_scn_mat_t *dkf_scn_mats_add(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const char *name,
                                const char *path)
{
    dkf_scn_mat_t *items = realloc(set->items, (set->len + 1) * sizeof *items);
    dkf_scn_mat_t *m;
    if (items == NULL) {
        dkf_scn_fail(c, NULL, "out of memory");
        return NULL;
    }
    set->items = items;
    m = &items[set->len];
    memset(m, 0, sizeof *m);
    m->name = dkf_scn_dupstr(name);
    m->path = dkf_scn_dupstr(path);
    if (m->name == NULL || m->path == NULL) {
        free(m->name);
        free(m->path);
        dkf_scn_fail(c, NULL, "out of memory");
        return NULL;
    }
    set->len++;
    return m;
}

void dkf_scn_mats_free(dkf_scn_mats_t *set)
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

const dkf_scn_mat_t *dkf_scn_mats_find(const dkf_scn_mats_t *set, const char *name)
{
    size_t i;
    for (i = 0; i < set->len; ++i)
        if (strcmp(set->items[i].name, name) == 0) return &set->items[i];
    return NULL;
}

/* Entry idx of m, a stack of `count` same-shape matrices: the first entry
 * fixes the shape and allocates m->data, the others must match it. */
int dkf_scn_stack_matrix(dkf_scn_ctx_t *c, dkf_scn_mat_t *m, dkf_scn_block_t *b, size_t idx,
                         size_t count,
                         const json_t *j, const char *path)
{
    double *one;
    size_t r, cc;
    int rc = 0;
    if (dkf_scn_parse_matrix(c, j, path, &r, &cc, &one) != 0) return -1;
    if (idx == 0) {
        m->rows = r;
        m->cols = cc;
        rc = dkf_scn_block_alloc(c, b, count, r * cc, path);
        m->data = b->v;
    } else if (r != m->rows || cc != m->cols) {
        rc = dkf_scn_shape_error(c, path, m->rows, m->cols, r, cc);
    }
    if (rc == 0) rc = dkf_scn_store(c, path, b, idx, one, r * cc);
    free(one);
    return rc;
}

/* A list of same-shape matrices (per_k, or a stacked init entry). */
static int parse_matrix_list(dkf_scn_ctx_t *c, const json_t *j, const char *path, dkf_scn_mat_t *m)
{
    size_t i, n;
    dkf_scn_block_t b;
    char p[DKF_SCN_PATH_LEN];
    if (dkf_scn_list_len(c, j, path, "matrices", "matrices", DKF_SCN_MAX_TIMES, &n) != 0)
        return -1;
    for (i = 0; i < n; ++i) {
        dkf_scn_subidx(p, path, i);
        if (dkf_scn_stack_matrix(c, m, &b, i, n, json_array_get(j, i), p) != 0) return -1;
    }
    m->count = n;
    return 0;
}

/* Matrices of the model and init are at most DKF_MAX_DIM x DKF_MAX_DIM. */
int dkf_scn_check_dims(dkf_scn_ctx_t *c, const dkf_scn_mat_t *m)
{
    if (m->rows > DKF_MAX_DIM || m->cols > DKF_MAX_DIM)
        return dkf_scn_fail(c, m->path, "%zux%zu: a dimension exceeds DKF_MAX_DIM = %d", m->rows,
                            m->cols, DKF_MAX_DIM);
    return 0;
}

/* A model entry: {"const": M}, {"per_k": [M_0, ...]} or a bare matrix M. */
static int parse_model_value(dkf_scn_ctx_t *c, dkf_scn_mat_t *m, const json_t *j, const char *path)
{
    char p[DKF_SCN_PATH_LEN];
    static const char *const known[] = {"const", "per_k", NULL};
    const json_t *cst, *pk;
    if (json_is_array(j)) return dkf_scn_parse_matrix(c, j, path, &m->rows, &m->cols, &m->data);
    if (dkf_scn_check_keys(c, j, path, known, NULL) != 0) return -1;
    cst = json_object_get(j, "const");
    pk = json_object_get(j, "per_k");
    if ((cst == NULL) == (pk == NULL))
        return dkf_scn_fail(c, path, "expected exactly one of \"const\" and \"per_k\"");
    if (cst != NULL) {
        dkf_scn_subkey(p, path, "const");
        return dkf_scn_parse_matrix(c, cst, p, &m->rows, &m->cols, &m->data);
    }
    dkf_scn_subkey(p, path, "per_k");
    return parse_matrix_list(c, pk, p, m);
}

int dkf_scn_parse_model_entry(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const char *name,
                              const json_t *j,
                              const char *path)
{
    dkf_scn_mat_t *m;
    if (json_is_string(j) || json_is_null(j)) return 0; /* notes */
    if (!json_is_object(j) && !json_is_array(j))
        return dkf_scn_fail(c, path,
                            "expected {\"const\": M}, {\"per_k\": [...]} or a matrix, got %s",
                            dkf_scn_json_kind(j));
    if ((m = dkf_scn_mats_add(c, set, name, path)) == NULL) return -1;
    if (parse_model_value(c, m, j, path) != 0) return -1;
    return dkf_scn_check_dims(c, m);
}

/* An init entry: vector (n x 1), matrix, or list of matrices; strings skipped. */
int dkf_scn_parse_init_entry(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const char *name,
                             const json_t *j,
                             const char *path)
{
    dkf_scn_mat_t *m;
    int depth, rc;
    if (json_is_string(j) || json_is_null(j)) return 0;
    if ((m = dkf_scn_mats_add(c, set, name, path)) == NULL) return -1;
    depth = dkf_scn_nest_depth(j);
    if (depth <= 1) {
        m->cols = 1;
        rc = dkf_scn_parse_vector(c, j, path, &m->rows, &m->data);
    } else if (depth == 2) {
        rc = dkf_scn_parse_matrix(c, j, path, &m->rows, &m->cols, &m->data);
    } else {
        rc = parse_matrix_list(c, j, path, m);
    }
    return rc != 0 ? -1 : dkf_scn_check_dims(c, m);
}

/* {"k": [...], "<vkey>": [[...], ...]}: times strictly increasing. */
int dkf_scn_parse_series(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *vkey,
                         size_t dim, size_t *count, long **kout, double **vout)
{
    /* truth's true inputs (d, d_stacked) are informational */
    const char *known[] = {"k", NULL, NULL, NULL, NULL};
    const json_t *jk, *jv;
    size_t i, n;
    long *k;
    dkf_scn_block_t v = {NULL, 0, 0};
    char p[DKF_SCN_PATH_LEN], pi[DKF_SCN_PATH_LEN];
    known[1] = vkey;
    if (strcmp(vkey, "x") == 0) known[2] = "d", known[3] = "d_stacked";
    if (!json_is_object(j))
        return dkf_scn_fail(c, path, "expected {\"k\": [...], \"%s\": [...]}, got %s", vkey,
                            dkf_scn_json_kind(j));
    if (dkf_scn_check_keys(c, j, path, known, NULL) != 0) return -1;
    jv = json_object_get(j, vkey);
    dkf_scn_subkey(p, path, vkey);
    if (dkf_scn_list_len(c, jv, p, "vectors", "entries", DKF_SCN_MAX_TIMES, &n) != 0) return -1;
    k = dkf_scn_calloc(c, n, sizeof *k);
    if (k == NULL || dkf_scn_block_alloc(c, &v, n, dim, p) != 0) goto bad;
    for (i = 0; i < n; ++i) {
        dkf_scn_subidx(pi, p, i);
        if (dkf_scn_store_vector(c, json_array_get(jv, i), pi, &v, i, NULL) != 0) goto bad;
    }
    jk = json_object_get(j, "k");
    dkf_scn_subkey(p, path, "k");
    if (jk == NULL) {
        /* Only truth may omit k: it then starts at k = 0. */
        for (i = 0; i < n; ++i) k[i] = (long)i;
    } else {
        if (!json_is_array(jk) || json_array_size(jk) != n) {
            dkf_scn_fail(c, p, "expected a list of %zu times (one per value), got %s of %zu", n,
                         dkf_scn_json_kind(jk),
                         json_is_array(jk) ? json_array_size(jk) : (size_t)0);
            goto bad;
        }
        for (i = 0; i < n; ++i) {
            dkf_scn_subidx(pi, p, i);
            if (dkf_scn_get_integer(c, json_array_get(jk, i), pi, 0.0, DKF_SCN_MAX_TIME,
                                    &k[i]) != 0)
                goto bad;
            if (i > 0 && k[i] <= k[i - 1]) {
                dkf_scn_fail(c, pi, "times must increase strictly (%ld after %ld)", k[i], k[i - 1]);
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
long dkf_scn_find_time(const long *ks, size_t n, long k)
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

/* A covariance read from a file must be symmetric within rounding:
 * max |M_ij - M_ji| <= DKF_SCN_SYM_TOL eps max |M| for each entry of a
 * per_k list or init list. A symmetric matrix written out and read back is
 * exactly symmetric (the same decimal parses to the same double); a matrix
 * computed in double without symmetrizing carries a few roundings (the
 * time-varying diffkf vectors tv3, tv4: at most 0.6 eps max|M|); a typo or a
 * transposed entry is far above 8 eps. */
#define DKF_SCN_SYM_TOL 8.0

int dkf_scn_check_symmetric(dkf_scn_ctx_t *c, const char *path, const double *a, size_t n)
{
    double amax = 0.0, worst = 0.0;
    size_t i, j, wi = 0, wj = 0;
    char va[32], vb[32];
    for (i = 0; i < n * n; ++i) amax = fmax(amax, fabs(a[i]));
    for (i = 0; i < n; ++i)
        for (j = i + 1; j < n; ++j)
            if (fabs(a[i * n + j] - a[j * n + i]) > worst) {
                worst = fabs(a[i * n + j] - a[j * n + i]);
                wi = i;
                wj = j;
            }
    if (worst <= DKF_SCN_SYM_TOL * DBL_EPSILON * amax) return 0;
    return dkf_scn_fail(c, path,
                        "not symmetric (a covariance): entries (%zu,%zu) = %s and (%zu,%zu) "
                        "= %s differ by %.3g > %g eps max|entry| = %.3g", wi, wj,
                        dkf_scn_num_str(va, sizeof va, a[wi * n + wj]), wj, wi,
                        dkf_scn_num_str(vb, sizeof vb, a[wj * n + wi]), worst, DKF_SCN_SYM_TOL,
                        DKF_SCN_SYM_TOL * DBL_EPSILON * amax);
}

/* Definiteness is judged on a + delta I, delta = DKF_SCN_SYM_TOL n eps max|a| + DBL_MIN
 * (rounding, the same scale as the symmetry test): a PSD matrix passes,
 * singular or not; one with an eigenvalue below -delta fails; SPD needs
 * the Cholesky factorisation of a itself. */
int dkf_scn_check_definite(dkf_scn_ctx_t *c, const char *path, const double *a, size_t n,
                           int spd, const char *what)
{
    double *b, *L, amax = 0.0, pivot = 0.0;
    size_t i, row;
    char v[32];
    if (n == 0 || n > DKF_MAX_DIM) return 0; /* shapes are checked elsewhere */
    if ((b = dkf_scn_calloc(c, 2 * n * n, sizeof *b)) == NULL) return -1;
    L = b + n * n;
    for (i = 0; i < n * n; ++i) amax = fmax(amax, fabs(a[i]));
    memcpy(b, a, n * n * sizeof *b);
    if (!spd)
        for (i = 0; i < n; ++i)
            b[i * n + i] += DKF_SCN_SYM_TOL * (double)n * DBL_EPSILON * amax + DBL_MIN;
    row = dkf_chol_double(b, n, L, &pivot);
    free(b);
    if (row == n) return 0;
    return dkf_scn_fail(c, path, "not positive %s (%s): its Cholesky factorisation stops at "
                        "row %zu, pivot %s", spd ? "definite" : "semidefinite", what, row,
                        dkf_scn_num_str(v, sizeof v, pivot));
}
