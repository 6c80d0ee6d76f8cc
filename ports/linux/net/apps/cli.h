/*
 * cli.h - what dkf-sim, dkf-node, dkf-fusion and dkf-tw-node share: signals,
 * the shared options and their parsing, scenario loading, files. Every error
 * is one line "PROG: problem" on stderr.
 *
 * Exit statuses (DKF_EXIT_*, util.h): 0 done, 2 bad options or input,
 * 3 a run failure (core call failed, a peer failed, a wait timed out),
 * 4 interrupted (SIGINT/SIGTERM or --timeout) before the end.
 */
#ifndef DKF_NET_CLI_H
#define DKF_NET_CLI_H

#include <getopt.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>

#include <jansson.h>

#include "codec.h"
#include "net.h"
#include "scenario.h"
#include "util.h"

extern volatile sig_atomic_t dkf_cli_stop;

/* SIGINT and SIGTERM set dkf_cli_stop (no SA_RESTART: waits return). */
void dkf_cli_signals(void);

/* *out = arg as a number in [lo, hi]; else prints "PROG: OPT ARG: ..." and
 * returns -1. */
int dkf_cli_num(const char *prog, const char *opt, const char *arg, double lo, double hi,
                double *out);

/* The one-line message for a getopt_long failure (opterr = 0). */
void dkf_cli_bad_option(const char *prog, int argc, char **argv, int optind_now, int optopt_now);

/* Loads the scenario, selects run (if the file has runs) and checks it for
 * the network (dkf_net_check_scenario). NULL after printing the error. */
dkf_scenario_t *dkf_cli_scenario(const char *prog, const char *path, long run);

/* The transport options (a bit set; dkf_cli_opts_t.ports). */
#define DKF_CLI_SPLIT 1u  /* --split-ports: dkf_net_split */
#define DKF_CLI_DIRECT 2u /* --direct-recv: dkf_net_direct */

/* The options the network programs share. A program lists in its
 * getopt_long table the ones it takes (DKF_CLI_LONGOPTS_*; short letters
 * u p t q h), fills the defaults with dkf_cli_opts_init and reads its
 * options with dkf_cli_getopt. */
typedef struct {
    const char *url;     /* -u, --url (default DKF_NET_DEFAULT_URL) */
    const char *prefix;  /* -p, --prefix */
    const char *key_dir; /* --key-dir DIR (NULL: unauthenticated) */
    const char *ready;   /* --ready-file F (NULL: none) */
    double timeout;      /* -t, --timeout S in [0, 1e7] (0: never) */
    double hb_ms;        /* --heartbeat-ms MS in [1, 1e7] */
    unsigned ports;      /* --split-ports, --direct-recv (DKF_CLI_*) */
    int quiet;           /* -q, --quiet */
    int lan;             /* --lan: the ttl=0 URL opened with ttl=1 (DKF_NET_LAN), keys required */
    int insecure;        /* --insecure: --lan without keys, said at every start */
    double clock_ms;     /* --clock-offset-ms MS (tests; clock.h), set when read */
} dkf_cli_opts_t;

/* The codes of the shared options without a letter (above any character). */
#define DKF_CLI_OPT_LAN 0x101
#define DKF_CLI_OPT_INSECURE 0x102
#define DKF_CLI_OPT_CLOCK 0x103

/* --url, --prefix, --timeout, --key-dir, --lan, --insecure,
 * --clock-offset-ms, --quiet, --help: every program's. */
#define DKF_CLI_LONGOPTS_NET                                                                    \
    {"url", required_argument, NULL, 'u'}, {"prefix", required_argument, NULL, 'p'},           \
        {"timeout", required_argument, NULL, 't'}, {"key-dir", required_argument, NULL, 'K'},  \
        {"lan", no_argument, NULL, DKF_CLI_OPT_LAN},                                           \
        {"insecure", no_argument, NULL, DKF_CLI_OPT_INSECURE},                                 \
        {"clock-offset-ms", required_argument, NULL, DKF_CLI_OPT_CLOCK},                       \
        {"quiet", no_argument, NULL, 'q'}, {"help", no_argument, NULL, 'h'}

/* The usage lines of --lan, --insecure and --clock-offset-ms (every program). */
#define DKF_CLI_LAN_USAGE                                                                   \
    "      --lan               several hosts on one segment: the udpm URL (ttl=0) is\n"      \
    "                          opened with one hop (ttl=1, never routed); needs --key-dir\n" \
    "                          (docs/guide/network.md, Several hosts)\n"                     \
    "      --insecure          with --lan: run without --key-dir, unauthenticated (said\n"    \
    "                          on stderr at every start)\n"                                   \
    "      --clock-offset-ms MS  (tests) run as if this host's wall clock were MS ms\n"      \
    "                          ahead (negative: behind); stamps and receive times shift\n"
/* --split-ports and --direct-recv (DKF_CLI_PORTS_USAGE). */
#define DKF_CLI_LONGOPTS_PORTS                                                                  \
    {"split-ports", no_argument, NULL, 'L'}, {"direct-recv", no_argument, NULL, 'Y'}
#define DKF_CLI_LONGOPT_DIRECT {"direct-recv", no_argument, NULL, 'Y'}
#define DKF_CLI_LONGOPT_READY {"ready-file", required_argument, NULL, 'R'}
#define DKF_CLI_LONGOPT_HEARTBEAT {"heartbeat-ms", required_argument, NULL, 'H'}

