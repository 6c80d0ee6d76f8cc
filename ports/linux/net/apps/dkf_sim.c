/*
 * dkf-sim - publishes a scenario's measurements, one channel per sensor,
 * and its truth, either paced (--rate HZ) or in lock-step with the fusion
 * centre (--lockstep) (docs/guide/network.md).
 *
 *   dkf-sim --lockstep tests/vectors/diffkf/ex3_multi.json
 */
#define _POSIX_C_SOURCE 200809L

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "agents.h"
#include "auth.h"
#include "cli.h"
#include "net.h"

static const char *prog = "dkf-sim";

static void usage(FILE *f)
{
    fprintf(f,
            "usage: %s (--rate HZ | --lockstep [--rate HZ]) [options] SCENARIO.json\n"
            "Publishes y^i_j of every sensor i on <prefix>_MEAS_<i> and x_j on <prefix>_TRUTH\n"
            "for j = 1..N+1. First waits until every node and the fusion centre has sent a\n"
            "status with this scenario's model id (unless --no-wait).\n"
            "\n"
            "  -r, --rate HZ           publish one time step every 1/HZ s\n"
            "  -l, --lockstep          publish y_{j+1} only after the fused estimate of step\n"
            "                          j-1 (which needs y_j) has been seen on <prefix>_FUSED;\n"
            "                          with --rate, also at most HZ steps per second (the run\n"
            "                          then cannot outpace a node the centre gave up on:\n"
            "                          docs/design/network.md, Faults)\n"
            "  -u, --url URL           LCM URL (default %s);\n"
            "                          only udpm://239.x.y.z...?ttl=0 or memq:// are\n"
            "                          accepted (--lan sends udpm with ttl=1)\n"
            "  -p, --prefix P          channel prefix (default %s)\n"
            "      --run R             Monte-Carlo run of the file to publish (default 0)\n"
            "      --wait-ready S      how long to wait for the peers (default 10)\n"
            "      --no-wait           do not wait for the peers\n"
            "      --optional-node I   do not wait for node I (late, or never starting;\n"
            "                          repeatable)\n"
            "      --step-timeout S    lock-step and final wait for a fused step (default 10)\n"
            "  -t, --timeout S         give up after S seconds (default 0: never)\n"
            DKF_CLI_PORTS_USAGE
            "      --key-dir DIR       authenticate every datagram with the keys in DIR\n"
            "                          (dkf-keygen; without it: unauthenticated, said on stderr)\n"
            DKF_CLI_LAN_USAGE
            "  -q, --quiet             no summary line\n"
            "  -h, --help              this text\n"
            "Exit: 0 every step published (and, unless --no-wait, fused), 2 bad options or\n"
            "scenario, 3 a peer failed, runs another model or a wait timed out, 4 interrupted.\n",
            prog, DKF_NET_DEFAULT_URL, DKF_NET_PREFIX);
}

/* Handles messages until cond(sim, j) holds, a peer is in trouble, the
 * wait or the run times out, or a signal; returns 0 when cond held. */
static int wait_for(dkf_net_t *net, dkf_net_sim_t *sim, int (*cond)(dkf_net_sim_t *, long),
                    long j, double wait_s, int64_t start, double timeout, const char *what)
{
    const int64_t t0 = dkf_net_mono_us();
    char why[256];
    while (!cond(sim, j)) {
        if (dkf_cli_stop || dkf_cli_expired(start, timeout)) return DKF_EXIT_STOPPED;
        if (dkf_net_sim_trouble(sim, why, sizeof why)) {
            fprintf(stderr, "%s: %s\n", prog, why);
            return DKF_EXIT_RUN;
        }
        if (dkf_cli_expired(t0, wait_s)) {
            dkf_net_sim_ready(sim, why, sizeof why);
            fprintf(stderr, "%s: no %s after %g s%s%s\n", prog, what, wait_s,
                    why[0] ? "; not ready: " : "", why[0] ? why : "");
            return DKF_EXIT_RUN;
        }
        if (dkf_net_handle(net, 10) < 0) return DKF_EXIT_RUN;
        dkf_net_sim_tick(sim, dkf_net_mono_us(), 0);
    }
    return DKF_EXIT_OK;
}

static int is_ready(dkf_net_sim_t *sim, long j)
{
    (void)j;
    return dkf_net_sim_ready(sim, NULL, 0);
}

static int has_fused(dkf_net_sim_t *sim, long k)
{
    return dkf_net_sim_fused_k(sim) >= k;
}

