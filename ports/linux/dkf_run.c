/*
 * dkf-run - runs a dkf filter over a JSON scenario and writes its per-step
 * estimates in the golden-vector layout (docs/scenario-format.md).
 *
 *   dkf-run --filter kf --output out.json scenarios/demo_cv2d.json
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

#include "estimator.h"
#include "scenario.h"

#define EXIT_BAD_INPUT 2
#define EXIT_FILTER 3

/* One row per filter. A single-sensor scenario gets one estimator written
 * under outputs.<label>; a multi-sensor one gets outputs.local[i] (sensor i
 * alone), outputs.central (all sensors stacked) and, when `fused`,
 * outputs.fused (per-sensor information contributions summed). */
typedef struct {
    const char *name;
    const char *label;
    dkf_est_kind_t kind;
    int fused;
    const char *help;
} filter_t;

static const filter_t filters[] = {
    {"kf", "KF", DKF_EST_KF, 0,
     "Kalman filter (dkf/kf.h) on F, Q, H, R;\n"
     "                           unknown-input terms (A, B, Rd, ...) are ignored"},
    {"info", "IF", DKF_EST_INFO, 1,
     "information filter (dkf/info.h); with several\n"
     "                           sensors it also writes `fused`"},
};
#define NFILTERS (sizeof filters / sizeof filters[0])

typedef struct {
    const char *filter;
    const char *output;
    const char *case_sel;
    const char *scenario;
    int quiet;
} options_t;

typedef struct {
    char name[32];        /* "KF", "local[1]", "central", "fused" */
    dkf_est_t *est;
} slot_t;

static void usage(FILE *f, const char *prog)
{
    size_t i;
    fprintf(f,
            "usage: %s --filter NAME [--output OUT.json] [--case NAME|INDEX] [--quiet] "
            "SCENARIO.json\n"
            "\n"
            "Runs a dkf filter over a scenario file (docs/scenario-format.md) and writes\n"
            "its per-step estimates laid out like the golden-vector files, so that\n"
            "tools/dkf_compare.py can check them key by key.\n"
            "\n"
            "options:\n"
            "  -f, --filter NAME    filter to run (required), one of:\n",
            prog);
    for (i = 0; i < NFILTERS; ++i)
        fprintf(f, "                         %s: %s\n", filters[i].name, filters[i].help);
    fprintf(f,
            "  -o, --output FILE    write the estimates to FILE (JSON); without it only the\n"
            "                       summary is printed\n"
            "  -c, --case SEL       cases layout (infofusion files): run case SEL, a name or\n"
            "                       a 0-based index (default 0)\n"
            "  -q, --quiet          do not print the summary\n"
            "  -h, --help           print this help and exit\n"
            "\n"
            "output: {\"k\": [1..N], \"outputs\": {...}}. One sensor: outputs.<LABEL> (KF, IF)\n"
            "with xp Pp xf Pf (info also yp Yp yf Yf). Several sensors: outputs.local[i],\n"
            "outputs.central (stacked measurement, block-diagonal R) and, for info,\n"
            "outputs.fused (with per-sensor contributions i, I). Cases-layout scenarios use\n"
            "that file's names: x_pred P_pred Y_pred y_pred i I Y y x P.\n"
            "\n"
            "exit status: 0 ok, 2 bad option or file (message names file and key),\n"
            "3 a filter call failed (message names the step and the status).\n");
}

static const filter_t *find_filter(const char *name)
{
    size_t i;
    for (i = 0; i < NFILTERS; ++i)
        if (strcmp(filters[i].name, name) == 0) return &filters[i];
    return NULL;
}

