/*
 * Authenticated datagrams (auth.h): every verdict of dkf_auth_verify on a
 * datagram that differs from a genuine one in one respect (a flipped bit of
 * the message or the tag, a replay, an older epoch, a node speaking for
 * another, a key not held, no trailer), the channel rule, key files
 * (parsing, permissions, dkf_auth_make_keys keeping what exists), and the
 * transport round trip over memq:// (the handler gets the message exactly,
 * a forged datagram never reaches it).
 */
#define _POSIX_C_SOURCE 200809L

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>
#include <sodium.h>

#include "auth.h"
#include "codec.h"
#include "net.h"

static unsigned char keys[DKF_AUTH_MAX_KEYS][DKF_AUTH_KEY_LEN];
static unsigned char have_all[DKF_AUTH_MAX_KEYS];
static unsigned char infra[DKF_AUTH_KEY_LEN];

static int setup(void **state)
{
    size_t i, j;
    (void)state;
    for (i = 0; i < DKF_AUTH_MAX_KEYS; ++i) {
        for (j = 0; j < DKF_AUTH_KEY_LEN; ++j) keys[i][j] = (unsigned char)(i * 31 + j * 7 + 1);
        have_all[i] = i < 4; /* a 4-node network */
    }
    for (j = 0; j < DKF_AUTH_KEY_LEN; ++j) infra[j] = (unsigned char)(200 - j);
    return 0;
}

static dkf_auth_t *node(size_t i, int64_t epoch)
{
    unsigned char have[DKF_AUTH_MAX_KEYS] = {0};
    have[i] = 1;
    return dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_NODE, i), &keys[0][0], have, NULL,
                              epoch);
}

static dkf_auth_t *centre(void)
{
    return dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_FUSION, 0), &keys[0][0], have_all,
                              infra, 1);
}

/* msg + trailer signed by a on channel, in out (returns its length). */
static size_t sign(dkf_auth_t *a, const char *ch, const char *msg, unsigned char *out)
{
    const size_t len = strlen(msg);
    memcpy(out, msg, len);
    assert_int_equal(dkf_auth_sign(a, ch, msg, len, out + len), 0);
    return len + DKF_AUTH_TRAILER;
}

static dkf_auth_verdict_t verify(dkf_auth_t *a, const char *ch, const unsigned char *d,
                                 size_t len)
{
    size_t ml = 12345;
    const dkf_auth_verdict_t v = dkf_auth_verify(a, ch, d, len, &ml);
    if (v == DKF_AUTH_ACCEPT)
        assert_int_equal(ml, len - DKF_AUTH_TRAILER);
    else
        assert_int_equal(ml, 12345); /* untouched */
    return v;
}

