/*
 * dkf-run - runs a dkf filter over a JSON scenario and writes its per-step
 * estimates in the golden-vector layout (docs/reference/scenario-format.md), or, over
 * every run of a Monte-Carlo scenario, only the squared estimation errors.
 *
 *   dkf-run --filter kf --output out.json scenarios/demo_cv2d.json
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

#include "dkf/tw.h"
#include "registry.h"
#include "scenario.h"
#include "util.h"

#define MAX_D00 64

typedef struct {
    const char *filter;
    const char *output;
    const char *errors;
    const char *case_sel;
    const char *scenario;
    long run;
    int quiet;
    int has_d00;
    long eta;         /* --eta, -1 if not given */
    int metrics_only; /* --metrics-only */
    size_t nd00;
    double d00[MAX_D00];
    double Pd00_scale;
} options_t;

static void usage(FILE *f, const char *prog)
{
    size_t i, j;
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
            "  -o, --output FILE    write the estimates to FILE (JSON); without it only the\n"
            "                       summary is printed\n"
            "  -e, --errors FILE    Monte-Carlo mode: run every run of the scenario (`runs`)\n"
            "                       and write only the squared errors ||x - x_true||^2 per\n"
            "                       run and step, of x_{k|k} (xf) and x_{k|k-1} (xp), and\n"
            "                       their means over the runs (needs truth x_1..x_N)\n"
            "  -r, --run R          without --errors: the run to process (default 0)\n"
            "  -c, --case SEL       cases layout (infofusion files): run case SEL, a name or\n"
            "                       a 0-based index (default 0)\n"
            "      --d00 A,B,...    askf/otskf: d_{0|0} instead of init.d00 (p values)\n"
            "      --Pd00-scale S   askf/otskf: P_{d0|0} = S * init.Pd00 (S > 0)\n"
            "      --eta N          tw3: consensus iterations per ACF (overrides the file's eta)\n"
            "      --metrics-only   tw1-3: record only the per-step metrics (errors against the\n"
            "                       truth, gap to Algorithm 1), not the per-node arrays\n"
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

/* 0: run; 1: --help printed; -1: bad usage (message printed). */
static int parse_options(int argc, char **argv, options_t *o)
{
    enum { OPT_D00 = 256, OPT_PD00_SCALE, OPT_ETA, OPT_METRICS_ONLY };
    static const struct option longopts[] = {
        {"filter", required_argument, NULL, 'f'},
        {"output", required_argument, NULL, 'o'},
        {"errors", required_argument, NULL, 'e'},
        {"run", required_argument, NULL, 'r'},
        {"case", required_argument, NULL, 'c'},
        {"d00", required_argument, NULL, OPT_D00},
        {"Pd00-scale", required_argument, NULL, OPT_PD00_SCALE},
        {"eta", required_argument, NULL, OPT_ETA},
        {"metrics-only", no_argument, NULL, OPT_METRICS_ONLY},
        {"quiet", no_argument, NULL, 'q'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    int c;
    char *end;
    memset(o, 0, sizeof *o);
    o->eta = -1;
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
        case OPT_D00:
            if (parse_list(optarg, o->d00, MAX_D00, &o->nd00) != 0) {
                fprintf(stderr, "dkf-run: --d00 %s: expected comma-separated finite numbers\n",
                        optarg);
                return -1;
            }
            o->has_d00 = 1;
            break;
        case OPT_PD00_SCALE:
            errno = 0;
            o->Pd00_scale = strtod(optarg, &end);
            if (end == optarg || *end != '\0' || errno != 0 || !isfinite(o->Pd00_scale) ||
                o->Pd00_scale <= 0) {
                fprintf(stderr, "dkf-run: --Pd00-scale %s: expected a finite number > 0\n",
                        optarg);
                return -1;
            }
            break;
        case OPT_ETA:
            errno = 0;
            o->eta = strtol(optarg, &end, 10);
            if (end == optarg || *end != '\0' || errno != 0 || o->eta < 0 ||
                (unsigned long)o->eta > DKF_TW_MAX_ETA) {
                fprintf(stderr, "dkf-run: --eta %s: expected an integer >= 0 (at most %u)\n",
                        optarg, DKF_TW_MAX_ETA);
                return -1;
            }
            break;
        case OPT_METRICS_ONLY: o->metrics_only = 1; break;
        case 'h': usage(stdout, argv[0]); return 1;
        case ':':
            fprintf(stderr, "dkf-run: %s: option needs an argument (try --help)\n",
                    argv[optind - 1]);
            return -1;
        default:
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
    if (optind != argc - 1) {
        fprintf(stderr, "dkf-run: expected exactly one SCENARIO.json argument, got %d\n",
                argc - optind);
        return -1;
    }
    o->scenario = argv[optind];
    return 0;
}

/* The options every family shares the rules of (which filters take
 * --eta, --metrics-only, --errors and --run), then the filter's own check
 * of the options and the scenario; 0 or an exit status. */
static int check_filter(const options_t *o, const dkf_filter_t *f, const dkf_run_opts_t *ro,
                        const dkf_scenario_t *s)
{
    char err[DKF_SCN_ERR_LEN], names[128];
    int rc;
    if (o->eta >= 0 && !(f->options & DKF_RUN_OPT_ETA)) {
        fprintf(stderr, "dkf-run: %s: --eta: only for %s\n", s->file,
                dkf_registry_names(names, sizeof names, DKF_RUN_OPT_ETA, -1));
        return DKF_EXIT_USAGE;
    }
    if (o->metrics_only && !(f->options & DKF_RUN_OPT_METRICS)) {
        fprintf(stderr, "dkf-run: %s: --metrics-only: only for %s\n", s->file,
                dkf_registry_names(names, sizeof names, DKF_RUN_OPT_METRICS, -1));
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

/* A runner of f on the selected run of s, stepped through every step;
 * NULL after printing the error (*rc: the exit status). */
static dkf_runner_t *run_filter(const dkf_filter_t *f, const dkf_run_opts_t *ro,
                                const dkf_scenario_t *s, int *rc)
{
    char err[DKF_SCN_ERR_LEN];
    dkf_runner_t *r = f->family->create(f, ro, s, err, sizeof err, rc);
    long k;
    for (k = s->k_first; r != NULL && *rc == DKF_EXIT_OK && k < s->k_first + (long)s->steps; ++k)
        *rc = f->family->step(r, k, err, sizeof err);
    if (*rc == DKF_EXIT_OK) return r;
    fprintf(stderr, "dkf-run: %s\n", err);
    f->family->destroy(r);
    return NULL;
}

static json_t *doc_header(const options_t *o, const dkf_filter_t *f, const dkf_scenario_t *s)
{
    json_t *doc = json_object(), *ks = json_array();
    long k;
    for (k = s->k_first; k < s->k_first + (long)s->steps; ++k)
        json_array_append_new(ks, json_integer(k));
    json_object_set_new(doc, "scenario", json_string(o->scenario));
    if (s->case_name != NULL) json_object_set_new(doc, "case", json_string(s->case_name));
    json_object_set_new(doc, "filter", json_string(f->name));
    json_object_set_new(doc, "real", json_string(DKF_USE_FLOAT ? "float" : "double"));
    json_object_set_new(doc, "k", ks);
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
    json_t *doc = doc_header(o, f, s), *outs = json_object();
    size_t i;
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
        if ((run = run_filter(f, ro, s, &rc)) == NULL) break;
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

static int run_one(const options_t *o, const dkf_filter_t *f, const dkf_run_opts_t *ro,
                   dkf_scenario_t *s)
{
    dkf_runner_t *r;
    int rc;
    dkf_scn_select_run(s, (size_t)o->run);
    if ((r = run_filter(f, ro, s, &rc)) == NULL) return rc;
    if (o->output != NULL) {
        json_t *doc = doc_header(o, f, s);
        f->family->record(r, doc);
        rc = write_doc(doc, o->output);
    }
    if (rc == 0 && !o->quiet) f->family->summary(r, stdout);
    f->family->destroy(r);
    return rc;
}

int main(int argc, char **argv)
{
    options_t o;
    const dkf_filter_t *f;
    dkf_scenario_t *s;
    dkf_run_opts_t ro;
    char err[DKF_SCN_ERR_LEN];
    int rc = parse_options(argc, argv, &o);

    if (rc != 0) return rc > 0 ? 0 : DKF_EXIT_USAGE;
    f = dkf_registry_find(o.filter);
    if (f == NULL) {
        fprintf(stderr, "dkf-run: %s: --filter %s: unknown filter (one of:", o.scenario,
                o.filter);
        list_filters(stderr);
        fprintf(stderr, ")\n");
        return DKF_EXIT_USAGE;
    }
    s = dkf_scenario_load(o.scenario, o.case_sel, err, sizeof err);
    if (s == NULL) {
        fprintf(stderr, "dkf-run: %s\n", err);
        return DKF_EXIT_USAGE;
    }
    memset(&ro, 0, sizeof ro);
    ro.record = o.output != NULL;
    ro.errors = o.errors != NULL;
    ro.run = o.run;
    ro.has_d00 = o.has_d00;
    ro.d00 = o.d00;
    ro.nd00 = o.nd00;
    ro.Pd00_scale = o.Pd00_scale;
    ro.eta = o.eta;
    ro.metrics_only = o.metrics_only;
    rc = check_filter(&o, f, &ro, s);
    if (rc == 0) rc = o.errors != NULL ? run_errors(&o, f, &ro, s) : run_one(&o, f, &ro, s);
    dkf_scenario_free(s);
    return rc;
}
