/*
 * dkf-node - one sensor node: runs a filter's node role (registry.h; the
 * local Difference KF by default) on its measurements and publishes
 * {x^i_{k|k}, x^i_{k|k-1}} after every step (docs/guide/network.md).
 *
 *   dkf-node --id 0 tests/vectors/diffkf/ex3_multi.json
 */
#include <getopt.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "agents.h"
#include "auth.h"
#include "cli.h"
#include "net.h"
#include "registry.h"

static const char *prog = "dkf-node";

/* The filters whose family has a node role, "a, b" (registry.h). */
static const char *node_filters(void)
{
    static char out[256];
    size_t i, j, len = 0;
    out[0] = '\0';
    for (i = 0; dkf_registry[i] != NULL; ++i)
        for (j = 0; dkf_registry[i]->node != NULL && j < dkf_registry[i]->nfilters; ++j)
            len += (size_t)snprintf(out + len, len < sizeof out ? sizeof out - len : 0, "%s%s",
                                    len ? ", " : "", dkf_registry[i]->filters[j].name);
    return out;
}

/* Leaves real-time priority (the demo's SCHED_FIFO) before the teardown:
 * freeing the scenario takes milliseconds of CPU, which must not delay the
 * centre's last step (docs/design/network.md, "Where the latency goes"). */
static void leave_realtime(void)
{
    struct sched_param p;
    const int policy = sched_getscheduler(0);
    memset(&p, 0, sizeof p);
    if (policy == SCHED_FIFO || policy == SCHED_RR) (void)sched_setscheduler(0, SCHED_OTHER, &p);
}

static void usage(FILE *f)
{
    fprintf(f,
            "usage: %s --id I [options] SCENARIO.json\n"
            "Runs node I of the scenario: subscribes to <prefix>_MEAS_I, runs the local\n"
            "Difference KF on sensor I and publishes its message on <prefix>_NODE_I after\n"
            "every step, with a heartbeat on <prefix>_STATUS. Exits after step N.\n"
            "\n"
            "  -i, --id I              sensor index (0-based), required\n"
            "  -f, --filter NAME       the filter whose node role to run (default dkf;\n"
            "                          the filters with one: %s)\n"
            "  -u, --url URL           LCM URL (default %s);\n"
            "                          only udpm://239.x.y.z...?ttl=0 or memq:// are\n"
            "                          accepted (--lan sends udpm with ttl=1)\n"
            "  -p, --prefix P          channel prefix (default %s)\n"
            "      --heartbeat-ms MS   status period (default %d)\n"
            "  -t, --timeout S         give up after S seconds (default 0: never)\n"
            DKF_CLI_PORTS_USAGE
            "      --key-dir DIR       authenticate every datagram with the keys in DIR\n"
            "                          (dkf-keygen; without it: unauthenticated, said on stderr)\n"
            DKF_CLI_LAN_USAGE
            "      --join-at K         start on the first measurement y_j with j >= K\n"
            "                          (default: the first one received; a late node)\n"
            "      --epoch E           epoch of this start (a restarted node: previous + 1)\n"
            "Fault injection (tests; docs/design/network.md, \"Faults\"):\n"
            "      --drop PCT          drop PCT %% of the outgoing messages\n"
            "      --dup PCT           send PCT %% of them twice\n"
            "      --reorder PCT       hold PCT %% back until after the next message\n"
            "      --seed S            seed of those draws (default 0; reproducible)\n"
            "      --exit-at K         stop dead at step K, before its message (a crash:\n"
            "                          no final status; exit status 0)\n"
            "      --ready-file F      create F once subscribed (for scripts)\n"
            "  -q, --quiet             no summary line\n"
            "  -h, --help              this text\n"
            "Exit: 0 done, 2 bad options/scenario, 3 filter or transport failure,\n"
            "4 interrupted (SIGINT/SIGTERM/--timeout) before step N.\n",
            prog, node_filters(), DKF_NET_DEFAULT_URL, DKF_NET_PREFIX,
            DKF_NET_HEARTBEAT_US / 1000);
}