/* The defaults: DKF_NET_DEFAULT_URL, prefix, DKF_NET_HEARTBEAT_US, the rest
 * 0 or NULL. */
void dkf_cli_opts_init(dkf_cli_opts_t *o, const char *prefix);

/* What dkf_cli_getopt returns instead of an option of the program's own. */
#define DKF_CLI_END (-1)  /* no more options (optind: the first operand) */
#define DKF_CLI_HELP (-2) /* --help: usage(stdout) has been called */
#define DKF_CLI_BAD (-3)  /* a bad option or value: said on stderr */

/* getopt_long (opterr = 0) over the program's table: takes the shared
 * options into o and answers --help with usage(stdout); returns the next
 * option of the program's own, or DKF_CLI_END, DKF_CLI_HELP, DKF_CLI_BAD. */
int dkf_cli_getopt(const char *prog, int argc, char **argv, const char *shortopts,
                   const struct option *longopts, void (*usage)(FILE *), dkf_cli_opts_t *o);

/* The exit status after dkf_cli_getopt returned c < 0 other than
 * DKF_CLI_END: DKF_EXIT_OK after --help, else DKF_EXIT_USAGE. */
#define DKF_CLI_EXIT(c) ((c) == DKF_CLI_HELP ? DKF_EXIT_OK : DKF_EXIT_USAGE)

/* The URL in o's scope (dkf_net_check_url_scope: DKF_NET_LAN with --lan)
 * and the authentication options: --lan needs --key-dir or --insecure,
 * --insecure needs --lan and no --key-dir. DKF_EXIT_OK, or DKF_EXIT_USAGE
 * after printing why in one line. */
int dkf_cli_check_net(const char *prog, const dkf_cli_opts_t *o);

/* dkf_net_open_scope of o->url in o's scope (dkf_cli_check_net has passed). */
dkf_net_t *dkf_cli_net_open(const dkf_cli_opts_t *o, char *err, size_t errlen);

/* The set-up dkf-sim, dkf-node and dkf-fusion share: checks --prefix
 * (1..24 characters), the URL and the authentication options
 * (dkf_cli_check_net), loads the scenario (dkf_cli_scenario), opens the
 * transport with o->ports and authenticates as `self` (dkf_cli_auth). On
 * success *s and *net are set and DKF_EXIT_OK is returned; otherwise the
 * error has been printed, nothing is left open, and the exit status to
 * return is given. */
int dkf_cli_open(const char *prog, const dkf_cli_opts_t *o, const char *path, long run,
                 uint32_t self, dkf_scenario_t **s, dkf_net_t **net);

/* The usage lines of --split-ports and --direct-recv. */
#define DKF_CLI_PORTS_USAGE                                                                 \
    "      --split-ports       node messages on the URL's port + 1, node i's\n"               \
    "                          measurements on port + 2 + i (every process of a run\n"        \
    "                          must say it; docs/guide/network.md, Split ports)\n"                  \
    "      --direct-recv       read the multicast sockets without LCM's receive thread\n"     \
    "                          (one wake-up per datagram; docs/guide/network.md, Direct receive)\n"

/* --key-dir: net signs and verifies as `self` (auth.h: dkf_auth_signer)
 * of a network of `nodes` nodes, with the keys in o->key_dir. No key_dir:
 * unauthenticated, said in one line on stderr (never silently; with --lan
 * --insecure a line that says so). DKF_EXIT_OK, or DKF_EXIT_USAGE after
 * printing why. */
int dkf_cli_auth(const char *prog, const dkf_cli_opts_t *o, dkf_net_t *net, uint32_t self,
                 size_t nodes);

/* The same for graph node `self` with the edge keys of its graph row
 * (auth.h, DKA2). */
int dkf_cli_auth_edges(const char *prog, const dkf_cli_opts_t *o, dkf_net_t *net, size_t self,
                       const size_t *row, size_t deg);

/* {"latency_us": "CLOCK_REALTIME", "offset_us": the --clock-offset-ms in
 * us}: the clock of a result file's latencies (this process's wall clock
 * minus the stamps of the processes whose data it used, each on its own
 * host's clock) and this process's test offset to it (clock.h). */
json_t *dkf_cli_clock_json(void);

/* {"mode": ..., "datagrams": {verdict: count}} of net's authenticator
 * (mode "off" without one): the result file's "auth". */
json_t *dkf_cli_auth_json(const dkf_net_t *net);

/* One line "PROG: refused: <reason>=<count>, ..." of the messages refused
 * by validation (why) and of the datagrams refused by net's authenticator,
 * nonzero counts only; nothing if none was refused. */
void dkf_cli_print_refusals(const char *prog, const dkf_net_rejects_t *why, const dkf_net_t *net);

/* {"mode": "direct" | "lcm", "datagrams", "fragments", "malformed",
 * "unmatched", "rcvbuf"} (dkf_net_rx; counts 0 in mode "lcm"): the result
 * file's "receive". */
json_t *dkf_cli_rx_json(const dkf_net_t *net);

/* Writes doc (17 significant digits, so doubles round-trip). 0 or -1. */
int dkf_cli_write_json(const char *prog, const char *path, const json_t *doc);

/* Creates an empty file (the "ready" signal for scripts). 0 or -1. */
int dkf_cli_touch(const char *prog, const char *path);

/* Deadline helper: 1 if timeout_s > 0 and start + timeout_s has passed. */
int dkf_cli_expired(int64_t start_mono_us, double timeout_s);

#endif /* DKF_NET_CLI_H */