static void test_every_verdict(void **state)
{
    dkf_auth_t *n0 = node(0, 100), *n1 = node(1, 100), *n7, *fc = centre();
    unsigned char d[256], e[256], r[256];
    size_t len, rl;
    unsigned char have7[DKF_AUTH_MAX_KEYS] = {0};
    (void)state;
    len = sign(n0, "DKF_NODE_0", "step 1 of node 0", d);
    memcpy(r, d, len); /* kept for the replay */
    rl = len;
    /* genuine: accepted once */
    assert_int_equal(verify(fc, "DKF_NODE_0", d, len), DKF_AUTH_ACCEPT);
    /* replayed: the same bytes again */
    assert_int_equal(verify(fc, "DKF_NODE_0", r, rl), DKF_AUTH_REJ_REPLAY);
    /* one bit of the message, of the tag, of the sequence number */
    len = sign(n0, "DKF_NODE_0", "step 2 of node 0", d);
    memcpy(e, d, len);
    e[3] ^= 0x10;
    assert_int_equal(verify(fc, "DKF_NODE_0", e, len), DKF_AUTH_REJ_MAC);
    memcpy(e, d, len);
    e[len - 1] ^= 0x01;
    assert_int_equal(verify(fc, "DKF_NODE_0", e, len), DKF_AUTH_REJ_MAC);
    memcpy(e, d, len);
    e[len - DKF_AUTH_TRAILER + 27] ^= 0x01;
    assert_int_equal(verify(fc, "DKF_NODE_0", e, len), DKF_AUTH_REJ_MAC);
    /* the same datagram on another channel: node 0's key is not node 1's channel's */
    assert_int_equal(verify(fc, "DKF_NODE_1", d, len), DKF_AUTH_REJ_FOREIGN);
    /* the genuine one still passes after all of those (nothing advanced) */
    assert_int_equal(verify(fc, "DKF_NODE_0", d, len), DKF_AUTH_ACCEPT);
    /* node 1 speaking for node 0 with its own key: foreign */
    assert_int_equal(dkf_auth_sign(n1, "DKF_NODE_0", "x", 1, e), -1); /* it cannot sign there */
    len = sign(n1, "DKF_NODE_1", "node 1", d);
    assert_int_equal(verify(fc, "DKF_NODE_0", d, len), DKF_AUTH_REJ_FOREIGN);
    assert_int_equal(verify(fc, "DKF_NODE_1", d, len), DKF_AUTH_ACCEPT);
    /* node 7 of a 4-node network: a key the centre does not hold */
    have7[7] = 1;
    n7 = dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_NODE, 7), &keys[0][0], have7, NULL, 100);
    len = sign(n7, "DKF_NODE_7", "node 7", d);
    assert_int_equal(verify(fc, "DKF_NODE_7", d, len), DKF_AUTH_REJ_NO_KEY);
    /* no trailer: an unauthenticated sender, or too short */
    assert_int_equal(verify(fc, "DKF_NODE_0", (const unsigned char *)"plain message", 13),
                     DKF_AUTH_REJ_FORMAT);
    memset(e, 'A', 100);
    assert_int_equal(verify(fc, "DKF_NODE_0", e, 100), DKF_AUTH_REJ_FORMAT);
    /* counted: 3 accepted, one of each rejection but MAC (3) and foreign (2) */
    assert_int_equal(dkf_auth_counts(fc)[DKF_AUTH_ACCEPT], 3);
    assert_int_equal(dkf_auth_counts(fc)[DKF_AUTH_REJ_REPLAY], 1);
    assert_int_equal(dkf_auth_counts(fc)[DKF_AUTH_REJ_MAC], 3);
    assert_int_equal(dkf_auth_counts(fc)[DKF_AUTH_REJ_FOREIGN], 2);
    assert_int_equal(dkf_auth_counts(fc)[DKF_AUTH_REJ_NO_KEY], 1);
    assert_int_equal(dkf_auth_counts(fc)[DKF_AUTH_REJ_FORMAT], 2);
    dkf_auth_free(n0);
    dkf_auth_free(n1);
    dkf_auth_free(n7);
    dkf_auth_free(fc);
}

/* A restarted node (a later epoch) is accepted from seq 1; a datagram of
 * the older epoch after that is a replay. */
/* The tag is HMAC-SHA-512-256 (libsodium's one-shot crypto_auth, an
 * independent path from the library's precomputed key state) of
 * len(channel) (4 bytes, big-endian) || channel || message || the trailer's
 * 28-byte header, under the signer's key (docs/network.md). Checked for
 * two signers and several messages in a row, so a key state that leaked
 * from one MAC into the next would fail. */
static void test_tag_is_documented_hmac(void **state)
{
    static const char *const chan[2] = {"DKF_NODE_1", "DKF_FUSED"};
    static const char *const msg[3] = {"a", "a node message of step 12", ""};
    dkf_auth_t *signer[2];
    int who, k;
    (void)state;
    signer[0] = node(1, 7);
    signer[1] = centre();
    assert_non_null(signer[0]);
    assert_non_null(signer[1]);
    for (k = 0; k < 6; ++k)
        for (who = 0; who < 2; ++who) {
            unsigned char d[256], in[256], tag[crypto_auth_hmacsha512256_BYTES];
            const char *m = msg[k % 3];
            const size_t cl = strlen(chan[who]), len = sign(signer[who], chan[who], m, d);
            const size_t ml = len - DKF_AUTH_TRAILER;
            size_t il = 0;
            in[il++] = 0;
            in[il++] = 0;
            in[il++] = 0;
            in[il++] = (unsigned char)cl;
            memcpy(in + il, chan[who], cl);
            il += cl;
            memcpy(in + il, d, ml + 28); /* message, then the header */
            il += ml + 28;
            assert_int_equal(crypto_auth_hmacsha512256(tag, in, il, who ? infra : keys[1]), 0);
            assert_memory_equal(tag, d + ml + 28, sizeof tag);
        }
    dkf_auth_free(signer[0]);
    dkf_auth_free(signer[1]);
}

