/*
 * Authenticated datagrams (auth.h): every verdict of dkf_auth_verify on a
 * datagram that differs from a genuine one in one respect (a flipped bit of
 * the message or the tag, a replay, an older epoch, a node speaking for
 * another, a key not held, no trailer), the channel rule, key files
 * (parsing, permissions, dkf_auth_make_keys keeping what exists), the
 * transport round trip over memq:// (the handler gets the message exactly
 * and its sender, a forged datagram never reaches it), and impersonation:
 * for every message type on every channel, and on names that are not
 * canonical, a holder of node 0's key that writes any signer and key id it
 * likes is refused and counted unless it speaks as itself on its own
 * channels, and a payload that names another sender than the key's is
 * refused by the codec.
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

static dkf_net_from_t last_from; /* the sender of the last datagram verify accepted */

static dkf_auth_verdict_t verify(dkf_auth_t *a, const char *ch, const unsigned char *d,
                                 size_t len)
{
    size_t ml = 12345;
    dkf_net_from_t from = {0, -7, -7};
    const dkf_auth_verdict_t v = dkf_auth_verify(a, ch, d, len, &ml, &from);
    if (v == DKF_AUTH_ACCEPT) {
        assert_int_equal(ml, len - DKF_AUTH_TRAILER);
        assert_int_equal(from.known, 1);
        last_from = from;
    } else {
        assert_int_equal(ml, 12345); /* untouched */
        assert_int_equal(from.known, 0);
        assert_int_equal(from.role, -7);
    }
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
 * 28-byte header, under the signer's key (docs/guide/network.md). Checked for
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
    dkf_net_from_t from = {0, -1, -1};
    const dkf_auth_verdict_t v = dkf_auth_verify(a, ch, d, len, &ml, &from);
    assert_int_equal(ml, v == DKF_AUTH_ACCEPT ? want_msg : 12345);
    assert_int_equal(from.known, v == DKF_AUTH_ACCEPT);
    if (v == DKF_AUTH_ACCEPT) { /* the sender is the channel's node, from its edge key */
        assert_int_equal(from.role, DKF_NET_ROLE_GRAPH);
        assert_int_equal(from.id, dkf_net_chan_parse(ch).id);
    }
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

/* ---- impersonation: identity comes from the key ------------------------------------- */

static void put_be(unsigned char *p, uint64_t v, int bytes)
{
    int i;
    for (i = bytes - 1; i >= 0; --i, v >>= 8) p[i] = (unsigned char)(v & 0xffu);
}

/* msg + a DKA1 trailer as a holder of `key` can write it: any signer and
 * key id, the tag over the documented input under `key` (libsodium's
 * one-shot HMAC, independent of auth.c). Returns the datagram's length. */
static size_t forge(const unsigned char *key, uint32_t signer, uint32_t key_id, uint64_t seq,
                    const char *ch, const unsigned char *msg, size_t len, unsigned char *out)
{
    static unsigned char in[4 + DKF_NET_CHAN_LEN + DKF_NET_MAX_MSG + 28];
    unsigned char *t = out + len;
    const size_t cl = strlen(ch);
    size_t il = 0;
    memcpy(out, msg, len);
    memcpy(t, "DKA1", 4);
    put_be(t + 4, signer, 4);
    put_be(t + 8, key_id, 4);
    put_be(t + 12, 1000, 8); /* epoch */
    put_be(t + 20, seq, 8);
    put_be(in, cl, 4);
    il = 4;
    memcpy(in + il, ch, cl), il += cl;
    memcpy(in + il, msg, len), il += len;
    memcpy(in + il, t, 28), il += 28;
    assert_int_equal(crypto_auth_hmacsha512256(t + 28, in, il, key), 0);
    return len + DKF_AUTH_TRAILER;
}

static uint64_t judged(const dkf_auth_t *a)
{
    uint64_t s = 0;
    int v;
    for (v = 0; v < DKF_AUTH_NVERDICTS; ++v) s += dkf_auth_counts(a)[v];
    return s;
}

#define MODEL_ID 77

/* A status of (role, id), encoded. */
static size_t status_of(int role, int id, unsigned char *buf, size_t cap)
{
    dkf_net_status_t st;
    size_t len;
    memset(&st, 0, sizeof st);
    st.model_id = MODEL_ID;
    st.role = role;
    st.id = id;
    st.state = DKF_NET_FAILED; /* what would stop the simulator */
    snprintf(st.detail, sizeof st.detail, "impostor");
    assert_int_equal(dkf_net_encode_status(buf, cap, &len, &st), 0);
    return len;
}

/* A node message of `node`, step 3, n = 2, encoded. */
static size_t node_msg_of(size_t node, unsigned char *buf, size_t cap)
{
    dkf_diffkf_msg_t m;
    dkf_net_meta_t meta;
    size_t len;
    memset(&m, 0, sizeof m);
    memset(&meta, 0, sizeof meta);
    m.node = (uint16_t)node;
    m.k = 3;
    m.n = 2;
    meta.model_id = MODEL_ID;
    meta.k_start = 1;
    assert_int_equal(dkf_net_encode_node_msg(buf, cap, &len, &m, NULL, &meta), 0);
    return len;
}

/* Node 0's key in the hands of an attacker. On every channel of the
 * protocol, and on aliases of them that are not canonical, it writes
 * trailers claiming to be node 0, node 1, the simulator, the fusion
 * centre, a graph node or an unknown role, with key ids 0, 1 and infra,
 * over every message type. The centre, the simulator and node 1 accept
 * exactly what node 0 may say as itself (its node channel and the status
 * channel) and count every refusal once; what they accept has node 0 as
 * its sender, and a payload on it that names another sender is refused
 * by the codec (a node message of node 1: unknown node; a status of the
 * centre, the simulator or node 1: not its sender). One more datagram
 * passes, as documented: the simulator's on MEAS_0, which is signed with
 * key 0 because node 0 must check it; node 0 can write its own
 * measurements, which only node 0 reads (docs/guide/network.md, "Threat model"). */
static void test_impersonation(void **state)
{
    static const char *const chans[] = {
        "DKF_NODE_0",  "DKF_NODE_1",    "DKF_MEAS_0",  "DKF_MEAS_1", "DKF_FUSED",
        "DKF_TRUTH",   "DKF_STATUS",    "DKF_NODE_00", "DKF_NODE_0001", "DKF_NODE_01",
        "DKF_NODE_1x", "DKF_MEAS_001",  "DKF_STATUS_", "DKF_0",      "DKF_TW_1",
        "DKF_OTHER",   "DKF_NODE_-0",   "DKF_NODE_+1", "DKF_NODE_"};
    const uint32_t N0 = dkf_auth_signer(DKF_NET_ROLE_NODE, 0);
    const uint32_t signers[] = {N0,
                                dkf_auth_signer(DKF_NET_ROLE_NODE, 1),
                                dkf_auth_signer(DKF_NET_ROLE_SIM, 0),
                                dkf_auth_signer(DKF_NET_ROLE_FUSION, 0),
                                dkf_auth_signer(DKF_NET_ROLE_GRAPH, 0),
                                7u << 16,
                                N0 | 0x8000u /* node 32768: no such key */};
    const uint32_t key_ids[] = {0, 1, DKF_AUTH_KEY_INFRA};
    static unsigned char msg[5][DKF_NET_MAX_MSG], d[DKF_NET_MAX_MSG + DKF_AUTH_TRAILER];
    size_t mlen[5], c, s, k, t, r, accepted = 0, refused = 0;
    dkf_auth_t *rx[3];
    uint64_t seq = 1;
    (void)state;
    rx[0] = centre();
    rx[1] = dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_SIM, 0), &keys[0][0], have_all,
                               infra, 1);
    rx[2] = node(1, 1);
    mlen[0] = node_msg_of(1, msg[0], sizeof msg[0]);
    mlen[1] = status_of(DKF_NET_ROLE_FUSION, -1, msg[1], sizeof msg[1]);
    mlen[2] = status_of(DKF_NET_ROLE_SIM, -1, msg[2], sizeof msg[2]);
    mlen[3] = status_of(DKF_NET_ROLE_NODE, 1, msg[3], sizeof msg[3]);
    mlen[4] = node_msg_of(0, msg[4], sizeof msg[4]);
    for (c = 0; c < sizeof chans / sizeof chans[0]; ++c)
        for (s = 0; s < sizeof signers / sizeof signers[0]; ++s)
            for (k = 0; k < 3; ++k)
                for (t = 0; t < 5; ++t)
                    for (r = 0; r < 3; ++r) {
                        const dkf_net_chan_id_t ch = dkf_net_chan_parse(chans[c]);
                        const int own = signers[s] == N0 && key_ids[k] == 0 &&
                                        ((ch.kind == DKF_CHAN_NODE && ch.id == 0) ||
                                         ch.kind == DKF_CHAN_STATUS);
                        const int own_meas = signers[s] == dkf_auth_signer(DKF_NET_ROLE_SIM, 0) &&
                                             key_ids[k] == 0 && ch.kind == DKF_CHAN_MEAS &&
                                             ch.id == 0;
                        const size_t len = forge(keys[0], signers[s], key_ids[k], seq++,
                                                 chans[c], msg[t], mlen[t], d);
                        const uint64_t before = judged(rx[r]);
                        const dkf_auth_verdict_t v = verify(rx[r], chans[c], d, len);
                        assert_int_equal(judged(rx[r]), before + 1); /* counted once */
                        if (r == 2 && (own || own_meas)) { /* node 1 holds no key 0 */
                            assert_int_equal(v, DKF_AUTH_REJ_NO_KEY);
                            continue;
                        }
                        if (v != DKF_AUTH_ACCEPT) {
                            if (own || own_meas)
                                fail_msg("%s: node 0 as itself refused (%d)", chans[c], v);
                            if (ch.kind == DKF_CHAN_NONE || ch.kind == DKF_CHAN_GRAPH)
                                assert_int_equal(v, DKF_AUTH_REJ_CHANNEL);
                            ++refused;
                            continue;
                        }
                        if (!own && !own_meas)
                            fail_msg("%s: signer %08x key %08x accepted", chans[c],
                                     (unsigned)signers[s], (unsigned)key_ids[k]);
                        ++accepted;
                        if (own_meas) {
                            assert_int_equal(last_from.role, DKF_NET_ROLE_SIM);
                            continue;
                        }
                        /* the sender is node 0, from its key */
                        assert_int_equal(last_from.role, DKF_NET_ROLE_NODE);
                        assert_int_equal(last_from.id, 0);
                        assert_int_equal(dkf_net_from_node(&last_from, "DKF_NODE_1"), 0);
                        if (ch.kind == DKF_CHAN_STATUS) {
                            dkf_net_status_t st;
                            dkf_net_rejects_t rej;
                            memset(&rej, 0, sizeof rej);
                            /* t 1..3 name another sender; 0 and 4 are no status */
                            assert_int_equal(
                                dkf_net_decode_status(msg[t], mlen[t], &last_from, &st, &rej),
                                t >= 1 && t <= 3 ? DKF_NET_REJ_SENDER : DKF_NET_REJ_MALFORMED);
                            assert_int_equal(rej.total, 1);
                        } else {
                            dkf_net_expect_t ex;
                            dkf_diffkf_msg_t m, pm;
                            dkf_net_meta_t meta;
                            ex.model_id = MODEL_ID;
                            ex.nnodes = 4;
                            ex.node = dkf_net_from_node(&last_from, chans[c]);
                            ex.n = 2;
                            ex.m = NULL;
                            ex.kmax = 10;
                            assert_int_equal(
                                dkf_net_decode_node_msg(msg[t], mlen[t], &ex, &m, &pm, &meta, NULL),
                                t == 4 ? DKF_NET_ACCEPT
                                : t == 0 ? DKF_NET_REJ_NODE : DKF_NET_REJ_MALFORMED);
                        }
                    }
    /* node 0 as itself on NODE_0 and STATUS, and as the simulator on MEAS_0:
     * 3 channels x 5 types x 2 receivers (node 1 holds no key 0) */
    assert_int_equal(accepted, 30);
    print_message("impersonation: %zu datagrams refused and counted, %zu genuine accepted\n",
                  refused, accepted);
    /* a genuine status of node 0 names its sender: accepted */
    {
        dkf_net_status_t st;
        const size_t len = status_of(DKF_NET_ROLE_NODE, 0, msg[0], sizeof msg[0]);
        assert_int_equal(dkf_net_decode_status(msg[0], len, &last_from, &st, NULL),
                         DKF_NET_ACCEPT);
    }
    for (r = 0; r < 3; ++r) dkf_auth_free(rx[r]);
}

