/*
 * nlm_expr.c - expression models (nlm.h): a model object's
 *
 *   "expr": {"f": [n strings], "g": [m strings],
 *            "A": [[n x n]], "G": [[n x p]], "C": [[m x n]], "H": [[m x p]],
 *            "angles": [indices of g]}
 *
 * parsed with muparser's C API (Debian libmuparser-dev, muParserDLL.h) in
 * the variables x1..xn, d1..dp. Operators + - * / ^ (right-associative),
 * comparisons and ?:, the functions of muparser (sin cos tan asin acos
 * atan sinh cosh tanh exp log = ln, log10, log2, sqrt, abs, sign, rint,
 * min, max, sum, avg), plus atan2(y, x) (muparser's own) and hypot(a, b),
 * and the constant pi (registered here at full precision; muparser's _pi
 * has 13 digits). A Jacobian entry may be a number instead of a string.
 *
 * Jacobians: the pair A, G (and C, H) as given, or, without the pair, the
 * core's forward differences (muparser has no symbolic derivative; see
 * docs/design/infofusion.md for the step and the error bound). With p = 0 G and
 * H are left out.
 *
 * Refused while loading, one "FILE: KEY: problem" line each: a key that is
 * not a string, an empty or overlong string, a syntax error (with its
 * position), a variable or function that does not exist (x4 in a model of
 * n = 3, y1, ...), an assignment (`x1 = 2`, which would change a variable
 * of the model), several comma-separated results, and a value that is not
 * finite at the case's initial (x0, d0) (division by zero, log(0), ...).
 * At run time a non-finite value fails the callback (DKF_ERR_MODEL).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <muParserDLL.h>

#include "nlm.h"
#include "scn_values.h"

/* One compiled expression. */
typedef struct {
    muParserHandle_t h;
    char key[DKF_SCN_PATH_LEN]; /* its key path, for messages */
} expr_t;

/* f (n), g (m), then the Jacobians' entries A (n x n), G (n x p),
 * C (m x n), H (m x p) when given; all bound to vars. */
typedef struct {
    double vars[2 * DKF_MAX_DIM]; /* x1..xn, then d1..dp */
    size_t n, m, p;
    expr_t *f, *g, *A, *G, *C, *H;
    size_t total;  /* slots of all (unused Jacobian slots keep h = NULL) */
    expr_t *all;   /* the one allocation f ... H point into */
} model_t;

static double hypot2(double a, double b)
{
    return hypot(a, b);
}

static void destroy(void *impl)
{
    model_t *e = impl;
    size_t i;
    if (e == NULL) return;
    for (i = 0; e->all != NULL && i < e->total; ++i)
        if (e->all[i].h != NULL) mupRelease(e->all[i].h);
    free(e->all);
    free(e);
}

/* The value of one expression at the current vars; -1 (reason in m) if it
 * is not finite. */
static int eval(dkf_nlm_t *m, const expr_t *x, double *out)
{
    const model_t *e = m->impl;
    size_t i;
    *out = mupEval(x->h);
    if (mupError(x->h)) {
        dkf_nlm_set_failure(m, "%s: %s", x->key, mupGetErrorMsg(x->h));
        return -1;
    }
    if (isfinite(*out)) return 0;
    {
        char at[160], text[96];
        size_t len = 0;
        /* muparser keeps the expression with a space appended */
        snprintf(text, sizeof text, "%s", mupGetExpr(x->h));
        len = strlen(text);
        while (len > 0 && text[len - 1] == ' ') text[--len] = '\0';
        len = 0;
        for (i = 0; i < e->n + e->p && len < sizeof at; ++i)
            len += (size_t)snprintf(at + len, sizeof at - len, "%s%c%zu=%.6g", i ? " " : "",
                                    i < e->n ? 'x' : 'd', i < e->n ? i + 1 : i - e->n + 1,
                                    e->vars[i]);
        dkf_nlm_set_failure(m, "%s: '%s' = %s at %s (division by zero or a value outside "
                            "the function's domain)", x->key, text,
                            isnan(*out) ? "NaN" : *out > 0 ? "inf" : "-inf", at);
    }
    return -1;
}

static void set_vars(model_t *e, const double *x, const double *d)
{
    memcpy(e->vars, x, e->n * sizeof *x);
    if (e->p > 0) memcpy(e->vars + e->n, d, e->p * sizeof *d);
}

