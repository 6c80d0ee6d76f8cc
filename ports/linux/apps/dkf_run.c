/*
 * dkf-run - runs a dkf filter over a JSON scenario and writes its per-step
 * estimates in the golden-vector layout (docs/reference/scenario-format.md), or, over
 * every run of a Monte-Carlo scenario, only the squared estimation errors.
 *
 *   dkf-run --filter kf --output out.json scenarios/demo_cv2d.json
 *   dkf-run --filter kf --output out.csv --format csv --every 10 long.json
 *   dkf-run --filter askf --d00 0,0 --errors err.json mc.json
 *
 * Exit status: 0 success, 2 bad options or bad/unreadable/unwritable file,
 * 3 a filter call failed (the message names the step and the status).
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "output.h"
#include "registry.h"
#include "scenario.h"
#include "util.h"

/* The families' options (family.h, dkf_run_optset_t) as given: their
 * values are parsed by the selected filter's family. */
#define MAX_FAMILY_OPTS 32 /* distinct family options of the registry */
#define MAX_GIVEN 32       /* family options on one command line */

typedef struct {
    const char *name;
    const char *arg; /* NULL for a flag */
} given_t;

typedef struct {
    const char *filter;
    const char *output;
    dkf_out_format_t format; /* --format */
    unsigned long every;     /* --every, >= 1 */
    const char *errors;
    const char *case_sel;
    const char *scenario;
    long run;
    int quiet;
    size_t ngiven;
    given_t given[MAX_GIVEN];
} options_t;

/* 1 if no family before family i of the registry has option --name. */
static int first_with(size_t i, const char *name)
{
    size_t k;
    for (k = 0; k < i; ++k)
        if (dkf_registry_opt(dkf_registry[k], name) != NULL) return 0;
    return 1;
}

/* Every family's options, each name once, in registry order, into out
 * (the first MAX_FAMILY_OPTS; main refuses a registry with more); the
 * count. */
static size_t family_opts(const dkf_run_opt_t **out)
{
    size_t i, j, n = 0;
    for (i = 0; dkf_registry[i] != NULL; ++i) {
        const dkf_run_optset_t *set = dkf_registry[i]->options;
        for (j = 0; set != NULL && j < set->nopts; ++j)
            if (first_with(i, set->opts[j].name)) {
                if (n < MAX_FAMILY_OPTS) out[n] = &set->opts[j];
                ++n;
            }
    }
    return n;
}

