/*
 * dkf-net-local - the whole network in one process over LCM's in-process
 * memq:// provider (no sockets at all): the simulator, every node and the
 * fusion centre share one transport, in lock-step. For machines where the
 * multicast demo cannot run (no root for a network namespace) and for
 * quick checks; the result file is dkf-fusion's.
 *
 *   dkf-net-local --output fused.json tests/vectors/diffkf/ex3_multi.json
 */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "agents.h"
#include "centre.h"
#include "cli.h"
#include "net.h"

static const char *prog = "dkf-net-local";

static void usage(FILE *f)
{
    fprintf(f,
            "usage: %s [--output FILE] [--run R] [--steady TOL] [--quiet] SCENARIO.json\n"
            "Runs dkf-sim --lockstep, one dkf-node per sensor and dkf-fusion as agents in one\n"
            "process over memq:// (nothing touches the network) and writes dkf-fusion's\n"
            "result file.\n"
            "  -o, --output FILE   result (JSON, as dkf-fusion --output)\n"
            "      --run R         Monte-Carlo run to publish (default 0)\n"
            "      --steady TOL    the centre's steady gain (as dkf-fusion --steady)\n"
            "  -q, --quiet         no summary line\n"
            "  -h, --help          this text\n"
            "Exit: 0 every step fused, 2 bad options/scenario, 3 failure.\n",
            prog);
}

int main(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'}, {"run", required_argument, NULL, 'n'},
        {"steady", required_argument, NULL, 'S'},
        {"quiet", no_argument, NULL, 'q'},        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    const char *out = NULL;
    double run = 0, steady = 0;
    int quiet = 0, c, code = DKF_EXIT_OK;
    char err[DKF_SCN_ERR_LEN];
    dkf_scenario_t *s;
    dkf_net_t *net;
    dkf_net_sim_t *sim;
    dkf_net_fusion_t *fu;
    dkf_net_node_t **nodes;
    size_t i;
    long j;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":o:qh", longopts, NULL)) != -1) {
        switch (c) {
        case 'o': out = optarg; break;
        case 'n': if (dkf_cli_num(prog, "--run", optarg, 0, 1e9, &run)) return DKF_EXIT_USAGE; break;
        case 'S': if (dkf_cli_num(prog, "--steady", optarg, 0, 0.5, &steady)) return DKF_EXIT_USAGE; break;
        case 'q': quiet = 1; break;
        case 'h': usage(stdout); return DKF_EXIT_OK;
        default: dkf_cli_bad_option(prog, argc, argv, optind, optopt); return DKF_EXIT_USAGE;
        }
    }
    if (optind != argc - 1 || run != (double)(long)run) {
        fprintf(stderr, "%s: %s (see --help)\n", prog,
                optind != argc - 1 ? "expected one SCENARIO file" : "--run: expected an integer");
        return DKF_EXIT_USAGE;
    }
    s = dkf_cli_scenario(prog, argv[optind], (long)run);
    if (s == NULL) return DKF_EXIT_USAGE;
    net = dkf_net_open("memq://", err, sizeof err);
    nodes = calloc(s->nsensors, sizeof *nodes);
    if (net == NULL || nodes == NULL) {
        fprintf(stderr, "%s: %s\n", prog, net == NULL ? err : "out of memory");
        return DKF_EXIT_RUN;
    }
    sim = dkf_net_sim_create(net, s, DKF_NET_PREFIX, err, sizeof err);
    fu = sim ? dkf_net_fusion_create(net, s, DKF_NET_PREFIX, 0, err, sizeof err) : NULL;
    if (fu != NULL && steady > 0 && dkf_net_fusion_steady(fu, steady) != 0) {
        snprintf(err, sizeof err, "--steady: a weighted-fusion centre has no gain to settle");
        dkf_net_fusion_free(fu);
        fu = NULL;
    }
    for (i = 0; fu != NULL && i < s->nsensors; ++i)
        /* the node role of the scenario's kind: seed 002's local KF, else the DKF */
        if ((nodes[i] = dkf_net_node_create(net, s,
                                            dkf_registry_find(s->layout == DKF_SCN_LAYOUT_WFCASES
                                                                  ? "local_kf"
                                                                  : "dkf"),
                                            i, DKF_NET_PREFIX, err, sizeof err)) == NULL)
            break;
    if (sim == NULL || fu == NULL || i < s->nsensors) {
        fprintf(stderr, "%s: %s\n", prog, err);
        code = DKF_EXIT_RUN;
    }
    for (j = 1; code == DKF_EXIT_OK && j <= dkf_net_sim_last(sim); ++j) {
        if (dkf_net_sim_publish(sim, j) != 0 || dkf_net_drain(net, 0) < 0) code = DKF_EXIT_RUN;
        for (i = 0; code == DKF_EXIT_OK && i < s->nsensors; ++i)
            if (dkf_net_node_state(nodes[i]) == DKF_NET_FAILED) {
                fprintf(stderr, "%s: %s\n", prog, dkf_net_node_error(nodes[i]));
                code = DKF_EXIT_RUN;
            }
    }
    if (code == DKF_EXIT_OK && dkf_net_fusion_state(fu) != DKF_NET_DONE) {
        fprintf(stderr, "%s: the fusion centre stopped at k=%ld\n", prog, dkf_net_fusion_k(fu));
        code = DKF_EXIT_RUN;
    }
    if (fu != NULL && out != NULL) {
        json_t *doc = dkf_net_fusion_result(fu);
        if (dkf_cli_write_json(prog, out, doc) != 0) code = DKF_EXIT_RUN;
        json_decref(doc);
    }
    if (!quiet && fu != NULL)
        fprintf(stderr, "%s: fused k=%ld/%zu over memq://, %zu nodes, degraded %lld\n", prog,
                dkf_net_fusion_k(fu), s->steps, s->nsensors,
                (long long)dkf_net_fusion_counts(fu)->missed);
    for (i = 0; i < s->nsensors; ++i) dkf_net_node_free(nodes[i]);
    free(nodes);
    dkf_net_fusion_free(fu);
    dkf_net_sim_free(sim);
    dkf_net_close(net);
    dkf_scenario_free(s);
    return code;
}