int main(int argc, char **argv)
{
    static const struct option longopts[] = {
        DKF_CLI_LONGOPTS_NET, DKF_CLI_LONGOPTS_PORTS, DKF_CLI_LONGOPT_READY,
        DKF_CLI_LONGOPT_HEARTBEAT,
        {"id", required_argument, NULL, 'i'},      {"filter", required_argument, NULL, 'f'},
        {"drop", required_argument, NULL, 'D'},    {"dup", required_argument, NULL, 'U'},
        {"reorder", required_argument, NULL, 'O'}, {"seed", required_argument, NULL, 'S'},
        {"exit-at", required_argument, NULL, 'X'}, {"join-at", required_argument, NULL, 'J'},
        {"epoch", required_argument, NULL, 'E'},   {NULL, 0, NULL, 0}};
    dkf_net_faults_t fx;
    dkf_cli_opts_t co;
    double seed = 0, exit_at = 0, join_at = 0, epoch = 0;
    const dkf_filter_t *filter = dkf_registry_find("dkf");
    double id = -1;
    int c, code;
    char err[DKF_SCN_ERR_LEN];
    dkf_scenario_t *s;
    dkf_net_t *net;
    dkf_net_node_t *nd;
    int64_t start;
    memset(&fx, 0, sizeof fx);
    dkf_cli_opts_init(&co, DKF_NET_PREFIX);
    while ((c = dkf_cli_getopt(prog, argc, argv, ":i:f:u:p:t:qh", longopts, usage, &co)) > 0) {
        switch (c) {
        case 'i': if (dkf_cli_num(prog, "--id", optarg, 0, 1e6, &id)) return DKF_EXIT_USAGE; break;
        case 'f':
            filter = dkf_registry_find(optarg);
            if (filter == NULL || filter->family->node == NULL) {
                fprintf(stderr, "%s: --filter %s: %s (filters with a node role: %s)\n", prog,
                        optarg, filter ? "has no node role" : "unknown filter", node_filters());
                return DKF_EXIT_USAGE;
            }
            break;
        case 'D': if (dkf_cli_num(prog, "--drop", optarg, 0, 100, &fx.drop_pct)) return DKF_EXIT_USAGE; break;
        case 'U': if (dkf_cli_num(prog, "--dup", optarg, 0, 100, &fx.dup_pct)) return DKF_EXIT_USAGE; break;
        case 'O': if (dkf_cli_num(prog, "--reorder", optarg, 0, 100, &fx.reorder_pct)) return DKF_EXIT_USAGE; break;
        case 'S': if (dkf_cli_num(prog, "--seed", optarg, 0, 4294967295.0, &seed)) return DKF_EXIT_USAGE; break;
        case 'X': if (dkf_cli_num(prog, "--exit-at", optarg, 1, 1e9, &exit_at)) return DKF_EXIT_USAGE; break;
        case 'J': if (dkf_cli_num(prog, "--join-at", optarg, 1, 1e9, &join_at)) return DKF_EXIT_USAGE; break;
        case 'E': if (dkf_cli_num(prog, "--epoch", optarg, 0, 1e6, &epoch)) return DKF_EXIT_USAGE; break;
        }
    }
    if (c != DKF_CLI_END) return DKF_CLI_EXIT(c);
    if (id < 0) {
        fprintf(stderr, "%s: --id: missing (see --help)\n", prog);
        return DKF_EXIT_USAGE;
    }
    if (seed != (double)(long)seed || exit_at != (double)(long)exit_at ||
        join_at != (double)(long)join_at || epoch != (double)(long)epoch) {
        fprintf(stderr, "%s: --seed, --exit-at, --join-at, --epoch: expected integers\n", prog);
        return DKF_EXIT_USAGE;
    }
    fx.seed = (uint64_t)seed;
    fx.exit_at = (long)exit_at;
    fx.join_at = (long)join_at;
    fx.epoch = (long)epoch;
    if (id != (double)(long)id || optind != argc - 1) {
        fprintf(stderr, "%s: %s\n", prog, id != (double)(long)id ? "--id: expected an integer"
                                                                  : "expected one SCENARIO file");
        return DKF_EXIT_USAGE;
    }
    code = dkf_cli_open(prog, &co, argv[optind], 0,
                        dkf_auth_signer(DKF_NET_ROLE_NODE, (size_t)id), &s, &net);
    if (code != DKF_EXIT_OK) return code;
    nd = dkf_net_node_create(net, s, filter, (size_t)id, co.prefix, err, sizeof err);
    if (nd == NULL) {
        fprintf(stderr, "%s: %s\n", prog, err);
        dkf_net_close(net);
        dkf_scenario_free(s);
        return DKF_EXIT_USAGE;
    }
    dkf_net_node_faults(nd, &fx);
    dkf_cli_signals();
    start = dkf_net_mono_us();
    dkf_net_node_tick(nd, start, (int64_t)(co.hb_ms * 1000));
    if (co.ready != NULL && dkf_cli_touch(prog, co.ready) != 0) dkf_cli_stop = 1;
    while (!dkf_cli_stop && dkf_net_node_state(nd) != DKF_NET_DONE &&
           dkf_net_node_state(nd) != DKF_NET_FAILED && !dkf_net_node_exited(nd) &&
           !dkf_cli_expired(start, co.timeout)) {
        if (dkf_net_handle(net, 20) < 0) break;
        dkf_net_node_tick(nd, dkf_net_mono_us(), (int64_t)(co.hb_ms * 1000));
    }
    leave_realtime();
    if (dkf_net_node_exited(nd)) {
        /* a crash, as asked: no final status, no summary but this line */
        if (!co.quiet) fprintf(stderr, "%s %ld: %s\n", prog, (long)id, dkf_net_node_error(nd));
        dkf_net_node_free(nd);
        dkf_net_close(net);
        dkf_scenario_free(s);
        return DKF_EXIT_OK;
    }
    switch (dkf_net_node_state(nd)) {
    case DKF_NET_DONE: code = DKF_EXIT_OK; break;
    case DKF_NET_FAILED: code = DKF_EXIT_RUN; break;
    default: code = DKF_EXIT_STOPPED; break;
    }
    dkf_net_node_report(nd);
    if (code == DKF_EXIT_RUN) fprintf(stderr, "%s: %s\n", prog, dkf_net_node_error(nd));
    if (!co.quiet) {
        const dkf_net_counts_t *cn = dkf_net_node_counts(nd);
        int64_t dr, du, re;
        dkf_net_node_fault_counts(nd, &dr, &du, &re);
        fprintf(stderr, "%s %ld: %s; epoch %ld from k=%ld; sent %lld, measurements accepted "
                "%lld, rejected %lld, out of sequence %lld; dropped %lld, duplicated %lld, "
                "reordered %lld\n", prog, (long)id,
                code == DKF_EXIT_OK ? "done" : code == DKF_EXIT_RUN ? "failed" : "stopped",
                dkf_net_node_epoch(nd), dkf_net_node_k_start(nd), (long long)cn->sent,
                (long long)cn->received, (long long)cn->rejected, (long long)cn->stale,
                (long long)dr, (long long)du, (long long)re);
    }
    dkf_net_node_free(nd);
    dkf_net_close(net);
    dkf_scenario_free(s);
    return code;
}
