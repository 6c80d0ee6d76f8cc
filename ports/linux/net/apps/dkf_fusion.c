/*
 * dkf-fusion - the fusion centre: subscribes to every node's messages,
 * rebuilds the centralized Difference-KF estimate (dkf/diffkf_fusion.h),
 * publishes it on <prefix>_FUSED and writes a result file
 * (docs/guide/network.md).
 *
 *   dkf-fusion --output fused.json tests/vectors/diffkf/ex3_multi.json
 */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "auth.h"
#include "centre.h"
#include "cli.h"
#include "net.h"

static const char *prog = "dkf-fusion";

static void usage(FILE *f)
{
    fprintf(f,
            "usage: %s [options] SCENARIO.json\n"
            "Fusion centre: subscribes to <prefix>_NODE_<i> of every node, fuses step k once\n"
            "every node's payload of step k is there (or the node has sent a later step's\n"
            "message k+2, or has been silent for DEADLINE of the others' arrivals) and\n"
            "publishes the centralized estimate on <prefix>_FUSED. A step still incomplete\n"
            "DEADLINE after it opened (its first payload, or a later step's), or pushed out\n"
            "of the 32-step window by newer data, is published DEGRADED: the centralized DKF\n"
            "given the rows of the nodes it could rebuild. A payload of one of the last %d\n"
            "steps that arrives late rolls back to a checkpoint, replays, and publishes\n"
            "every replayed step again (revision > 0). Exits after step N.\n"
            "\n"
            "  -u, --url URL           LCM URL (default %s);\n"
            "                          only udpm://239.x.y.z...?ttl=0 or memq:// are\n"
            "                          accepted (--lan sends udpm with ttl=1)\n"
            "  -p, --prefix P          channel prefix (default %s)\n"
            "  -d, --deadline-ms MS    per-step deadline (default %d)\n"
            "  -o, --output FILE       write the result (JSON: k, outputs.fused.{xf,xp,Pf,Pp},\n"
            "                          status, contributors, revisions, epochs, latency_us,\n"
            "                          counters) at exit\n"
            "  -j, --journal FILE      append every step as it is computed (JSON lines,\n"
            "                          flushed; default with --output: FILE.jsonl)\n"
            "      --heartbeat-ms MS   status period (default %d)\n"
            "  -t, --timeout S         give up after S seconds (default 0: never)\n"
            "      --steady TOL        reuse the centre's gain once the covariance recursion\n"
            "                          moves by less than TOL (relative) per step, for a\n"
            "                          time-invariant model (docs/design/diffkf-fusion.md §11;\n"
            "                          default 0: recompute every step)\n"
            DKF_CLI_PORTS_USAGE
            "      --key-dir DIR       authenticate every datagram with the keys in DIR\n"
            "                          (dkf-keygen; without it: unauthenticated, said on stderr)\n"
            DKF_CLI_LAN_USAGE
            "      --ready-file F      create F once subscribed (for scripts)\n"
            "  -q, --quiet             no summary line\n"
            "  -h, --help              this text\n"
            "A centre started or restarted mid-run joins at the first step it gets data of.\n"
            "A scenario of the weighted-fusion layout (seed 002) runs the weighted fusion\n"
            "centre instead: the local KFs' x_i(k|k) (dkf-node --filter local_kf) fused with\n"
            "scalar and matrix weights over the nodes present (docs/guide/network.md).\n"
            "Exit: 0 step N published, 2 bad options/scenario, 3 set-up, core or output failure,\n"
            "4 interrupted (SIGINT/SIGTERM/--timeout) before step N (the file is written).\n",
            prog, DKF_NET_CKPT, DKF_NET_DEFAULT_URL, DKF_NET_PREFIX, DKF_NET_DEADLINE_US / 1000,
            DKF_NET_HEARTBEAT_US / 1000);
}

