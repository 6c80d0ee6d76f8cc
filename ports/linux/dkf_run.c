/*
 * dkf-run - runs a dkf filter over a JSON scenario and writes its per-step
 * estimates in the golden-vector layout (docs/scenario-format.md), or, over
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
#include "estimator.h"
#include "scenario.h"
#include "tw_run.h"
#include "uif_run.h"
#include "util.h"

#define MAX_D00 64

/* One row per filter. A single-sensor scenario gets one estimator written
 * under outputs.<label>; a multi-sensor one gets outputs.local[i] (sensor i
 * alone), outputs.central (all sensors stacked) and, when `fused`,
 * outputs.fused (information filter: contributions summed; Difference KF:
 * the fusion centre fed with the local filters' messages). */
typedef struct {
    const char *name;
    const char *label;
    dkf_est_kind_t kind;
    int fused;
    int ui;    /* 0: ignores A, B, Rd; 1: Difference KF (y up to N+1); 2: needs d00, Pd00 */
    const char *help;
    int fam;   /* FAM_KF: estimator.h; FAM_UIF: uif_run.h (seed 004); FAM_TW: tw_run.h (seed 003) */
} filter_t;

enum { FAM_KF = 0, FAM_UIF = 1, FAM_TW = 2 };

static const filter_t filters[] = {
    {"kf", "KF", DKF_EST_KF, 0, 0,
     "Kalman filter (dkf/kf.h) on F, Q, H, R;\n"
     "                           unknown-input terms (A, B, Rd, ...) are ignored", FAM_KF},
    {"info", "IF", DKF_EST_INFO, 1, 0,
     "information filter (dkf/info.h); with several\n"
     "                           sensors it also writes `fused`", FAM_KF},
    {"dkf", "DKF", DKF_EST_DKF, 1, 1,
     "Difference KF (dkf/diffkf.h); needs A, B, Rd and\n"
     "                           y_1..y_{N+1}; xp = x_{k|k-1}. With several sensors\n"
     "                           also `fused` (fusion centre, dkf/diffkf_fusion.h)", FAM_KF},
    {"askf", "ASKF", DKF_EST_ASKF, 0, 2,
     "augmented-state KF (dkf/askf.h) on [x; d]; needs A, B,\n"
     "                           Rd, init.d00, init.Pd00; one sensor", FAM_KF},
    {"otskf", "OTSKF", DKF_EST_OTSKF, 0, 2,
     "optimal two-stage KF (dkf/otskf.h); like askf", FAM_KF},
    {"rtsf", "RTSF", DKF_EST_KF, 0, 0,
     "seed 004: recursive three-step filter with direct\n"
     "                           feedthrough (dkf/uif.h); needs rank H = m; steps from k = 0",
     FAM_UIF},
    {"nrtsf_df", "NRTSF_DF", DKF_EST_KF, 0, 0,
     "seed 004: NRTSF-DF, any rank of H (minimum-norm\n"
     "                           input estimate); steps from k = 0", FAM_UIF},
    {"nrtsf", "NRTSF", DKF_EST_KF, 0, 0,
     "seed 004: NRTSF, no feedthrough (no H), any rank of G;\n"
     "                           d = d_{k-1|k}; steps from k = 1", FAM_UIF},
    {"tw1", "alg1", DKF_EST_KF, 0, 0,
     "seed 003: Algorithm 1, centralized filter with unknown\n"
     "                           actuations (dkf/tw.h) over every node", FAM_TW},
    {"tw2", "alg2", DKF_EST_KF, 0, 0,
     "seed 003: Algorithm 2, diffusion, whole graph in process", FAM_TW},
    {"tw3", "alg3", DKF_EST_KF, 0, 0,
     "seed 003: Algorithm 3, consensus (eta ACF iterations:\n"
     "                           the file's eta or --eta N), whole graph in process", FAM_TW},
};
#define NFILTERS (sizeof filters / sizeof filters[0])

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

typedef struct {
    char name[32];        /* "KF", "local[1]", "central", "fused" */
    dkf_est_t *est;
} slot_t;

