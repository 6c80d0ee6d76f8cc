/*
 * tw_inject - hostile traffic for the graph filters' authentication test
 * (tests/tw_net.sh, mode auth): waits for one genuine datagram of graph node
 * V on <prefix>_V, then publishes --bursts bursts of 5 datagrams on that
 * channel, each of which every neighbour of V must reject (auth.h, DKA2),
 * one per reason:
 *   no trailer    V's packet with one bit of its last real changed, unsigned
 *   bad MAC       the same, signed as V with a tag for every other node under
 *                 keys of its own (a stranger)
 *   foreign       the same, signed by node U with U's real edge keys (a
 *                 compromised node U) on its own channel, sent on V's
 *   unknown key   the same, signed as V for node N + 5 only
 *   replayed      the genuine datagram, sent again (at least 250 ms later)
 * Only the transport's URLs (udpm ttl=0 in 239/8, memq) can be used, and the
 * test runs it inside a namespace.
 *
 *   tw_inject --url URL --key-dir DIR --nodes 6 --victim 1 --impostor 5
 *
 * Exit 0 after the last burst, 3 on a transport error or when no datagram
 * of V arrives within --timeout seconds.
 */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "auth.h"
#include "net.h"
#include "round_agent.h"

#define TRAILER_MAX (DKF_AUTH_EDGE_HEADER + DKF_AUTH_EDGE_ENTRY * DKF_AUTH_MAX_KEYS)

typedef struct {
    unsigned char d[DKF_RA_MAX_MSG + TRAILER_MAX];
    size_t len;
} capture_t;

static void on_victim(const char *channel, const dkf_net_from_t *from, const void *data,
                      size_t len, int64_t recv_utime, void *user)
{
    (void)from;
    capture_t *c = user;
    (void)channel;
    (void)recv_utime;
    if (c->len == 0 && len <= sizeof c->d) {
        memcpy(c->d, data, len);
        c->len = len;
    }
}

static void sleep_ms(long ms)
{
    struct timespec t;
    t.tv_sec = ms / 1000;
    t.tv_nsec = ms % 1000 * 1000000L;
    nanosleep(&t, NULL);
}

/* body signed by a on sign_ch, published on pub_ch. 0 or -1. */
static int pub_signed(dkf_net_t *net, dkf_auth_t *a, const char *sign_ch, const char *pub_ch,
                      const unsigned char *body, size_t len)
{
    static unsigned char out[DKF_RA_MAX_MSG + TRAILER_MAX];
    if (a == NULL || len > DKF_RA_MAX_MSG) return -1;
    memcpy(out, body, len);
    if (dkf_auth_sign(a, sign_ch, out, len, out + len) != 0) return -1;
    return dkf_net_publish(net, pub_ch, out, len + dkf_auth_trailer_len(a));
}