static int eval_all(dkf_nlm_t *m, const expr_t *xs, size_t count, double *out)
{
    size_t i;
    for (i = 0; i < count; ++i)
        if (eval(m, &xs[i], &out[i]) != 0) return -1;
    return 0;
}

static int f_cb(dkf_nlm_t *m, const double *x, const double *d, double *x_next)
{
    model_t *e = m->impl;
    set_vars(e, x, d);
    return eval_all(m, e->f, e->n, x_next);
}

static int h_cb(dkf_nlm_t *m, const double *x, const double *d, double *z)
{
    model_t *e = m->impl;
    set_vars(e, x, d);
    return eval_all(m, e->g, e->m, z);
}

static int f_jac_cb(dkf_nlm_t *m, const double *x, const double *d, double *Fx, double *Fd)
{
    model_t *e = m->impl;
    set_vars(e, x, d);
    if (eval_all(m, e->A, e->n * e->n, Fx) != 0) return -1;
    return eval_all(m, e->G, e->n * e->p, Fd);
}

static int h_jac_cb(dkf_nlm_t *m, const double *x, const double *d, double *Hx, double *Hd)
{
    model_t *e = m->impl;
    set_vars(e, x, d);
    if (eval_all(m, e->C, e->m * e->n, Hx) != 0) return -1;
    return eval_all(m, e->H, e->m * e->p, Hd);
}

/* The four tables: with or without each Jacobian pair. */
static const dkf_nlm_ops_t ops_table[4] = {
    {f_cb, h_cb, NULL, NULL, destroy},
    {f_cb, h_cb, f_jac_cb, NULL, destroy},
    {f_cb, h_cb, NULL, h_jac_cb, destroy},
    {f_cb, h_cb, f_jac_cb, h_jac_cb, destroy},
};

/* ---- compiling ------------------------------------------------------------------ */

/* What muparser's error code means, in our words. */
static const char *syntax_problem(int code)
{
    switch (code) {
    case 0: return "unexpected operator";
    case 2: return "unexpected end of the expression";
    case 3: return "unexpected ','";
    case 4: return "unexpected argument";
    case 5: return "unexpected value";
    case 6: return "unexpected variable";
    case 7: return "unexpected parenthesis";
    case 8: case 9: case 13: case 17: return "strings are not allowed";
    case 11: return "missing ')'";
    case 12: return "unexpected function";
    case 14: return "too many arguments";
    case 15: return "too few arguments";
    case 25: return "empty expression";
    case 32: case 33: case 34: return "malformed '?:'";
    default: return "syntax error";
    }
}

/* 0 if s has no assignment '=' (comparisons ==, <=, >=, != are fine). */
static long assignment_at(const char *s)
{
    size_t i;
    for (i = 0; s[i] != '\0'; ++i) {
        if (s[i] != '=') continue;
        if (s[i + 1] == '=') {
            ++i;
            continue;
        }
        if (i > 0 && (s[i - 1] == '<' || s[i - 1] == '>' || s[i - 1] == '!')) continue;
        return (long)i + 1;
    }
    return 0;
}

/* The variable list of a model, for messages: "x1..x3, d1" */
static void var_list(char *out, size_t cap, size_t n, size_t p)
{
    int len = n == 1 ? snprintf(out, cap, "x1") : snprintf(out, cap, "x1..x%zu", n);
    if (len < 0 || (size_t)len >= cap) return;
    if (p == 1) snprintf(out + len, cap - (size_t)len, ", d1");
    if (p > 1) snprintf(out + len, cap - (size_t)len, ", d1..d%zu", p);
}

