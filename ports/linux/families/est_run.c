/*
 * est_run.c - the registry operations shared by the estimator families
 * (kf, info, dkf, askf, otskf: est_*.c, one dkf_est_kind_t each) over the
 * canonical and cases layouts.
 *
 * A single-sensor scenario gets one estimator written under
 * outputs.<label>; a several-sensor one gets outputs.local[i] (sensor i
 * alone), outputs.central (all sensors stacked) and, for a kind with a
 * fused mode, outputs.fused (information filter: contributions summed;
 * Difference KF: the fusion centre fed with the local filters' messages,
 * whose messages and fc_recovered sit beside it, as in the vector files).
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "est_family.h"
#include "registry.h"
#include "util.h"

/* ---- the options: --d00, --Pd00-scale (askf, otskf) ---- */

#define MAX_D00 64

typedef struct {
    int has_d00;
    size_t nd00;
    double d00[MAX_D00]; /* d_{0|0} instead of init.d00 */
    double Pd00_scale;   /* P_{d0|0} = scale * init.Pd00 (0: not given, means 1) */
} est_cli_t;

static const est_cli_t no_options;

static const est_cli_t *cli(const dkf_run_opts_t *o)
{
    return o->fam != NULL ? (const est_cli_t *)o->fam : &no_options;
}

static void cli_init(void *area)
{
    memset(area, 0, sizeof(est_cli_t));
}

/* "a,b,c" -> values; 0 on success. */
static int parse_list(const char *arg, double *out, size_t cap, size_t *count)
{
    const char *p = arg;
    size_t n = 0;
    for (;;) {
        char *end;
        double v;
        errno = 0;
        v = strtod(p, &end);
        if (end == p || errno != 0 || !isfinite(v) || n == cap) return -1;
        out[n++] = v;
        if (*end == '\0') break;
        if (*end != ',') return -1;
        p = end + 1;
    }
    *count = n;
    return 0;
}

static int cli_parse(void *area, const dkf_run_opt_t *opt, const char *arg, char *err,
                     size_t errlen)
{
    est_cli_t *c = area;
    char *end;
    if (strcmp(opt->name, "d00") == 0) {
        if (parse_list(arg, c->d00, MAX_D00, &c->nd00) != 0)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                             "--d00 %s: expected comma-separated finite numbers", arg);
        c->has_d00 = 1;
        return DKF_EXIT_OK;
    }
    errno = 0;
    c->Pd00_scale = strtod(arg, &end);
    if (end == arg || *end != '\0' || errno != 0 || !isfinite(c->Pd00_scale) ||
        c->Pd00_scale <= 0)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "--Pd00-scale %s: expected a finite number > 0", arg);
    return DKF_EXIT_OK;
}

static const dkf_run_opt_t est_opts[] = {
    {"d00", 1, DKF_EST_OPT_D00,
     "--d00 A,B,...    askf/otskf: d_{0|0} instead of init.d00 (p values)"},
    {"Pd00-scale", 1, DKF_EST_OPT_D00,
     "--Pd00-scale S   askf/otskf: P_{d0|0} = S * init.Pd00 (S > 0)"},
};

const dkf_run_optset_t dkf_est_run_options = {
    est_opts, sizeof est_opts / sizeof est_opts[0], sizeof(est_cli_t), cli_init, cli_parse,
};

/* ---- the runner ---- */
#include "status_text.h"

typedef struct {
    char name[32]; /* "KF", "local[1]", "central", "fused" */
    dkf_est_t *est;
} slot_t;

typedef struct {
    const dkf_filter_t *f;
    const dkf_scenario_t *s;
    slot_t *slots;
    size_t count;
} est_runner_t;

static est_runner_t *runner(dkf_runner_t *r)
{
    return (est_runner_t *)(void *)r;
}

static const est_runner_t *const_runner(const dkf_runner_t *r)
{
    return (const est_runner_t *)(const void *)r;
}

