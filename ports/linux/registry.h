/*
 * registry.h - the host's filter families: one const table of operations
 * per family and one registry array listing them (the style of LCM's
 * provider vtables). dkf-run (one run or the Monte-Carlo error mode that
 * tools/dkf_mc.py uses), dkf-node (a family's node role, below) and the
 * network processes' scenario checks reach a filter only through it:
 *
 *   const dkf_filter_t *f = dkf_registry_find("askf");
 *   const dkf_family_t *fam = f->family;
 *   rc = fam->check(f, &o, s, err, len);             0 or DKF_EXIT_USAGE
 *   r = fam->create(f, &o, s, err, len, &rc);        NULL: rc, message
 *   for (k = s->k_first; k < s->k_first + (long)s->steps; ++k) {
 *       rc = fam->step(r, k, err, len);              0 or DKF_EXIT_RUN
 *       dkf_out_step(out, k);                        with an output (output.h)
 *       fam->record(r, out);                         step k's outputs.<...>
 *   }
 *   if (fam->record_end) fam->record_end(r, out);    the run's totals
 *   fam->summary(r, stdout);
 *   fam->destroy(r);
 *
 * Adding a family on the host is one file defining its dkf_family_t (and
 * its dkf_filter_t rows) plus one row in registry.c: docs/layout.md,
 * "Adding a filter family on the host".
 */
#ifndef DKF_HOST_REGISTRY_H
#define DKF_HOST_REGISTRY_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <jansson.h>

#include "dkf/diffkf_fusion.h" /* dkf_diffkf_msg_t: the node payload */
#include "output.h"
#include "scenario.h"
#include "util.h"

/* What a run was asked for (dkf-run's options; zeroed = the defaults, but
 * eta = -1 means "not given"). */
typedef struct {
    int record;            /* 1: keep each step's values for record() (an --output) */
    int errors;            /* 1: Monte-Carlo error mode (every run, squared errors only) */
    long run;              /* the run to process without errors (checked by check()) */
    int has_d00;           /* askf/otskf: d00 given */
    const double *d00;     /* d_{0|0} (nd00 values) instead of init.d00 */
    size_t nd00;
    double Pd00_scale;     /* P_{d0|0} = scale * init.Pd00 (0: not given, means 1) */
    long eta;              /* tw3: >= 0 overrides the file's eta; -1: the file's */
    int metrics_only;      /* tw1-3: record the metrics, not the per-node arrays */
} dkf_run_opts_t;

/* Options a filter takes beyond the common ones (dkf-run refuses the
 * others naming the filters that do take them). */
#define DKF_RUN_OPT_D00 1u     /* --d00, --Pd00-scale */
#define DKF_RUN_OPT_ETA 2u     /* --eta */
#define DKF_RUN_OPT_METRICS 4u /* --metrics-only */

typedef struct dkf_runner dkf_runner_t; /* a family's running filter (its own struct) */
typedef struct dkf_family dkf_family_t;
typedef struct dkf_node_ops dkf_node_ops_t;

/* One --filter NAME. */
typedef struct {
    const char *name;   /* --filter NAME */
    const char *label;  /* outputs.<label> of a single-estimator run */
    const char *help;   /* dkf-run --help text */
    unsigned options;   /* DKF_RUN_OPT_* */
    const dkf_family_t *family;
    const void *impl;   /* the family's own data for this filter (kind, algorithm) */
} dkf_filter_t;

/* A family: its filters and the operations every one of them runs with.
 * Every operation returns DKF_EXIT_OK or the exit status to give, with a
 * one-line "FILE: ..." message in err. */
