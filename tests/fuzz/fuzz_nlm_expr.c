/*
 * fuzz_nlm_expr.c - the expression reader of the host's nonlinear models
 * (ports/linux/nlm/nlm.h, nlm_expr.c: muparser) on any expression text
 * (docs/guide/fuzzing.md).
 *
 * Input: byte 0 picks the state size n = 1 + b0 % 4 and, with bit 7, an
 * angle channel; byte 1 the unknown input p = b1 % 3; the rest is split at
 * '\n' into expressions, which fill f (n), g (m = max(p, 1) + b1 / 3 % 2)
 * and, when byte 1 has bit 6, the Jacobians A, G, C, H, in that order
 * (missing ones are "x1"). The strings are passed as they are (any bytes,
 * NUL excepted, which the JSON string cannot hold past its length).
 *
 * Besides "no crash, no sanitizer report":
 *   - a refused model gives one non-empty line starting "fuzz.json: ";
 *   - a loaded one has the asked n, m, p, and its callbacks, called at a
 *     few points (the probe point and far from it), either succeed with
 *     finite values or fail with a reason (dkf_nlm_failure non-empty);
 *     y_diff (if any) puts angle channels into [-pi, pi).
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "fuzz_check.h"
#include "nlm.h"
#include "scenario.h"

#define MAXE 64

static json_t *str(const char *s, size_t len)
{
    json_t *j = json_stringn_nocheck(s, len);
    return j != NULL ? j : json_string("x1");
}

/* expression number *next of the input (or "x1" when used up) */
static json_t *next_expr(const char **pieces, const size_t *lens, size_t count, size_t *next)
{
    if (*next < count) {
        const size_t i = (*next)++;
        return str(pieces[i], lens[i]);
    }
    return json_string("x1");
}

static json_t *matrix(const char **pc, const size_t *pl, size_t cnt, size_t *next, size_t r,
                      size_t c)
{
    json_t *m = json_array();
    size_t i, j;
    for (i = 0; i < r; ++i) {
        json_t *row = json_array();
        for (j = 0; j < c; ++j) json_array_append_new(row, next_expr(pc, pl, cnt, next));
        json_array_append_new(m, row);
    }
    return m;
}

static json_t *identity(size_t n)
{
    json_t *m = json_array();
    size_t i, j;
    for (i = 0; i < n; ++i) {
        json_t *row = json_array();
        for (j = 0; j < n; ++j) json_array_append_new(row, json_real(i == j ? 1.0 : 0.0));
        json_array_append_new(m, row);
    }
    return m;
}

static volatile double sink;

