/*
 * fuzz_core.h - what the core harnesses (fuzz_core_<name>.c) share: a
 * reader that turns the fuzzer's bytes into bounded dimensions, operation
 * codes and reals (including NaN, +-Inf, huge, tiny and subnormal values),
 * model matrices that start from a valid default and take byte-chosen
 * edits (values, a wrong shape, a NULL data pointer, a scaling), and the
 * property checks: after a call that returns an error, the filter object
 * and the state part of its storage are byte-identical to a copy taken
 * before the call; after a call that succeeds, the state is finite (and a
 * covariance the module keeps symmetric is exactly symmetric). A broken
 * property calls __builtin_trap(), which libFuzzer reports as a crash and
 * the corpus replay as a failed test. A one-filter harness is a table of
 * operations that fz_run drives (FZ_HARNESS defines its entry point).
 * Header-only: a harness links the dkf library, libc and libm, nothing
 * else.
 */
#ifndef DKF_FUZZ_CORE_H
#define DKF_FUZZ_CORE_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "dkf/mat.h"

/* A broken property names itself in the log (run_fuzz.sh greps
 * "property broken"), then traps: libFuzzer keeps the input. */
#define FZ_CHECK(cond) \
    do { \
        if (!(cond)) { \
            fprintf(stderr, "property broken: %s:%d: %s\n", __FILE__, __LINE__, #cond); \
            __builtin_trap(); \
        } \
    } while (0)

/* ---- bytes ------------------------------------------------------------------ */

typedef struct {
    const uint8_t *d;
    size_t n, i;
} fz_t;

static inline uint8_t fz_byte(fz_t *z) { return z->i < z->n ? z->d[z->i++] : 0; }
static inline int fz_more(const fz_t *z) { return z->i < z->n; }
/* 1 + (a byte mod hi): a dimension in [1, hi]. */
static inline size_t fz_dim(fz_t *z, size_t hi) { return 1 + (size_t)(fz_byte(z) % hi); }
/* The sizes n, m, p of an unknown-input harness, fz_dim each, in that
 * byte order. */
static inline void fz_nmp(fz_t *z, size_t *n, size_t *m, size_t *p, size_t nmax, size_t mmax,
                          size_t pmax)
{
    *n = fz_dim(z, nmax);
    *m = fz_dim(z, mmax);
    *p = fz_dim(z, pmax);
}

/* A real: mostly small values in [-4, 4] (so that models stay valid
 * often enough to reach deep states), else the special values. */
static inline dkf_real_t fz_real(fz_t *z)
{
    const uint8_t s = fz_byte(z);
    if (s < 200) return (dkf_real_t)((int)s - 100) / DKF_R(25.0);
    switch (s) {
    case 200: return (dkf_real_t)NAN;
    case 201: return (dkf_real_t)INFINITY;
    case 202: return -(dkf_real_t)INFINITY;
    case 203: return DKF_REAL_MAX / DKF_R(4.0);
    case 204: return -DKF_REAL_MAX / DKF_R(4.0);
    case 205: return DKF_REAL_MIN;
    case 206: return DKF_REAL_MIN * DKF_REAL_EPSILON; /* subnormal */
    case 207: return DKF_R(2.0) * DKF_SQRT(DKF_REAL_MAX);
    case 208: return DKF_R(1e-30);
    case 209: return DKF_R(1e30);
    default: {
        /* four raw bytes as a float: any bit pattern */
        uint32_t u = 0;
        float f;
        int k;
        for (k = 0; k < 4; ++k) u = (u << 8) | fz_byte(z);
        memcpy(&f, &u, sizeof f);
        return (dkf_real_t)f;
    }
    }
}

/* ---- model matrices ----------------------------------------------------------- */

/* A matrix with room for one more row and column of any dimension up to 7. */
#define FZ_CAP 64
typedef struct {
    dkf_real_t d[FZ_CAP];
    dkf_mat_t v;
} fz_mat_t;

static inline dkf_mat_t *fz_set(fz_mat_t *b, size_t r, size_t c, dkf_real_t diag, dkf_real_t off)
{
    size_t i, j;
    memset(b->d, 0, sizeof b->d);
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) b->d[i * c + j] = i == j ? diag : off;
    b->v.rows = r;
    b->v.cols = c;
    b->v.data = b->d;
    return &b->v;
}

