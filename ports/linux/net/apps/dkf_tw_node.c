/*
 * dkf-tw-node - one node of a graph filter as its own process, exchanging
 * packets with its neighbours only (round_agent.h; docs/guide/network.md "Graph
 * filters over LCM"): the seed-003 diffusion (Algorithm 2) or consensus
 * (Algorithm 3) filter (tw_agent.h), or seed 001's consensus network
 * DF-DNERTSIF / DF-CKF (df_agent.h).
 *
 *   dkf-tw-node --id 3 --alg 3 --output n3.json tests/vectors/uif/s003_6node.json
 *   dkf-tw-node --id 0 --filter df_dnertsif --output n0.json radar12.json
 */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "df_agent.h"
#include "net.h"
#include "registry.h"
#include "tw_agent.h"

static const char *prog = "dkf-tw-node";

static void usage(FILE *f)
{
    fprintf(f,
            "usage: %s --id I (--alg 2|3 | --filter NAME) [options] SCENARIO.json\n"
            "Runs node I of a graph filter: reads its own measurements from the file,\n"
            "publishes its packets on <prefix>_I and subscribes only to its neighbours'\n"
            "channels. Seed 003 (steps layout with a graph): Algorithm 2 exchanges twice\n"
            "per step (info packet, psi), Algorithm 3 2*eta times (two average-consensus\n"
            "filters). Seed 001 (a network case of the nonlinear-cases layout): T_p\n"
            "consensus rounds per step on the information pair.\n"
            "\n"
            "  -i, --id I              node index (0-based), required\n"
            "  -a, --alg A             2 (diffusion) or 3 (consensus): --filter tw2 / tw3\n"
            "  -f, --filter NAME       tw2, tw3, df_dnertsif, df_ckf or df_dnertsif_joint\n"
            "  -c, --case SEL          a case of a cases-layout file: name or 0-based index\n"
            "      --join              a node (re)started while the others run (seed 001):\n"
            "                          wait for a neighbour's last round of a step, take\n"
            "                          the prior from it and run from the next step\n"
            "  -e, --eta N             Algorithm 3: consensus iterations (default: the file's)\n"
            "  -o, --output FILE       write the estimates per step and the counters (JSON)\n"
            "  -u, --url URL           LCM URL (default %s);\n"
            "                          only udpm://239.x.y.z...?ttl=0 or memq:// are\n"
            "                          accepted (--lan sends udpm with ttl=1)\n"
            "  -p, --prefix P          channel prefix (default DKF_TW; letters, digits, _)\n"
            "      --round-timeout S   give up waiting for a neighbour's packet after S s\n"
            "                          (default 2); the round completes without it\n"
            "      --start-timeout S   the same for the first round (default 10)\n"
            "      --retry-ms MS       re-publish after MS ms without progress (default 50)\n"
            "  -t, --timeout S         stop after S seconds in all (default 0: never)\n"
            "      --drop PCT          drop PCT %% of the outgoing packets (tests)\n"
            "      --seed S            seed of the drops (default 0)\n"
            "      --ready-file F      create F once subscribed (for scripts)\n"
            "      --direct-recv       read the multicast socket without LCM's receive thread\n"
            "                          (one wake-up per datagram; docs/guide/network.md, Direct receive)\n"
            "      --key-dir DIR       authenticate every packet with the edge keys in DIR\n"
            "                          (dkf-keygen --edges; without it: unauthenticated,\n"
            "                          said on stderr)\n"
            DKF_CLI_LAN_USAGE
            "  -q, --quiet             no summary line\n"
            "  -h, --help              this text\n"
            "Exit: 0 every step done (degraded steps are marked in the output), 2 bad\n"
            "options/scenario, 3 filter or transport failure, 4 interrupted or --timeout.\n",
            prog, DKF_NET_DEFAULT_URL);
}

typedef struct {
    dkf_cli_opts_t co; /* --url, --prefix, --timeout, --key-dir, --ready-file, ... */
    double id, alg, eta, round_to, start_to, retry_ms, drop, seed;
    const char *output, *scn, *filter, *case_sel;
    int join;
} opts_t;

static int prefix_ok(const char *p)
{
    if (*p == '\0' || strlen(p) > 32) return 0;
    for (; *p; ++p)
        if (!((*p >= 'A' && *p <= 'Z') || (*p >= 'a' && *p <= 'z') || (*p >= '0' && *p <= '9') ||
              *p == '_'))
            return 0;
    return 1;
}