static void usage(FILE *f, const char *prog)
{
    size_t i;
    fprintf(f,
            "usage: %s --filter NAME [--output OUT.json | --errors ERR.json] [options] "
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
            "errors: {\"k\": [1..N], \"runs\": R, \"errors\": {<LABEL> or local[i], central,\n"
            "fused: {\"xf\": [[e_1..e_N] per run], \"xp\": [...], \"mean_xf\": [...],\n"
            "\"mean_xp\": [...]}}}.\n"
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
        for (c = 0; c < (int)NFILTERS; ++c) fprintf(stderr, " %s", filters[c].name);
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

/* Filter-specific checks of options and scenario; 0 or an exit status. */
static int check_filter(const options_t *o, const filter_t *f, const dkf_scenario_t *s)
{
    char err[DKF_SCN_ERR_LEN];
    const dkf_scn_mat_t *A;
    if (o->eta >= 0 && strcmp(f->name, "tw3") != 0) {
        fprintf(stderr, "dkf-run: %s: --eta: only for tw3\n", s->file);
        return DKF_EXIT_USAGE;
    }
    if (o->metrics_only && f->fam != FAM_TW) {
        fprintf(stderr, "dkf-run: %s: --metrics-only: only for tw1, tw2, tw3\n", s->file);
        return DKF_EXIT_USAGE;
    }
    if (f->fam != FAM_KF && (o->errors != NULL || o->run != 0)) {
        fprintf(stderr, "dkf-run: %s: %s: not available for filter %s (steps-layout files "
                "have one run)\n", s->file, o->errors != NULL ? "--errors" : "--run", f->name);
        return DKF_EXIT_USAGE;
    }
    if (f->fam == FAM_KF &&
        (s->layout == DKF_SCN_LAYOUT_STEPS || s->layout == DKF_SCN_LAYOUT_NETWORK)) {
        fprintf(stderr, "dkf-run: %s: steps: filter %s reads the canonical or cases layout; "
                "this seed-%s file runs with %s\n", s->file, f->name,
                s->layout == DKF_SCN_LAYOUT_NETWORK ? "003" : "004",
                s->layout == DKF_SCN_LAYOUT_NETWORK ? "tw1, tw2, tw3" : "rtsf, nrtsf_df, nrtsf");
        return DKF_EXIT_USAGE;
    }
    if (f->fam != FAM_KF) return 0; /* uif_run / tw_run check the rest */
    if ((o->has_d00 || o->Pd00_scale > 0) && f->ui != 2) {
        fprintf(stderr, "dkf-run: %s: --d00/--Pd00-scale: only for askf and otskf\n", s->file);
        return DKF_EXIT_USAGE;
    }
    if (f->ui == 2 && s->multi) {
        fprintf(stderr, "dkf-run: %s: model.sensors: filter %s supports single-sensor "
                "scenarios only\n", s->file, f->name);
        return DKF_EXIT_USAGE;
    }
    if (f->ui != 0 &&
        dkf_scn_require_ui(s, f->ui == 1 ? s->steps : s->steps - 1,
                           f->ui == 1 ? s->steps + 1 : s->steps, f->ui == 2 && !o->has_d00,
                           f->name, err, sizeof err) != 0) {
        fprintf(stderr, "dkf-run: %s\n", err);
        return DKF_EXIT_USAGE;
    }
    if (f->ui == 2) {
        A = dkf_scn_sensor_model(s, 0, "A");
        if (o->has_d00 && o->nd00 != A->cols) {
            fprintf(stderr, "dkf-run: %s: --d00: expected %zu values (the columns of A), got %zu\n",
                    s->file, A->cols, o->nd00);
            return DKF_EXIT_USAGE;
        }
        if (o->has_d00 && dkf_scn_init(s, "Pd00") == NULL) {
            fprintf(stderr, "dkf-run: %s: init.Pd00: missing key (filter %s needs it)\n",
                    s->file, f->name);
            return DKF_EXIT_USAGE;
        }
    }
    if (o->errors != NULL && dkf_scn_require_truth(s, err, sizeof err) != 0) {
        fprintf(stderr, "dkf-run: %s\n", err);
        return DKF_EXIT_USAGE;
    }
    if (o->errors == NULL && (size_t)o->run >= s->nruns) {
        fprintf(stderr, "dkf-run: %s: --run %ld: the file has %zu run%s (0..%zu)\n", s->file,
                o->run, s->nruns, s->nruns == 1 ? "" : "s", s->nruns - 1);
        return DKF_EXIT_USAGE;
    }
    return 0;
}

static void free_slots(slot_t *slots, size_t count)
{
    size_t i;
    for (i = 0; slots != NULL && i < count; ++i) dkf_est_free(slots[i].est);
    free(slots);
}

/* The estimators a filter runs on a scenario (see filter_t). */
static int make_slots(const filter_t *f, const dkf_scenario_t *s, const dkf_est_opts_t *opts,
                      slot_t **out, size_t *count)
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
        return DKF_EXIT_USAGE;
    }
    for (i = 0; i < s->nsensors; ++i) all[i] = i;
    if (!s->multi) {
        snprintf(slots[0].name, sizeof slots[0].name, "%s", f->label);
        slots[0].est = dkf_est_create(f->kind, DKF_EST_STACKED, s, all, 1,
                                      dkf_scn_P00_central(s), opts, err, sizeof err);
    } else {
        for (i = 0; i < s->nsensors && rc == 0; ++i) {
            snprintf(slots[i].name, sizeof slots[i].name, "local[%zu]", i);
            slots[i].est = dkf_est_create(f->kind, DKF_EST_STACKED, s, &all[i], 1,
                                          dkf_scn_P00_local(s, i), opts, err, sizeof err);
            if (slots[i].est == NULL) rc = 1;
        }
        if (rc == 0) {
            snprintf(slots[i].name, sizeof slots[i].name, "central");
            slots[i].est = dkf_est_create(f->kind, DKF_EST_STACKED, s, all, s->nsensors,
                                          dkf_scn_P00_central(s), opts, err, sizeof err);
            if (slots[i].est == NULL) rc = 1;
        }
        if (rc == 0 && f->fused) {
            ++i;
            snprintf(slots[i].name, sizeof slots[i].name, "fused");
            slots[i].est = dkf_est_create(f->kind, DKF_EST_FUSED, s, all, s->nsensors,
                                          dkf_scn_P00_central(s), opts, err, sizeof err);
        }
    }
    free(all);
    for (i = 0; i < n; ++i)
        if (slots[i].est == NULL) {
            fprintf(stderr, "dkf-run: %s: %s: %s\n", s->file, slots[i].name, err);
            free_slots(slots, n);
            return DKF_EXIT_RUN;
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
                if (s->has_runs)
                    fprintf(stderr, "dkf-run: %s: run %zu: step k=%ld: %s: %s failed: %s (%d)\n",
                            s->file, s->run, k, slots[i].name, what, dkf_status_str(st),
                            (int)st);
                else
                    fprintf(stderr, "dkf-run: %s: step k=%ld: %s: %s failed: %s (%d)\n", s->file,
                            k, slots[i].name, what, dkf_status_str(st), (int)st);
                return DKF_EXIT_RUN;
            }
        }
    return 0;
}

