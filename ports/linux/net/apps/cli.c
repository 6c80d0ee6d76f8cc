/*
 * cli.c - shared helpers of the network programs (cli.h).
 */
#define _POSIX_C_SOURCE 200809L

#include "cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "auth.h"
#include "model.h"
#include "net.h"
#include "report.h"

volatile sig_atomic_t dkf_cli_stop = 0;

static void on_signal(int sig)
{
    (void)sig;
    dkf_cli_stop = 1;
}

void dkf_cli_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

int dkf_cli_num(const char *prog, const char *opt, const char *arg, double lo, double hi,
                double *out)
{
    char *end = NULL;
    double v;
    errno = 0;
    v = strtod(arg, &end);
    if (end == arg || *end != '\0' || errno != 0 || !isfinite(v) || v < lo || v > hi) {
        fprintf(stderr, "%s: %s %s: expected a number in [%g, %g]\n", prog, opt, arg, lo, hi);
        return -1;
    }
    *out = v;
    return 0;
}

void dkf_cli_bad_option(const char *prog, int argc, char **argv, int optind_now, int optopt_now)
{
    const char *what = (optind_now - 1 >= 1 && optind_now - 1 < argc) ? argv[optind_now - 1] : "?";
    (void)optopt_now;
    fprintf(stderr, "%s: %s: unrecognized option or missing argument (see --help)\n", prog, what);
}

dkf_scenario_t *dkf_cli_scenario(const char *prog, const char *path, long run)
{
    char err[DKF_SCN_ERR_LEN];
    dkf_scenario_t *s = dkf_scenario_load(path, NULL, err, sizeof err);
    if (s == NULL) {
        fprintf(stderr, "%s: %s\n", prog, err);
        return NULL;
    }
    if (run < 0 || (size_t)run >= s->nruns) {
        fprintf(stderr, "%s: %s: --run %ld: the file has %zu run(s)\n", prog, path, run, s->nruns);
        dkf_scenario_free(s);
        return NULL;
    }
    dkf_scn_select_run(s, (size_t)run);
    if (dkf_net_check_scenario(s, err, sizeof err) != 0) {
        fprintf(stderr, "%s: %s\n", prog, err);
        dkf_scenario_free(s);
        return NULL;
    }
    return s;
}

int dkf_cli_write_json(const char *prog, const char *path, const json_t *doc)
{
    if (json_dump_file(doc, path, JSON_COMPACT | JSON_REAL_PRECISION(17)) != 0) {
        fprintf(stderr, "%s: %s: cannot write the output\n", prog, path);
        return -1;
    }
    return 0;
}

int dkf_cli_touch(const char *prog, const char *path)
{
    FILE *f = fopen(path, "w");
    if (f == NULL || fclose(f) != 0) {
        fprintf(stderr, "%s: %s: cannot create the ready file\n", prog, path);
        return -1;
    }
    return 0;
}

int dkf_cli_expired(int64_t start_mono_us, double timeout_s)
{
    return timeout_s > 0 && (double)(dkf_net_mono_us() - start_mono_us) >= timeout_s * 1e6;
}

void dkf_cli_opts_init(dkf_cli_opts_t *o, const char *prefix)
{
    memset(o, 0, sizeof *o);
    o->url = DKF_NET_DEFAULT_URL;
    o->prefix = prefix;
    o->hb_ms = DKF_NET_HEARTBEAT_US / 1000;
}

/* Takes c (with arg) into o if it is a shared option: 1 when it was one,
 * 0 when it is not, -1 after printing why its value is bad. */
static int shared_opt(const char *prog, int c, const char *arg, dkf_cli_opts_t *o)
{
    switch (c) {
    case 'u': o->url = arg; return 1;
    case 'p': o->prefix = arg; return 1;
    case 't': return dkf_cli_num(prog, "--timeout", arg, 0, 1e7, &o->timeout) ? -1 : 1;
    case 'H': return dkf_cli_num(prog, "--heartbeat-ms", arg, 1, 1e7, &o->hb_ms) ? -1 : 1;
    case 'K': o->key_dir = arg; return 1;
    case 'R': o->ready = arg; return 1;
    case 'L': o->ports |= DKF_CLI_SPLIT; return 1;
    case 'Y': o->ports |= DKF_CLI_DIRECT; return 1;
    case 'q': o->quiet = 1; return 1;
    case DKF_CLI_OPT_LAN: o->lan = 1; return 1;
    case DKF_CLI_OPT_INSECURE: o->insecure = 1; return 1;
    case DKF_CLI_OPT_CLOCK:
        if (dkf_cli_num(prog, "--clock-offset-ms", arg, -1e9, 1e9, &o->clock_ms)) return -1;
        dkf_net_clock_set_offset_us((int64_t)llround(o->clock_ms * 1000));
        return 1;
    default: return 0;
    }
}

