/*
 * fuzz_net_auth.c - the readers of authentication input (ports/linux/net/
 * auth.h; docs/guide/fuzzing.md): a key file's bytes, and datagrams as a host on
 * the multicast group could send them to an authenticating fusion centre.
 * Byte 0 picks the mode:
 *   0  dkf_auth_parse_key on the rest: accepted only for 64 hex digits and
 *      an optional newline, and then the key printed in hex is the input;
 *   1  a channel name (byte 1: its length, then its bytes), then a sequence
 *      of datagrams (a 2-byte length before each): every verdict is counted
 *      once; an accepted one is on a canonical channel of the protocol
 *      (chan.h), its sender is the signer the channel allows, its trailer
 *      is stripped, and the same bytes again are a replay;
 *   2  node (byte 1 mod 4) signs the rest as a message on a channel named
 *      as in 1: it can sign only on its own node channel and the status
 *      channel; what it signed the centre accepts as that node's (never as
 *      anyone else's), and any one byte changed (position and value from
 *      the message) is refused, the replay state untouched by it;
 *   3  as 1, at graph node 0 of peers 1 and 2 (DKA2, edge keys);
 *   4  as 2, graph node 1 (its one peer: 0) signing, node 0 checking: only
 *      on a channel whose canonical number is 1.
 * Keys are fixed: a fuzzer cannot find a valid tag, mode 2 makes them.
 * The channel names explore the spellings (leading zeros, aliases, other
 * kinds): a name that is not canonical is never signed nor accepted.
 */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "auth.h"
#include "codec.h"
#include "fuzz_check.h"

static unsigned char keys[DKF_AUTH_MAX_KEYS * DKF_AUTH_KEY_LEN];
static unsigned char have[DKF_AUTH_MAX_KEYS], infra[DKF_AUTH_KEY_LEN];
static unsigned char buf[65536 + DKF_AUTH_TRAILER + DKF_AUTH_EDGE_HEADER + DKF_AUTH_EDGE_ENTRY];

/* A channel name from the input: byte 0 its length (at most
 * DKF_NET_CHAN_LEN - 1, bytes up to a NUL), then its bytes; advances d, n. */
static void channel_name(const uint8_t **d, size_t *n, char name[DKF_NET_CHAN_LEN])
{
    size_t len = 0, i;
    if (*n > 0) {
        len = (size_t)(*d)[0] % DKF_NET_CHAN_LEN;
        ++*d, --*n;
    }
    if (len > *n) len = *n;
    for (i = 0; i < len && (*d)[i] != '\0'; ++i) name[i] = (char)(*d)[i];
    name[i] = '\0';
    *d += len, *n -= len;
}

/* 1 if `from` may have signed on channel (auth.h's table, DKA1). */
static int allowed(const char *channel, const dkf_net_from_t *from)
{
    const dkf_net_chan_id_t c = dkf_net_chan_parse(channel);
    const int node = from->role == DKF_NET_ROLE_NODE && from->id >= 0 && from->id < 4;
    switch (c.kind) {
    case DKF_CHAN_NODE: return node && from->id == c.id;
    case DKF_CHAN_MEAS: return from->role == DKF_NET_ROLE_SIM && from->id == -1;
    case DKF_CHAN_FUSED: return from->role == DKF_NET_ROLE_FUSION && from->id == -1;
    case DKF_CHAN_TRUTH: return from->role == DKF_NET_ROLE_SIM && from->id == -1;
    case DKF_CHAN_STATUS:
        return node || ((from->role == DKF_NET_ROLE_SIM || from->role == DKF_NET_ROLE_FUSION) &&
                        from->id == -1);
    default: return 0;
    }
}

static void init_keys(void)
{
    size_t i;
    for (i = 0; i < sizeof keys; ++i) keys[i] = (unsigned char)(i * 13 + 5);
    for (i = 0; i < 4; ++i) have[i] = 1;
    for (i = 0; i < sizeof infra; ++i) infra[i] = (unsigned char)(i + 77);
}

static dkf_auth_t *centre(void)
{
    return dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_FUSION, 0), keys, have, infra, 1);
}

/* graph node self < 4 with peers (mask bit p: peer p < 4); edge {i, j}'s
 * key is key (4 min(i, j) + max(i, j)) of keys, the same at both ends */
static dkf_auth_t *graph_node(size_t self, unsigned mask)
{
    static unsigned char k[4 * DKF_AUTH_KEY_LEN];
    unsigned char h[DKF_AUTH_MAX_KEYS] = {0};
    size_t p;
    for (p = 0; p < 4; ++p) {
        const size_t e = self < p ? 4 * self + p : 4 * p + self;
        h[p] = (unsigned char)(mask >> p & 1u);
        memcpy(k + p * DKF_AUTH_KEY_LEN, keys + e * DKF_AUTH_KEY_LEN, DKF_AUTH_KEY_LEN);
    }
    return dkf_auth_open_edge_keys(self, k, h, 1);
}

static uint64_t total(const dkf_auth_t *a)
{
    uint64_t t = 0;
    int v;
    for (v = 0; v < DKF_AUTH_NVERDICTS; ++v) t += dkf_auth_counts(a)[v];
    return t;
}