int dkf_est_run_check(const dkf_filter_t *f, const dkf_run_opts_t *o, const dkf_scenario_t *s,
                      char *err, size_t errlen)
{
    const dkf_est_kind_t *kind = (const dkf_est_kind_t *)f->impl;
    const est_cli_t *c = cli(o);
    char names[128];
    if (s->layout == DKF_SCN_LAYOUT_STEPS || s->layout == DKF_SCN_LAYOUT_NETWORK)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: steps: filter %s reads the canonical "
                         "or cases layout; this seed-%s file runs with %s", s->file, f->name,
                         s->layout == DKF_SCN_LAYOUT_NETWORK ? "003" : "004",
                         dkf_registry_names(names, sizeof names, NULL, (int)s->layout));
    if (s->layout == DKF_SCN_LAYOUT_NLCASES)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: cases[%zu]: filter %s is linear; "
                         "this case has a nonlinear model and runs with %s", s->file,
                         s->case_index, f->name,
                         dkf_registry_names(names, sizeof names, NULL, (int)s->layout));
    if (kind->input_prior && s->multi)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: model.sensors: filter %s supports "
                         "single-sensor scenarios only", s->file, f->name);
    if (kind->needs_ui &&
        dkf_scn_require_ui(s, kind->y_ahead ? s->steps : s->steps - 1,
                           kind->y_ahead ? s->steps + 1 : s->steps,
                           kind->input_prior && !c->has_d00, f->name, err, errlen) != 0)
        return DKF_EXIT_USAGE;
    if (kind->input_prior) {
        const dkf_scn_mat_t *D = dkf_scn_sensor_model(s, 0, "D");
        if (c->has_d00 && c->nd00 != D->cols)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: --d00: expected %zu values (the "
                             "columns of D), got %zu", s->file, D->cols, c->nd00);
        if (c->has_d00 && dkf_scn_init(s, "Pd00") == NULL)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: init.Pd00: missing key (filter "
                             "%s needs it)", s->file, f->name);
    }
    if (o->errors && dkf_scn_require_truth(s, err, errlen) != 0) return DKF_EXIT_USAGE;
    if (!o->errors && (size_t)o->run >= s->nruns)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: --run %ld: the file has %zu run%s "
                         "(0..%zu)", s->file, o->run, s->nruns, s->nruns == 1 ? "" : "s",
                         s->nruns - 1);
    return DKF_EXIT_OK;
}

void dkf_est_run_destroy(dkf_runner_t *r)
{
    est_runner_t *er = runner(r);
    size_t i;
    if (er == NULL) return;
    for (i = 0; er->slots != NULL && i < er->count; ++i) dkf_est_free(er->slots[i].est);
    free(er->slots);
    free(er);
}

/* Slot i: estimator `name` over sensors[0..count-1]. 0, or -1 with the
 * message in err. */
static int make_slot(est_runner_t *er, size_t i, const char *name, dkf_est_mode_t mode,
                     const size_t *sensors, size_t count, const double *P00,
                     const dkf_est_opts_t *opts, char *err, size_t errlen)
{
    char why[256];
    slot_t *sl = &er->slots[i];
    snprintf(sl->name, sizeof sl->name, "%s", name);
    sl->est = dkf_est_create((const dkf_est_kind_t *)er->f->impl, mode, er->s, sensors, count,
                             P00, opts, why, sizeof why);
    if (sl->est != NULL) return 0;
    snprintf(err, errlen, "%s: %s: %s", er->s->file, sl->name, why);
    return -1;
}

dkf_runner_t *dkf_est_run_create(const dkf_filter_t *f, const dkf_run_opts_t *o,
                                 const dkf_scenario_t *s, char *err, size_t errlen, int *rc)
{
    const dkf_est_kind_t *kind = (const dkf_est_kind_t *)f->impl;
    size_t n = s->multi ? s->nsensors + 1 + (size_t)kind->fused : 1, i;
    size_t *all = malloc(s->nsensors * sizeof *all);
    est_runner_t *er = calloc(1, sizeof *er);
    dkf_est_opts_t opts;
    char name[32];
    int bad = 0;
    if (er != NULL) er->slots = calloc(n, sizeof *er->slots);
    if (all == NULL || er == NULL || er->slots == NULL) {
        free(all);
        if (er != NULL) free(er->slots);
        free(er);
        *rc = dkf_failf(err, errlen, DKF_EXIT_USAGE, "out of memory");
        return NULL;
    }
    er->f = f;
    er->s = s;
    er->count = n;
    memset(&opts, 0, sizeof opts);
    opts.no_record = !o->record;
    opts.d00 = cli(o)->has_d00 ? cli(o)->d00 : NULL;
    opts.Pd00_scale = cli(o)->Pd00_scale;
    for (i = 0; i < s->nsensors; ++i) all[i] = i;
    if (!s->multi) {
        bad = make_slot(er, 0, f->label, DKF_EST_STACKED, all, 1, dkf_scn_P00_central(s), &opts,
                        err, errlen);
    } else {
        for (i = 0; i < s->nsensors && !bad; ++i) {
            snprintf(name, sizeof name, "local[%zu]", i);
            bad = make_slot(er, i, name, DKF_EST_STACKED, &all[i], 1, dkf_scn_P00_local(s, i),
                            &opts, err, errlen);
        }
        if (!bad)
            bad = make_slot(er, i, "central", DKF_EST_STACKED, all, s->nsensors,
                            dkf_scn_P00_central(s), &opts, err, errlen);
        if (!bad && kind->fused)
            bad = make_slot(er, i + 1, "fused", DKF_EST_FUSED, all, s->nsensors,
                            dkf_scn_P00_central(s), &opts, err, errlen);
    }
    free(all);
    if (bad) {
        dkf_est_run_destroy((dkf_runner_t *)(void *)er);
        *rc = DKF_EXIT_RUN;
        return NULL;
    }
    *rc = DKF_EXIT_OK;
    return (dkf_runner_t *)(void *)er;
}