static void usage(FILE *f, const char *prog)
{
    const dkf_run_opt_t *fo[MAX_FAMILY_OPTS];
    size_t i, j, nfo = family_opts(fo);
    fprintf(f,
            "usage: %s --filter NAME [--output OUT.json | --errors ERR.json] [options] "
            "SCENARIO.json\n"
            "\n"
            "Runs a dkf filter over a scenario file (docs/reference/scenario-format.md) and writes\n"
            "its per-step estimates laid out like the golden-vector files, so that\n"
            "tools/dkf_compare.py can check them key by key.\n"
            "\n"
            "options:\n"
            "  -f, --filter NAME    filter to run (required), one of:\n",
            prog);
    for (i = 0; dkf_registry[i] != NULL; ++i)
        for (j = 0; j < dkf_registry[i]->nfilters; ++j)
            fprintf(f, "                         %s: %s\n", dkf_registry[i]->filters[j].name,
                    dkf_registry[i]->filters[j].help);
    fprintf(f,
            "  -o, --output FILE    write the estimates to FILE, streamed as the steps run\n"
            "                       (memory does not grow with the steps); without it only\n"
            "                       the summary is printed\n"
            "      --format F       --output's format: json (default, below) or csv (a header\n"
            "                       line, then one line per step: k and every number of the\n"
            "                       step's outputs, columns named like outputs.KF.Pp[0][1];\n"
            "                       the document's one-off keys are JSON only)\n"
            "      --every N        --output keeps steps k_first, k_first + N, ... (N >= 1,\n"
            "                       default 1); the filter still runs every step\n"
            "  -e, --errors FILE    Monte-Carlo mode: run every run of the scenario (`runs`)\n"
            "                       and write only the squared errors ||x - x_true||^2 per\n"
            "                       run and step, of x_{k|k} (xf) and x_{k|k-1} (xp), and\n"
            "                       their means over the runs (needs truth x_1..x_N)\n"
            "  -r, --run R          without --errors: the run to process (default 0)\n"
            "  -c, --case SEL       cases layout (infofusion files): run case SEL, a name or\n"
            "                       a 0-based index (default 0)\n");
    for (i = 0; i < nfo; ++i) fprintf(f, "      %s\n", fo[i]->help);
    fprintf(f,
            "  -q, --quiet          do not print the summary\n"
            "  -h, --help           print this help and exit\n"
            "\n"
            "output: {\"k\": [1..N], \"outputs\": {...}}. One sensor: outputs.<LABEL> (KF, IF,\n"
            "DKF, ASKF, OTSKF) with xp Pp xf Pf (info also yp Yp yf Yf; dkf z dz J L K;\n"
            "askf Xp PXp Xf PXf; otskf xtp Pxp xtf Pxf dp Pdp df Pdf U V). Several\n"
            "sensors: outputs.local[i], outputs.central (stacked measurement, block-\n"
            "diagonal R, A, B, Rd) and, for info and dkf, outputs.fused (dkf: also\n"
            "outputs.messages, outputs.fc_recovered). Cases-layout scenarios use that\n"
            "file's names: x_pred P_pred Y_pred y_pred i I Y y x P.\n"
            "Steps-layout files (seed 004/003 vectors): outputs.RTSF / NRTSF_DF / NRTSF with\n"
            "the vectors' expected names (x_pred P_pred Rtilde d Pd x Px Pxd L K M rank proj,\n"
            "Pxd_extra for nrtsf) plus estimable, bias_risk, bias_steps; outputs.alg1 / alg2 /\n"
            "alg3 with x P z and the intermediates ([N][...] per node for alg2/3) plus the\n"
            "metrics mse_x mse_z nees spread_x gap_x gap_z gap_x_rel_max; \"k\" lists the\n"
            "steps' own times.\n"
            "Nonlinear cases (seed-001 files, models built in or written as expressions:\n"
            "docs/guide/nl-models.md): outputs.NERTSF / NERTSIF / DNERTSF / DNERTSIF / CF_DNERTSF\n"
            "with the files' expected names (x_pred P_pred z_hat nu R_tilde M x Px d Pd Pxd,\n"
            "...), outputs.DF_DNERTSIF / DF_CKF / DF_DNERTSIF_JOINT the same per node\n"
            "([steps][nodes]).\n"
            "errors: {\"k\": [1..N], \"runs\": R, \"errors\": {<LABEL> or local[i], central,\n"
            "fused: {\"xf\": [[e_1..e_N] per run], \"xp\": [...], \"mean_xf\": [...],\n"
            "\"mean_xp\": [...]}}}.\n"
            "\n"
            "exit status: 0 ok, 2 bad option or file (message names file and key),\n"
            "3 a filter call failed (message names the step and the status).\n");
}

/* " kf info ..." (every --filter name) on f. */
static void list_filters(FILE *f)
{
    size_t i, j;
    for (i = 0; dkf_registry[i] != NULL; ++i)
        for (j = 0; j < dkf_registry[i]->nfilters; ++j)
            fprintf(f, " %s", dkf_registry[i]->filters[j].name);
}

