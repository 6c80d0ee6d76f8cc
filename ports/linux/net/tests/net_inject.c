/*
 * net_inject - hostile traffic for the fault tests (ports/linux/net/tests/
 * net_faults.sh, mode hostile): follows <prefix>_FUSED and, when it first
 * sees the fused step of each --at K, publishes one burst of invalid node
 * messages on the node channels. Only the transport's URLs (udpm ttl=0 in
 * 239/8, memq) can be used, and the test runs it inside a namespace.
 *
 *   net_inject --url URL --at 5 --at 20 --timeout 60 SCENARIO.json
 *
 * One burst, by the reason the fusion centre must give (codec.h's order):
 *   malformed 4: a message cut in half, 100 bytes of garbage, a length
 *                field of 1000, one trailing byte
 *   unknown node 2: node 7 on <prefix>_NODE_7, node 1 on <prefix>_NODE_0
 *   wrong model id 1, wrong dimension 1
 *   step out of range 2: k = N + 5, k_start after k
 *   non-finite 2: NaN in xf, +Inf in the previous payload's xp
 * = 12 per burst. Every message would be plausible but for its one defect
 * (valid k, the node's true model id, finite numbers...), so a check that
 * let it through would change the fused output.
 *
 * With --auth DIR (an authenticated run, keys in DIR: auth.h) a burst is
 * instead 8 datagrams, each of which must be refused:
 *   no trailer    a plausible node-0 message, unsigned
 *   bad MAC       the same with a trailer of node 0 under a wrong key
 *   foreign       signed with node 1's real key (a compromised node 1),
 *                 published on node 0's channel
 *   unknown key   node nsensors+5 with a key of its own
 *   replayed      node 1's newest genuine datagram, sent again
 *   bad channel   node 1's message, signed by node 1, published on
 *                 <prefix>_NODE_0001 (an alias of node 1's channel)
 * (the six above at the fusion centre) and, signed by node 1 with its real
 * key on <prefix>_STATUS, where it may speak as itself:
 *   not its sender  a status claiming to be the fusion centre, FAILED
 *                 (that would end the simulator's run), and one claiming
 *                 to be node 0, FAILED (at the simulator)
 * Exit 0 after the last burst, 3 on a transport error or if --timeout
 * passes first.
 */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "auth.h"
#include "cli.h"
#include "codec.h"
#include "model.h"
#include "net.h"

#define MAX_AT 16

typedef struct {
    long fused_k;
    dkf_net_expect_t ex;
    size_t trailer;                    /* bytes to strip from a fused datagram (auth) */
    unsigned char last1[DKF_NET_MAX_MSG + DKF_AUTH_TRAILER]; /* node 1's newest datagram */
    size_t last1_len;
} watch_t;

static void on_fused(const char *channel, const dkf_net_from_t *from, const void *data,
                     size_t len, int64_t recv_utime, void *user)
{
    (void)from;
    static dkf_net_fused_t f;
    watch_t *w = user;
    (void)channel;
    (void)recv_utime;
    if (len >= w->trailer &&
        dkf_net_decode_fused(data, len - w->trailer, &w->ex, &f, NULL) == DKF_NET_ACCEPT &&
        f.k > w->fused_k)
        w->fused_k = f.k;
}

static void on_node1(const char *channel, const dkf_net_from_t *from, const void *data,
                     size_t len, int64_t recv_utime, void *user)
{
    (void)from;
    watch_t *w = user;
    (void)channel;
    (void)recv_utime;
    if (len > sizeof w->last1) return;
    memcpy(w->last1, data, len);
    w->last1_len = len;
}

static int pub(dkf_net_t *net, const char *prefix, size_t node, const void *buf, size_t len)
{
    char chan[DKF_NET_CHAN_LEN];
    dkf_net_chan_node(chan, prefix, node);
    return dkf_net_publish(net, chan, buf, len);
}