static void key_text(const uint8_t *d, size_t n)
{
    unsigned char k[DKF_AUTH_KEY_LEN];
    char hex[2 * DKF_AUTH_KEY_LEN + 1];
    size_t i;
    if (dkf_auth_parse_key((const char *)d, n, k) != 0) return;
    FUZZ_REQUIRE(n == 64 || (n == 65 && d[64] == '\n'));
    for (i = 0; i < DKF_AUTH_KEY_LEN; ++i) snprintf(hex + 2 * i, 3, "%02x", k[i]);
    for (i = 0; i < 64; ++i) FUZZ_REQUIRE((d[i] | 0x20) == (unsigned char)hex[i]);
}

static void datagrams(const uint8_t *d, size_t n, int graph)
{
    dkf_auth_t *a = graph ? graph_node(0, 6u) : centre();
    char ch[DKF_NET_CHAN_LEN];
    if (a == NULL) return;
    channel_name(&d, &n, ch);
    while (n >= 2) {
        size_t len = (size_t)d[0] << 8 | d[1], ml = 0;
        uint64_t before = total(a);
        dkf_net_from_t from = {0, -1, -1};
        dkf_auth_verdict_t v;
        d += 2, n -= 2;
        if (len > n) len = n;
        v = dkf_auth_verify(a, ch, d, len, &ml, &from);
        FUZZ_REQUIRE((unsigned)v < DKF_AUTH_NVERDICTS && total(a) == before + 1);
        FUZZ_REQUIRE(from.known == (v == DKF_AUTH_ACCEPT));
        if (v == DKF_AUTH_ACCEPT) {
            const long l = dkf_net_chan_parse(ch).id;
            FUZZ_REQUIRE(graph ? ml + DKF_AUTH_EDGE_HEADER + DKF_AUTH_EDGE_ENTRY <= len &&
                                     from.role == DKF_NET_ROLE_GRAPH && from.id == l &&
                                     (l == 1 || l == 2)
                               : ml == len - DKF_AUTH_TRAILER && allowed(ch, &from));
            FUZZ_REQUIRE(dkf_auth_verify(a, ch, d, len, &ml, NULL) == DKF_AUTH_REJ_REPLAY);
        }
        d += len, n -= len;
    }
    dkf_auth_free(a);
}

static void signed_message(const uint8_t *d, size_t n, int graph)
{
    const size_t node = graph ? 1 : n > 0 ? d[0] % 4u : 0;
    unsigned char h[DKF_AUTH_MAX_KEYS] = {0};
    char ch[DKF_NET_CHAN_LEN];
    dkf_auth_t *a = graph ? graph_node(0, 2u) : centre(), *s;
    dkf_net_from_t from = {0, -1, -1};
    dkf_net_chan_id_t c;
    size_t ml = 0, pos, t;
    int own;
    if (n > 0) ++d, --n;
    channel_name(&d, &n, ch);
    if (n > 65536) n = 65536;
    h[node] = 1;
    s = graph ? graph_node(1, 1u)
              : dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_NODE, node), keys, h, NULL, 7);
    FUZZ_REQUIRE(a != NULL && s != NULL);
    t = dkf_auth_trailer_len(s);
    c = dkf_net_chan_parse(ch);
    /* node's own channels: its node channel and the status (DKA1), or any
     * canonical name ending in its number (DKA2) */
    own = graph ? c.id == (long)node
                : (c.kind == DKF_CHAN_NODE && c.id == (long)node) || c.kind == DKF_CHAN_STATUS;
    memcpy(buf, d, n);
    if (dkf_auth_sign(s, ch, buf, n, buf + n) != 0) {
        FUZZ_REQUIRE(!own);
        dkf_auth_free(a);
        dkf_auth_free(s);
        return;
    }
    FUZZ_REQUIRE(own);
    pos = n > 0 ? (size_t)d[0] * 257u % (n + t) : n;
    buf[pos] ^= (unsigned char)(n > 1 ? d[1] | 1u : 1u);
    FUZZ_REQUIRE(dkf_auth_verify(a, ch, buf, n + t, &ml, &from) != DKF_AUTH_ACCEPT);
    FUZZ_REQUIRE(!from.known);
    buf[pos] ^= (unsigned char)(n > 1 ? d[1] | 1u : 1u);
    FUZZ_REQUIRE(dkf_auth_verify(a, ch, buf, n + t, &ml, &from) == DKF_AUTH_ACCEPT);
    FUZZ_REQUIRE(ml == n && from.known && from.id == (long)node &&
                 from.role == (graph ? DKF_NET_ROLE_GRAPH : DKF_NET_ROLE_NODE));
    dkf_auth_free(a);
    dkf_auth_free(s);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int ready;
    if (!ready) {
        init_keys();
        ready = 1;
    }
    if (size == 0) return 0;
    switch (data[0] % 5) {
    case 0: key_text(data + 1, size - 1); break;
    case 1: datagrams(data + 1, size - 1, 0); break;
    case 2: signed_message(data + 1, size - 1, 0); break;
    case 3: datagrams(data + 1, size - 1, 1); break;
    default: signed_message(data + 1, size - 1, 1); break;
    }
    return 0;
}