/* 0: run; 1: --help printed; -1: bad usage (message printed). */
static int parse_options(int argc, char **argv, options_t *o)
{
    enum { OPT_FORMAT = 256, OPT_EVERY, OPT_FAMILY };
    static const struct option common[] = {
        {"filter", required_argument, NULL, 'f'},
        {"output", required_argument, NULL, 'o'},
        {"format", required_argument, NULL, OPT_FORMAT},
        {"every", required_argument, NULL, OPT_EVERY},
        {"errors", required_argument, NULL, 'e'},
        {"run", required_argument, NULL, 'r'},
        {"case", required_argument, NULL, 'c'},
        {"quiet", no_argument, NULL, 'q'},
        {"help", no_argument, NULL, 'h'},
    };
    const size_t ncommon = sizeof common / sizeof common[0];
    struct option longopts[sizeof common / sizeof common[0] + MAX_FAMILY_OPTS + 1];
    const dkf_run_opt_t *fo[MAX_FAMILY_OPTS];
    size_t i, nfo = family_opts(fo);
    int c, out_opts = 0; /* --format, --every: only with --output */
    char *end;
    memset(o, 0, sizeof *o);
    o->format = DKF_OUT_JSON;
    o->every = 1;
    memset(longopts, 0, sizeof longopts);
    memcpy(longopts, common, sizeof common);
    for (i = 0; i < nfo; ++i) {
        longopts[ncommon + i].name = fo[i]->name;
        longopts[ncommon + i].has_arg = fo[i]->has_arg ? required_argument : no_argument;
        longopts[ncommon + i].val = OPT_FAMILY + (int)i;
    }
    opterr = 0; /* our own one-line messages instead of getopt's */
    while ((c = getopt_long(argc, argv, ":f:o:e:r:c:qh", longopts, NULL)) != -1) {
        switch (c) {
        case 'f': o->filter = optarg; break;
        case 'o': o->output = optarg; break;
        case 'e': o->errors = optarg; break;
        case 'c': o->case_sel = optarg; break;
        case 'q': o->quiet = 1; break;
        case 'r':
            errno = 0;
            o->run = strtol(optarg, &end, 10);
            if (end == optarg || *end != '\0' || errno != 0 || o->run < 0) {
                fprintf(stderr, "dkf-run: --run %s: expected a run index >= 0\n", optarg);
                return -1;
            }
            break;
        case OPT_FORMAT:
            if (strcmp(optarg, "json") != 0 && strcmp(optarg, "csv") != 0) {
                fprintf(stderr, "dkf-run: --format %s: expected json or csv\n", optarg);
                return -1;
            }
            o->format = strcmp(optarg, "csv") == 0 ? DKF_OUT_CSV : DKF_OUT_JSON;
            ++out_opts;
            break;
        case OPT_EVERY:
            errno = 0;
            o->every = strtoul(optarg, &end, 10);
            if (end == optarg || *end != '\0' || errno != 0 || o->every < 1 ||
                optarg[0] == '-' || o->every > DKF_SCN_MAX_STEPS) {
                fprintf(stderr, "dkf-run: --every %s: expected an integer 1..%lu\n", optarg,
                        DKF_SCN_MAX_STEPS);
                return -1;
            }
            ++out_opts;
            break;
        case 'h': usage(stdout, argv[0]); return 1;
        case ':':
            fprintf(stderr, "dkf-run: %s: option needs an argument (try --help)\n",
                    argv[optind - 1]);
            return -1;
        default:
            if (c >= OPT_FAMILY && (size_t)(c - OPT_FAMILY) < nfo) {
                if (o->ngiven == MAX_GIVEN) {
                    fprintf(stderr, "dkf-run: %s: more than %d filter options\n",
                            argv[optind - 1], MAX_GIVEN);
                    return -1;
                }
                o->given[o->ngiven].name = fo[c - OPT_FAMILY]->name;
                o->given[o->ngiven++].arg = optarg;
                break;
            }
            fprintf(stderr, "dkf-run: %s: unrecognized option (try --help)\n", argv[optind - 1]);
            return -1;
        }
    }
    if (o->filter == NULL) {
        fprintf(stderr, "dkf-run: --filter: missing (one of:");
        list_filters(stderr);
        fprintf(stderr, ")\n");
        return -1;
    }
    if (o->output != NULL && o->errors != NULL) {
        fprintf(stderr, "dkf-run: --output and --errors: give one of them\n");
        return -1;
    }
    if (out_opts > 0 && o->output == NULL) {
        fprintf(stderr, "dkf-run: --format and --every: only with --output\n");
        return -1;
    }
    if (optind != argc - 1) {
        fprintf(stderr, "dkf-run: expected exactly one SCENARIO.json argument, got %d\n",
                argc - optind);
        return -1;
    }
    o->scenario = argv[optind];
    return 0;
}

/* The options: which filters take the family options given, --errors
 * and --run; then the filter's own check of the options and the scenario;
 * 0 or an exit status. */