int main(int argc, char **argv)
{
    static const struct option lo[] = {
        {"url", required_argument, NULL, 'u'},      {"prefix", required_argument, NULL, 'p'},
        {"key-dir", required_argument, NULL, 'K'},  {"nodes", required_argument, NULL, 'n'},
        {"victim", required_argument, NULL, 'v'},   {"impostor", required_argument, NULL, 'i'},
        {"bursts", required_argument, NULL, 'b'},   {"timeout", required_argument, NULL, 't'},
        {NULL, 0, NULL, 0}};
    const char *url = DKF_NET_DEFAULT_URL, *prefix = "DKF_TW", *dir = NULL;
    long nodes = 0, v = -1, u = -1, bursts = 3, timeout = 20, b, waited;
    static unsigned char keys[DKF_AUTH_MAX_KEYS * DKF_AUTH_KEY_LEN], body[DKF_RA_MAX_MSG];
    unsigned char all[DKF_AUTH_MAX_KEYS] = {0}, nobody[DKF_AUTH_MAX_KEYS] = {0};
    size_t peers[DKF_AUTH_MAX_KEYS], i, count, blen;
    char ch_v[DKF_NET_CHAN_LEN], ch_u[DKF_NET_CHAN_LEN], err[4200];
    static capture_t cap;
    dkf_auth_t *stranger, *none, *impostor;
    dkf_net_t *net;
    int c, rc = 0;
    while ((c = getopt_long(argc, argv, "", lo, NULL)) != -1) switch (c) {
        case 'u': url = optarg; break;
        case 'p': prefix = optarg; break;
        case 'K': dir = optarg; break;
        case 'n': nodes = strtol(optarg, NULL, 10); break;
        case 'v': v = strtol(optarg, NULL, 10); break;
        case 'i': u = strtol(optarg, NULL, 10); break;
        case 'b': bursts = strtol(optarg, NULL, 10); break;
        case 't': timeout = strtol(optarg, NULL, 10); break;
        default: return 2;
        }
    if (dir == NULL || nodes < 2 || nodes + 5 >= DKF_AUTH_MAX_KEYS || v < 0 || v >= nodes ||
        u < 0 || u >= nodes || u == v || bursts < 1 || bursts > 100 || strlen(prefix) > 32) {
        fprintf(stderr, "usage: tw_inject --key-dir DIR --nodes N --victim V --impostor U "
                        "[--url URL] [--prefix P] [--bursts B] [--timeout S]\n");
        return 2;
    }
    for (i = 0; i < sizeof keys; ++i) keys[i] = (unsigned char)(i * 7 + 3); /* nobody's */
    for (i = 0; i < (size_t)nodes; ++i) {
        all[i] = i != (size_t)v;
        peers[i] = i;
    }
    nobody[nodes + 5] = 1;
    stranger = dkf_auth_open_edge_keys((size_t)v, keys, all, 1);
    none = dkf_auth_open_edge_keys((size_t)v, keys, nobody, 1);
    impostor = dkf_auth_open_edges(dir, (size_t)u, peers, (size_t)nodes, err, sizeof err);
    if (impostor == NULL) fprintf(stderr, "tw_inject: %s\n", err);
    dkf_ra_chan(ch_v, prefix, (size_t)v);
    dkf_ra_chan(ch_u, prefix, (size_t)u);
    net = dkf_net_open(url, err, sizeof err);
    if (net == NULL || stranger == NULL || none == NULL || impostor == NULL ||
        dkf_net_subscribe(net, ch_v, on_victim, &cap) != 0) {
        fprintf(stderr, "tw_inject: cannot start: %s\n", net == NULL ? err : "keys or subscribe");
        rc = 3;
    }
    for (waited = 0; rc == 0 && cap.len == 0 && waited < timeout * 10; ++waited)
        if (dkf_net_drain(net, 100) < 0) rc = 3;
    count = cap.len >= DKF_AUTH_EDGE_HEADER
                ? (size_t)cap.d[cap.len - 4] << 24 | (size_t)cap.d[cap.len - 3] << 16 |
                      (size_t)cap.d[cap.len - 2] << 8 | cap.d[cap.len - 1]
                : 0;
    if (rc == 0 && (cap.len == 0 || count > DKF_AUTH_MAX_KEYS ||
                    cap.len < DKF_AUTH_EDGE_HEADER + DKF_AUTH_EDGE_ENTRY * count + 1)) {
        fprintf(stderr, "tw_inject: no authenticated datagram of node %ld\n", v);
        rc = 3;
    }
    blen = rc == 0 ? cap.len - DKF_AUTH_EDGE_HEADER - DKF_AUTH_EDGE_ENTRY * count : 0;
    if (blen > 0) {
        memcpy(body, cap.d, blen);
        body[blen - 1] ^= 1u; /* the last real's lowest bit: plausible, and wrong */
    }
    sleep_ms(250); /* V's neighbours have accepted the captured one or newer */
    for (b = 0; rc == 0 && b < bursts; ++b) {
        if (dkf_net_publish(net, ch_v, body, blen) != 0 ||
            pub_signed(net, stranger, ch_v, ch_v, body, blen) != 0 ||
            pub_signed(net, impostor, ch_u, ch_v, body, blen) != 0 ||
            pub_signed(net, none, ch_v, ch_v, body, blen) != 0 ||
            dkf_net_publish(net, ch_v, cap.d, cap.len) != 0)
            rc = 3;
        sleep_ms(100);
    }
    if (rc != 0) fprintf(stderr, "tw_inject: failed\n");
    else fprintf(stderr, "tw_inject: %ld bursts of 5 on %s\n", bursts, ch_v);
    dkf_auth_free(stranger);
    dkf_auth_free(none);
    dkf_auth_free(impostor);
    dkf_net_close(net);
    return rc;
}
