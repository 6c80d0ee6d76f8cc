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
 *      from the message) is refused, the replay state untouched by it.
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
static unsigned char buf[65536 + DKF_AUTH_TRAILER];

static const char *const channels[] = {"DKF_NODE_0", "DKF_NODE_3", "DKF_NODE_7", "DKF_MEAS_1",
                                       "DKF_FUSED",  "DKF_TRUTH",  "DKF_STATUS", "DKF_NODE_",
                                       "X"};
#define NCHAN (sizeof channels / sizeof channels[0])

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

static void datagrams(const uint8_t *d, size_t n)
{
    dkf_auth_t *a = centre();
    const char *ch;
    if (a == NULL || n < 1) {
        dkf_auth_free(a);
        return;
    }
    ch = channels[d[0] % NCHAN];
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
            FUZZ_REQUIRE(ml == len - DKF_AUTH_TRAILER);
            FUZZ_REQUIRE(dkf_auth_verify(a, ch, d, len, &ml) == DKF_AUTH_REJ_REPLAY);
        }
        d += len, n -= len;
    }
    dkf_auth_free(a);
}

static void signed_message(const uint8_t *d, size_t n)
{
    const size_t node = n > 0 ? d[0] % 4u : 0;
    unsigned char h[DKF_AUTH_MAX_KEYS] = {0};
    char ch[32];
    dkf_auth_t *a = centre(), *s;
    size_t ml = 0, pos;
    if (n > 0) ++d, --n;
    if (n > 65536) n = 65536;
    h[node] = 1;
    s = dkf_auth_open_keys(dkf_auth_signer(DKF_NET_ROLE_NODE, node), keys, h, NULL, 7);
    FUZZ_REQUIRE(a != NULL && s != NULL);
    snprintf(ch, sizeof ch, "DKF_NODE_%zu", node);
    memcpy(buf, d, n);
    FUZZ_REQUIRE(dkf_auth_sign(s, ch, buf, n, buf + n) == 0);
    pos = n > 0 ? (size_t)d[0] * 257u % (n + DKF_AUTH_TRAILER) : n;
    buf[pos] ^= (unsigned char)(n > 1 ? d[1] | 1u : 1u);
    FUZZ_REQUIRE(dkf_auth_verify(a, ch, buf, n + DKF_AUTH_TRAILER, &ml) != DKF_AUTH_ACCEPT);
    buf[pos] ^= (unsigned char)(n > 1 ? d[1] | 1u : 1u);
    FUZZ_REQUIRE(dkf_auth_verify(a, ch, buf, n + DKF_AUTH_TRAILER, &ml) == DKF_AUTH_ACCEPT);
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
    switch (data[0] % 3) {
    case 0: key_text(data + 1, size - 1); break;
    case 1: datagrams(data + 1, size - 1); break;
    default: signed_message(data + 1, size - 1); break;
    }
    return 0;
}