int dkf_cli_getopt(const char *prog, int argc, char **argv, const char *shortopts,
                   const struct option *longopts, void (*usage)(FILE *), dkf_cli_opts_t *o)
{
    int c, shared;
    opterr = 0;
    do {
        c = getopt_long(argc, argv, shortopts, longopts, NULL);
        if (c == -1) return DKF_CLI_END;
        if (c == 'h') {
            usage(stdout);
            return DKF_CLI_HELP;
        }
        if (c == '?' || c == ':') {
            dkf_cli_bad_option(prog, argc, argv, optind, optopt);
            return DKF_CLI_BAD;
        }
        shared = shared_opt(prog, c, optarg, o);
    } while (shared > 0);
    return shared < 0 ? DKF_CLI_BAD : c;
}

int dkf_cli_check_net(const char *prog, const dkf_cli_opts_t *o)
{
    char err[DKF_NET_ERR_LEN];
    if (dkf_net_check_url_scope(o->url, o->lan ? DKF_NET_LAN : DKF_NET_HOST, err, sizeof err) !=
        0) {
        fprintf(stderr, "%s: %s\n", prog, err);
        return DKF_EXIT_USAGE;
    }
    if (o->insecure && !o->lan) {
        fprintf(stderr, "%s: --insecure: only with --lan (without it the run stays on this "
                "host)\n", prog);
        return DKF_EXIT_USAGE;
    }
    if (o->insecure && o->key_dir != NULL) {
        fprintf(stderr, "%s: --insecure and --key-dir: give one\n", prog);
        return DKF_EXIT_USAGE;
    }
    if (o->lan && o->key_dir == NULL && !o->insecure) {
        fprintf(stderr, "%s: --lan without --key-dir: refused: on a shared segment anyone "
                "could speak for any process of this run; give the keys (dkf-keygen; "
                "docs/guide/network.md, Several hosts), or --insecure to run unauthenticated\n",
                prog);
        return DKF_EXIT_USAGE;
    }
    return DKF_EXIT_OK;
}

dkf_net_t *dkf_cli_net_open(const dkf_cli_opts_t *o, char *err, size_t errlen)
{
    return dkf_net_open_scope(o->url, o->lan ? DKF_NET_LAN : DKF_NET_HOST, err, errlen);
}

int dkf_cli_open(const char *prog, const dkf_cli_opts_t *o, const char *path, long run,
                 uint32_t self, dkf_scenario_t **s, dkf_net_t **net)
{
    char err[256];
    int st;
    if (strlen(o->prefix) == 0 || strlen(o->prefix) > 24) {
        fprintf(stderr, "%s: --prefix %s: expected 1..24 characters\n", prog, o->prefix);
        return DKF_EXIT_USAGE;
    }
    if (dkf_cli_check_net(prog, o) != DKF_EXIT_OK) return DKF_EXIT_USAGE;
    *s = dkf_cli_scenario(prog, path, run);
    if (*s == NULL) return DKF_EXIT_USAGE;
    *net = dkf_cli_net_open(o, err, sizeof err);
    if (*net == NULL) {
        fprintf(stderr, "%s: %s\n", prog, err);
        dkf_scenario_free(*s);
        *s = NULL;
        return DKF_EXIT_RUN;
    }
    if (((o->ports & DKF_CLI_SPLIT) && dkf_net_split(*net, err, sizeof err) != 0) ||
        ((o->ports & DKF_CLI_DIRECT) && dkf_net_direct(*net, err, sizeof err) != 0)) {
        fprintf(stderr, "%s: %s\n", prog, err);
        st = DKF_EXIT_USAGE;
    } else {
        st = dkf_cli_auth(prog, o, *net, self, (*s)->nsensors);
    }
    if (st != DKF_EXIT_OK) {
        dkf_net_close(*net);
        dkf_scenario_free(*s);
        *net = NULL;
        *s = NULL;
    }
    return st;
}

/* Installs what dkf_auth_open* made of o->key_dir (NULL: that failed, err
 * says why); without key_dir says it runs unauthenticated (--lan
 * --insecure: on the segment). Exit status. */
