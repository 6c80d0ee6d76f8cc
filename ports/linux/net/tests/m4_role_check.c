/*
 * m4_role_check.c - the live node image's node role (agents/m4_node.h)
 * against the dkf family's own (what dkf-node runs), in one process, on
 * the same measurements: sensor I of SCENARIO started at k = 1, stepped to
 * RESTART - 1, restarted at RESTART (a node's new epoch after a gap, the
 * general start with dkf_diffkf_set_time) and stepped to N. Every payload
 * x_{k|k}, x_{k|k-1} of the image must equal the host's within REL
 * (relative to max(1, max|host|)); REL 0: bit for bit (memcmp).
 *
 *   m4_role_check IMAGE SCENARIO I RESTART REL
 *
 * Exit 0 if every step agrees, 1 if one does not or a role failed,
 * 77 (skip) without qemu-system-arm on PATH.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "m4_node.h"
#include "registry.h"
#include "scenario.h"
#include "util.h"

#define FAIL(...) (fprintf(stderr, "m4_role_check: " __VA_ARGS__), fputc('\n', stderr), 1)

/* Both roles over y_{k0} (start) and y_{k+1} (step k) for k = k0..last. */
static int run(const dkf_node_ops_t *ops[2], dkf_node_filter_t *nf[2], const dkf_scenario_t *s,
               size_t id, long k0, long last, double rel, double *worst)
{
    char err[256];
    long k;
    size_t r, j;
    for (r = 0; r < 2; ++r)
        if (ops[r]->start(nf[r], k0, dkf_scn_y(s, id, k0), err, sizeof err) != DKF_EXIT_OK)
            return FAIL("%s start at k=%ld: %s", r ? "image" : "host", k0, err);
    for (k = k0; k <= last; ++k) {
        dkf_node_estimate_t e[2];
        double scale = 1.0, d = 0.0;
        for (r = 0; r < 2; ++r) {
            memset(&e[r], 0, sizeof e[r]);
            if (ops[r]->step(nf[r], k, dkf_scn_y(s, id, k + 1), err, sizeof err) != DKF_EXIT_OK ||
                ops[r]->payload(nf[r], &e[r]) != 0)
                return FAIL("%s step k=%ld: %s", r ? "image" : "host", k, err);
        }
        if (e[0].k != e[1].k || e[0].n != e[1].n || e[1].k != (uint32_t)k)
            return FAIL("step k=%ld: payload k %u / %u, n %u / %u", k, e[0].k, e[1].k, e[0].n,
                        e[1].n);
        if (rel == 0.0) {
            if (memcmp(e[0].xf, e[1].xf, sizeof e[0].xf) != 0 ||
                memcmp(e[0].xp, e[1].xp, sizeof e[0].xp) != 0)
                return FAIL("step k=%ld: the image's message differs from the host's in a bit", k);
            continue;
        }
        for (j = 0; j < e[0].n; ++j) {
            scale = fmax(scale, fmax(fabs((double)e[0].xf[j]), fabs((double)e[0].xp[j])));
            d = fmax(d, fmax(fabs((double)(e[0].xf[j] - e[1].xf[j])),
                             fabs((double)(e[0].xp[j] - e[1].xp[j]))));
        }
        *worst = fmax(*worst, d / scale);
        if (d / scale > rel)
            return FAIL("step k=%ld: the image's message differs by %.3g relative (> %g)", k,
                        d / scale, rel);
    }
    return 0;
}

int main(int argc, char **argv)
{
    dkf_m4_conf_t conf = {"qemu-system-arm", NULL, 30.0, NULL};
    dkf_family_t fam;
    dkf_filter_t m4;
    const dkf_filter_t *host = dkf_registry_find("dkf");
    const dkf_node_ops_t *ops[2];
    dkf_node_filter_t *nf[2] = {NULL, NULL};
    char err[256];
    dkf_scenario_t *s;
    long restart;
    size_t id;
    double rel, worst = 0.0;
    int rc = 1;
    if (argc != 6) return FAIL("usage: m4_role_check IMAGE SCENARIO I RESTART REL");
    if (system("command -v qemu-system-arm >/dev/null 2>&1") != 0) {
        printf("SKIP: qemu-system-arm missing\n");
        return 77;
    }
    conf.image = argv[1];
    id = (size_t)atol(argv[3]);
    restart = atol(argv[4]);
    rel = atof(argv[5]);
    if ((s = dkf_scenario_load(argv[2], NULL, err, sizeof err)) == NULL) return FAIL("%s", err);
    if (id >= s->nsensors || restart < 3 || restart >= (long)s->steps) {
        dkf_scenario_free(s);
        return FAIL("I or RESTART out of range");
    }
    dkf_m4_filter(&conf, &fam, &m4);
    ops[0] = host->family->node;
    ops[1] = fam.node;
    if ((nf[0] = ops[0]->create(host, s, id, err, sizeof err)) == NULL ||
        (nf[1] = ops[1]->create(&m4, s, id, err, sizeof err)) == NULL) {
        rc = FAIL("%s", err);
    } else if (run(ops, nf, s, id, 1, restart - 2, rel, &worst) == 0 &&
               run(ops, nf, s, id, restart, (long)s->steps, rel, &worst) == 0) {
        if (dkf_m4_node_finish(nf[1], err, sizeof err) != 0) {
            rc = FAIL("%s", err);
        } else {
            printf("PASS: sensor %zu, steps 1..%ld and, restarted, %ld..%zu: the image's "
                   "messages == the host node's %s (largest difference %.2g relative)\n", id,
                   restart - 2, restart, s->steps, rel == 0.0 ? "bit for bit" : "within REL",
                   worst);
            rc = 0;
        }
    }
    if (nf[0] != NULL) ops[0]->destroy(nf[0]);
    if (nf[1] != NULL) ops[1]->destroy(nf[1]);
    dkf_scenario_free(s);
    return rc;
}