static int parse(int argc, char **argv, opts_t *o)
{
    static const struct option lo[] = {
        DKF_CLI_LONGOPTS_NET, DKF_CLI_LONGOPT_DIRECT, DKF_CLI_LONGOPT_READY,
        {"id", required_argument, NULL, 'i'},          {"alg", required_argument, NULL, 'a'},
        {"eta", required_argument, NULL, 'e'},         {"output", required_argument, NULL, 'o'},
        {"round-timeout", required_argument, NULL, 'T'}, {"start-timeout", required_argument, NULL, 'S'},
        {"retry-ms", required_argument, NULL, 'M'},    {"drop", required_argument, NULL, 'D'},
        {"seed", required_argument, NULL, 'Z'},        {"filter", required_argument, NULL, 'f'},
        {"case", required_argument, NULL, 'c'},        {"join", no_argument, NULL, 'J'},
        {NULL, 0, NULL, 0}};
    int c, bad = 0;
    memset(o, 0, sizeof *o);
    dkf_cli_opts_init(&o->co, "DKF_TW");
    o->id = o->alg = o->eta = -1;
    o->round_to = 2;
    o->start_to = 10;
    o->retry_ms = 50;
    while (!bad && (c = dkf_cli_getopt(prog, argc, argv, ":i:a:f:c:e:o:u:p:t:qh", lo, usage,
                                       &o->co)) > 0) {
        switch (c) {
        case 'i': bad = dkf_cli_num(prog, "--id", optarg, 0, 1e6, &o->id); break;
        case 'a': bad = dkf_cli_num(prog, "--alg", optarg, 2, 3, &o->alg); break;
        case 'e': bad = dkf_cli_num(prog, "--eta", optarg, 0, 1e6, &o->eta); break;
        case 'f': o->filter = optarg; break;
        case 'c': o->case_sel = optarg; break;
        case 'J': o->join = 1; break;
        case 'o': o->output = optarg; break;
        case 'T': bad = dkf_cli_num(prog, "--round-timeout", optarg, 1e-3, 1e6, &o->round_to); break;
        case 'S': bad = dkf_cli_num(prog, "--start-timeout", optarg, 1e-3, 1e6, &o->start_to); break;
        case 'M': bad = dkf_cli_num(prog, "--retry-ms", optarg, 1, 1e6, &o->retry_ms); break;
        case 'D': bad = dkf_cli_num(prog, "--drop", optarg, 0, 100, &o->drop); break;
        case 'Z': bad = dkf_cli_num(prog, "--seed", optarg, 0, 4e9, &o->seed); break;
        }
    }
    if (bad || c == DKF_CLI_BAD) return -1;
    if (c == DKF_CLI_HELP) exit(DKF_EXIT_OK);
    if (o->alg >= 0 && o->filter != NULL) {
        fprintf(stderr, "%s: --alg and --filter: give one\n", prog);
        return -1;
    }
    if (o->alg >= 0 && o->alg == (double)(int)o->alg) o->filter = o->alg == 2 ? "tw2" : "tw3";
    if (optind != argc - 1 || o->id < 0 || o->filter == NULL || o->id != (double)(long)o->id ||
        (o->alg >= 0 && o->alg != (double)(int)o->alg) ||
        (o->eta >= 0 && o->eta != (double)(long)o->eta)) {
        fprintf(stderr, "%s: need --id I, --alg 2|3 or --filter NAME (integers) and one "
                "SCENARIO (see --help)\n", prog);
        return -1;
    }
    if (o->eta >= 0 && strcmp(o->filter, "tw3") != 0) {
        fprintf(stderr, "%s: --eta: only for --alg 3 (tw3)\n", prog);
        return -1;
    }
    if (!prefix_ok(o->co.prefix)) {
        fprintf(stderr, "%s: --prefix %s: letters, digits and _ only (at most 32)\n", prog,
                o->co.prefix);
        return -1;
    }
    o->scn = argv[optind];
    return 0;
}

/* The node's agent, seed 003's or seed 001's, through its rounds. */
typedef struct {
    dkf_ra_t *ra;
    dkf_net_twa_scn_t tw;            /* seed 003: the bound scenario */
    dkf_net_twa_t *tw_agent;
    dkf_df_agent_t *df_agent;
} agent_t;

typedef struct {
    dkf_net_t *net;
    agent_t ag;
    const char *prefix;
    char chan[DKF_NET_CHAN_LEN];
    double drop;
    uint64_t rng;
    unsigned long dropped;
} ctx_t;

