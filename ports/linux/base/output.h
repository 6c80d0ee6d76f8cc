/*
 * output.h - dkf-run's output writer: a run's per-step values streamed to
 * a file, in memory independent of the number of steps (docs/decisions.md
 * item 50).
 *
 *   w = dkf_out_open("out.json", DKF_OUT_JSON, every, k_first, err, len);
 *   dkf_out_value(w, "filter", json_string("kf"));   a one-off value
 *   for each step k:
 *       dkf_out_step(w, k);                          kept steps: k % every
 *       dkf_out_series(w, "outputs.KF", series);     the step's values
 *   rc = dkf_out_close(w, keep, err, len);
 *
 * JSON: the document dkf-run has always written, {"scenario", ..., "k":
 * [kept steps], "outputs": {...}, ...} with every per-step key a list
 * over the kept steps, byte for byte what json_dump_file(JSON_COMPACT |
 * JSON_REAL_PRECISION(17)) writes of it. Each per-step list is spooled to
 * one temporary file in chunks (a chunk index per list stays in memory)
 * and the document is assembled at close.
 * CSV: a header line, then one line per kept step: k, then every number
 * of the step's values, columns named by key path and index
 * ("outputs.KF.Pp[0][1]"); every step must have the first step's columns.
 * One-off values are JSON only.
 * A path is keys joined by '.', a key may end in one list index
 * ("outputs.local[1].xp"). A failure (out of memory, a write error, a
 * CSV step of other columns) is latched: later calls do nothing and
 * dkf_out_close reports it.
 */
#ifndef DKF_HOST_OUTPUT_H
#define DKF_HOST_OUTPUT_H

#include <stddef.h>

#include <jansson.h>

typedef enum { DKF_OUT_JSON, DKF_OUT_CSV } dkf_out_format_t;

typedef struct dkf_out dkf_out_t;

/* path opened for writing (truncated); steps k_first, k_first + every,
 * ... are kept (every >= 1). NULL with a "PATH: problem" err. */
dkf_out_t *dkf_out_open(const char *path, dkf_out_format_t format, unsigned long every,
                        long k_first, char *err, size_t errlen);
/* doc[path] = value (reference stolen), written where it was first set. */
void dkf_out_value(dkf_out_t *w, const char *path, json_t *value);
/* Starts step k; 1 if it is kept. */
int dkf_out_step(dkf_out_t *w, long k);
/* The step's value of the list at path (reference stolen; dropped when
 * the step is not kept). */
void dkf_out_put(dkf_out_t *w, const char *path, json_t *value);
/* Every element of every list series[key] at base.key (dkf_out_put);
 * the lists are emptied, so a runner's series holds one step at a time. */
void dkf_out_series(dkf_out_t *w, const char *base, json_t *series);
/* dkf_out_series at outputs.<label>: a runner's per-step record. */
void dkf_out_outputs(dkf_out_t *w, const char *label, json_t *series);
/* 1 once a failure is latched. */
int dkf_out_failed(const dkf_out_t *w);
/* Writes the rest and closes (keep = 0: removes the file, as after a
 * failed run). DKF_EXIT_OK, or DKF_EXIT_USAGE with a "PATH: problem" err.
 * Frees w. */
int dkf_out_close(dkf_out_t *w, int keep, char *err, size_t errlen);

#endif /* DKF_HOST_OUTPUT_H */