/* ---- graph nodes (DKA2): a key per edge ------------------------------------------- */

/* The graph: edges {0,1} {0,2} {1,2} {2,3}; edge {i,j}'s key made from i, j. */
static const int edge[4][4] = {{0, 1, 1, 0}, {1, 0, 1, 0}, {1, 1, 0, 1}, {0, 0, 1, 0}};

static void edge_key(size_t i, size_t j, unsigned char k[DKF_AUTH_KEY_LEN])
{
    size_t b;
    for (b = 0; b < DKF_AUTH_KEY_LEN; ++b)
        k[b] = (unsigned char)((i < j ? i : j) * 17 + (i < j ? j : i) * 101 + b * 3);
}

/* Graph node self with the keys of its edges; `as` != self: a node that
 * holds self's edge keys only toward the peers in mask (a forger). */
static dkf_auth_t *gnode(size_t self, size_t as, int64_t epoch)
{
    unsigned char k[DKF_AUTH_MAX_KEYS][DKF_AUTH_KEY_LEN], have[DKF_AUTH_MAX_KEYS] = {0};
    size_t p;
    for (p = 0; p < 4; ++p)
        if (edge[self][p]) {
            have[p] = 1;
            edge_key(as, p, k[p]);
        }
    return dkf_auth_open_edge_keys(self, &k[0][0], have, epoch);
}

static size_t gsign(dkf_auth_t *a, const char *ch, const char *msg, unsigned char *out)
{
    const size_t len = strlen(msg);
    memcpy(out, msg, len);
    assert_int_equal(dkf_auth_sign(a, ch, msg, len, out + len), 0);
    return len + dkf_auth_trailer_len(a);
}

static dkf_auth_verdict_t gverify(dkf_auth_t *a, const char *ch, const unsigned char *d,
                                  size_t len, size_t want_msg)
{
    size_t ml = 12345;
    const dkf_auth_verdict_t v = dkf_auth_verify(a, ch, d, len, &ml);
    assert_int_equal(ml, v == DKF_AUTH_ACCEPT ? want_msg : 12345);
    return v;
}

/* Node 1 speaks to its neighbours 0 and 2: each checks its own tag; one
 * neighbour's tag broken does not affect the other's; a node that is not a
 * neighbour, a node speaking on another's channel, a neighbour that holds
 * only its own edge key to node 1 (it cannot speak for 1 to 2), replays and
 * foreign trailers are refused; each tag is the documented HMAC. */