/* 0: run; 1: --help printed; -1: bad usage (message printed). */
static int parse_options(int argc, char **argv, options_t *o)
{
    static const struct option longopts[] = {
        {"filter", required_argument, NULL, 'f'},
        {"output", required_argument, NULL, 'o'},
        {"case", required_argument, NULL, 'c'},
        {"quiet", no_argument, NULL, 'q'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    int c;
    memset(o, 0, sizeof *o);
    opterr = 0; /* our own one-line messages instead of getopt's */
    while ((c = getopt_long(argc, argv, ":f:o:c:qh", longopts, NULL)) != -1) {
        switch (c) {
        case 'f': o->filter = optarg; break;
        case 'o': o->output = optarg; break;
        case 'c': o->case_sel = optarg; break;
        case 'q': o->quiet = 1; break;
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
        for (c = 0; c < (int)NFILTERS; ++c) fprintf(stderr, " %s", filters[c].name);
        fprintf(stderr, ")\n");
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

/* The estimators a filter runs on a scenario (see filter_t). */
static int make_slots(const filter_t *f, const dkf_scenario_t *s, slot_t **out, size_t *count)
{
    size_t n = s->multi ? s->nsensors + 1 + (size_t)f->fused : 1, i;
    size_t *all = malloc(s->nsensors * sizeof *all);
    slot_t *slots = calloc(n, sizeof *slots);
    char err[256];
    int rc = 0;
    if (all == NULL || slots == NULL) {
        fprintf(stderr, "dkf-run: out of memory\n");
        free(all);
        free(slots);
        return EXIT_BAD_INPUT;
    }
    for (i = 0; i < s->nsensors; ++i) all[i] = i;
    if (!s->multi) {
        snprintf(slots[0].name, sizeof slots[0].name, "%s", f->label);
        slots[0].est = dkf_est_create(f->kind, DKF_EST_STACKED, s, all, 1,
                                      dkf_scn_P00_central(s), err, sizeof err);
    } else {
        for (i = 0; i < s->nsensors && rc == 0; ++i) {
            snprintf(slots[i].name, sizeof slots[i].name, "local[%zu]", i);
            slots[i].est = dkf_est_create(f->kind, DKF_EST_STACKED, s, &all[i], 1,
                                          dkf_scn_P00_local(s, i), err, sizeof err);
            if (slots[i].est == NULL) rc = 1;
        }
        if (rc == 0) {
            snprintf(slots[i].name, sizeof slots[i].name, "central");
            slots[i].est = dkf_est_create(f->kind, DKF_EST_STACKED, s, all, s->nsensors,
                                          dkf_scn_P00_central(s), err, sizeof err);
            if (slots[i].est == NULL) rc = 1;
        }
        if (rc == 0 && f->fused) {
            ++i;
            snprintf(slots[i].name, sizeof slots[i].name, "fused");
            slots[i].est = dkf_est_create(f->kind, DKF_EST_FUSED, s, all, s->nsensors,
                                          dkf_scn_P00_central(s), err, sizeof err);
        }
    }
    free(all);
    for (i = 0; i < n; ++i)
        if (slots[i].est == NULL) {
            fprintf(stderr, "dkf-run: %s: %s: %s\n", s->file, slots[i].name, err);
            for (i = 0; i < n; ++i) dkf_est_free(slots[i].est);
            free(slots);
            return EXIT_FILTER;
        }
    *out = slots;
    *count = n;
    return 0;
}

/* Steps k = 1..N through every estimator; the first failure stops the run. */
static int run_steps(const dkf_scenario_t *s, slot_t *slots, size_t count)
{
    long k;
    size_t i;
    for (k = 1; k <= (long)s->steps; ++k)
        for (i = 0; i < count; ++i) {
            const char *what = "?";
            dkf_status_t st = dkf_est_step(slots[i].est, k, &what);
            if (st != DKF_OK) {
                fprintf(stderr, "dkf-run: %s: step k=%ld: %s: %s failed: %s (%d)\n", s->file, k,
                        slots[i].name, what, dkf_status_str(st), (int)st);
                return EXIT_FILTER;
            }
        }
    return 0;
}

static json_t *output_document(const options_t *o, const filter_t *f, const dkf_scenario_t *s,
                               const slot_t *slots, size_t count)
{
    json_t *doc = json_object(), *outs = json_object(), *ks = json_array();
    size_t i;
    long k;
    for (k = 1; k <= (long)s->steps; ++k) json_array_append_new(ks, json_integer(k));
    json_object_set_new(doc, "scenario", json_string(o->scenario));
    if (s->case_name != NULL) json_object_set_new(doc, "case", json_string(s->case_name));
    json_object_set_new(doc, "filter", json_string(f->name));
    json_object_set_new(doc, "real", json_string(DKF_USE_FLOAT ? "float" : "double"));
    json_object_set_new(doc, "k", ks);
    if (!s->multi) {
        json_object_set(outs, f->label, dkf_est_series(slots[0].est));
    } else {
        json_t *local = json_array();
        for (i = 0; i < s->nsensors; ++i)
            json_array_append(local, dkf_est_series(slots[i].est));
        json_object_set_new(outs, "local", local);
        for (; i < count; ++i) json_object_set(outs, slots[i].name, dkf_est_series(slots[i].est));
    }
    json_object_set_new(doc, "outputs", outs);
    return doc;
}

static void print_summary(const filter_t *f, const dkf_scenario_t *s, const slot_t *slots,
                          size_t count)
{
    size_t i, j;
    double *comp = calloc(s->n, sizeof *comp);
    printf("scenario %s%s%s: %zu steps, %zu sensor%s, n = %zu; filter %s (%s)\n", s->file,
           s->case_name != NULL ? " case " : "", s->case_name != NULL ? s->case_name : "",
           s->steps, s->nsensors, s->nsensors == 1 ? "" : "s", s->n, f->name,
           DKF_USE_FLOAT ? "float" : "double");
    printf("  %-10s %16s %14s  %s\n", "estimator", "trace P_{N|N}", "RMSE(xf)",
           "RMSE per component");
    for (i = 0; i < count; ++i) {
        double rmse;
        size_t nt = dkf_est_rmse(slots[i].est, &rmse, comp);
        printf("  %-10s %16.9g ", slots[i].name, dkf_est_trace_P(slots[i].est));
        if (nt == 0 || comp == NULL) {
            printf("%14s\n", "(no truth)");
            continue;
        }
        printf("%14.6g  [", rmse);
        for (j = 0; j < s->n; ++j) printf("%s%.4g", j ? " " : "", comp[j]);
        printf("]\n");
    }
    free(comp);
}

int main(int argc, char **argv)
{
    options_t o;
    const filter_t *f;
    dkf_scenario_t *s;
    slot_t *slots = NULL;
    size_t count = 0, i;
    char err[DKF_SCN_ERR_LEN];
    int rc = parse_options(argc, argv, &o);

    if (rc != 0) return rc > 0 ? 0 : EXIT_BAD_INPUT;
    f = find_filter(o.filter);
    if (f == NULL) {
        fprintf(stderr, "dkf-run: %s: --filter %s: unknown filter (one of:", o.scenario,
                o.filter);
        for (i = 0; i < NFILTERS; ++i) fprintf(stderr, " %s", filters[i].name);
        fprintf(stderr, ")\n");
        return EXIT_BAD_INPUT;
    }
    s = dkf_scenario_load(o.scenario, o.case_sel, err, sizeof err);
    if (s == NULL) {
        fprintf(stderr, "dkf-run: %s\n", err);
        return EXIT_BAD_INPUT;
    }
    rc = make_slots(f, s, &slots, &count);
    if (rc == 0) rc = run_steps(s, slots, count);
    if (rc == 0 && o.output != NULL) {
        json_t *doc = output_document(&o, f, s, slots, count);
        errno = 0;
        if (json_dump_file(doc, o.output, JSON_COMPACT | JSON_REAL_PRECISION(17)) != 0) {
            fprintf(stderr, "dkf-run: %s: cannot write the output: %s\n", o.output,
                    errno != 0 ? strerror(errno) : "error");
            rc = EXIT_BAD_INPUT;
        }
        json_decref(doc);
    }
    if (rc == 0 && !o.quiet) print_summary(f, s, slots, count);
    for (i = 0; i < count; ++i) dkf_est_free(slots[i].est);
    free(slots);
    dkf_scenario_free(s);
    return rc;
}