static int check_filter(const options_t *o, const dkf_filter_t *f, const dkf_run_opts_t *ro,
                        const dkf_scenario_t *s)
{
    char err[DKF_SCN_ERR_LEN], names[128], label[64];
    size_t i;
    int rc;
    for (i = 0; i < o->ngiven; ++i)
        if (!dkf_registry_takes(f, o->given[i].name)) {
            fprintf(stderr, "dkf-run: %s: %s: only for %s\n", s->file,
                    dkf_registry_opt_label(label, sizeof label, o->given[i].name),
                    dkf_registry_names(names, sizeof names, o->given[i].name, -1));
            return DKF_EXIT_USAGE;
        }
    if (f->family->errors == NULL && (o->errors != NULL || o->run != 0)) {
        fprintf(stderr, "dkf-run: %s: %s: not available for filter %s (steps-layout files "
                "have one run)\n", s->file, o->errors != NULL ? "--errors" : "--run", f->name);
        return DKF_EXIT_USAGE;
    }
    rc = f->family->check(f, ro, s, err, sizeof err);
    if (rc != DKF_EXIT_OK) fprintf(stderr, "dkf-run: %s\n", err);
    return rc;
}

/* The family options given into f's family's area (*area: NULL if it
 * takes none); those of other families are refused by check_filter. 0 or
 * an exit status, after the message. */
static int family_options(const options_t *o, const dkf_filter_t *f, void **area)
{
    char err[DKF_SCN_ERR_LEN];
    size_t i;
    int oom;
    *area = dkf_registry_opts_new(f, &oom);
    if (oom) {
        fprintf(stderr, "dkf-run: out of memory\n");
        return DKF_EXIT_USAGE;
    }
    for (i = 0; i < o->ngiven; ++i)
        if (dkf_registry_opt(f->family, o->given[i].name) != NULL &&
            dkf_registry_opt_set(f, *area, o->given[i].name, o->given[i].arg, err,
                                 sizeof err) != DKF_EXIT_OK) {
            fprintf(stderr, "dkf-run: %s\n", err);
            return DKF_EXIT_USAGE;
        }
    return DKF_EXIT_OK;
}

/* A runner of f on the selected run of s, stepped through every step,
 * each step's values to out (NULL: none); NULL after printing the error
 * (*rc: the exit status). */
static dkf_runner_t *run_filter(const dkf_filter_t *f, const dkf_run_opts_t *ro,
                                const dkf_scenario_t *s, dkf_out_t *out, int *rc)
{
    char err[DKF_SCN_ERR_LEN];
    dkf_runner_t *r = f->family->create(f, ro, s, err, sizeof err, rc);
    long k;
    for (k = s->k_first; r != NULL && *rc == DKF_EXIT_OK && k < s->k_first + (long)s->steps;
         ++k) {
        *rc = f->family->step(r, k, err, sizeof err);
        if (*rc != DKF_EXIT_OK || out == NULL) continue;
        dkf_out_step(out, k);
        f->family->record(r, out);
        if (dkf_out_failed(out)) return r; /* dkf_out_close reports it */
    }
    if (*rc == DKF_EXIT_OK) return r;
    fprintf(stderr, "dkf-run: %s\n", err);
    f->family->destroy(r);
    return NULL;
}

/* Every output document's first keys: scenario, case, filter, real. */
static json_t *doc_header(const options_t *o, const dkf_filter_t *f, const dkf_scenario_t *s)
{
    json_t *doc = json_object();
    json_object_set_new(doc, "scenario", json_string(o->scenario));
    if (s->case_name != NULL) json_object_set_new(doc, "case", json_string(s->case_name));
    json_object_set_new(doc, "filter", json_string(f->name));
    json_object_set_new(doc, "real", json_string(DKF_USE_FLOAT ? "float" : "double"));
    return doc;
}

static int write_doc(json_t *doc, const char *path)
{
    int rc = 0;
    errno = 0;
    if (doc == NULL || json_dump_file(doc, path, JSON_COMPACT | JSON_REAL_PRECISION(17)) != 0) {
        fprintf(stderr, "dkf-run: %s: cannot write the output: %s\n", path,
                errno != 0 ? strerror(errno) : "error");
        rc = DKF_EXIT_USAGE;
    }
    json_decref(doc);
    return rc;
}

/* ---- Monte-Carlo error mode ------------------------------------------------------ */

typedef struct {
    char name[32];
    double *sq[2]; /* [xf, xp]: nruns * N squared errors */
} errs_t;

/* mean_k sqrt(mean_r e) of an nruns x N table: the average tracking error. */
static double avg_tracking_error(const double *e, size_t nruns, size_t N)
{
    double tot = 0;
    size_t r, k;
    for (k = 0; k < N; ++k) {
        double m = 0;
        for (r = 0; r < nruns; ++r) m += e[r * N + k];
        tot += sqrt(m / (double)nruns);
    }
    return tot / (double)N;
}

