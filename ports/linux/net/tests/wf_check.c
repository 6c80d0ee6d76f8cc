/*
 * wf_check SCENARIO RESULT.json [--complete] [--absent I:K1:K2]...
 *
 * Checks a weighted-fusion centre's result file (dkf-fusion --output on a
 * weighted-fusion scenario; docs/design/network.md, "The weighted-fusion centre")
 * against the core run in this process: dkf_wfusion_step with every
 * sensor's y, then dkf_wfusion_fuse_scalar / _fuse_matrix with x[i] = NULL
 * for every node the result says did not contribute at that step. Every
 * step must be published and equal it exactly (x0, P0, s0, PS0, w: max
 * |difference| == 0; the processes run the same core calls on the same
 * bits). --complete: every node contributed at every step; --absent
 * I:K1:K2: node I is missing exactly on steps K1..K2 and every other node
 * contributes at every step (several allowed; nodes not named: always
 * present). Prints the maximum difference, the degraded steps and the
 * contributors' pattern. Exit 0 pass, 1 fail, 2 usage.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "dkf/wfusion.h"
#include "scenario.h"
#include "wf_model.h"

#define MAXL 16

static double num(const json_t *a, size_t i) { return json_number_value(json_array_get(a, i)); }

static void upd(double *worst, double a, double b)
{
    const double d = fabs(a - b);
    if (!(d <= *worst)) *worst = d; /* NaN counts as a difference */
}

int main(int argc, char **argv)
{
    char err[DKF_SCN_ERR_LEN];
    dkf_scenario_t *s;
    dkf_wf_model_t md;
    json_error_t je;
    json_t *doc;
    const json_t *o, *cont, *status;
    dkf_wfusion_t fu;
    dkf_wfusion_local_t nodes[MAXL];
    dkf_real_t *store;
    long absent[MAXL][2];
    int complete = 0, fail = 0, ai;
    size_t n, l, N, k, i, a, b, ndeg = 0, first_deg = 0, last_deg = 0;
    double worst = 0;
    if (argc < 3) {
        fprintf(stderr, "usage: wf_check SCENARIO RESULT.json [--complete] [--absent I:K1:K2]\n");
        return 2;
    }
    for (i = 0; i < MAXL; ++i) absent[i][0] = absent[i][1] = 0;
    for (ai = 3; ai < argc; ++ai) {
        long id, k1, k2;
        if (strcmp(argv[ai], "--complete") == 0) {
            complete = 1;
        } else if (strcmp(argv[ai], "--absent") == 0 && ai + 1 < argc &&
                   sscanf(argv[ai + 1], "%ld:%ld:%ld", &id, &k1, &k2) == 3 && id >= 0 &&
                   id < MAXL) {
            absent[id][0] = k1;
            absent[id][1] = k2;
            ++ai;
        } else {
            fprintf(stderr, "wf_check: %s: unknown option\n", argv[ai]);
            return 2;
        }
    }
    s = dkf_scenario_load(argv[1], NULL, err, sizeof err);
    if (s == NULL || dkf_wf_model_load(s, &md, err, sizeof err) != 0) {
        fprintf(stderr, "wf_check: %s\n", err);
        return 2;
    }
    n = md.n;
    l = md.l;
    N = s->steps;
    doc = json_load_file(argv[2], 0, &je);
    if (doc == NULL || l > MAXL) {
        fprintf(stderr, "wf_check: %s: %s\n", argv[2], doc ? "too many nodes" : je.text);
        return 2;
    }
    o = json_object_get(json_object_get(doc, "outputs"), "wfusion");
    cont = json_object_get(doc, "contributors");
    status = json_object_get(doc, "status");
    if (o == NULL || json_array_size(cont) != N || json_array_size(status) != N) {
        fprintf(stderr, "FAIL: %s: %zu of %zu steps published (or no outputs.wfusion)\n",
                argv[2], json_array_size(cont), N);
        return 1;
    }
    store = calloc(dkf_wfusion_storage_len(n, l, md.m), sizeof *store);
    if (store == NULL ||
        dkf_wfusion_init(&fu, n, l, md.m, nodes, store, dkf_wfusion_storage_len(n, l, md.m),
                         &md.Hs, &md.x0, &md.P0) != DKF_OK) {
        fprintf(stderr, "wf_check: dkf_wfusion_init failed\n");
        return 2;
    }
    for (k = 1; k <= N; ++k) {
        const json_t *ck = json_array_get(cont, k - 1);
        const dkf_mat_t *x[MAXL];
        int in[MAXL] = {0};
        size_t used = 0;
        for (i = 0; i < json_array_size(ck); ++i) {
            const json_int_t id = json_integer_value(json_array_get(ck, i));
            if (id >= 0 && (size_t)id < l) in[id] = 1;
        }
        for (i = 0; i < l; ++i) {
            const int want = complete || !((long)k >= absent[i][0] && (long)k <= absent[i][1]);
            if (argc > 3 && in[i] != want) {
                if (fail < 10)
                    printf("FAIL: step %zu: node %zu %s\n", k, i,
                           in[i] ? "contributed, expected absent" : "missing");
                ++fail;
            }
            x[i] = in[i] ? &fu.nodes[i].x : NULL;
            used += (size_t)in[i];
        }
        if (used < l) {
            if (ndeg++ == 0) first_deg = k;
            last_deg = k;
        }
        if (strcmp(json_string_value(json_array_get(status, k - 1)),
                   used < l ? "degraded" : "complete") != 0) {
            printf("FAIL: step %zu: status %s with %zu of %zu nodes\n", k,
                   json_string_value(json_array_get(status, k - 1)), used, l);
            ++fail;
        }
        if (dkf_wf_model_y(&md, s, (long)k) != 0 ||
            dkf_wfusion_step(&fu, &md.dyn, md.meas, md.y) != DKF_OK) {
            fprintf(stderr, "wf_check: step %zu: dkf_wfusion_step failed\n", k);
            return 2;
        }
        if (used == 0) continue; /* the prediction alone: not a fusion */
        if (dkf_wfusion_fuse_scalar(&fu, x) != DKF_OK || dkf_wfusion_fuse_matrix(&fu, x) != DKF_OK) {
            fprintf(stderr, "wf_check: step %zu: the fusion failed\n", k);
            return 2;
        }
        for (a = 0; a < n; ++a) {
            upd(&worst, num(json_array_get(json_object_get(o, "x0"), k - 1), a),
                (double)fu.xf.data[a]);
            for (b = 0; b < n; ++b)
                upd(&worst,
                    num(json_array_get(json_array_get(json_object_get(o, "P0"), k - 1), a), b),
                    (double)fu.Pf.data[a * n + b]);
        }
        upd(&worst, num(json_object_get(o, "s0"), k - 1), (double)fu.s0);
        upd(&worst, num(json_object_get(o, "PS0"), k - 1), (double)fu.PS0);
        for (i = 0; i < l; ++i)
            upd(&worst, num(json_array_get(json_object_get(o, "w"), k - 1), i),
                (double)fu.w.data[i]);
    }
    printf("wf_check: %zu steps, %zu nodes: max |process - in-process| = %.3g (x0, P0, s0, PS0, "
           "w); degraded %zu steps", N, l, worst, ndeg);
    if (ndeg) printf(" (%zu..%zu)", first_deg, last_deg);
    printf("\n");
    if (worst != 0) {
        printf("FAIL: the processes' fusion differs from the in-process core fusion\n");
        ++fail;
    }
    json_decref(doc);
    free(store);
    dkf_wf_model_free(&md);
    dkf_scenario_free(s);
    return fail ? 1 : 0;
}