static void test_edges_every_verdict(void **state)
{
    dkf_auth_t *g[4], *forger, *star, *dka1;
    unsigned char d[512], e[512], in[256], tag[32], k[DKF_AUTH_KEY_LEN];
    const size_t T = DKF_AUTH_EDGE_HEADER + 2 * DKF_AUTH_EDGE_ENTRY;
    size_t len, i, il;
    (void)state;
    for (i = 0; i < 4; ++i) g[i] = gnode(i, i, 50);
    assert_int_equal(dkf_auth_trailer_len(g[1]), T);
    assert_int_equal(dkf_auth_trailer_len(g[3]), DKF_AUTH_EDGE_HEADER + DKF_AUTH_EDGE_ENTRY);
    len = gsign(g[1], "DKF_TW_1", "round 0 of node 1", d);
    assert_int_equal(len, 17 + T);
    /* the documented input, under edge {1,0}, entry 0 (peers ascending) */
    il = 0;
    in[il++] = 0, in[il++] = 0, in[il++] = 0, in[il++] = 8;
    memcpy(in + il, "DKF_TW_1", 8), il += 8;
    memcpy(in + il, d, 17), il += 17;
    memcpy(in + il, d + len - DKF_AUTH_EDGE_HEADER, DKF_AUTH_EDGE_HEADER);
    il += DKF_AUTH_EDGE_HEADER;
    in[il++] = 0, in[il++] = 0, in[il++] = 0, in[il++] = 0;
    edge_key(1, 0, k);
    assert_int_equal(crypto_auth_hmacsha512256(tag, in, il, k), 0);
    assert_memory_equal(d + 17 + 4, tag, 32);
    assert_memory_equal(d + len - DKF_AUTH_EDGE_HEADER, "DKA2", 4);
    assert_int_equal(gverify(g[0], "DKF_TW_1", d, len, 17), DKF_AUTH_ACCEPT);
    assert_int_equal(gverify(g[2], "DKF_TW_1", d, len, 17), DKF_AUTH_ACCEPT);
    assert_int_equal(gverify(g[0], "DKF_TW_1", d, len, 17), DKF_AUTH_REJ_REPLAY);
    /* node 3 is no neighbour of 1: no tag for it, no key */
    assert_int_equal(gverify(g[3], "DKF_TW_1", d, len, 17), DKF_AUTH_REJ_NO_KEY);
    /* a fresh datagram with node 0's tag broken: 0 refuses, 2 accepts */
    len = gsign(g[1], "DKF_TW_1", "round 1 of node 1", e);
    e[17 + 4 + 5] ^= 0x10;
    assert_int_equal(gverify(g[0], "DKF_TW_1", e, len, 17), DKF_AUTH_REJ_MAC);
    assert_int_equal(gverify(g[2], "DKF_TW_1", e, len, 17), DKF_AUTH_ACCEPT);
    /* a message bit */
    len = gsign(g[1], "DKF_TW_1", "round 2 of node 1", e);
    e[3] ^= 1;
    assert_int_equal(gverify(g[2], "DKF_TW_1", e, len, 17), DKF_AUTH_REJ_MAC);
    /* node 2 on node 1's channel (it cannot even sign there), and on the
     * receiver's own */
    assert_int_equal(dkf_auth_sign(g[2], "DKF_TW_1", "x", 1, e), -1);
    len = gsign(g[2], "DKF_TW_2", "node 2", e);
    assert_int_equal(gverify(g[0], "DKF_TW_1", e, len, 6), DKF_AUTH_REJ_FOREIGN);
    assert_int_equal(gverify(g[0], "DKF_TW_0", e, len, 6), DKF_AUTH_REJ_FOREIGN);
    assert_int_equal(gverify(g[3], "DKF_TW_2", e, len, 6), DKF_AUTH_ACCEPT);
    /* neighbour 0 forging node 1 toward 2 has only its own edge key to 1 */
    forger = gnode(1, 0, 60);
    len = gsign(forger, "DKF_TW_1", "forged by 0", e);
    assert_int_equal(gverify(g[2], "DKF_TW_1", e, len, 11), DKF_AUTH_REJ_MAC);
    /* trailers that are not DKA2: too short, DKA1, a count past the datagram */
    assert_int_equal(gverify(g[0], "DKF_TW_1", e, 20, 0), DKF_AUTH_REJ_FORMAT);
    dka1 = node(1, 5);
    len = sign(dka1, "DKF_NODE_1", "dka1", e);
    assert_int_equal(gverify(g[0], "DKF_TW_1", e, len, 4), DKF_AUTH_REJ_FORMAT);
    len = gsign(g[1], "DKF_TW_1", "count", e);
    e[len - 1] = 3; /* 3 entries do not fit before the fixed part */
    assert_int_equal(gverify(g[0], "DKF_TW_1", e, len, 5), DKF_AUTH_REJ_FORMAT);
    /* a node of every other node (the centre of a star) signs one tag each */
    star = gnode(2, 2, 70);
    assert_int_equal(dkf_auth_trailer_len(star), DKF_AUTH_EDGE_HEADER + 3 * DKF_AUTH_EDGE_ENTRY);
    assert_int_equal(dkf_auth_counts(g[0])[DKF_AUTH_ACCEPT], 1);
    assert_int_equal(dkf_auth_counts(g[0])[DKF_AUTH_REJ_REPLAY], 1);
    assert_int_equal(dkf_auth_counts(g[0])[DKF_AUTH_REJ_MAC], 1);
    assert_int_equal(dkf_auth_counts(g[0])[DKF_AUTH_REJ_FOREIGN], 2);
    assert_int_equal(dkf_auth_counts(g[0])[DKF_AUTH_REJ_FORMAT], 3);
    assert_int_equal(dkf_auth_counts(g[2])[DKF_AUTH_ACCEPT], 2);
    assert_int_equal(dkf_auth_counts(g[2])[DKF_AUTH_REJ_MAC], 2);
    assert_int_equal(dkf_auth_counts(g[3])[DKF_AUTH_REJ_NO_KEY], 1);
    for (i = 0; i < 4; ++i) dkf_auth_free(g[i]);
    dkf_auth_free(forger);
    dkf_auth_free(star);
    dkf_auth_free(dka1);
}