static json_t *errors_json(const double *e, size_t nruns, size_t N, json_t **mean)
{
    json_t *runs = dkf_json_doubles(e, nruns, N);
    size_t r, k;
    *mean = json_array();
    for (k = 0; k < N; ++k) {
        double m = 0;
        for (r = 0; r < nruns; ++r) m += e[r * N + k];
        json_array_append_new(*mean, json_real(m / (double)nruns));
    }
    return runs;
}

/* The estimators of runner r (the first run sizes the table). 0 or -1. */
static int errs_alloc(const dkf_filter_t *f, const dkf_runner_t *r, size_t R, size_t N,
                      errs_t **out, size_t *count)
{
    const char *name;
    const double *sf, *sp;
    size_t n = 0, i;
    errs_t *errs;
    while (f->family->errors(r, n, &name, &sf, &sp)) ++n;
    if ((errs = calloc(n, sizeof *errs)) == NULL) return -1;
    *out = errs;
    *count = n;
    for (i = 0; i < n; ++i) {
        f->family->errors(r, i, &name, &sf, &sp);
        snprintf(errs[i].name, sizeof errs[i].name, "%s", name);
        errs[i].sq[0] = calloc(R * N, sizeof(double));
        errs[i].sq[1] = calloc(R * N, sizeof(double));
        if (errs[i].sq[0] == NULL || errs[i].sq[1] == NULL) return -1;
    }
    return 0;
}

static int write_errors(const options_t *o, const dkf_filter_t *f, const dkf_scenario_t *s,
                        const errs_t *errs, size_t count)
{
    const size_t N = s->steps, R = s->nruns;
    json_t *doc = doc_header(o, f, s), *outs = json_object(), *ks = json_array();
    size_t i;
    for (i = 0; i < N; ++i) json_array_append_new(ks, json_integer(s->k_first + (long)i));
    json_object_set_new(doc, "k", ks);
    for (i = 0; i < count; ++i) {
        json_t *mf, *mp;
        json_t *ef = errors_json(errs[i].sq[0], R, N, &mf);
        json_t *ep = errors_json(errs[i].sq[1], R, N, &mp);
        dkf_json_place(outs, errs[i].name,
                       json_pack("{s:o, s:o, s:o, s:o}", "xf", ef, "xp", ep, "mean_xf", mf,
                                 "mean_xp", mp));
    }
    json_object_set_new(doc, "runs", json_integer((json_int_t)R));
    json_object_set_new(doc, "definition",
                        json_string("errors.<est>.xf[r][k-1] = ||x_{k|k} - x_k||^2 "
                                    "in run r; xp: x_{k|k-1}; mean_*: mean over runs"));
    json_object_set_new(doc, "errors", outs);
    return write_doc(doc, o->errors);
}

/* Every run of s through the filter, keeping only the squared errors. */
static int run_errors(const options_t *o, const dkf_filter_t *f, const dkf_run_opts_t *ro,
                      dkf_scenario_t *s)
{
    const size_t N = s->steps, R = s->nruns;
    size_t count = 0, r, i, w;
    errs_t *errs = NULL;
    int rc = 0;
    for (r = 0; r < R && rc == 0; ++r) {
        dkf_runner_t *run;
        dkf_scn_select_run(s, r);
        if ((run = run_filter(f, ro, s, NULL, &rc)) == NULL) break;
        if (errs == NULL && errs_alloc(f, run, R, N, &errs, &count) != 0) {
            fprintf(stderr, "dkf-run: out of memory\n");
            rc = DKF_EXIT_USAGE;
        }
        for (i = 0; rc == 0 && i < count; ++i) {
            const char *name;
            const double *sq[2];
            f->family->errors(run, i, &name, &sq[0], &sq[1]);
            for (w = 0; w < 2; ++w) memcpy(errs[i].sq[w] + r * N, sq[w], N * sizeof(double));
        }
        f->family->destroy(run);
    }
    dkf_scn_select_run(s, 0);
    if (rc == 0) rc = write_errors(o, f, s, errs, count);
    if (rc == 0 && !o->quiet) {
        printf("scenario %s: %zu runs x %zu steps, filter %s (%s)\n", s->file, R, N, f->name,
               DKF_USE_FLOAT ? "float" : "double");
        printf("  average tracking error mean_k sqrt(mean_runs ||e_k||^2):\n");
        printf("  %-10s %14s %14s\n", "estimator", "x_{k|k}", "x_{k|k-1}");
        for (i = 0; i < count; ++i)
            printf("  %-10s %14.6f %14.6f\n", errs[i].name, avg_tracking_error(errs[i].sq[0], R, N),
                   avg_tracking_error(errs[i].sq[1], R, N));
    }
    for (i = 0; errs != NULL && i < count; ++i) {
        free(errs[i].sq[0]);
        free(errs[i].sq[1]);
    }
    free(errs);
    return rc;
}

