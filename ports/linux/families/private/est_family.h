/*
 * est_family.h - the registry families of the estimator kinds (private to
 * the families layer): est_run.c's operations, shared by every kind's
 * family (kf, info, dkf, askf, otskf: est_*.c, one dkf_est_kind_t each,
 * estimator.h), their options, and the macro that defines a family.
 */
#ifndef DKF_HOST_EST_FAMILY_H
#define DKF_HOST_EST_FAMILY_H

#include <stddef.h>
#include <stdio.h>

#include <jansson.h>

#include "estimator.h"
#include "family.h"

/* ---- the registry operations of every estimator family (est_run.c) ---- */
int dkf_est_run_check(const dkf_filter_t *f, const dkf_run_opts_t *o, const dkf_scenario_t *s,
                      char *err, size_t errlen);
dkf_runner_t *dkf_est_run_create(const dkf_filter_t *f, const dkf_run_opts_t *o,
                                 const dkf_scenario_t *s, char *err, size_t errlen, int *rc);
int dkf_est_run_step(dkf_runner_t *r, long k, char *err, size_t errlen);
void dkf_est_run_record(dkf_runner_t *r, dkf_out_t *out);
int dkf_est_run_errors(const dkf_runner_t *r, size_t i, const char **name, const double **sq_f,
                       const double **sq_p);
void dkf_est_run_summary(const dkf_runner_t *r, FILE *out);
void dkf_est_run_destroy(dkf_runner_t *r);

/* Their options (est_run.c): --d00 and --Pd00-scale, bit DKF_EST_OPT_D00. */
#define DKF_EST_OPT_D00 1u
extern const dkf_run_optset_t dkf_est_run_options;

/* Defines the registry family dkf_family_<fam> of the kind dkf_est_<fam>:
 * one filter (--filter <fam>, outputs.<label>, the --help text and the
 * DKF_EST_OPT_* options it takes), the canonical and cases layouts, the
 * operations above. */
#define DKF_EST_FAMILY(fam, label, options, node, help)                                     \
    extern const dkf_family_t dkf_family_##fam;                                             \
    static const dkf_filter_t fam##_filters[] = {                                           \
        {#fam, label, help, options, &dkf_family_##fam, &dkf_est_##fam}};                   \
    const dkf_family_t dkf_family_##fam = {                                                 \
        #fam, fam##_filters, 1,                                                             \
        (1u << DKF_SCN_LAYOUT_CANONICAL) | (1u << DKF_SCN_LAYOUT_CASES), dkf_est_run_check, \
        dkf_est_run_create, dkf_est_run_step, dkf_est_run_record, NULL, dkf_est_run_errors, \
        dkf_est_run_summary, dkf_est_run_destroy, node, &dkf_est_run_options}

#endif /* DKF_HOST_EST_FAMILY_H */