/* Step k through every estimator; the first failure stops the run. */
int dkf_est_run_step(dkf_runner_t *r, long k, char *err, size_t errlen)
{
    est_runner_t *er = runner(r);
    const dkf_scenario_t *s = er->s;
    size_t i;
    for (i = 0; i < er->count; ++i) {
        const char *what = "?";
        char text[DKF_STATUS_TEXT_LEN];
        dkf_status_t st = dkf_est_step(er->slots[i].est, k, &what);
        if (st == DKF_OK) continue;
        dkf_host_status_text(text, sizeof text, what, st);
        if (s->has_runs)
            return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: run %zu: step k=%ld: %s: %s "
                             "failed: %s", s->file, s->run, k, er->slots[i].name, what, text);
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: step k=%ld: %s: %s failed: %s", s->file,
                         k, er->slots[i].name, what, text);
    }
    return DKF_EXIT_OK;
}

/* The step's values: the fused DKF's node messages and FC recoveries
 * beside `fused` (outputs.messages, outputs.fc_recovered), then every
 * estimator's under outputs.<its name>. */
void dkf_est_run_record(dkf_runner_t *r, dkf_out_t *out)
{
    static const char *const beside[] = {"messages", "fc_recovered"};
    const est_runner_t *er = const_runner(r);
    size_t i, j;
    for (i = 0; i < er->count; ++i)
        for (j = 0; j < 2; ++j) {
            json_t *v = json_object_get(dkf_est_series(er->slots[i].est), beside[j]), *one;
            if (v == NULL || (one = json_object()) == NULL) continue;
            json_object_set(one, beside[j], v);
            dkf_out_series(out, "outputs", one);
            json_decref(one);
        }
    for (i = 0; i < er->count; ++i)
        dkf_out_outputs(out, er->slots[i].name, dkf_est_series(er->slots[i].est));
}

int dkf_est_run_errors(const dkf_runner_t *r, size_t i, const char **name, const double **sq_f,
                       const double **sq_p)
{
    const est_runner_t *er = const_runner(r);
    if (i >= er->count) return 0;
    *name = er->slots[i].name;
    *sq_f = dkf_est_sqerr(er->slots[i].est, 0);
    *sq_p = dkf_est_sqerr(er->slots[i].est, 1);
    return 1;
}

void dkf_est_run_summary(const dkf_runner_t *r, FILE *out)
{
    const est_runner_t *er = const_runner(r);
    const dkf_scenario_t *s = er->s;
    size_t i, j;
    double *comp = calloc(s->n, sizeof *comp);
    fprintf(out, "scenario %s%s%s: %zu steps, %zu sensor%s, n = %zu; filter %s (%s)\n", s->file,
            s->case_name != NULL ? " case " : "", s->case_name != NULL ? s->case_name : "",
            s->steps, s->nsensors, s->nsensors == 1 ? "" : "s", s->n, er->f->name,
            DKF_USE_FLOAT ? "float" : "double");
    fprintf(out, "  %-10s %16s %14s  %s\n", "estimator", "trace P_{N|N}", "RMSE(xf)",
            "RMSE per component");
    for (i = 0; i < er->count; ++i) {
        double rmse;
        size_t nt = dkf_est_rmse(er->slots[i].est, &rmse, comp);
        fprintf(out, "  %-10s %16.9g ", er->slots[i].name, dkf_est_trace_P(er->slots[i].est));
        if (nt == 0 || comp == NULL) {
            fprintf(out, "%14s\n", "(no truth)");
            continue;
        }
        fprintf(out, "%14.6g  [", rmse);
        for (j = 0; j < s->n; ++j) fprintf(out, "%s%.4g", j ? " " : "", comp[j]);
        fprintf(out, "]\n");
    }
    free(comp);
}
