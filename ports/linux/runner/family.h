/*
 * family.h - what a host filter family implements: one const table of
 * operations per family (the style of LCM's provider vtables) with its
 * --filter rows, the options of its filters and, for a family whose
 * filter runs as one process per sensor, its node role. The registry
 * (families/registry.h) lists the families; dkf-run (one run or the
 * Monte-Carlo error mode that tools/dkf_mc.py uses), dkf-node (a
 * family's node role, below) and the network processes' scenario checks
 * reach a filter only through it:
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
 * Nothing here is any one family's: a family's options are its own
 * (dkf_run_optset_t), a node role's payload is the neutral
 * dkf_node_estimate_t. Adding a family on the host: docs/layout.md,
 * "Adding a filter family on the host".
 */
#ifndef DKF_HOST_FAMILY_H
#define DKF_HOST_FAMILY_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <jansson.h>

#include "dkf/config.h"
#include "output.h"
#include "scenario.h"
#include "util.h"

/* What a run was asked for (zeroed = the defaults). */
typedef struct {
    int record;       /* 1: emit each step's values through record() (an --output) */
    int errors;       /* 1: Monte-Carlo error mode (every run, squared errors only) */
    long run;         /* the run to process without errors (checked by check()) */
    const void *fam;  /* the family's own options (its optset's area); NULL: its defaults */
} dkf_run_opts_t;

/* One command-line option of a family's filters beyond dkf-run's own:
 * --name, with an argument or not. The filters that take it have `bit`
 * in dkf_filter_t.options; options that share a bit are named together
 * in messages ("--d00/--Pd00-scale: only for askf and otskf"). */
typedef struct {
    const char *name; /* "eta" for --eta */
    int has_arg;
    unsigned bit;     /* the family's own bit */
    const char *help; /* its dkf-run --help lines, from the option: "--eta N  tw3: ..." */
} dkf_run_opt_t;

/* A family's options: the table, and the area of `size` bytes they are
 * parsed into (dkf_run_opts_t.fam): init writes the defaults, parse one
 * option's argument (arg NULL for an option without one), DKF_EXIT_OK or
 * DKF_EXIT_USAGE with "--name ARG: problem" in err. */
typedef struct {
    const dkf_run_opt_t *opts;
    size_t nopts;
    size_t size;
    void (*init)(void *area);
    int (*parse)(void *area, const dkf_run_opt_t *opt, const char *arg, char *err,
                 size_t errlen);
} dkf_run_optset_t;

typedef struct dkf_runner dkf_runner_t; /* a family's running filter (its own struct) */
typedef struct dkf_family dkf_family_t;
typedef struct dkf_node_ops dkf_node_ops_t;

/* One --filter NAME. */
typedef struct {
    const char *name;   /* --filter NAME */
    const char *label;  /* outputs.<label> of a single-estimator run */
    const char *help;   /* dkf-run --help text */
    unsigned options;   /* the bits of its family's options it takes */
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
    /* The options its filters take beyond dkf-run's own (NULL: none). */
    const dkf_run_optset_t *options;
};

/* A family's create starts with this: calloc(1, size) of its runner, or
 * NULL with *rc = DKF_EXIT_USAGE and err "FILE: out of memory". */
void *dkf_runner_calloc(size_t size, const dkf_scenario_t *s, char *err, size_t errlen, int *rc);

/* ---- a family's sensor-node role ----------------------------------------------
 * What one networked sensor node computes: its local filter, fed its own
 * measurements one time at a time, whose estimate after every step goes to
 * a fusion centre (dkf_node_estimate_t; dkf-node sends it as the node
 * message, lcmtypes/node_msg_t.lcm). dkf-node (net/node.c) owns everything
 * else: the transport, measurement order and gaps, epochs, faults, status. */
typedef struct dkf_node_filter dkf_node_filter_t; /* the family's own struct */

/* A node's estimate after its step k: x_{k|k} and x_{k|k-1}, n values each
 * (entries n..DKF_MAX_DIM-1 zero). */
typedef struct {
    uint32_t k;
    uint16_t n;
    dkf_real_t xf[DKF_MAX_DIM]; /* x_{k|k} */
    dkf_real_t xp[DKF_MAX_DIM]; /* x_{k|k-1} */
} dkf_node_estimate_t;
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
    /* The estimate of the step just completed (after a successful step).
     * 0, or -1 (k out of range). */
    int (*payload)(const dkf_node_filter_t *nf, dkf_node_estimate_t *est);
    void (*destroy)(dkf_node_filter_t *nf);
    /* 0 (the Difference KF): step k completes with y_{k+1}, the start
     * completes no step. 1 (a Kalman filter, seed 002's local filters):
     * y_k completes step k itself; start(k0, y_{k0}) completes step k0
     * and step(k, y_k) step k, each followed by its message. */
    int same_step;
};

#endif /* DKF_HOST_FAMILY_H */
