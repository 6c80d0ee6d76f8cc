/*
 * scn_values.h - the JSON value readers of the host (ports/linux/json):
 * numbers (integers range-checked before any cast), vectors, matrices,
 * named matrix sets, time series, symmetric covariances, each failure a
 * "FILE: KEY.PATH: problem" line (dkf_scn_fail). The scenario reader's
 * layouts (scenario/) and the nonlinear model builders (nlm/) read every
 * value through these, so a key is checked the same way wherever it is.
 *
 * Rule of every reader: the first problem found is reported and -1 is
 * returned; what was allocated belongs to the caller's structure, which
 * frees it.
 */
#ifndef DKF_HOST_SCN_VALUES_H
#define DKF_HOST_SCN_VALUES_H

#include <stddef.h>

#include <jansson.h>

#include "dkf/mat.h"

/* Every error message fits in this many bytes. */
#define DKF_SCN_ERR_LEN 1024

/* Limits on what a file can ask for (docs/reference/scenario-format.md, "Limits").
 * Every count that sizes a loop or an allocation is one of these, the
 * length of a list in the file, or a matrix dimension (<= DKF_MAX_DIM);
 * a file above a limit is refused with a one-line message. */
#define DKF_SCN_MAX_STEPS 1000000UL  /* N, the `k` list, the steps list */
#define DKF_SCN_MAX_TIMES (DKF_SCN_MAX_STEPS + 3) /* per_k, y, truth: k = 0..N+2 */
#define DKF_SCN_MAX_RUNS 100000UL    /* `runs` */
#define DKF_SCN_MAX_SENSORS 4096UL   /* sensors, cases' C list, seed-003 nodes */
#define DKF_SCN_MAX_TIME 9007199254740992.0 /* 2^53: times k are 0..2^53 */

/* A named matrix that is either constant or given per absolute k, or (for
 * init entries such as P00_local) a plain list of same-shape matrices.
 * A vector is stored as rows x 1. */
typedef struct {
    char *name;    /* JSON key, e.g. "F", "P00_local" */
    char *path;    /* its key path in the file, e.g. "model.sensors[1].H", for messages */
    size_t rows;
    size_t cols;
    size_t count;  /* 0: one constant matrix; else count matrices (per_k / list) */
    double *data;  /* max(count, 1) * rows * cols, row-major */
    size_t k0;     /* per_k: entry j is M_{k0 + j} (steps layout; 0 elsewhere) */
} dkf_scn_mat_t;

/* A named set of matrices (model, one sensor, init). */
typedef struct {
    size_t len;
    dkf_scn_mat_t *items;
} dkf_scn_mats_t;

/* Key paths longer than this are cut short: they only label messages. */
#define DKF_SCN_PATH_LEN 256

typedef struct dkf_scn_ctx {
    const char *file;
    char *err;
    size_t errlen;
} dkf_scn_ctx_t;

/* count rows of dim doubles in one allocation; dkf_scn_store checks every
 * write against the shape it was allocated with. */
typedef struct {
    double *v;
    size_t count, dim;
} dkf_scn_block_t;

/* ---- messages and key paths (scn_values.c) ---- */
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
int dkf_scn_fail(dkf_scn_ctx_t *c, const char *path, const char *fmt, ...);
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
void dkf_scn_pathf(char *out, const char *fmt, ...);
void dkf_scn_subkey(char *out, const char *base, const char *key);
void dkf_scn_subidx(char *out, const char *base, size_t i);
char *dkf_scn_dupstr(const char *s);
void *dkf_scn_calloc(dkf_scn_ctx_t *c, size_t n, size_t size);
const char *dkf_scn_json_kind(const json_t *j);
const char *dkf_scn_num_str(char *buf, size_t len, double v);

/* ---- values (scn_values.c) ---- */
/* An integer in lo..hi, range-checked before any cast. */
int dkf_scn_get_integer(dkf_scn_ctx_t *c, const json_t *j, const char *path, double lo,
                        double hi, long *out);
int dkf_scn_block_alloc(dkf_scn_ctx_t *c, dkf_scn_block_t *b, size_t count, size_t dim,
                        const char *path);