/* Up to 3 byte-chosen edits on the matrices mats[0..count-1]: an element
 * set to a real, the shape grown or shrunk by one, the data pointer NULL,
 * every element scaled by a real, or a symmetric element pair (which
 * keeps a covariance symmetric) set. */
static inline void fz_edit(fz_t *z, fz_mat_t *const mats[], size_t count)
{
    size_t k, edits = fz_byte(z) % 4;
    for (k = 0; k < edits && fz_more(z); ++k) {
        fz_mat_t *b = mats[fz_byte(z) % count];
        dkf_mat_t *v = &b->v;
        const uint8_t kind = fz_byte(z) % 8;
        const size_t len = v->rows * v->cols;
        size_t e = len > 0 ? fz_byte(z) % len : 0, i;
        dkf_real_t x;
        switch (kind) {
        case 0:
        case 1:
            if (v->data != NULL && len > 0) v->data[e] = fz_real(z);
            break;
        case 2:
            if (v->data != NULL && len > 0 && v->rows == v->cols) {
                const size_t r = e / v->cols, c = e % v->cols;
                x = fz_real(z);
                v->data[r * v->cols + c] = x;
                v->data[c * v->cols + r] = x;
            }
            break;
        case 3:
            if (v->rows < 7) v->rows += 1;
            break;
        case 4:
            if (v->cols < 7) v->cols += 1;
            break;
        case 5:
            if (v->rows > 0) v->rows -= 1;
            break;
        case 6: v->data = NULL; break;
        default:
            x = fz_real(z);
            if (v->data != NULL)
                for (i = 0; i < len; ++i) v->data[i] *= x;
            break;
        }
    }
}

/* ---- the property ------------------------------------------------------------- */

#define FZ_SNAP_CAP (1u << 18)
typedef struct {
    const void *p[40];
    size_t len[40];
    size_t n;
    unsigned char copy[FZ_SNAP_CAP];
} fz_snap_t;

static inline void fz_regions_clear(fz_snap_t *s) { s->n = 0; }
static inline void fz_region(fz_snap_t *s, const void *p, size_t len)
{
    FZ_CHECK(s->n < 40);
    s->p[s->n] = p;
    s->len[s->n] = len;
    s->n++;
}

static inline void fz_take(fz_snap_t *s)
{
    size_t i, off = 0;
    for (i = 0; i < s->n; ++i) {
        FZ_CHECK(off + s->len[i] <= FZ_SNAP_CAP);
        memcpy(s->copy + off, s->p[i], s->len[i]);
        off += s->len[i];
    }
}

/* Traps unless every region is byte-identical to the copy. */
static inline void fz_untouched(const fz_snap_t *s)
{
    size_t i, off = 0;
    for (i = 0; i < s->n; ++i) {
        FZ_CHECK(memcmp(s->copy + off, s->p[i], s->len[i]) == 0);
        off += s->len[i];
    }
}

static inline void fz_finite(const dkf_real_t *p, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) FZ_CHECK(isfinite(p[i]));
}

/* 1 if the n x n at p is exactly symmetric. */
static inline int fz_is_symmetric(const dkf_real_t *p, size_t n)
{
    size_t i, j;
    for (i = 0; i < n; ++i)
        for (j = 0; j < i; ++j)
            if (memcmp(&p[i * n + j], &p[j * n + i], sizeof *p) != 0) return 0;
    return 1;
}

/* Traps unless the n x n at p is exactly symmetric. The inits accept a
 * non-symmetric prior (they read one triangle), so a harness asks this
 * only when its prior was symmetric (sym != 0). */
static inline void fz_symmetric(const dkf_real_t *p, size_t n, int sym)
{
    if (sym) FZ_CHECK(fz_is_symmetric(p, n));
}

/* After a call: an error must leave the snapshot's regions untouched; a
 * success is checked by the caller (finite state, symmetric P). Returns
 * 1 on success. */