int main(int argc, char **argv)
{
    static const struct option longopts[] = {
        DKF_CLI_LONGOPTS_NET, DKF_CLI_LONGOPTS_PORTS,
        {"rate", required_argument, NULL, 'r'},      {"lockstep", no_argument, NULL, 'l'},
        {"run", required_argument, NULL, 'n'},       {"wait-ready", required_argument, NULL, 'w'},
        {"no-wait", no_argument, NULL, 'W'},         {"step-timeout", required_argument, NULL, 's'},
        {"optional-node", required_argument, NULL, 'O'}, {NULL, 0, NULL, 0}};
    dkf_cli_opts_t co;
    double optional[DKF_NET_MAX_NODES];
    size_t noptional = 0, oi;
    double rate = 0, run = 0, wait_ready = 10, step_timeout = 10;
    int lockstep = 0, no_wait = 0, c, code = DKF_EXIT_OK;
    char err[DKF_SCN_ERR_LEN];
    dkf_scenario_t *s;
    dkf_net_t *net;
    dkf_net_sim_t *sim;
    int64_t start, next;
    long j, last;
    dkf_cli_opts_init(&co, DKF_NET_PREFIX);
    while ((c = dkf_cli_getopt(prog, argc, argv, ":r:lu:p:t:qh", longopts, usage, &co)) > 0) {
        switch (c) {
        case 'r': if (dkf_cli_num(prog, "--rate", optarg, 1e-3, 1e6, &rate)) return DKF_EXIT_USAGE; break;
        case 'l': lockstep = 1; break;
        case 'n': if (dkf_cli_num(prog, "--run", optarg, 0, 1e9, &run)) return DKF_EXIT_USAGE; break;
        case 'w': if (dkf_cli_num(prog, "--wait-ready", optarg, 0, 1e6, &wait_ready)) return DKF_EXIT_USAGE; break;
        case 'W': no_wait = 1; break;
        case 's': if (dkf_cli_num(prog, "--step-timeout", optarg, 0.001, 1e6, &step_timeout)) return DKF_EXIT_USAGE; break;
        case 'O':
            if (noptional == DKF_NET_MAX_NODES ||
                dkf_cli_num(prog, "--optional-node", optarg, 0, DKF_NET_MAX_NODES - 1,
                            &optional[noptional]))
                return DKF_EXIT_USAGE;
            ++noptional;
            break;
        }
    }
    if (c != DKF_CLI_END) return DKF_CLI_EXIT(c);
    if (rate <= 0 && !lockstep) {
        fprintf(stderr, "%s: give --rate HZ, --lockstep or both (see --help)\n", prog);
        return DKF_EXIT_USAGE;
    }
    if (lockstep && no_wait) {
        fprintf(stderr, "%s: --lockstep needs the fusion centre: --no-wait is not allowed\n", prog);
        return DKF_EXIT_USAGE;
    }
    if (optind != argc - 1 || run != (double)(long)run) {
        fprintf(stderr, "%s: %s (see --help)\n", prog,
                optind != argc - 1 ? "expected one SCENARIO file" : "--run: expected an integer");
        return DKF_EXIT_USAGE;
    }
    code = dkf_cli_open(prog, &co, argv[optind], (long)run, dkf_auth_signer(DKF_NET_ROLE_SIM, 0),
                        &s, &net);
    if (code != DKF_EXIT_OK) return code;
    sim = dkf_net_sim_create(net, s, co.prefix, err, sizeof err);
    if (sim == NULL) {
        fprintf(stderr, "%s: %s\n", prog, err);
        dkf_net_close(net);
        dkf_scenario_free(s);
        return DKF_EXIT_RUN;
    }
    for (oi = 0; oi < noptional; ++oi)
        if (optional[oi] != (double)(long)optional[oi] ||
            dkf_net_sim_optional_node(sim, (size_t)optional[oi]) != 0) {
            fprintf(stderr, "%s: --optional-node %g: the scenario has %zu nodes\n", prog,
                    optional[oi], s->nsensors);
            dkf_net_sim_free(sim);
            dkf_net_close(net);
            dkf_scenario_free(s);
            return DKF_EXIT_USAGE;
        }
    dkf_cli_signals();
    start = dkf_net_mono_us();
    dkf_net_sim_tick(sim, start, 0);
    if (!no_wait)
        code = wait_for(net, sim, is_ready, 0, wait_ready, start, co.timeout, "peers");
    last = dkf_net_sim_last(sim);
    next = dkf_net_mono_us();
    for (j = 1; code == DKF_EXIT_OK && j <= last; ++j) {
        if (dkf_net_sim_publish(sim, j) != 0) {
            fprintf(stderr, "%s: step %ld: cannot publish\n", prog, j);
            code = DKF_EXIT_RUN;
            break;
        }
        if (lockstep && j >= 2)
            code = wait_for(net, sim, has_fused, j - 1, step_timeout, start, co.timeout,
                            "fused estimate");
        if (code == DKF_EXIT_OK && rate > 0) {
            /* paced: keep handling (status, fused) until the next tick; in
             * lock-step the tick is at least 1/HZ after this step's (a long
             * wait for a fused step is no credit for a burst after it) */
            const int64_t now = dkf_net_mono_us();
            if (lockstep && next < now) next = now;
            next += (int64_t)(1e6 / rate);
            while (!dkf_cli_stop && dkf_net_mono_us() < next) {
                int64_t left = (next - dkf_net_mono_us()) / 1000;
                dkf_net_handle(net, left > 10 ? 10 : (int)(left > 0 ? left : 0));
                dkf_net_sim_tick(sim, dkf_net_mono_us(), 0);
            }
            if (dkf_cli_stop) code = DKF_EXIT_STOPPED;
            else if (dkf_net_sim_trouble(sim, err, sizeof err)) {
                fprintf(stderr, "%s: %s\n", prog, err);
                code = DKF_EXIT_RUN;
            }
        }
    }
    /* paced: wait for the last fused step as well (unless told not to wait) */
    if (code == DKF_EXIT_OK && !lockstep && !no_wait)
        code = wait_for(net, sim, has_fused, last - 1, step_timeout, start, co.timeout,
                        "fused estimate");
    dkf_net_sim_report(sim, code == DKF_EXIT_OK ? DKF_NET_DONE : DKF_NET_FAILED);
    if (!co.quiet) {
        const dkf_net_counts_t *cn = dkf_net_sim_counts(sim);
        fprintf(stderr, "%s: %s; published %lld measurements, fused steps seen up to k=%ld\n",
                prog, code == DKF_EXIT_OK ? "done" : code == DKF_EXIT_STOPPED ? "stopped" : "failed",
                (long long)cn->sent, dkf_net_sim_fused_k(sim));
        dkf_cli_print_refusals(prog, &cn->why, net);
    }
    dkf_net_sim_free(sim);
    dkf_net_close(net);
    dkf_scenario_free(s);
    return code;
}
