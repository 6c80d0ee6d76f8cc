/*
 * dkf-m4-bridge - node I of the network computed by the live node image on
 * an emulated Cortex-M4F (qemu-system-arm -M mps2-an386, dkf_m4_live.elf;
 * docs/guide/network.md, "A firmware node in the network"): subscribes to
 * <prefix>_MEAS_I, hands each measurement (with the step's model) to the
 * image, and publishes the image's {x_{k|k}, x_{k|k-1}} on <prefix>_NODE_I
 * signed as node I, through the same node agent as dkf-node.
 *
 *   dkf-m4-bridge --id 1 --image build/m4-double/dkf_m4_live.elf \
 *                 --key-dir keys --output m4.json SCENARIO.json
 */
#define _POSIX_C_SOURCE 200809L /* access */
#include <errno.h>
#include <getopt.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "agents.h"
#include "auth.h"
#include "cli.h"
#include "m4_node.h"
#include "net.h"

static const char *prog = "dkf-m4-bridge";

static void usage(FILE *f)
{
    fprintf(f,
            "usage: %s --id I --image ELF [options] SCENARIO.json\n"
            "Runs node I of the scenario on the emulated Cortex-M4F: subscribes to\n"
            "<prefix>_MEAS_I, feeds each measurement to the live node image under\n"
            "qemu-system-arm -M mps2-an386 and publishes the image's message on\n"
            "<prefix>_NODE_I, as dkf-node does (same message, same signature).\n"
            "\n"
            "  -i, --id I              sensor index (0-based), required\n"
            "      --image ELF         the live node image (ports/cortex-m4: dkf_m4_live.elf,\n"
            "                          built with this build's DKF_REAL), required\n"
            "      --qemu PROG         the emulator (default qemu-system-arm on PATH)\n"
            "      --m4-timeout S      the longest wait for one answer of the image\n"
            "                          (default 10)\n"
            "  -o, --output FILE       write the image's messages and the counters (JSON)\n"
            "The network options are dkf-node's (dkf-node --help): -u/--url URL\n"
            "(default %s), -p/--prefix P (default %s), --heartbeat-ms MS\n"
            "(default %d), -t/--timeout S, --split-ports, --direct-recv, --key-dir DIR,\n"
            "--ready-file F, -q/--quiet, -h/--help.\n"
            "Exit: 0 done, 2 bad options/scenario or no emulator, 3 the image, a filter\n"
            "call or the transport failed, 4 interrupted (SIGINT/SIGTERM/--timeout).\n",
            prog, DKF_NET_DEFAULT_URL, DKF_NET_PREFIX, DKF_NET_HEARTBEAT_US / 1000);
}

/* 1 if prog names an executable (a path, or a name found on PATH). */
static int executable(const char *p)
{
    const char *path = getenv("PATH");
    char buf[PATH_MAX];
    if (strchr(p, '/') != NULL) return access(p, X_OK) == 0;
    while (path != NULL && *path != '\0') {
        const char *end = strchr(path, ':');
        const size_t len = end != NULL ? (size_t)(end - path) : strlen(path);
        if (snprintf(buf, sizeof buf, "%.*s/%s", (int)len, path, p) < (int)sizeof buf &&
            access(buf, X_OK) == 0)
            return 1;
        path = end != NULL ? end + 1 : NULL;
    }
    return 0;
}

/* The result file: the image's messages, the node's counters, auth. */
static int write_output(const char *path, const dkf_m4_conf_t *conf, dkf_net_node_t *nd,
                        const dkf_net_t *net, long id, int code)
{
    const dkf_net_counts_t *cn = dkf_net_node_counts(nd);
    json_t *doc = json_pack("{sIsssssosIsIsIsIsoso}", "node", (json_int_t)id, "image",
                            conf->image, "state",
                            code == DKF_EXIT_OK ? "done" : code == DKF_EXIT_RUN ? "failed" : "stopped",
                            "messages", conf->live != NULL ? dkf_m4_node_json(conf->live) : json_null(),
                            "sent", (json_int_t)cn->sent, "received", (json_int_t)cn->received,
                            "rejected", (json_int_t)cn->rejected, "out_of_sequence",
                            (json_int_t)cn->stale, "auth", dkf_cli_auth_json(net), "error",
                            json_string(dkf_net_node_error(nd)));
    int rc = doc != NULL ? dkf_cli_write_json(prog, path, doc) : -1;
    json_decref(doc);
    return rc;
}

/* The command line into conf, co, *id, *output: DKF_EXIT_OK to run, -1
 * after --help, or the exit status to give (the problem said). */