static void exercise(dkf_nlm_t *m, size_t n, size_t p)
{
    static const double points[3] = {0.0, 0.7, -1e3};
    dkf_real_t x[DKF_MAX_DIM], d[DKF_MAX_DIM], out[DKF_MAX_DIM];
    static dkf_real_t J1[DKF_MAX_DIM * DKF_MAX_DIM], J2[DKF_MAX_DIM * DKF_MAX_DIM];
    size_t c, i;
    for (c = 0; c < 3; ++c) {
        int rc;
        for (i = 0; i < n; ++i) x[i] = (dkf_real_t)(points[c] + 0.1 * (double)i);
        for (i = 0; i < p; ++i) d[i] = (dkf_real_t)(points[c] - 0.2 * (double)i);
        m->failure[0] = '\0';
        rc = m->model.f(m->model.ctx, 0, x, d, NULL, out);
        if (rc == 0)
            for (i = 0; i < n; ++i) FUZZ_REQUIRE(isfinite(out[i]));
        else
            FUZZ_REQUIRE(dkf_nlm_failure(m)[0] != '\0');
        m->failure[0] = '\0';
        rc = m->model.h(m->model.ctx, 0, x, d, NULL, out);
        if (rc == 0) {
            for (i = 0; i < m->m; ++i) FUZZ_REQUIRE(isfinite(out[i]));
            if (m->model.y_diff != NULL) {
                dkf_real_t w[DKF_MAX_DIM], b[DKF_MAX_DIM];
                for (i = 0; i < m->m; ++i) b[i] = (dkf_real_t)(0.5 * (double)i - 3.0);
                m->model.y_diff(m->model.ctx, out, b, w);
                /* [-pi, pi), to float's rounding of pi in float builds */
                for (i = 0; i < m->m; ++i)
                    if (m->angle[i]) FUZZ_REQUIRE(fabs((double)w[i]) <= 3.14159275);
            }
        } else {
            FUZZ_REQUIRE(dkf_nlm_failure(m)[0] != '\0');
        }
        if (m->model.f_jac != NULL) {
            m->failure[0] = '\0';
            rc = m->model.f_jac(m->model.ctx, 0, x, d, NULL, J1, J2);
            FUZZ_REQUIRE(rc == 0 || dkf_nlm_failure(m)[0] != '\0');
            if (rc == 0) sink = (double)J1[0];
        }
        if (m->model.h_jac != NULL) {
            m->failure[0] = '\0';
            rc = m->model.h_jac(m->model.ctx, 0, x, d, NULL, J1, J2);
            FUZZ_REQUIRE(rc == 0 || dkf_nlm_failure(m)[0] != '\0');
            if (rc == 0) sink = (double)J1[0];
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static char err[DKF_SCN_ERR_LEN];
    const char *pieces[MAXE];
    size_t lens[MAXE], count = 0, next = 0, n, p, mm, i, start;
    const double x0[4] = {0.1, 0.2, 0.3, 0.4}, d0[2] = {0.05, -0.05};
    json_t *model, *expr, *f, *g;
    dkf_nlm_t *m;
    if (size < 2) return 0;
    n = 1 + data[0] % 4;
    p = data[1] % 3;
    mm = (p > 0 ? p : 1) + (size_t)(data[1] / 3 % 2);
    for (start = 2, i = 2; i <= size && count < MAXE; ++i)
        if (i == size || data[i] == '\n') {
            pieces[count] = (const char *)data + start;
            lens[count++] = i - start;
            start = i + 1;
        }
    expr = json_object();
    f = json_array();
    g = json_array();
    for (i = 0; i < n; ++i) json_array_append_new(f, next_expr(pieces, lens, count, &next));
    for (i = 0; i < mm; ++i) json_array_append_new(g, next_expr(pieces, lens, count, &next));
    json_object_set_new(expr, "f", f);
    json_object_set_new(expr, "g", g);
    if (data[1] & 0x40) {
        json_object_set_new(expr, "A", matrix(pieces, lens, count, &next, n, n));
        if (p > 0) json_object_set_new(expr, "G", matrix(pieces, lens, count, &next, n, p));
        json_object_set_new(expr, "C", matrix(pieces, lens, count, &next, mm, n));
        if (p > 0) json_object_set_new(expr, "H", matrix(pieces, lens, count, &next, mm, p));
    }
    if (data[0] & 0x80) json_object_set_new(expr, "angles", json_pack("[i]", 0));
    model = json_pack("{s:o, s:o, s:o}", "expr", expr, "Q", identity(n), "R", identity(mm));
    FUZZ_REQUIRE(model != NULL);
    memset(err, 'x', sizeof err);
    m = dkf_nlm_load(model, "fuzz.json", "model", n, p, x0, d0, err, sizeof err);
    json_decref(model);
    if (m == NULL) {
        FUZZ_REQUIRE(memchr(err, '\0', sizeof err) != NULL);
        FUZZ_REQUIRE(strncmp(err, "fuzz.json: ", 11) == 0 && strchr(err, '\n') == NULL);
        return 0;
    }
    FUZZ_REQUIRE(m->n == n && m->m == mm && m->p == p);
    FUZZ_REQUIRE(m->model.n == n && m->model.m == mm && m->model.p == p);
    exercise(m, n, p);
    dkf_nlm_free(m);
    return 0;
}