static int compile(dkf_scn_ctx_t *c, model_t *e, const json_t *j, const char *path, expr_t *out)
{
    char text[DKF_NLM_EXPR_MAX + 1], vars[48];
    size_t i, len;
    long at;
    int nres = 0;
    double v;
    snprintf(out->key, sizeof out->key, "%s", path);
    if (json_is_number(j)) {
        snprintf(text, sizeof text, "%.17g", json_number_value(j));
    } else if (json_is_string(j)) {
        len = json_string_length(j);
        if (len > DKF_NLM_EXPR_MAX)
            return dkf_scn_fail(c, path, "expression of %zu characters, more than the %d "
                                "allowed", len, DKF_NLM_EXPR_MAX);
        if (strlen(json_string_value(j)) != len)
            return dkf_scn_fail(c, path, "expression contains a NUL character");
        memcpy(text, json_string_value(j), len + 1);
    } else {
        return dkf_scn_fail(c, path, "expected an expression string, got %s",
                            dkf_scn_json_kind(j));
    }
    if ((at = assignment_at(text)) != 0)
        return dkf_scn_fail(c, path, "'%s': assignment '=' at position %ld is not allowed "
                            "(compare with ==)", text, at);
    if ((out->h = mupCreate(muBASETYPE_FLOAT)) == NULL)
        return dkf_scn_fail(c, NULL, "out of memory");
    for (i = 0; i < e->n + e->p; ++i) {
        char name[16];
        snprintf(name, sizeof name, "%c%zu", i < e->n ? 'x' : 'd',
                 i < e->n ? i + 1 : i - e->n + 1);
        mupDefineVar(out->h, name, &e->vars[i]);
    }
    mupDefineConst(out->h, "pi", 3.14159265358979323846);
    mupDefineFun2(out->h, "hypot", hypot2, 1);
    mupSetExpr(out->h, text);
    v = mupEval(out->h);
    var_list(vars, sizeof vars, e->n, e->p);
    if (mupError(out->h)) {
        const int code = (int)mupGetErrorCode(out->h);
        const long pos = (long)mupGetErrorPos(out->h);
        const char *tok = mupGetErrorToken(out->h);
        if (code == 1)
            return dkf_scn_fail(c, path, "'%s': unknown variable or function '%s' at position "
                                "%ld (variables: %s)", text, tok, pos + 1, vars);
        if (pos >= 0)
            return dkf_scn_fail(c, path, "'%s': %s at position %ld", text,
                                syntax_problem(code), pos + 1);
        return dkf_scn_fail(c, path, "'%s': %s", text, syntax_problem(code));
    }
    mupEvalMulti(out->h, &nres);
    if (nres != 1)
        return dkf_scn_fail(c, path, "'%s': gives %d values, expected one (a ',' outside a "
                            "function's arguments?)", text, nres);
    (void)v;
    return 0;
}

/* A list of `count` expressions at expr[key] into out. */
static int compile_list(dkf_scn_ctx_t *c, model_t *e, const json_t *list, const char *path,
                        size_t count, expr_t *out)
{
    size_t i;
    char p[DKF_SCN_PATH_LEN];
    if (!json_is_array(list))
        return dkf_scn_fail(c, path, "expected a list of %zu expressions, got %s", count,
                            dkf_scn_json_kind(list));
    if (json_array_size(list) != count)
        return dkf_scn_fail(c, path, "expected %zu expressions, got %zu", count,
                            json_array_size(list));
    for (i = 0; i < count; ++i) {
        dkf_scn_subidx(p, path, i);
        if (compile(c, e, json_array_get(list, i), p, &out[i]) != 0) return -1;
    }
    return 0;
}

/* A rows x cols matrix of expressions into out (row-major). */
static int compile_matrix(dkf_scn_ctx_t *c, model_t *e, const json_t *mat, const char *path,
                          size_t rows, size_t cols, expr_t *out)
{
    size_t i;
    char p[DKF_SCN_PATH_LEN];
    if (!json_is_array(mat) || json_array_size(mat) != rows)
        return dkf_scn_fail(c, path, "expected a %zu x %zu matrix of expressions (a list of "
                            "%zu rows)", rows, cols, rows);
    for (i = 0; i < rows; ++i) {
        dkf_scn_subidx(p, path, i);
        if (compile_list(c, e, json_array_get(mat, i), p, cols, out + i * cols) != 0) return -1;
    }
    return 0;
}

/* Jacobian pair (J1: r x n, J2: r x p) keys k1, k2 of expr: both or neither
 * (J2 left out when p = 0). 1 if given, 0 if not, -1 on error. */
static int compile_pair(dkf_scn_ctx_t *c, model_t *e, const json_t *expr, const char *path,
                        const char *k1, const char *k2, size_t r, expr_t *J1, expr_t *J2)
{
    const json_t *a = json_object_get(expr, k1), *b = json_object_get(expr, k2);
    char p1[DKF_SCN_PATH_LEN], p2[DKF_SCN_PATH_LEN];
    dkf_scn_subkey(p1, path, k1);
    dkf_scn_subkey(p2, path, k2);
    if (e->p == 0 && b != NULL)
        return dkf_scn_fail(c, p2, "the model has no unknown input (p = 0): leave %s out", k2);
    if (a == NULL && b == NULL) return 0;
    if (a == NULL) return dkf_scn_fail(c, p1, "missing key (%s is given: give both or neither)",
                                       k2);
    if (b == NULL && e->p > 0)
        return dkf_scn_fail(c, p2, "missing key (%s is given: give both or neither)", k1);
    if (compile_matrix(c, e, a, p1, r, e->n, J1) != 0) return -1;
    if (e->p > 0 && compile_matrix(c, e, b, p2, r, e->p, J2) != 0) return -1;
    return 1;
}

