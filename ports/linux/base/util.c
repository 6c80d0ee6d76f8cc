/*
 * util.c - the host programs' shared helpers (see util.h).
 */
#include "util.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

int dkf_failf(char *err, size_t errlen, int rc, const char *fmt, ...)
{
    va_list ap;
    if (err == NULL || errlen == 0) return rc;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
    return rc;
}

json_t *dkf_json_from_mat(const dkf_mat_t *A, int as_vector)
{
    size_t r, c;
    json_t *out = json_array();
    if (out == NULL) return NULL;
    for (r = 0; r < A->rows; ++r) {
        json_t *row = as_vector ? out : json_array();
        if (row == NULL) goto oom;
        for (c = 0; c < A->cols; ++c)
            if (json_array_append_new(row, json_real((double)DKF_AT(A, r, c))) != 0) goto oom;
        if (!as_vector && json_array_append_new(out, row) != 0) goto oom;
    }
    return out;
oom:
    json_decref(out);
    return NULL;
}

json_t *dkf_json_doubles(const double *v, size_t rows, size_t cols)
{
    json_t *a = json_array();
    size_t i, j;
    for (i = 0; i < rows; ++i) {
        if (cols == 0) {
            json_array_append_new(a, json_real(v[i]));
        } else {
            json_t *r = json_array();
            for (j = 0; j < cols; ++j) json_array_append_new(r, json_real(v[i * cols + j]));
            json_array_append_new(a, r);
        }
    }
    return a;
}

void dkf_json_append(json_t *series, const char *key, json_t *value)
{
    json_t *list = json_object_get(series, key);
    if (list == NULL) {
        list = json_array();
        json_object_set_new(series, key, list);
    }
    json_array_append_new(list, value);
}

void dkf_json_place(json_t *outs, const char *name, json_t *value)
{
    const char *br = strchr(name, '[');
    char key[64];
    json_t *list;
    if (br == NULL || (size_t)(br - name) >= sizeof key) {
        json_object_set_new(outs, name, value);
        return;
    }
    memcpy(key, name, (size_t)(br - name));
    key[br - name] = '\0';
    if ((list = json_object_get(outs, key)) == NULL) {
        list = json_array();
        json_object_set_new(outs, key, list);
    }
    json_array_append_new(list, value);
}

#define FNV1A_PRIME 0x100000001b3ull

uint64_t dkf_fnv1a_u64(uint64_t h, uint64_t v)
{
    int i;
    for (i = 56; i >= 0; i -= 8) {
        h ^= (v >> i) & 0xffu;
        h *= FNV1A_PRIME;
    }
    return h;
}

uint64_t dkf_fnv1a_doubles(uint64_t h, const double *v, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) {
        uint64_t bits;
        memcpy(&bits, &v[i], sizeof bits);
        h = dkf_fnv1a_u64(h, bits);
    }
    return h;
}

size_t dkf_chol_double(const double *a, size_t n, double *L, double *pivot)
{
    size_t i, j, k;
    for (j = 0; j < n; ++j) {
        double d = a[j * n + j];
        for (k = 0; k < j; ++k) d -= L[j * n + k] * L[j * n + k];
        if (!(d > 0.0) || !isfinite(d)) {
            if (pivot != NULL) *pivot = d;
            return j;
        }
        L[j * n + j] = sqrt(d);
        for (i = j + 1; i < n; ++i) {
            double e = a[i * n + j];
            for (k = 0; k < j; ++k) e -= L[i * n + k] * L[j * n + k];
            L[i * n + j] = e / L[j * n + j];
        }
    }
    return n;
}