/* splitmix64: reproducible drop decisions */
static double uniform(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    z ^= z >> 31;
    return (double)(z >> 11) / 9007199254740992.0;
}

static int send_own(void *user, const void *data, size_t len)
{
    ctx_t *x = user;
    if (x->drop > 0 && uniform(&x->rng) * 100 < x->drop) {
        ++x->dropped;
        return 0;
    }
    return dkf_net_publish(x->net, x->chan, data, len);
}

static void on_packet(const char *channel, const dkf_net_from_t *from, const void *data,
                      size_t len, int64_t recv_utime, void *user)
{
    ctx_t *x = user;
    /* the sender: the graph node whose edge key verified the packet, or
     * without authentication the channel's node */
    const long node = from->known ? (from->role == DKF_NET_ROLE_GRAPH ? from->id : -1)
                                  : dkf_ra_chan_node(channel, x->prefix);
    (void)recv_utime;
    (void)dkf_ra_receive(x->ag.ra, node >= 0 ? node : DKF_NET_CHAN_MAX_ID + 1 /* none: refused */,
                         data, len, dkf_net_mono_us());
}

static int write_result(const opts_t *o, const ctx_t *x, const char *exit_what, double wall)
{
    json_t *doc;
    int rc;
    if (o->output == NULL) return 0;
    doc = x->ag.tw_agent ? dkf_net_twa_result(x->ag.tw_agent)
                         : dkf_df_agent_result(x->ag.df_agent);
    json_object_set_new(doc, "scenario", json_string(o->scn));
    json_object_set_new(doc, "exit", json_string(exit_what));
    json_object_set_new(doc, "wall_s", json_real(wall));
    json_object_set_new(doc, "dropped_by_flag", json_integer((json_int_t)x->dropped));
    json_object_set_new(doc, "auth", dkf_cli_auth_json(x->net));
    json_object_set_new(doc, "receive", dkf_cli_rx_json(x->net));
    rc = dkf_cli_write_json(prog, o->output, doc);
    json_decref(doc);
    return rc;
}

/* Runs the agent until it finishes, fails, or is stopped. Exit status. */
static int run(const opts_t *o, ctx_t *x)
{
    const int64_t t0 = dkf_net_mono_us();
    dkf_ra_t *ra = x->ag.ra;
    int st = o->join ? dkf_ra_join(ra, t0) : dkf_ra_start(ra, t0), code;
    const char *what;
    while (st == DKF_RA_RUNNING || st == DKF_RA_LINGER || st == DKF_RA_JOINING) {
        int64_t now = dkf_net_mono_us(), w = dkf_ra_wait_us(ra, now) / 1000;
        if (dkf_cli_stop || dkf_cli_expired(t0, o->co.timeout)) break;
        if (dkf_net_drain(x->net, (int)(w > 100 ? 100 : w)) < 0) {
            fprintf(stderr, "%s: node %.0f: LCM receive failed\n", prog, o->id);
            st = DKF_NET_TWA_FAILED;
            break;
        }
        st = dkf_ra_poll(ra, dkf_net_mono_us());
    }
    if (st == DKF_RA_FINISHED) {
        code = DKF_EXIT_OK, what = "done";
    } else if (st == DKF_RA_FAILED) {
        code = DKF_EXIT_RUN, what = "failed";
        if (dkf_ra_error(ra)[0] != '\0') fprintf(stderr, "%s: %s\n", prog, dkf_ra_error(ra));
    } else {
        code = DKF_EXIT_STOPPED, what = "stopped";
        fprintf(stderr, "%s: node %.0f: %s after %zu steps\n", prog, o->id,
                dkf_cli_stop ? "interrupted" : "--timeout", dkf_ra_steps_done(ra));
    }
    if (write_result(o, x, what, (double)(dkf_net_mono_us() - t0) * 1e-6) != 0 && code == 0)
        code = DKF_EXIT_RUN;
    if (!o->co.quiet) {
        const dkf_ra_counters_t *c = dkf_ra_counters(ra);
        fprintf(stderr,
                "%s: node %.0f %s: %s, %zu steps (%lu degraded), sent %lu (%lu "
                "retransmits, %lu answers), received %lu, rejected %llu\n",
                prog, o->id, o->filter, what, dkf_ra_steps_done(ra), c->degraded_steps,
                c->sent, c->retransmits, c->answers, c->received,
                (unsigned long long)c->rej.total);
    }
    return code;
}