static void test_epochs(void **state)
{
    dkf_auth_t *old = node(2, 100), *now = node(2, 200), *fc = centre();
    unsigned char a[128], b[128], c[128];
    size_t la, lb, lc;
    (void)state;
    la = sign(old, "DKF_NODE_2", "old 1", a);
    lc = sign(old, "DKF_NODE_2", "old 2", c);
    lb = sign(now, "DKF_NODE_2", "new 1", b);
    assert_int_equal(verify(fc, "DKF_NODE_2", a, la), DKF_AUTH_ACCEPT);
    assert_int_equal(verify(fc, "DKF_NODE_2", b, lb), DKF_AUTH_ACCEPT);
    assert_int_equal(verify(fc, "DKF_NODE_2", c, lc), DKF_AUTH_REJ_REPLAY);
    dkf_auth_free(old);
    dkf_auth_free(now);
    dkf_auth_free(fc);
}

/* Who may speak where: the simulator signs MEAS_i with key i and TRUTH with
 * infra; a node may not sign the fused channel or another node's
 * measurements; the centre only with infra. */
static void test_channel_rule(void **state)
{
    dkf_auth_t *sim = dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_SIM, 0), &keys[0][0],
                                         have_all, infra, 5);
    dkf_auth_t *fc = centre(), *n3 = node(3, 5);
    unsigned char d[128], t[DKF_AUTH_TRAILER];
    size_t len;
    (void)state;
    len = sign(sim, "DKF_MEAS_3", "y3", d);
    assert_int_equal(verify(n3, "DKF_MEAS_3", d, len), DKF_AUTH_ACCEPT);
    assert_int_equal(verify(n3, "DKF_MEAS_2", d, len), DKF_AUTH_REJ_FOREIGN);
    len = sign(sim, "DKF_TRUTH", "x", d);
    assert_int_equal(verify(fc, "DKF_TRUTH", d, len), DKF_AUTH_ACCEPT);
    /* infra: not a node's */
    assert_int_equal(verify(n3, "DKF_TRUTH", d, len), DKF_AUTH_REJ_NO_KEY);
    len = sign(fc, "DKF_FUSED", "fused", d);
    assert_int_equal(verify(sim, "DKF_FUSED", d, len), DKF_AUTH_ACCEPT);
    assert_int_equal(dkf_auth_sign(n3, "DKF_FUSED", "f", 1, t), -1);
    assert_int_equal(dkf_auth_sign(n3, "DKF_MEAS_3", "y", 1, t), -1);
    assert_int_equal(dkf_auth_sign(fc, "DKF_NODE_0", "m", 1, t), -1);
    len = sign(n3, "DKF_STATUS", "node 3 status", d);
    assert_int_equal(verify(sim, "DKF_STATUS", d, len), DKF_AUTH_ACCEPT);
    dkf_auth_free(sim);
    dkf_auth_free(fc);
    dkf_auth_free(n3);
}