/* Non-canonical aliases of a node's own channel are neither signed nor
 * accepted; the graph's channels too. */
static void test_aliases(void **state)
{
    static const char *const alias[] = {"DKF_NODE_00", "DKF_NODE_0001", "DKF_NODE_", "DKF_X_0 "};
    dkf_auth_t *n0 = node(0, 3), *fc = centre(), *g1 = gnode(1, 1, 3), *g0 = gnode(0, 0, 3);
    unsigned char t[DKF_AUTH_TRAILER + 2 * DKF_AUTH_EDGE_ENTRY + DKF_AUTH_EDGE_HEADER], d[256];
    size_t i, len;
    (void)state;
    for (i = 0; i < sizeof alias / sizeof alias[0]; ++i)
        assert_int_equal(dkf_auth_sign(n0, alias[i], "m", 1, t), -1);
    assert_int_equal(dkf_auth_sign(g1, "DKF_TW_01", "m", 1, t), -1);
    assert_int_equal(dkf_auth_sign(g1, "DKF_TW_001", "m", 1, t), -1);
    /* signed on the canonical name, presented under an alias: refused, not as a MAC failure */
    len = sign(n0, "DKF_NODE_0", "m", d);
    assert_int_equal(verify(fc, "DKF_NODE_0001", d, len), DKF_AUTH_REJ_CHANNEL);
    len = gsign(g1, "DKF_TW_1", "m", d);
    assert_int_equal(gverify(g0, "DKF_TW_01", d, len, 1), DKF_AUTH_REJ_CHANNEL);
    assert_int_equal(gverify(g0, "DKF_TW_1", d, len, 1), DKF_AUTH_ACCEPT);
    assert_string_equal(dkf_auth_verdict_str(DKF_AUTH_REJ_CHANNEL), "bad channel");
    dkf_auth_free(n0);
    dkf_auth_free(fc);
    dkf_auth_free(g1);
    dkf_auth_free(g0);
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
    dkf_net_from_t from;
} sink_t;

static void on_msg(const char *channel, const dkf_net_from_t *from, const void *data, size_t len,
                   int64_t t, void *user)
{
    sink_t *s = user;
    (void)channel;
    s->from = *from;
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
    assert_int_equal(sk.from.known, 1); /* the sender, from the key */
    assert_int_equal(sk.from.role, DKF_NET_ROLE_NODE);
    assert_int_equal(sk.from.id, 0);
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
        cmocka_unit_test(test_impersonation),
        cmocka_unit_test(test_aliases),
        cmocka_unit_test(test_key_files),
        cmocka_unit_test(test_transport_round_trip),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
