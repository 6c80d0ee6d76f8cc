/*
 * fuzz_net_auth.c - the readers of authentication input (ports/linux/net/
 * auth.h; docs/fuzzing.md): a key file's bytes, and datagrams as a host on
 * the multicast group could send them to an authenticating fusion centre.
 * Byte 0 picks the mode:
 *   0  dkf_auth_parse_key on the rest: accepted only for 64 hex digits and
 *      an optional newline, and then the key printed in hex is the input;
 *   1  byte 1 picks a channel, the rest is a sequence of datagrams (a 2-byte
 *      length before each): every verdict is counted once, an accepted one
 *      has its trailer stripped, and the same bytes again are a replay;
 *   2  the rest is a message that node (byte 1 mod 4) signs on its channel:
 *      the centre accepts it, and any one byte changed (position and value
 *      from the message) is refused, the replay state untouched by it;
 *   3  as 1, at graph node 0 of peers 1 and 2 (DKA2, edge keys), byte 1
 *      picking a graph channel;
 *   4  as 2, graph node 1 (its one peer: 0) signing on DKF_TW_1, node 0
 *      checking.
 * Keys are fixed: a fuzzer cannot find a valid tag, mode 2 makes them.
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

static const char *const channels[] = {"DKF_NODE_0", "DKF_NODE_3", "DKF_NODE_7", "DKF_MEAS_1",
                                       "DKF_FUSED",  "DKF_TRUTH",  "DKF_STATUS", "DKF_NODE_",
                                       "X"};
#define NCHAN (sizeof channels / sizeof channels[0])
static const char *const graph_channels[] = {"DKF_TW_1", "DKF_TW_2", "DKF_TW_0", "DKF_TW_3",
                                             "DKF_TW_", "DKF_TW_1x", "X"};
#define NGCHAN (sizeof graph_channels / sizeof graph_channels[0])

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
    const char *ch;
    if (a == NULL || n < 1) {
        dkf_auth_free(a);
        return;
    }
    ch = graph ? graph_channels[d[0] % NGCHAN] : channels[d[0] % NCHAN];
    ++d, --n;
    while (n >= 2) {
        size_t len = (size_t)d[0] << 8 | d[1], ml = 0;
        uint64_t before = total(a);
        dkf_auth_verdict_t v;
        d += 2, n -= 2;
        if (len > n) len = n;
        v = dkf_auth_verify(a, ch, d, len, &ml);
        FUZZ_REQUIRE((unsigned)v < DKF_AUTH_NVERDICTS && total(a) == before + 1);
        if (v == DKF_AUTH_ACCEPT) {
            FUZZ_REQUIRE(graph ? ml + DKF_AUTH_EDGE_HEADER + DKF_AUTH_EDGE_ENTRY <= len
                               : ml == len - DKF_AUTH_TRAILER);
            FUZZ_REQUIRE(dkf_auth_verify(a, ch, d, len, &ml) == DKF_AUTH_REJ_REPLAY);
        }
        d += len, n -= len;
    }
    dkf_auth_free(a);
}

static void signed_message(const uint8_t *d, size_t n, int graph)
{
    const size_t node = graph ? 1 : n > 0 ? d[0] % 4u : 0;
    unsigned char h[DKF_AUTH_MAX_KEYS] = {0};
    char ch[32];
    dkf_auth_t *a = graph ? graph_node(0, 2u) : centre(), *s;
    size_t ml = 0, pos, t;
    if (n > 0) ++d, --n;
    if (n > 65536) n = 65536;
    h[node] = 1;
    s = graph ? graph_node(1, 1u)
              : dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_NODE, node), keys, h, NULL, 7);
    FUZZ_REQUIRE(a != NULL && s != NULL);
    t = dkf_auth_trailer_len(s);
    snprintf(ch, sizeof ch, graph ? "DKF_TW_%zu" : "DKF_NODE_%zu", node);
    memcpy(buf, d, n);
    FUZZ_REQUIRE(dkf_auth_sign(s, ch, buf, n, buf + n) == 0);
    pos = n > 0 ? (size_t)d[0] * 257u % (n + t) : n;
    buf[pos] ^= (unsigned char)(n > 1 ? d[1] | 1u : 1u);
    FUZZ_REQUIRE(dkf_auth_verify(a, ch, buf, n + t, &ml) != DKF_AUTH_ACCEPT);
    buf[pos] ^= (unsigned char)(n > 1 ? d[1] | 1u : 1u);
    FUZZ_REQUIRE(dkf_auth_verify(a, ch, buf, n + t, &ml) == DKF_AUTH_ACCEPT);
    FUZZ_REQUIRE(ml == n);
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