/* A plausible message of node `node`, step k (payload 1e6: absurd if used). */
static void plausible(dkf_diffkf_msg_t *m, dkf_diffkf_msg_t *pv, dkf_net_meta_t *meta,
                      size_t node, long k, size_t n, int64_t model)
{
    size_t i;
    memset(m, 0, sizeof *m);
    m->node = (uint16_t)node;
    m->k = (uint32_t)k;
    m->n = (uint16_t)n;
    for (i = 0; i < n; ++i) m->xf[i] = m->xp[i] = (dkf_real_t)1e6;
    *pv = *m;
    pv->k = (uint32_t)(k - 1);
    memset(meta, 0, sizeof *meta);
    meta->utime = dkf_net_now_us();
    meta->model_id = model;
    meta->seq = 1000000;
    meta->epoch = 0;
    meta->k_start = 1;
    meta->has_prev = k > 1;
}

static int burst(dkf_net_t *net, const char *prefix, const dkf_scenario_t *s, long k)
{
    static unsigned char buf[DKF_NET_MAX_MSG];
    unsigned char junk[100];
    dkf_diffkf_msg_t m, pv;
    dkf_net_meta_t meta;
    const int64_t model = dkf_net_model_id(s);
    const size_t n = s->n;
    size_t len;
    int rc = 0;
    if (k < 2) k = 2;
    if (k > (long)s->steps) k = (long)s->steps;
    /* malformed */
    plausible(&m, &pv, &meta, 0, k, n, model);
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta) != 0) return -1;
    rc |= pub(net, prefix, 0, buf, len / 2);
    memset(junk, 0xab, sizeof junk);
    rc |= pub(net, prefix, 1, junk, sizeof junk);
    buf[48] = 0, buf[49] = 0, buf[50] = 0x03, buf[51] = 0xe8; /* n = 1000 */
    rc |= pub(net, prefix, 0, buf, len);
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta) != 0) return -1;
    buf[len] = 0;
    rc |= pub(net, prefix, 0, buf, len + 1);
    /* unknown node: an index the scenario does not have, another node's channel */
    plausible(&m, &pv, &meta, s->nsensors + 5, k, n, model);
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta) != 0) return -1;
    rc |= pub(net, prefix, s->nsensors + 5, buf, len);
    plausible(&m, &pv, &meta, 1 % s->nsensors, k, n, model);
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta) != 0) return -1;
    rc |= pub(net, prefix, s->nsensors > 1 ? 0 : 1, buf, len);
    /* wrong model id */
    plausible(&m, &pv, &meta, 0, k, n, model ^ 0x10);
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta) != 0) return -1;
    rc |= pub(net, prefix, 0, buf, len);
    /* wrong dimension */
    plausible(&m, &pv, &meta, 0, k, n > 1 ? n - 1 : n + 1, model);
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta) != 0) return -1;
    rc |= pub(net, prefix, 0, buf, len);
    /* step out of range */
    plausible(&m, &pv, &meta, 0, (long)s->steps + 5, n, model);
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta) != 0) return -1;
    rc |= pub(net, prefix, 0, buf, len);
    plausible(&m, &pv, &meta, 0, k, n, model);
    meta.k_start = k + 1;
    meta.has_prev = 0;
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, NULL, &meta) != 0) return -1;
    rc |= pub(net, prefix, 0, buf, len);
    /* non-finite numbers */
    plausible(&m, &pv, &meta, 0, k, n, model);
    m.xf[0] = (dkf_real_t)NAN;
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta) != 0) return -1;
    rc |= pub(net, prefix, 0, buf, len);
    plausible(&m, &pv, &meta, s->nsensors - 1, k, n, model);
    pv.xp[n - 1] = (dkf_real_t)INFINITY;
    if (dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta) != 0) return -1;
    rc |= pub(net, prefix, s->nsensors - 1, buf, len);
    return rc ? -1 : 0;
}

/* msg[0..len-1] with a trailer of a (signed as for channel `as`), published
 * on node `node`'s channel. */
static int pub_signed(dkf_net_t *net, const char *prefix, size_t node, dkf_auth_t *a,
                      const char *as, unsigned char *msg, size_t len)
{
    if (a == NULL || dkf_auth_sign(a, as, msg, len, msg + len) != 0) return -1;
    return pub(net, prefix, node, msg, len + DKF_AUTH_TRAILER);
}