static void test_key_files(void **state)
{
    char dir[] = "/tmp/dkf_auth_XXXXXX", path[256], err[4200];
    unsigned char k[DKF_AUTH_KEY_LEN], k2[DKF_AUTH_KEY_LEN];
    struct stat st;
    dkf_auth_t *a;
    FILE *f;
    (void)state;
    assert_non_null(mkdtemp(dir));
    assert_int_equal(dkf_auth_parse_key("00112233445566778899aabbccddeeff"
                                        "00112233445566778899AABBCCDDEEFF\n", 65, k), 0);
    assert_int_equal(k[1], 0x11);
    assert_int_equal(k[31], 0xff);
    assert_int_equal(dkf_auth_parse_key("0011", 4, k), -1);
    assert_int_equal(dkf_auth_parse_key("g0112233445566778899aabbccddeeff"
                                        "00112233445566778899aabbccddeeff", 64, k), -1);
    assert_int_equal(dkf_auth_parse_key("00112233445566778899aabbccddeeff"
                                        "00112233445566778899aabbccddeeff\n\n", 66, k), -1);
    snprintf(path, sizeof path, "%s/keys", dir);
    assert_int_equal(dkf_auth_make_keys(path, 3, err, sizeof err), 0);
    snprintf(path, sizeof path, "%s/keys/node-2.key", dir);
    assert_int_equal(stat(path, &st), 0);
    assert_int_equal(st.st_mode & 0777, 0600);
    assert_int_equal(dkf_auth_read_key(path, k, err, sizeof err), 0);
    snprintf(path, sizeof path, "%s/keys", dir);
    assert_int_equal(dkf_auth_make_keys(path, 3, err, sizeof err), 0); /* again: kept */
    snprintf(path, sizeof path, "%s/keys/node-2.key", dir);
    assert_int_equal(dkf_auth_read_key(path, k2, err, sizeof err), 0);
    assert_memory_equal(k, k2, sizeof k);
    /* the centre of 3 nodes opens; of 4 nodes it lacks node-3.key */
    snprintf(path, sizeof path, "%s/keys", dir);
    a = dkf_auth_open(path, dkf_auth_signer(DKF_NET_ROLE_FUSION, 0), 3, err, sizeof err);
    assert_non_null(a);
    dkf_auth_free(a);
    assert_null(dkf_auth_open(path, dkf_auth_signer(DKF_NET_ROLE_FUSION, 0), 4, err, sizeof err));
    assert_non_null(strstr(err, "node-3.key"));
    /* a key readable by others is refused */
    snprintf(path, sizeof path, "%s/keys/node-1.key", dir);
    assert_int_equal(chmod(path, 0644), 0);
    assert_int_equal(dkf_auth_read_key(path, k, err, sizeof err), -1);
    assert_non_null(strstr(err, "readable by group or others"));
    /* a file that is not a key */
    snprintf(path, sizeof path, "%s/keys/bad.key", dir);
    f = fopen(path, "w");
    assert_non_null(f);
    fputs("not a key\n", f);
    fclose(f);
    assert_int_equal(chmod(path, 0600), 0);
    assert_int_equal(dkf_auth_read_key(path, k, err, sizeof err), -1);
    snprintf(path, sizeof path, "rm -rf %s", dir);
    assert_int_equal(system(path), 0);
}

typedef struct {
    int calls;
    size_t len;
    char got[64];
} sink_t;

static void on_msg(const char *channel, const void *data, size_t len, int64_t t, void *user)
{
    sink_t *s = user;
    (void)channel;
    (void)t;
    ++s->calls;
    s->len = len;
    memcpy(s->got, data, len < sizeof s->got ? len : sizeof s->got);
}

/* Over the transport: the handler gets the message without its trailer; a
 * plain (unsigned) datagram from a second, unauthenticated sender never
 * reaches it and is counted. */
static void test_transport_round_trip(void **state)
{
    char err[DKF_NET_ERR_LEN];
    dkf_net_t *net = dkf_net_open("memq://", err, sizeof err);
    sink_t sk;
    (void)state;
    memset(&sk, 0, sizeof sk);
    assert_non_null(net);
    dkf_net_set_auth(net, node(0, 9));
    assert_int_equal(dkf_net_subscribe(net, "DKF_NODE_0", on_msg, &sk), 0);
    assert_int_equal(dkf_net_publish(net, "DKF_NODE_0", "hello", 5), 0);
    assert_int_equal(dkf_net_drain(net, 100), 1);
    assert_int_equal(sk.calls, 1);
    assert_int_equal(sk.len, 5);
    assert_memory_equal(sk.got, "hello", 5);
    /* node 0 may not publish on node 1's channel: refused at the sender */
    assert_int_equal(dkf_net_publish(net, "DKF_NODE_1", "x", 1), -1);
    /* an unsigned datagram: with authentication off, published as is; back
     * on, the receiving side rejects it */
    dkf_net_set_auth(net, NULL);
    assert_int_equal(dkf_net_publish(net, "DKF_NODE_0", "forged", 6), 0);
    dkf_net_set_auth(net, node(0, 10));
    assert_true(dkf_net_drain(net, 100) >= 0);
    assert_int_equal(sk.calls, 1);
    assert_int_equal(dkf_auth_counts(dkf_net_auth(net))[DKF_AUTH_REJ_FORMAT], 1);
    dkf_net_close(net);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_verdict),
        cmocka_unit_test(test_tag_is_documented_hmac),
        cmocka_unit_test(test_edges_every_verdict),
        cmocka_unit_test(test_epochs),
        cmocka_unit_test(test_channel_rule),
        cmocka_unit_test(test_key_files),
        cmocka_unit_test(test_transport_round_trip),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