static json_t *doc_header(const options_t *o, const filter_t *f, const dkf_scenario_t *s)
{
    json_t *doc = json_object(), *ks = json_array();
    long k;
    for (k = 1; k <= (long)s->steps; ++k) json_array_append_new(ks, json_integer(k));
    json_object_set_new(doc, "scenario", json_string(o->scenario));
    if (s->case_name != NULL) json_object_set_new(doc, "case", json_string(s->case_name));
    json_object_set_new(doc, "filter", json_string(f->name));
    json_object_set_new(doc, "real", json_string(DKF_USE_FLOAT ? "float" : "double"));
    json_object_set_new(doc, "k", ks);
    return doc;
}

/* outputs (or errors) laid out by estimator: <LABEL>, or local[i], central, fused. */
static void put_by_slot(json_t *outs, const dkf_scenario_t *s, const slot_t *slots, size_t count,
                        json_t *const *values)
{
    size_t i;
    if (!s->multi) {
        json_object_set(outs, slots[0].name, values[0]);
        return;
    }
    {
        json_t *local = json_array();
        for (i = 0; i < s->nsensors; ++i) json_array_append(local, values[i]);
        json_object_set_new(outs, "local", local);
    }
    for (i = s->nsensors; i < count; ++i) json_object_set(outs, slots[i].name, values[i]);
}