static int parse(int argc, char **argv, dkf_m4_conf_t *conf, dkf_cli_opts_t *co, long *id,
                 const char **output)
{
    static const struct option longopts[] = {
        DKF_CLI_LONGOPTS_NET, DKF_CLI_LONGOPTS_PORTS, DKF_CLI_LONGOPT_READY,
        DKF_CLI_LONGOPT_HEARTBEAT,
        {"id", required_argument, NULL, 'i'},      {"image", required_argument, NULL, 'I'},
        {"qemu", required_argument, NULL, 'Q'},    {"m4-timeout", required_argument, NULL, 'T'},
        {"output", required_argument, NULL, 'o'},  {NULL, 0, NULL, 0}};
    double num = -1;
    const char *bad = NULL;
    int c;
    dkf_cli_opts_init(co, DKF_NET_PREFIX);
    while ((c = dkf_cli_getopt(prog, argc, argv, ":i:o:u:p:t:qh", longopts, usage, co)) > 0) {
        if (c == 'I') conf->image = optarg;
        else if (c == 'Q') conf->qemu = optarg;
        else if (c == 'o') *output = optarg;
        else if ((c == 'i' && dkf_cli_num(prog, "--id", optarg, 0, 1e6, &num)) ||
                 (c == 'T' && dkf_cli_num(prog, "--m4-timeout", optarg, 0.01, 1e6, &conf->timeout_s)))
            return DKF_EXIT_USAGE;
    }
    if (c != DKF_CLI_END) return c == DKF_CLI_HELP ? -1 : DKF_EXIT_USAGE;
    if (num < 0) bad = "--id: missing";
    else if (num != (double)(long)num) bad = "--id: expected an integer";
    else if (conf->image == NULL) bad = "--image: missing";
    else if (optind != argc - 1) bad = "expected one SCENARIO file";
    if (bad != NULL) {
        fprintf(stderr, "%s: %s (see --help)\n", prog, bad);
        return DKF_EXIT_USAGE;
    }
    if (!executable(conf->qemu)) {
        fprintf(stderr, "%s: %s: not found; the emulated node needs QEMU's Arm system "
                "emulator (Debian: apt-get install qemu-system-arm), or --qemu PROG\n", prog,
                conf->qemu);
        return DKF_EXIT_USAGE;
    }
    if (access(conf->image, R_OK) != 0) {
        fprintf(stderr, "%s: --image %s: %s\n", prog, conf->image, strerror(errno));
        return DKF_EXIT_USAGE;
    }
    *id = (long)num;
    return DKF_EXIT_OK;
}

int main(int argc, char **argv)
{
    dkf_m4_conf_t conf = {"qemu-system-arm", NULL, 10.0, NULL};
    dkf_family_t fam;
    dkf_filter_t filter;
    dkf_cli_opts_t co;
    const char *output = NULL;
    char err[DKF_SCN_ERR_LEN];
    long id = -1;
    int code = parse(argc, argv, &conf, &co, &id, &output);
    dkf_scenario_t *s;
    dkf_net_t *net;
    dkf_net_node_t *nd;
    int64_t start;
    if (code != DKF_EXIT_OK) return code < 0 ? DKF_EXIT_OK : code;
    dkf_m4_filter(&conf, &fam, &filter);
    code = dkf_cli_open(prog, &co, argv[optind], 0,
                        dkf_auth_signer(DKF_NET_ROLE_NODE, (size_t)id), &s, &net);
    if (code != DKF_EXIT_OK) return code;
    nd = dkf_net_node_create(net, s, &filter, (size_t)id, co.prefix, err, sizeof err);
    if (nd == NULL) {
        fprintf(stderr, "%s: %s\n", prog, err);
        dkf_net_close(net);
        dkf_scenario_free(s);
        return DKF_EXIT_RUN;
    }
    dkf_cli_signals();
    start = dkf_net_mono_us();
    dkf_net_node_tick(nd, start, (int64_t)(co.hb_ms * 1000));
    if (co.ready != NULL && dkf_cli_touch(prog, co.ready) != 0) dkf_cli_stop = 1;
    while (!dkf_cli_stop && dkf_net_node_state(nd) != DKF_NET_DONE &&
           dkf_net_node_state(nd) != DKF_NET_FAILED && !dkf_cli_expired(start, co.timeout)) {
        if (dkf_net_handle(net, 20) < 0) break;
        dkf_net_node_tick(nd, dkf_net_mono_us(), (int64_t)(co.hb_ms * 1000));
    }
    code = dkf_net_node_state(nd) == DKF_NET_DONE     ? DKF_EXIT_OK
           : dkf_net_node_state(nd) == DKF_NET_FAILED ? DKF_EXIT_RUN
                                                      : DKF_EXIT_STOPPED;
    dkf_net_node_report(nd);
    if (code == DKF_EXIT_OK && dkf_m4_node_finish(conf.live, err, sizeof err) != 0) {
        fprintf(stderr, "%s: %s\n", prog, err);
        code = DKF_EXIT_RUN;
    }
    if (code == DKF_EXIT_RUN && dkf_net_node_error(nd)[0] != '\0')
        fprintf(stderr, "%s: %s\n", prog, dkf_net_node_error(nd));
    if (output != NULL && write_output(output, &conf, nd, net, id, code) != 0 &&
        code == DKF_EXIT_OK)
        code = DKF_EXIT_USAGE;
    if (!co.quiet) {
        const dkf_net_counts_t *cn = dkf_net_node_counts(nd);
        fprintf(stderr, "%s %ld: %s; sent %lld, measurements accepted %lld, rejected %lld, out "
                "of sequence %lld\n", prog, id,
                code == DKF_EXIT_OK ? "done" : code == DKF_EXIT_RUN ? "failed" : "stopped",
                (long long)cn->sent, (long long)cn->received, (long long)cn->rejected,
                (long long)cn->stale);
    }
    dkf_net_node_free(nd);
    dkf_net_close(net);
    dkf_scenario_free(s);
    return code;
}
