/*
 * scenario.h - the JSON scenario format, loaded into memory (host side).
 *
 * docs/scenario-format.md is the specification; this is its reader. Two
 * layouts are accepted and normalised into one dkf_scenario_t:
 *
 *  - canonical (the diffkf golden-vector layout): top-level `model`, `init`,
 *    `y`, optional `truth`, `k`, `N`;
 *  - cases (the infofusion golden-vector layout): `cases[c]` with `x0`, `P0`,
 *    `Q`, `C[j]`, `R[j]` and `steps[]` carrying `k`, `F`, `z[j]`.
 *
 * Numbers stay in double here, whatever the library's real type is;
 * dkf_scn_to_real converts at the point where the core is called.
 *
 * Every error is one line, "FILE: KEY.PATH: problem", written into the
 * caller's buffer (DKF_SCN_ERR_LEN bytes is always enough to hold it).
 * Time index k is absolute: the filters start from (x00, P00) at k = 0 and
 * step k = 1..steps predicts with F_{k-1}, Q_{k-1}, updates with H_k, R_k, y_k.
 */
#ifndef DKF_HOST_SCENARIO_H
#define DKF_HOST_SCENARIO_H

#include <stddef.h>

#include <jansson.h>

#include "dkf/mat.h"

#define DKF_SCN_ERR_LEN 1024

typedef enum {
    DKF_SCN_LAYOUT_CANONICAL = 0, /* model / init / y (diffkf vectors) */
    DKF_SCN_LAYOUT_CASES = 1      /* cases[].steps[] (infofusion vectors) */
} dkf_scn_layout_t;

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
} dkf_scn_mat_t;

/* A named set of matrices (model, one sensor, init). */
typedef struct {
    size_t len;
    dkf_scn_mat_t *items;
} dkf_scn_mats_t;

typedef struct {
    size_t m;            /* measurement dimension (rows of H) */
    dkf_scn_mats_t mats; /* this sensor's own matrices (H, R, A, B, Rd, ...) */
    size_t ny;           /* measurements y at absolute times yk[0..ny-1] */
    long *yk;            /* strictly increasing */
    double *y;           /* ny * m */
} dkf_scn_sensor_t;

typedef struct {
    char *file;               /* path as given to dkf_scenario_load */
    dkf_scn_layout_t layout;
    char *case_name;          /* cases layout: the selected case's name, else NULL */
    size_t case_index;
    size_t n;                 /* state dimension (rows of F) */
    size_t steps;             /* N: filters run k = 1..N */
    int multi;                /* 1: several-sensor layout (model.sensors or cases) */
    size_t nsensors;          /* 1 for a single-sensor scenario */
    dkf_scn_sensor_t *sensors;
    dkf_scn_mats_t model;     /* F, Q and (single sensor) H, R, A, B, Rd, ... */
    dkf_scn_mats_t init;      /* x00, P00, P00_local, P00_central, d00, Pd00, ... */
    size_t ntruth;            /* truth x at absolute times truth_k (0 if none) */
    long *truth_k;
    double *truth_x;          /* ntruth * n */
    json_t *root;             /* the parsed document (read-only), for keys not modelled */
} dkf_scenario_t;

/* Loads and validates a scenario. case_sel selects a case of the cases
 * layout by name or decimal index (NULL: case 0); it is an error for a
 * canonical file. Returns NULL and fills err on any problem. */
dkf_scenario_t *dkf_scenario_load(const char *path, const char *case_sel, char *err,
                                  size_t errlen);
void dkf_scenario_free(dkf_scenario_t *s);

/* Matrix `name` of the global model, of sensor i (falling back to the
 * global model, so a single-sensor file's H is every sensor's H), or of
 * `init`. NULL if absent. */
const dkf_scn_mat_t *dkf_scn_model(const dkf_scenario_t *s, const char *name);
const dkf_scn_mat_t *dkf_scn_sensor_model(const dkf_scenario_t *s, size_t i, const char *name);
const dkf_scn_mat_t *dkf_scn_init(const dkf_scenario_t *s, const char *name);

/* The matrix valid at absolute time k (per_k), the constant one, or entry k
 * of a list. NULL if k is outside a per_k / list range. */
const double *dkf_scn_at(const dkf_scn_mat_t *m, size_t k);

/* Initial covariance for the filter of sensor i alone (P00_local[i], else
 * P00) or for a filter using every sensor (P00_central, else P00). Never
 * NULL for a loaded scenario (the loader checks). */
const double *dkf_scn_P00_local(const dkf_scenario_t *s, size_t i);
const double *dkf_scn_P00_central(const dkf_scenario_t *s);

/* y_k of sensor i (m values), NULL if the sensor has no measurement at k. */
const double *dkf_scn_y(const dkf_scenario_t *s, size_t i, long k);
/* True state x_k (n values), NULL if absent. */
const double *dkf_scn_truth(const dkf_scenario_t *s, long k);

/* dst[0..n-1] = src converted to the library's real type. */
void dkf_scn_to_real(dkf_real_t *dst, const double *src, size_t n);

#endif /* DKF_HOST_SCENARIO_H */