/* The agent of o->filter for node o->id of s. 0, or -1 with err. */
static int make_agent(const opts_t *o, const dkf_scenario_t *s, const dkf_ra_opts_t *ao,
                      agent_t *ag, char *err, size_t errlen)
{
    const dkf_filter_t *f = dkf_registry_find(o->filter);
    memset(ag, 0, sizeof *ag);
    if (f == NULL) {
        snprintf(err, errlen, "--filter %s: unknown filter", o->filter);
        return -1;
    }
    if (strcmp(o->filter, "tw2") == 0 || strcmp(o->filter, "tw3") == 0) {
        if (dkf_net_twa_scn_bind(&ag->tw, s, o->filter[2] - '0', (long)o->eta, err, errlen) != 0)
            return -1;
        if ((ag->tw_agent = dkf_net_twa_new(&ag->tw, (size_t)o->id, ao, err, errlen)) == NULL)
            return -1;
        ag->ra = dkf_net_twa_rounds(ag->tw_agent);
        return 0;
    }
    if ((ag->df_agent = dkf_df_agent_new(f, s, (size_t)o->id, ao, err, errlen)) == NULL) return -1;
    ag->ra = dkf_df_agent_rounds(ag->df_agent);
    return 0;
}

static void free_agent(agent_t *ag)
{
    dkf_net_twa_free(ag->tw_agent);
    dkf_df_agent_free(ag->df_agent);
    dkf_net_twa_scn_free(&ag->tw);
}

/* --key-dir: the edge keys of the node's graph row (auth.h, DKA2). */
static int authenticate(const opts_t *o, ctx_t *x)
{
    size_t deg;
    const size_t *row = dkf_ra_row(x->ag.ra, &deg);
    return dkf_cli_auth_edges(prog, &o->co, x->net, (size_t)o->id, row, deg);
}

int main(int argc, char **argv)
{
    opts_t o;
    ctx_t x;
    dkf_ra_opts_t ao;
    dkf_scenario_t *s;
    char err[DKF_SCN_ERR_LEN], sub[4096];
    int code = DKF_EXIT_USAGE;
    if (parse(argc, argv, &o) != 0 || dkf_cli_check_net(prog, &o.co) != DKF_EXIT_OK)
        return DKF_EXIT_USAGE;
    dkf_cli_signals();
    if ((s = dkf_scenario_load(o.scn, o.case_sel, err, sizeof err)) == NULL) {
        fprintf(stderr, "%s: %s\n", prog, err);
        return DKF_EXIT_USAGE;
    }
    memset(&x, 0, sizeof x);
    x.prefix = o.co.prefix;
    x.drop = o.drop;
    x.rng = (uint64_t)o.seed * 1000003ULL + (uint64_t)o.id;
    dkf_ra_chan(x.chan, o.co.prefix, (size_t)o.id);
    ao.send = send_own;
    ao.user = &x;
    ao.round_timeout_us = (int64_t)(o.round_to * 1e6);
    ao.start_timeout_us = (int64_t)(o.start_to * 1e6);
    ao.retry_us = (int64_t)(o.retry_ms * 1e3);
    if (make_agent(&o, s, &ao, &x.ag, err, sizeof err) != 0) {
        fprintf(stderr, "%s: %s\n", prog, err);
    } else if (dkf_ra_neighbours_regex(x.ag.ra, o.co.prefix, sub, sizeof sub) != 0) {
        fprintf(stderr, "%s: node %.0f: no neighbours, or too many for one subscription\n", prog,
                o.id);
    } else if ((x.net = dkf_cli_net_open(&o.co, err, sizeof err)) == NULL) {
        fprintf(stderr, "%s: %s\n", prog, err);
        code = DKF_EXIT_RUN;
    } else if ((o.co.ports & DKF_CLI_DIRECT) && dkf_net_direct(x.net, err, sizeof err) != 0) {
        fprintf(stderr, "%s: %s\n", prog, err); /* e.g. a memq:// URL */
    } else if ((code = authenticate(&o, &x)) != DKF_EXIT_OK) {
        /* said by dkf_cli_auth_edges */
    } else if (dkf_net_subscribe(x.net, sub, on_packet, &x) != 0) {
        fprintf(stderr, "%s: %s: cannot subscribe\n", prog, sub);
        code = DKF_EXIT_RUN;
    } else if (o.co.ready != NULL && dkf_cli_touch(prog, o.co.ready) != 0) {
        code = DKF_EXIT_RUN;
    } else {
        code = run(&o, &x);
    }
    dkf_net_close(x.net);
    free_agent(&x.ag);
    dkf_scenario_free(s);
    return code;
}