static inline int fz_after(const fz_snap_t *s, dkf_status_t st)
{
    if (st != DKF_OK) {
        FZ_CHECK(st < 0);
        fz_untouched(s);
        return 0;
    }
    return 1;
}

/* ---- priors -------------------------------------------------------------------- */

/* 1 if the square covariance b is exactly symmetric or has no data (the
 * init then refuses it). The inits accept a non-symmetric prior (they read
 * one triangle): then no symmetry is promised. */
static inline int fz_cov_symmetric(const fz_mat_t *b)
{
    return b->v.data == NULL || fz_is_symmetric(b->v.data, b->v.rows);
}

/* The default x0 (n), P0 (n x n), then byte-chosen edits of both; returns
 * fz_cov_symmetric(P0). */
static inline int fz_kf_prior(fz_t *z, fz_mat_t *x0, fz_mat_t *P0, size_t n)
{
    fz_mat_t *const prior[] = {x0, P0};
    fz_set(x0, n, 1, DKF_R(0.5), DKF_R(0.5));
    fz_set(P0, n, n, DKF_R(1.0), DKF_R(0.1));
    fz_edit(z, prior, 2);
    return fz_cov_symmetric(P0);
}

/* The default x0 (n), P0 (n x n), d0 (p), Pd0 (p x p) of dkf/askf.h and
 * dkf/otskf.h into prior[0..3], then byte-chosen edits; returns 1 if both
 * covariances are symmetric (fz_cov_symmetric). */
static inline int fz_ui_prior(fz_t *z, fz_mat_t *const prior[4], size_t n, size_t p)
{
    fz_set(prior[0], n, 1, DKF_R(0.5), DKF_R(0.5));
    fz_set(prior[1], n, n, DKF_R(1.0), DKF_R(0.1));
    fz_set(prior[2], p, 1, DKF_R(0.1), DKF_R(0.1));
    fz_set(prior[3], p, p, DKF_R(1.0), DKF_R(0.0));
    fz_edit(z, prior, 4);
    return fz_cov_symmetric(prior[1]) && fz_cov_symmetric(prior[3]);
}

/* The default x0 (n), P0 (n x n), d0 (p), Pd0 (p x p), Pxd0 (n x p) of
 * dkf/nerts.h's and dkf/dfnerts.h's filters into prior[0..4] (a prior
 * every init accepts); with z, then byte-chosen edits. */
static inline void fz_nerts_prior(fz_t *z, fz_mat_t *const prior[5], size_t n, size_t p)
{
    fz_set(prior[0], n, 1, DKF_R(0.5), DKF_R(0.5));
    fz_set(prior[1], n, n, DKF_R(1.0), DKF_R(0.1));
    fz_set(prior[2], p, 1, DKF_R(0.2), DKF_R(0.2));
    fz_set(prior[3], p, p, DKF_R(0.5), DKF_R(0.0));
    fz_set(prior[4], n, p, DKF_R(0.05), DKF_R(0.0));
    if (z != NULL) fz_edit(z, prior, 5);
}

/* ---- the driver of a one-filter harness ------------------------------------------ */

/* What an operation returns when it made no call the driver should check. */
#define FZ_SKIP ((dkf_status_t)1)

/* A family's part of fz_run. The harness keeps its filter, storage and
 * matrices in file-scope statics, so the operations take no context. */
typedef struct {
    void *obj;       /* the filter struct: zeroed, then guarded from the first init on */
    size_t obj_size;
    /* Dimensions, prior and model set-up from the bytes (before the first init). */
    void (*decode)(fz_t *z);
    /* The first init. */
    dkf_status_t (*init)(void);
    /* After it succeeded: adds the storage regions an error must leave
     * untouched (the struct is already in s); NULL: none. */
    void (*guard)(fz_snap_t *s);
    /* One byte-chosen call (code); calls fz_take(s) just before it (and may
     * first change s's regions). FZ_SKIP: no call of the filter was made. */
    dkf_status_t (*op)(fz_t *z, uint8_t code, fz_snap_t *s);
    /* The property after a successful call (finite state, symmetric P). */
    void (*ok)(void);
} fz_family_t;