struct dkf_family {
    const char *name;               /* "kf", "uif", "tw", ... */
    const dkf_filter_t *filters;    /* its --filter names, in --help order */
    size_t nfilters;
    unsigned layouts;               /* 1u << dkf_scn_layout_t of every layout it reads */
    /* What filter f needs of the options and of the scenario beyond the
     * reader's own checks (layout, keys, shapes, time coverage, run index).
     * DKF_EXIT_OK or DKF_EXIT_USAGE. */
    int (*check)(const dkf_filter_t *f, const dkf_run_opts_t *o, const dkf_scenario_t *s,
                 char *err, size_t errlen);
    /* f over s (which passed check) started from the file's initial
     * estimate, on the selected run. NULL with *rc = DKF_EXIT_RUN (a core
     * init failed) or DKF_EXIT_USAGE (out of memory). */
    dkf_runner_t *(*create)(const dkf_filter_t *f, const dkf_run_opts_t *o,
                            const dkf_scenario_t *s, char *err, size_t errlen, int *rc);
    /* Step k (k = s->k_first, k_first + 1, ... in order); with o->record the
     * step's values are kept as JSON until record(). DKF_EXIT_OK or
     * DKF_EXIT_RUN naming the step and the failing call. */
    int (*step)(dkf_runner_t *r, long k, char *err, size_t errlen);
    /* With o->record, after every step (dkf_out_step called): the step's
     * values to out (outputs.<...>, dkf_out_series), and forgotten, so
     * a runner holds one step's values whatever the number of steps. */
    void (*record)(dkf_runner_t *r, dkf_out_t *out);
    /* After the last step's record (NULL: nothing): the family's one-off
     * values (dkf_out_value; top-level keys of the document). */
    void (*record_end)(const dkf_runner_t *r, dkf_out_t *out);
    /* Monte-Carlo error mode (NULL: the family has none): estimator i's
     * name ("KF", "local[1]", "central", ...) and squared errors per step
     * ||x_{k|k} - x_k||^2 (sq_f) and ||x_{k|k-1} - x_k||^2 (sq_p); returns
     * 0 once i is past the last estimator. */
    int (*errors)(const dkf_runner_t *r, size_t i, const char **name, const double **sq_f,
                  const double **sq_p);
    /* The run's summary (errors against the truth, ...) on out. */
    void (*summary)(const dkf_runner_t *r, FILE *out);
    void (*destroy)(dkf_runner_t *r);
    /* The family's sensor-node role (dkf-node; NULL: it has none). */
    const dkf_node_ops_t *node;
};

/* ---- a family's sensor-node role ----------------------------------------------
 * What one networked sensor node computes: its local filter, fed its own
 * measurements one time at a time, whose estimate after every step goes to
 * a fusion centre as the node message's payload (x_{k|k}, x_{k|k-1};
 * lcmtypes/node_msg_t.lcm). dkf-node (net/node.c) owns everything else:
 * the transport, measurement order and gaps, epochs, faults, status. */
typedef struct dkf_node_filter dkf_node_filter_t; /* the family's own struct */
struct dkf_node_ops {
    /* Sensor id's local filter of f over s (s passed f's check and id <
     * s->nsensors); the prior is checked now, so a bad file fails at
     * start-up. NULL with a one-line "FILE: ..." err. */
    dkf_node_filter_t *(*create)(const dkf_filter_t *f, const dkf_scenario_t *s, size_t id,
                                 char *err, size_t errlen);
    /* (Re)starts the filter from the scenario's prior on y (sensor id's m
     * values) of time k0 >= 1, which completes no step (same_step: step k0). DKF_EXIT_OK or
     * DKF_EXIT_RUN with err naming the step and the failing call. */
    int (*start)(dkf_node_filter_t *nf, long k0, const double *y, char *err, size_t errlen);
    /* Completes step k (> the start's k0 - 1) with y_{k+1} (same_step: with
     * y_k, k > k0). As start. */
    int (*step)(dkf_node_filter_t *nf, long k, const double *y, char *err, size_t errlen);
    /* The payload of the step just completed (after a successful step):
     * msg->k, x_{k|k}, x_{k|k-1} of node id. 0, or -1 (k out of range). */
    int (*payload)(const dkf_node_filter_t *nf, uint16_t id, dkf_diffkf_msg_t *msg);
    void (*destroy)(dkf_node_filter_t *nf);
    /* 0 (the Difference KF): step k completes with y_{k+1}, the start
     * completes no step. 1 (a Kalman filter, seed 002's local filters):
     * y_k completes step k itself; start(k0, y_{k0}) completes step k0
     * and step(k, y_k) step k, each followed by its message. */
    int same_step;
};

/* The registry: every family, in --help order; NULL-terminated. */
extern const dkf_family_t *const dkf_registry[];

/* The filter called name, or NULL. */
const dkf_filter_t *dkf_registry_find(const char *name);

/* The names of the filters that take option bit opt / read layout, joined
 * as "a", "a and b" or "a, b, c" into out (cap bytes). Returns out. */
const char *dkf_registry_names(char *out, size_t cap, unsigned opt, int layout);

#endif /* DKF_HOST_REGISTRY_H */