static int install_auth(const char *prog, const dkf_cli_opts_t *o, dkf_net_t *net, dkf_auth_t *a,
                        const char *err)
{
    if (o->key_dir == NULL && o->lan) {
        fprintf(stderr, "%s: UNAUTHENTICATED on the LAN (--insecure): anyone on the local "
                "segment can speak for any process of this run (docs/guide/network.md, "
                "Several hosts)\n", prog);
        return DKF_EXIT_OK;
    }
    if (o->key_dir == NULL) {
        fprintf(stderr, "%s: UNAUTHENTICATED: no --key-dir, so anyone on the multicast group "
                "can speak for any process of this run (docs/guide/network.md, Authentication)\n",
                prog);
        return DKF_EXIT_OK;
    }
    if (a == NULL) {
        fprintf(stderr, "%s: --key-dir %s: %s\n", prog, o->key_dir, err);
        return DKF_EXIT_USAGE;
    }
    dkf_net_set_auth(net, a);
    return DKF_EXIT_OK;
}

int dkf_cli_auth(const char *prog, const dkf_cli_opts_t *o, dkf_net_t *net, uint32_t self,
                 size_t nodes)
{
    char err[4200] = "";
    dkf_auth_t *a = o->key_dir ? dkf_auth_open(o->key_dir, self, nodes, err, sizeof err) : NULL;
    return install_auth(prog, o, net, a, err);
}

int dkf_cli_auth_edges(const char *prog, const dkf_cli_opts_t *o, dkf_net_t *net, size_t self,
                       const size_t *row, size_t deg)
{
    char err[4200] = "";
    dkf_auth_t *a =
        o->key_dir ? dkf_auth_open_edges(o->key_dir, self, row, deg, err, sizeof err) : NULL;
    return install_auth(prog, o, net, a, err);
}

void dkf_cli_print_refusals(const char *prog, const dkf_net_rejects_t *why, const dkf_net_t *net)
{
    const dkf_auth_t *a = dkf_net_auth(net);
    char line[512];
    size_t off = 0;
    int v;
    line[0] = '\0';
    for (v = 1; v < DKF_NET_NVERDICTS; ++v)
        if (why->by[v] > 0 && off < sizeof line)
            off += (size_t)snprintf(line + off, sizeof line - off, "%s%s=%llu", off ? ", " : "",
                                    dkf_net_verdict_str((dkf_net_verdict_t)v),
                                    (unsigned long long)why->by[v]);
    for (v = 1; a != NULL && v < DKF_AUTH_NVERDICTS; ++v)
        if (dkf_auth_counts(a)[v] > 0 && off < sizeof line)
            off += (size_t)snprintf(line + off, sizeof line - off, "%s%s=%llu", off ? ", " : "",
                                    dkf_auth_verdict_str((dkf_auth_verdict_t)v),
                                    (unsigned long long)dkf_auth_counts(a)[v]);
    if (off > 0) fprintf(stderr, "%s: refused: %s\n", prog, line);
}

json_t *dkf_cli_rx_json(const dkf_net_t *net)
{
    const dkf_net_rx_t rx = dkf_net_rx(net);
    return json_pack("{s:s, s:I, s:I, s:I, s:I, s:I}", "mode",
                     rx.direct ? "direct" : "lcm", "datagrams", (json_int_t)rx.datagrams,
                     "fragments", (json_int_t)rx.fragments, "malformed",
                     (json_int_t)rx.malformed, "unmatched", (json_int_t)rx.unmatched,
                     "rcvbuf", (json_int_t)rx.rcvbuf);
}

json_t *dkf_cli_clock_json(void)
{
    return json_pack("{s:s, s:I}", "latency_us", "CLOCK_REALTIME", "offset_us",
                     (json_int_t)dkf_net_clock_offset_us());
}

json_t *dkf_cli_auth_json(const dkf_net_t *net)
{
    const dkf_auth_t *a = dkf_net_auth(net);
    json_t *o = json_object(), *by = json_object();
    int v;
    json_object_set_new(o, "mode", json_string(a != NULL ? "hmac-sha512-256" : "off"));
    for (v = 0; a != NULL && v < DKF_AUTH_NVERDICTS; ++v)
        json_object_set_new(by, dkf_auth_verdict_str((dkf_auth_verdict_t)v),
                            json_integer((json_int_t)dkf_auth_counts(a)[v]));
    json_object_set_new(o, "datagrams", by);
    return o;
}