/* Decode, init, then up to 24 byte-chosen operations: an error (of the
 * init too) must leave the guarded regions byte-identical; each success
 * is checked by fam->ok. */
static inline int fz_run(const fz_family_t *fam, fz_t *z)
{
    static fz_snap_t snap;
    size_t k;
    memset(fam->obj, 0, fam->obj_size);
    fam->decode(z);
    fz_regions_clear(&snap);
    fz_region(&snap, fam->obj, fam->obj_size);
    fz_take(&snap);
    if (!fz_after(&snap, fam->init())) return 0;
    if (fam->guard != NULL) fam->guard(&snap);
    for (k = 0; k < 24 && fz_more(z); ++k) {
        const uint8_t code = fz_byte(z);
        const dkf_status_t r = fam->op(z, code, &snap);
        if (r != FZ_SKIP && fz_after(&snap, r)) fam->ok();
    }
    return 0;
}

/* ---- checkpoints ------------------------------------------------------------------ */

/* The restore operation of a harness that saved cklen reals at ck (0: none
 * saved, skip it): with code & 16 one byte-chosen element takes a
 * byte-chosen real (restore accepts any finite values, so no symmetry is
 * promised afterwards: *sym = 0); returns the length to restore, one short
 * with code & 32. */
static inline size_t fz_ckpt_restore_len(fz_t *z, uint8_t code, dkf_real_t *ck, size_t cklen,
                                         int *sym)
{
    if (cklen == 0) return 0;
    if (code & 16) {
        ck[fz_byte(z) % cklen] = fz_real(z);
        *sym = 0;
    }
    return cklen - (code & 32 ? 1 : 0);
}

/* ---- the unknown-input model of dkf/ui_model.h ---------------------------------- */

#include "dkf/ui_model.h"

/* Default model (n states, m measurements, p inputs; A of full column rank
 * when p <= m), then byte-chosen edits of the dynamics (dyn_edits) or of
 * the measurement model and y. */
typedef struct {
    fz_mat_t F, Q, B, Rd, H, A, R, y;
    dkf_ui_dyn_t dyn;
    dkf_ui_meas_t meas;
} fz_ui_t;

static inline void fz_ui_default(fz_ui_t *u, size_t n, size_t m, size_t p)
{
    fz_set(&u->F, n, n, DKF_R(1.0), DKF_R(0.05));
    fz_set(&u->Q, n, n, DKF_R(0.1), DKF_R(0.0));
    fz_set(&u->B, p, p, DKF_R(0.9), DKF_R(0.0));
    fz_set(&u->Rd, p, p, DKF_R(0.1), DKF_R(0.0));
    fz_set(&u->H, m, n, DKF_R(1.0), DKF_R(0.0));
    fz_set(&u->A, m, p, DKF_R(1.0), DKF_R(0.0));
    fz_set(&u->R, m, m, DKF_R(0.5), DKF_R(0.0));
    fz_set(&u->y, m, 1, DKF_R(0.3), DKF_R(0.3));
    u->dyn.F = &u->F.v, u->dyn.Q = &u->Q.v, u->dyn.B = &u->B.v, u->dyn.Rd = &u->Rd.v;
    u->meas.H = &u->H.v, u->meas.D = &u->A.v, u->meas.R = &u->R.v;
}

static inline void fz_ui_edit(fz_t *z, fz_ui_t *u, int dyn)
{
    fz_mat_t *const d[] = {&u->F, &u->Q, &u->B, &u->Rd}, *const m[] = {&u->H, &u->A, &u->R, &u->y};
    fz_edit(z, dyn ? d : m, 4);
}

/* A one-filter harness's entry point: fz_run over the file's static
 * functions decode, init, op, ok, the given guard (or NULL) and the filter
 * struct obj. */
#define FZ_HARNESS(obj, guard_fn)                                                        \
    int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);                        \
    int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)                         \
    {                                                                                    \
        static const fz_family_t fam = {&(obj), sizeof(obj), decode, init, guard_fn, op, ok}; \
        fz_t z = {data, size, 0};                                                        \
        return fz_run(&fam, &z);                                                         \
    }

#endif /* DKF_FUZZ_CORE_H */
