/*
 * util.h - what every host program shares (dkf-run, dkf-sim, dkf-node,
 * dkf-fusion, dkf-net-local, dkf-tw-node): the exit statuses, the one-line
 * error formatter, the JSON matrix writer and the FNV-1a hash behind the
 * model ids. One copy of each, here; the programs do not keep their own.
 */
#ifndef DKF_HOST_UTIL_H
#define DKF_HOST_UTIL_H

#include <stddef.h>
#include <stdint.h>

#include <jansson.h>

#include "dkf/mat.h"

/* Exit statuses of every host program (and the return codes of the
 * runner operations, family.h). */
#define DKF_EXIT_OK 0
#define DKF_EXIT_USAGE 2   /* bad options or bad input: unreadable, invalid or unwritable file */
#define DKF_EXIT_RUN 3     /* a run failed: a core call, a peer, a wait that timed out */
#define DKF_EXIT_STOPPED 4 /* interrupted (SIGINT/SIGTERM or --timeout) before the end */

/* printf-style message into err[0..errlen-1] (nothing if err is NULL or
 * errlen is 0); returns rc, so a caller writes `return dkf_failf(...)`. */
#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
int dkf_failf(char *err, size_t errlen, int rc, const char *fmt, ...);

/* A as JSON: a flat list of numbers when as_vector (A is n x 1), else a
 * list of rows. New reference; NULL if out of memory. */
json_t *dkf_json_from_mat(const dkf_mat_t *A, int as_vector);

/* rows x cols doubles (row-major) as a list of rows; cols == 0: v is a
 * flat vector of rows numbers. New reference. */
json_t *dkf_json_doubles(const double *v, size_t rows, size_t cols);

/* series[key].append(value), creating the list on first use; the value
 * reference is stolen. The per-step series of every runner. */
void dkf_json_append(json_t *series, const char *key, json_t *value);

/* value into outs under name: outs[name] = value, or, for a name
 * "key[i]", appended to the list outs[key] (estimators "local[0]",
 * "local[1]", ... become outputs.local). The value reference is stolen. */
void dkf_json_place(json_t *outs, const char *name, json_t *value);

/* 64-bit FNV-1a. Integers and doubles are hashed by value, most
 * significant byte first (a double by its IEEE-754 bit pattern), so a hash
 * does not depend on the host's byte order. Start from DKF_FNV1A_OFFSET. */
#define DKF_FNV1A_OFFSET 0xcbf29ce484222325ull
uint64_t dkf_fnv1a_u64(uint64_t h, uint64_t v);
uint64_t dkf_fnv1a_doubles(uint64_t h, const double *v, size_t n);

/* Cholesky in double: L (n x n, row-major, lower; the rest untouched)
 * with L L^T = a (symmetric, row-major; its lower triangle read). n, or
 * the index of the first pivot that is not a finite positive number (its
 * value in *pivot). Each L_ij = (a_ij - sum_{k<j} L_ik L_jk) / L_jj, k
 * ascending. */
size_t dkf_chol_double(const double *a, size_t n, double *L, double *pivot);

#endif /* DKF_HOST_UTIL_H */