/* ---- one run ------------------------------------------------------------------- */

/* The document's header (dkf_out_step adds "k" at the first step). */
static void out_header(dkf_out_t *out, const options_t *o, const dkf_filter_t *f,
                       const dkf_scenario_t *s)
{
    json_t *doc = doc_header(o, f, s), *v;
    const char *key;
    json_object_foreach(doc, key, v) dkf_out_value(out, key, json_incref(v));
    json_decref(doc);
}

static int run_one(const options_t *o, const dkf_filter_t *f, const dkf_run_opts_t *ro,
                   dkf_scenario_t *s)
{
    char err[DKF_SCN_ERR_LEN];
    dkf_out_t *out = NULL;
    dkf_runner_t *r;
    int rc;
    dkf_scn_select_run(s, (size_t)o->run);
    if (o->output != NULL) {
        out = dkf_out_open(o->output, o->format, o->every, s->k_first, err, sizeof err);
        if (out == NULL) {
            fprintf(stderr, "dkf-run: %s\n", err);
            return DKF_EXIT_USAGE;
        }
        out_header(out, o, f, s);
    }
    r = run_filter(f, ro, s, out, &rc);
    if (r != NULL && out != NULL && !dkf_out_failed(out) && f->family->record_end != NULL)
        f->family->record_end(r, out);
    if (out != NULL && dkf_out_close(out, r != NULL, err, sizeof err) != DKF_EXIT_OK) {
        fprintf(stderr, "dkf-run: %s\n", err);
        rc = DKF_EXIT_USAGE;
    }
    if (rc == 0 && r != NULL && !o->quiet) f->family->summary(r, stdout);
    if (r != NULL) f->family->destroy(r);
    return rc;
}

int main(int argc, char **argv)
{
    options_t o;
    const dkf_filter_t *f;
    dkf_scenario_t *s;
    dkf_run_opts_t ro;
    void *area = NULL;
    const dkf_run_opt_t *fo[MAX_FAMILY_OPTS];
    char err[DKF_SCN_ERR_LEN];
    int rc;

    if (family_opts(fo) > MAX_FAMILY_OPTS) {
        fprintf(stderr, "dkf-run: the registry's families have more than %d options\n",
                MAX_FAMILY_OPTS);
        return DKF_EXIT_USAGE;
    }
    rc = parse_options(argc, argv, &o);
    if (rc != 0) return rc > 0 ? 0 : DKF_EXIT_USAGE;
    f = dkf_registry_find(o.filter);
    if (f == NULL) {
        fprintf(stderr, "dkf-run: %s: --filter %s: unknown filter (one of:", o.scenario,
                o.filter);
        list_filters(stderr);
        fprintf(stderr, ")\n");
        return DKF_EXIT_USAGE;
    }
    if ((rc = family_options(&o, f, &area)) != DKF_EXIT_OK) {
        free(area);
        return rc;
    }
    s = dkf_scenario_load(o.scenario, o.case_sel, err, sizeof err);
    if (s == NULL) {
        fprintf(stderr, "dkf-run: %s\n", err);
        free(area);
        return DKF_EXIT_USAGE;
    }
    memset(&ro, 0, sizeof ro);
    ro.record = o.output != NULL;
    ro.errors = o.errors != NULL;
    ro.run = o.run;
    ro.fam = area;
    rc = check_filter(&o, f, &ro, s);
    if (rc == 0) rc = o.errors != NULL ? run_errors(&o, f, &ro, s) : run_one(&o, f, &ro, s);
    dkf_scenario_free(s);
    free(area);
    return rc;
}