/* A status claiming (role, id), FAILED, signed by a on <prefix>_STATUS. */
static int pub_status_as(dkf_net_t *net, const char *prefix, dkf_auth_t *a, int role, int id,
                         int64_t model)
{
    static unsigned char buf[DKF_NET_MAX_MSG + DKF_AUTH_TRAILER];
    char chan[DKF_NET_CHAN_LEN];
    dkf_net_status_t st;
    size_t len;
    memset(&st, 0, sizeof st);
    st.utime = dkf_net_now_us();
    st.model_id = model;
    st.role = role;
    st.id = id;
    st.state = DKF_NET_FAILED;
    snprintf(st.detail, sizeof st.detail, "net_inject: an impostor");
    dkf_net_chan(chan, prefix, "STATUS");
    if (a == NULL || dkf_net_encode_status(buf, DKF_NET_MAX_MSG, &len, &st) != 0 ||
        dkf_auth_sign(a, chan, buf, len, buf + len) != 0)
        return -1;
    return dkf_net_publish(net, chan, buf, len + DKF_AUTH_TRAILER);
}

/* The eight datagrams of an authenticated run's burst (see the top). */
static int auth_burst(dkf_net_t *net, const char *prefix, const dkf_scenario_t *s, long k,
                      const char *key_dir, const watch_t *w)
{
    static unsigned char buf[DKF_NET_MAX_MSG + DKF_AUTH_TRAILER];
    unsigned char wrong[DKF_AUTH_MAX_KEYS * DKF_AUTH_KEY_LEN], have[DKF_AUTH_MAX_KEYS] = {0};
    char err[4200], ch0[DKF_NET_CHAN_LEN], ch1[DKF_NET_CHAN_LEN], chx[DKF_NET_CHAN_LEN];
    const size_t x = s->nsensors + 5;
    dkf_diffkf_msg_t m, pv;
    dkf_net_meta_t meta;
    dkf_auth_t *forger, *node1, *stranger;
    size_t len;
    int rc = 0;
    if (k < 2) k = 2;
    if (k > (long)s->steps) k = (long)s->steps;
    memset(wrong, 0x5a, sizeof wrong);
    have[0] = 1;
    have[x] = 1;
    forger = dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_NODE, 0), wrong, have, NULL, 1);
    stranger = dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_NODE, x), wrong, have, NULL, 1);
    node1 = dkf_auth_open(key_dir, dkf_auth_signer(DKF_NET_ROLE_NODE, 1), s->nsensors, err,
                          sizeof err);
    if (node1 == NULL) fprintf(stderr, "net_inject: %s\n", err);
    dkf_net_chan_node(ch0, prefix, 0);
    dkf_net_chan_node(ch1, prefix, 1);
    dkf_net_chan_node(chx, prefix, x);
    plausible(&m, &pv, &meta, 0, k, s->n, dkf_net_model_id(s));
    rc |= dkf_net_encode_node_msg(buf, DKF_NET_MAX_MSG, &len, &m, &pv, &meta);
    rc |= pub(net, prefix, 0, buf, len);                          /* no trailer */
    rc |= pub_signed(net, prefix, 0, forger, ch0, buf, len);      /* bad MAC */
    rc |= pub_signed(net, prefix, 0, node1, ch1, buf, len);       /* foreign */
    rc |= pub_signed(net, prefix, x, stranger, chx, buf, len);    /* unknown key */
    if (w->last1_len == 0) rc = -1;
    else rc |= pub(net, prefix, 1, w->last1, w->last1_len);       /* replayed */
    /* bad channel: node 1's own message, signed for its channel, on an alias */
    plausible(&m, &pv, &meta, 1, k, s->n, dkf_net_model_id(s));
    rc |= dkf_net_encode_node_msg(buf, DKF_NET_MAX_MSG, &len, &m, &pv, &meta);
    if (node1 == NULL || dkf_auth_sign(node1, ch1, buf, len, buf + len) != 0) rc = -1;
    snprintf(chx, sizeof chx, "%s_NODE_0001", prefix);
    rc |= dkf_net_publish(net, chx, buf, len + DKF_AUTH_TRAILER);
    /* not its sender: node 1 speaking as the centre and as node 0 */
    rc |= pub_status_as(net, prefix, node1, DKF_NET_ROLE_FUSION, -1, dkf_net_model_id(s));
    rc |= pub_status_as(net, prefix, node1, DKF_NET_ROLE_NODE, 0, dkf_net_model_id(s));
    dkf_auth_free(forger);
    dkf_auth_free(stranger);
    dkf_auth_free(node1);
    return rc ? -1 : 0;
}