/* Row `row` of b = src[0..len-1]: refused unless row < count and len == dim. */
int dkf_scn_store(dkf_scn_ctx_t *c, const char *path, const dkf_scn_block_t *b, size_t row,
                  const double *src, size_t len);
/* j (at path) a non-empty list of at most max entries, its length into *n;
 * else "missing key", "expected a non-empty list of WHAT, got ..." or
 * "N UNIT, more than the MAX allowed". */
int dkf_scn_list_len(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *what,
                     const char *unit, unsigned long max, size_t *n);
/* Row `row` of b = the vector j (at path), of b->dim values: another length
 * is refused as "expected a vector of DIM values (LEN_OF), got LEN", len_of
 * naming what sets the length (e.g. "the rows of H[1]"; NULL: no name). */
int dkf_scn_store_vector(dkf_scn_ctx_t *c, const json_t *j, const char *path,
                         const dkf_scn_block_t *b, size_t row, const char *len_of);
int dkf_scn_parse_vector(dkf_scn_ctx_t *c, const json_t *j, const char *path, size_t *len,
                         double **out);
int dkf_scn_parse_matrix(dkf_scn_ctx_t *c, const json_t *j, const char *path, size_t *rows,
                         size_t *cols, double **out);
/* Depth of the first-element chain: 1 for [1,2], 2 for [[1]], 3 for [[[1]]]. */
int dkf_scn_nest_depth(const json_t *j);
int dkf_scn_shape_error(dkf_scn_ctx_t *c, const char *path, size_t er, size_t ec, size_t r,
                        size_t cc);
dkf_scn_mat_t *dkf_scn_mats_add(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const char *name,
                                const char *path);
void dkf_scn_mats_free(dkf_scn_mats_t *set);
const dkf_scn_mat_t *dkf_scn_mats_find(const dkf_scn_mats_t *set, const char *name);
/* Entry idx of m, a stack of `count` same-shape matrices. */
int dkf_scn_stack_matrix(dkf_scn_ctx_t *c, dkf_scn_mat_t *m, dkf_scn_block_t *b, size_t idx,
                         size_t count, const json_t *j, const char *path);
/* Matrices of the model and init are at most DKF_MAX_DIM x DKF_MAX_DIM. */
int dkf_scn_check_dims(dkf_scn_ctx_t *c, const dkf_scn_mat_t *m);
/* A model entry ({"const": M}, {"per_k": [...]}, a bare matrix; strings
 * skipped) / an init entry (vector, matrix or list of matrices). */
int dkf_scn_parse_model_entry(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const char *name,
                              const json_t *j, const char *path);
int dkf_scn_parse_init_entry(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const char *name,
                             const json_t *j, const char *path);
/* {"k": [...], "<vkey>": [[...], ...]}: times strictly increasing. */
int dkf_scn_parse_series(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *vkey,
                         size_t dim, size_t *count, long **kout, double **vout);
/* Index of time k in the strictly increasing list ks, or -1. */
long dkf_scn_find_time(const long *ks, size_t n, long k);

/* ---- keys (scn_keys.c) ---- */
/* Every key of obj (at path) is in known (NULL-terminated); string and
 * null values are comments; at the top level (path "") the vector files'
 * informational keys (outputs, tolerance, dims, ...) are known too. Else
 * "PATH.KEY: unknown key (did you mean K?)" with the nearest known key, or
 * the nearest of elsewhere (full paths such as "init.P00_central", NULL
 * for none), when one is near. */
int dkf_scn_check_keys(dkf_scn_ctx_t *c, const json_t *obj, const char *path,
                       const char *const *known, const char *const *elsewhere);

/* The n x n covariance a (read from the file at path) symmetric within
 * rounding (8 eps max|a|, docs/reference/scenario-format.md "Limits and checks"). */
int dkf_scn_check_symmetric(dkf_scn_ctx_t *c, const char *path, const double *a, size_t n);
/* The symmetric n x n a (at path) positive semidefinite within rounding
 * (spd = 0) or positive definite (spd = 1); else a message naming path,
 * what (which matrix must be what) and the failing Cholesky pivot. */
int dkf_scn_check_definite(dkf_scn_ctx_t *c, const char *path, const double *a, size_t n,
                           int spd, const char *what);

#endif /* DKF_HOST_SCN_VALUES_H */