int main(int argc, char **argv)
{
    static const struct option longopts[] = {
        DKF_CLI_LONGOPTS_NET, DKF_CLI_LONGOPTS_PORTS, DKF_CLI_LONGOPT_READY,
        DKF_CLI_LONGOPT_HEARTBEAT,
        {"deadline-ms", required_argument, NULL, 'd'}, {"output", required_argument, NULL, 'o'},
        {"journal", required_argument, NULL, 'j'},     {"steady", required_argument, NULL, 'S'},
        {NULL, 0, NULL, 0}};
    dkf_cli_opts_t co;
    const char *out = NULL;
    const char *jpath = NULL;
    char jdefault[4096];
    FILE *jf = NULL;
    double deadline_ms = DKF_NET_DEADLINE_US / 1000;
    double steady = 0;
    int c, code;
    char err[DKF_SCN_ERR_LEN];
    dkf_scenario_t *s;
    dkf_net_t *net;
    dkf_net_fusion_t *fu;
    int64_t start;
    dkf_cli_opts_init(&co, DKF_NET_PREFIX);
    while ((c = dkf_cli_getopt(prog, argc, argv, ":u:p:d:o:j:t:qh", longopts, usage, &co)) > 0) {
        switch (c) {
        case 'd': if (dkf_cli_num(prog, "--deadline-ms", optarg, 1, 1e8, &deadline_ms)) return DKF_EXIT_USAGE; break;
        case 'o': out = optarg; break;
        case 'j': jpath = optarg; break;
        case 'S': if (dkf_cli_num(prog, "--steady", optarg, 0, 0.5, &steady)) return DKF_EXIT_USAGE; break;
        }
    }
    if (c != DKF_CLI_END) return DKF_CLI_EXIT(c);
    if (optind != argc - 1) {
        fprintf(stderr, "%s: expected one SCENARIO file (see --help)\n", prog);
        return DKF_EXIT_USAGE;
    }
    code = dkf_cli_open(prog, &co, argv[optind], 0, dkf_auth_signer(DKF_NET_ROLE_FUSION, 0), &s,
                        &net);
    if (code != DKF_EXIT_OK) return code;
    fu = dkf_net_fusion_create(net, s, co.prefix, (int64_t)(deadline_ms * 1000), err, sizeof err);
    if (fu != NULL && steady > 0 && dkf_net_fusion_steady(fu, steady) != 0) {
        snprintf(err, sizeof err, "--steady: a weighted-fusion centre has no gain to settle");
        dkf_net_fusion_free(fu);
        fu = NULL;
    }
    if (fu == NULL) {
        fprintf(stderr, "%s: %s\n", prog, err);
        dkf_net_close(net);
        dkf_scenario_free(s);
        return DKF_EXIT_RUN;
    }
    if (jpath == NULL && out != NULL) {
        snprintf(jdefault, sizeof jdefault, "%s.jsonl", out);
        jpath = jdefault;
    }
    if (jpath != NULL) {
        jf = fopen(jpath, "a");
        if (jf == NULL) {
            fprintf(stderr, "%s: %s: cannot open the journal\n", prog, jpath);
            dkf_net_fusion_free(fu);
            dkf_net_close(net);
            dkf_scenario_free(s);
            return DKF_EXIT_RUN;
        }
        dkf_net_fusion_journal(fu, jf);
    }
    dkf_cli_signals();
    start = dkf_net_mono_us();
    dkf_net_fusion_tick(fu, start, (int64_t)(co.hb_ms * 1000));
    if (co.ready != NULL && dkf_cli_touch(prog, co.ready) != 0) dkf_cli_stop = 1;
    while (!dkf_cli_stop && dkf_net_fusion_state(fu) == DKF_NET_RUNNING &&
           !dkf_cli_expired(start, co.timeout)) {
        if (dkf_net_handle(net, 10) < 0) break;
        dkf_net_fusion_tick(fu, dkf_net_mono_us(), (int64_t)(co.hb_ms * 1000));
    }
    code = dkf_net_fusion_state(fu) == DKF_NET_DONE     ? DKF_EXIT_OK
           : dkf_net_fusion_state(fu) == DKF_NET_FAILED ? DKF_EXIT_RUN
                                                        : DKF_EXIT_STOPPED;
    dkf_net_fusion_report(fu);
    if (code == DKF_EXIT_OK) {
        /* the last fused datagram has no successor to make up for its loss:
         * the final status (k = N) is repeated for 0.1 s, which dkf-sim also
         * takes as the confirmation of step N */
        int i;
        for (i = 0; i < 5 && dkf_net_handle(net, 20) >= 0; ++i) dkf_net_fusion_report(fu);
    }
    if (out != NULL) {
        json_t *doc = dkf_net_fusion_result(fu);
        json_object_set_new(doc, "auth", dkf_cli_auth_json(net));
        json_object_set_new(doc, "receive", dkf_cli_rx_json(net));
        json_object_set_new(doc, "clock", dkf_cli_clock_json());
        if (dkf_cli_write_json(prog, out, doc) != 0) code = DKF_EXIT_RUN;
        json_decref(doc);
    }
    if (!co.quiet) {
        const dkf_net_counts_t *cn = dkf_net_fusion_counts(fu);
        fprintf(stderr, "%s: %s at k=%ld/%zu; degraded %lld, messages accepted %lld, rejected "
                "%lld, stale %lld\n", prog,
                code == DKF_EXIT_OK ? "done" : code == DKF_EXIT_RUN ? "failed" : "stopped",
                dkf_net_fusion_k(fu), s->steps, (long long)cn->missed, (long long)cn->received,
                (long long)cn->rejected, (long long)cn->stale);
    }
    if (jf != NULL && fclose(jf) != 0) {
        fprintf(stderr, "%s: %s: cannot write the journal\n", prog, jpath);
        code = DKF_EXIT_RUN;
    }
    dkf_net_fusion_free(fu);
    dkf_net_close(net);
    dkf_scenario_free(s);
    return code;
}