int main(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"url", required_argument, NULL, 'u'},     {"prefix", required_argument, NULL, 'p'},
        {"at", required_argument, NULL, 'a'},      {"timeout", required_argument, NULL, 't'},
        {"auth", required_argument, NULL, 'K'},    {NULL, 0, NULL, 0}};
    const char *key_dir = NULL;
    const char *prog = "net_inject", *url = DKF_NET_DEFAULT_URL, *prefix = DKF_NET_PREFIX;
    double at[MAX_AT], timeout = 60;
    size_t nat = 0, next = 0;
    char err[DKF_SCN_ERR_LEN], chan[DKF_NET_CHAN_LEN];
    dkf_scenario_t *s;
    dkf_net_t *net;
    watch_t w;
    int64_t start;
    int c, code = DKF_EXIT_OK;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "", longopts, NULL)) != -1) {
        switch (c) {
        case 'u': url = optarg; break;
        case 'p': prefix = optarg; break;
        case 'a':
            if (nat == MAX_AT || dkf_cli_num(prog, "--at", optarg, 0, 1e9, &at[nat])) return DKF_EXIT_USAGE;
            ++nat;
            break;
        case 't': if (dkf_cli_num(prog, "--timeout", optarg, 0.1, 1e6, &timeout)) return DKF_EXIT_USAGE; break;
        case 'K': key_dir = optarg; break;
        default: dkf_cli_bad_option(prog, argc, argv, optind, optopt); return DKF_EXIT_USAGE;
        }
    }
    if (optind != argc - 1 || nat == 0) {
        fprintf(stderr, "%s: usage: %s [--url URL] [--prefix P] --at K... [--timeout S] SCENARIO\n",
                prog, prog);
        return DKF_EXIT_USAGE;
    }
    if (dkf_net_check_url(url, err, sizeof err) != 0) {
        fprintf(stderr, "%s: %s\n", prog, err);
        return DKF_EXIT_USAGE;
    }
    s = dkf_cli_scenario(prog, argv[optind], 0);
    if (s == NULL) return DKF_EXIT_USAGE;
    net = dkf_net_open(url, err, sizeof err);
    if (net == NULL) {
        fprintf(stderr, "%s: %s\n", prog, err);
        dkf_scenario_free(s);
        return DKF_EXIT_RUN;
    }
    memset(&w, 0, sizeof w);
    w.ex.model_id = dkf_net_model_id(s);
    w.ex.nnodes = s->nsensors;
    w.ex.node = -1;
    w.ex.n = s->n;
    w.ex.kmax = (long)s->steps;
    w.trailer = key_dir != NULL ? DKF_AUTH_TRAILER : 0;
    dkf_net_chan(chan, prefix, "FUSED");
    if (dkf_net_subscribe(net, chan, on_fused, &w) != 0) code = DKF_EXIT_RUN;
    dkf_net_chan_node(chan, prefix, 1);
    if (key_dir != NULL && dkf_net_subscribe(net, chan, on_node1, &w) != 0) code = DKF_EXIT_RUN;
    dkf_cli_signals();
    start = dkf_net_mono_us();
    while (code == DKF_EXIT_OK && next < nat) {
        if (dkf_cli_stop || dkf_cli_expired(start, timeout)) {
            fprintf(stderr, "%s: stopped before the burst at k=%g\n", prog, at[next]);
            code = DKF_EXIT_RUN;
            break;
        }
        if (dkf_net_handle(net, 10) < 0) code = DKF_EXIT_RUN;
        while (code == DKF_EXIT_OK && next < nat && w.fused_k >= (long)at[next]) {
            /* the next step is in progress: its payloads are on their way */
            if ((key_dir != NULL ? auth_burst(net, prefix, s, w.fused_k + 1, key_dir, &w)
                                 : burst(net, prefix, s, w.fused_k + 1)) != 0)
                code = DKF_EXIT_RUN;
            ++next;
        }
    }
    fprintf(stderr, "%s: %zu burst(s) of %d invalid messages sent\n", prog, next,
            key_dir != NULL ? 8 : 12);
    dkf_net_close(net);
    dkf_scenario_free(s);
    return code;
}