static json_t *output_document(const options_t *o, const filter_t *f, const dkf_scenario_t *s,
                               const slot_t *slots, size_t count)
{
    json_t *doc = doc_header(o, f, s), *outs = json_object();
    json_t **values = calloc(count, sizeof *values);
    size_t i;
    if (values == NULL) return NULL;
    for (i = 0; i < count; ++i) values[i] = json_copy(dkf_est_series(slots[i].est));
    /* the fused DKF's node messages and FC recoveries sit beside `fused`,
     * as in the vector files */
    for (i = 0; i < count; ++i) {
        static const char *const beside[] = {"messages", "fc_recovered"};
        size_t j;
        for (j = 0; j < 2; ++j) {
            json_t *v = json_object_get(values[i], beside[j]);
            if (v == NULL) continue;
            json_object_set(outs, beside[j], v);
            json_object_del(values[i], beside[j]);
        }
    }
    put_by_slot(outs, s, slots, count, values);
    for (i = 0; i < count; ++i) json_decref(values[i]);
    free(values);
    json_object_set_new(doc, "outputs", outs);
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

static int run_errors(const options_t *o, const filter_t *f, dkf_scenario_t *s,
                      const dkf_est_opts_t *opts)
{
    size_t N = s->steps, R = s->nruns, count = 0, r, i, w;
    errs_t *errs = NULL;
    slot_t *slots = NULL;
    int rc = 0;
    for (r = 0; r < R && rc == 0; ++r) {
        dkf_scn_select_run(s, r);
        rc = make_slots(f, s, opts, &slots, &count);
        if (rc != 0) break;
        if (errs == NULL) {
            errs = calloc(count, sizeof *errs);
            for (i = 0; errs != NULL && i < count; ++i) {
                snprintf(errs[i].name, sizeof errs[i].name, "%s", slots[i].name);
                errs[i].sq[0] = calloc(R * N, sizeof(double));
                errs[i].sq[1] = calloc(R * N, sizeof(double));
                if (errs[i].sq[0] == NULL || errs[i].sq[1] == NULL) rc = DKF_EXIT_USAGE;
            }
            if (errs == NULL || rc != 0) {
                fprintf(stderr, "dkf-run: out of memory\n");
                rc = DKF_EXIT_USAGE;
            }
        }
        if (rc == 0) rc = run_steps(s, slots, count);
        for (i = 0; rc == 0 && i < count; ++i)
            for (w = 0; w < 2; ++w)
                memcpy(errs[i].sq[w] + r * N, dkf_est_sqerr(slots[i].est, (int)w),
                       N * sizeof(double));
        free_slots(slots, count);
        slots = NULL;
    }
    dkf_scn_select_run(s, 0);
    if (rc == 0) {
        json_t *doc = doc_header(o, f, s), *outs = json_object();
        json_t **values = calloc(count, sizeof *values);
        slot_t *names = calloc(count, sizeof *names);
        if (values == NULL || names == NULL) {
            fprintf(stderr, "dkf-run: out of memory\n");
            rc = DKF_EXIT_USAGE;
        }
        for (i = 0; rc == 0 && i < count; ++i) {
            json_t *mf, *mp;
            json_t *ef = errors_json(errs[i].sq[0], R, N, &mf);
            json_t *ep = errors_json(errs[i].sq[1], R, N, &mp);
            values[i] = json_pack("{s:o, s:o, s:o, s:o}", "xf", ef, "xp", ep, "mean_xf", mf,
                                  "mean_xp", mp);
            memcpy(names[i].name, errs[i].name, sizeof names[i].name);
        }
        if (rc == 0) {
            json_object_set_new(doc, "runs", json_integer((json_int_t)R));
            json_object_set_new(doc, "definition",
                                json_string("errors.<est>.xf[r][k-1] = ||x_{k|k} - x_k||^2 "
                                            "in run r; xp: x_{k|k-1}; mean_*: mean over runs"));
            put_by_slot(outs, s, names, count, values);
            json_object_set_new(doc, "errors", outs);
            rc = write_doc(doc, o->errors);
        } else {
            json_decref(outs);
            json_decref(doc);
        }
        for (i = 0; values != NULL && i < count; ++i) json_decref(values[i]);
        free(values);
        free(names);
    }
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

/* ---- seed-004 / seed-003 filters (steps layout) ---------------------------------- */

static json_t *steps_header(const options_t *o, const filter_t *f, const dkf_scenario_t *s)
{
    json_t *doc = json_object(), *ks = json_array();
    long k;
    for (k = s->k_first; k < s->k_first + (long)s->steps; ++k)
        json_array_append_new(ks, json_integer(k));
    json_object_set_new(doc, "scenario", json_string(o->scenario));
    json_object_set_new(doc, "filter", json_string(f->name));
    json_object_set_new(doc, "real", json_string(DKF_USE_FLOAT ? "float" : "double"));
    json_object_set_new(doc, "k", ks);
    return doc;
}

static void print_uif_summary(const filter_t *f, const dkf_scenario_t *s,
                              const dkf_uifrun_summary_t *u)
{
    static const char *const est[] = {"none", "partial", "full"};
    size_t i;
    printf("scenario %s: %zu steps (k = %ld..%ld), n = %zu, m = %zu; filter %s (%s)\n", s->file,
           s->steps, s->k_first, s->k_first + (long)s->steps - 1, s->n, u->m, f->name,
           DKF_USE_FLOAT ? "float" : "double");
    printf("  rank %zu..%zu; steps with bias risk: %zu\n", u->rank_min, u->rank_max,
           u->bias_steps);
    printf("  RMSE(x) %s%.6g\n", isnan(u->rmse_x) ? "(no truth) " : "", u->rmse_x);
    for (i = 0; i < u->m; ++i) {
        size_t e, best = 0;
        for (e = 1; e < 3; ++e)
            if (u->est_count[i][e] > u->est_count[i][best]) best = e;
        printf("  d%zu: estimable %s (%zu/%zu steps), RMSE vs truth %s %.6g\n", i + 1,
               est[best], u->est_count[i][best], u->steps,
               s->truth_u_key[0] != '\0' ? s->truth_u_key : "(none)", u->rmse_d[i]);
    }
}

static void print_tw_summary(const filter_t *f, const dkf_scenario_t *s,
                             const dkf_twrun_summary_t *t)
{
    printf("scenario %s: %zu steps, %zu nodes, %zu edges, n = %zu; filter %s (%s)", s->file,
           t->steps, t->N, t->E, s->n, f->name, DKF_USE_FLOAT ? "float" : "double");
    if (strcmp(f->name, "tw3") == 0) printf(", eta = %zu", t->eta);
    printf("\n  weights: alpha %s, W %s\n", t->alpha_default ? "uniform (computed)" : "from file",
           t->W_default ? "Metropolis (computed)" : "from file");
    printf("  RMSE x %.6g, z %.6g (over steps, nodes, components)\n", t->rmse_x, t->rmse_z);
    printf("  reals sent per node per step %.6g (%.6g messages)\n", t->reals_per_node_step,
           t->broadcasts_per_node_step);
    if (strcmp(f->name, "tw1") != 0)
        printf("  gap to Algorithm 1 (max over steps, nodes): ||dx||/||x1|| %.6g, "
               "max|dx|/max(1, max|x1|) %.6g\n", t->gap_x_rel_max, t->gap_x_vec_rule);
}

static int run_steps_family(const options_t *o, const filter_t *f, const dkf_scenario_t *s)
{
    json_t *series = o->output != NULL ? json_object() : NULL;
    char err[DKF_SCN_ERR_LEN];
    int rc;
    dkf_uifrun_summary_t u;
    dkf_twrun_summary_t t;
    json_t *doc, *outs, *comm;
    if (f->fam == FAM_UIF) {
        rc = dkf_uifrun(s, (dkf_uif_kind_t)dkf_uifrun_kind(f->name), series, &u, err, sizeof err);
    } else {
        dkf_twrun_opts_t to;
        to.alg = dkf_twrun_alg(f->name);
        to.eta = o->eta;
        to.no_nodes = o->metrics_only;
        rc = dkf_twrun(s, &to, series, &t, err, sizeof err);
    }
    if (rc != 0) {
        fprintf(stderr, "dkf-run: %s\n", err);
        json_decref(series);
        return rc;
    }
    if (o->output != NULL) {
        doc = steps_header(o, f, s);
        outs = json_object();
        json_object_set_new(outs, f->label, series);
        json_object_set_new(doc, "outputs", outs);
        if (f->fam == FAM_TW) {
            if (strcmp(f->name, "tw3") == 0)
                json_object_set_new(doc, "eta", json_integer((json_int_t)t.eta));
            comm = json_pack("{s:f, s:f, s:i, s:i}", "reals_per_node_step",
                             t.reals_per_node_step, "messages_per_node_step",
                             t.broadcasts_per_node_step, "N", (json_int_t)t.N, "edges",
                             (json_int_t)t.E);
            json_object_set_new(doc, "communication", comm);
        }
        rc = write_doc(doc, o->output);
        if (rc != 0) return rc;
    }
    if (!o->quiet) {
        if (f->fam == FAM_UIF)
            print_uif_summary(f, s, &u);
        else
            print_tw_summary(f, s, &t);
    }
    return 0;
}

int main(int argc, char **argv)
{
    options_t o;
    const filter_t *f;
    dkf_scenario_t *s;
    slot_t *slots = NULL;
    size_t count = 0, i;
    dkf_est_opts_t opts;
    char err[DKF_SCN_ERR_LEN];
    int rc = parse_options(argc, argv, &o);

    if (rc != 0) return rc > 0 ? 0 : DKF_EXIT_USAGE;
    f = find_filter(o.filter);
    if (f == NULL) {
        fprintf(stderr, "dkf-run: %s: --filter %s: unknown filter (one of:", o.scenario,
                o.filter);
        for (i = 0; i < NFILTERS; ++i) fprintf(stderr, " %s", filters[i].name);
        fprintf(stderr, ")\n");
        return DKF_EXIT_USAGE;
    }
    s = dkf_scenario_load(o.scenario, o.case_sel, err, sizeof err);
    if (s == NULL) {
        fprintf(stderr, "dkf-run: %s\n", err);
        return DKF_EXIT_USAGE;
    }
    rc = check_filter(&o, f, s);
    if (rc == 0 && f->fam != FAM_KF) {
        rc = run_steps_family(&o, f, s);
        dkf_scenario_free(s);
        return rc;
    }
    memset(&opts, 0, sizeof opts);
    opts.d00 = o.has_d00 ? o.d00 : NULL;
    opts.Pd00_scale = o.Pd00_scale;
    if (rc == 0 && o.errors != NULL) {
        opts.no_record = 1;
        rc = run_errors(&o, f, s, &opts);
        dkf_scenario_free(s);
        return rc;
    }
    if (rc == 0) {
        dkf_scn_select_run(s, (size_t)o.run);
        opts.no_record = o.output == NULL;
        rc = make_slots(f, s, &opts, &slots, &count);
    }
    if (rc == 0) rc = run_steps(s, slots, count);
    if (rc == 0 && o.output != NULL) rc = write_doc(output_document(&o, f, s, slots, count), o.output);
    if (rc == 0 && !o.quiet) print_summary(f, s, slots, count);
    free_slots(slots, count);
    dkf_scenario_free(s);
    return rc;
}