/* Every expression finite at (x0, d0). */
static int probe(dkf_scn_ctx_t *c, dkf_nlm_t *m, model_t *e, const double *x0, const double *d0)
{
    size_t i;
    double v;
    if (x0 == NULL) return 0;
    set_vars(e, x0, d0);
    for (i = 0; i < e->total; ++i)
        if (e->all[i].h != NULL && eval(m, &e->all[i], &v) != 0) {
            dkf_scn_fail(c, NULL, "%s", m->failure);
            m->failure[0] = '\0';
            return -1;
        }
    return 0;
}

static const char *const known_keys[] = {"f", "g", "A", "G", "C", "H", "angles", NULL};

int dkf_nlm_load_expr(dkf_scn_ctx_t *c, dkf_nlm_t *m, const json_t *expr, const char *path,
                      const double *x0, const double *d0)
{
    model_t *e;
    const json_t *g;
    const char *key;
    json_t *val;
    char p[DKF_SCN_PATH_LEN];
    size_t total, i;
    int hasf, hash;
    if (!json_is_object(expr))
        return dkf_scn_fail(c, path, "expected {\"f\": [...], \"g\": [...]}, got %s",
                            dkf_scn_json_kind(expr));
    json_object_foreach((json_t *)expr, key, val) {
        for (i = 0; known_keys[i] != NULL && strcmp(known_keys[i], key) != 0; ++i) continue;
        if (known_keys[i] == NULL) {
            dkf_scn_subkey(p, path, key);
            return dkf_scn_fail(c, p, "unknown key (known: f, g, A, G, C, H, angles)");
        }
    }
    g = json_object_get(expr, "g");
    dkf_scn_subkey(p, path, "g");
    if (g == NULL) return dkf_scn_fail(c, p, "missing key (the measurement expressions)");
    if (!json_is_array(g) || json_array_size(g) == 0 || json_array_size(g) > DKF_MAX_DIM)
        return dkf_scn_fail(c, p, "expected a list of 1..%d expressions, got %s", DKF_MAX_DIM,
                            dkf_scn_json_kind(g));
    m->m = json_array_size(g);
    if (m->m < m->p)
        return dkf_scn_fail(c, p, "%zu measurements for %zu unknown inputs: the filters need "
                            "m >= p", m->m, m->p);
    if ((e = calloc(1, sizeof *e)) == NULL) return dkf_scn_fail(c, NULL, "out of memory");
    e->n = m->n;
    e->m = m->m;
    e->p = m->p;
    m->impl = e;
    total = e->n + e->m + (e->n + e->m) * (e->n + e->p);
    e->total = total;
    if ((e->all = calloc(total, sizeof *e->all)) == NULL) {
        m->ops = &ops_table[0];
        return dkf_scn_fail(c, NULL, "out of memory");
    }
    e->f = e->all;
    e->g = e->f + e->n;
    e->A = e->g + e->m;
    e->G = e->A + e->n * e->n;
    e->C = e->G + e->n * e->p;
    e->H = e->C + e->m * e->n;
    m->ops = &ops_table[0]; /* destroy from here on */
    dkf_scn_subkey(p, path, "f");
    if (json_object_get(expr, "f") == NULL)
        return dkf_scn_fail(c, p, "missing key (the %zu state-transition expressions)", e->n);
    if (compile_list(c, e, json_object_get(expr, "f"), p, e->n, e->f) != 0) return -1;
    dkf_scn_subkey(p, path, "g");
    if (compile_list(c, e, g, p, e->m, e->g) != 0) return -1;
    if ((hasf = compile_pair(c, e, expr, path, "A", "G", e->n, e->A, e->G)) < 0) return -1;
    if ((hash = compile_pair(c, e, expr, path, "C", "H", e->m, e->C, e->H)) < 0) return -1;
    m->ops = &ops_table[(hasf ? 1 : 0) + (hash ? 2 : 0)];
    return probe(c, m, e, x0, d0);
}
