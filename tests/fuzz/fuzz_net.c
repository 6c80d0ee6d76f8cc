/*
 * fuzz_net.c - every decoder of network input (codec.h, tw_agent.h) on any
 * datagram (docs/guide/fuzzing.md). Byte 0 picks the decoder (fuzz_net.h), the
 * rest is the datagram, as a host on the multicast group could send it.
 *
 * Besides "no crash, no sanitizer report", each call must keep what
 * codec.h promises:
 *   - a rejected datagram leaves the outputs untouched and counts once in
 *     the rejects, under its verdict; an accepted one counts nothing;
 *   - an accepted datagram re-encodes (the matching encoder must take it)
 *     to a datagram that decodes to the same outputs; for the host-double
 *     types (measurement, truth, fused) and the graph packet in a double
 *     build, the re-encoded bytes are the input bytes.
 */
#include <stdint.h>
#include <string.h>

#include "fuzz_check.h"
#include "fuzz_net.h"

#define FUZZ_NET_BUF (DKF_NET_MAX_MSG > DKF_NET_TWA_MAX_MSG ? DKF_NET_MAX_MSG : DKF_NET_TWA_MAX_MSG)

static unsigned char re[FUZZ_NET_BUF + 8192];

static void require_counted(const dkf_net_rejects_t *rej, dkf_net_verdict_t v)
{
    size_t i, sum = 0;
    FUZZ_REQUIRE(v >= DKF_NET_ACCEPT && v < DKF_NET_NVERDICTS);
    for (i = 0; i < DKF_NET_NVERDICTS; ++i) sum += rej->by[i];
    FUZZ_REQUIRE(rej->total == sum);
    FUZZ_REQUIRE(rej->by[0] == 0);
    if (v == DKF_NET_ACCEPT)
        FUZZ_REQUIRE(rej->total == 0);
    else
        FUZZ_REQUIRE(rej->total == 1 && rej->by[v] == 1);
}

/* The checks of every decoding: counted as codec.h says, and a rejection
 * left out (size bytes, prefilled like keep) untouched. 1 if accepted. */
static int accepted(const dkf_net_rejects_t *rej, dkf_net_verdict_t v, const void *out,
                    const void *keep, size_t size)
{
    require_counted(rej, v);
    if (v == DKF_NET_ACCEPT) return 1;
    FUZZ_REQUIRE(memcmp(out, keep, size) == 0);
    return 0;
}

/* The bytes re-encoded from an accepted datagram are the datagram. */
static void require_same_bytes(const uint8_t *d, size_t n, size_t len)
{
    FUZZ_REQUIRE(len == n && memcmp(re, d, n) == 0);
}

static void node_msg(const uint8_t *d, size_t n)
{
    static dkf_diffkf_msg_t msg, prev, msg2, prev2, keep;
    static dkf_net_meta_t meta, meta2, keep_meta;
    const dkf_net_expect_t ex = fuzz_net_expect();
    dkf_net_rejects_t rej;
    dkf_net_verdict_t v;
    size_t len;
    memset(&rej, 0, sizeof rej);
    memset(&msg, 0xa5, sizeof msg);
    memset(&meta, 0xa5, sizeof meta);
    prev = keep = msg2 = prev2 = msg;
    keep_meta = meta2 = meta;
    v = dkf_net_decode_node_msg(d, n, &ex, &msg, &prev, &meta, &rej);
    require_counted(&rej, v);
    if (v != DKF_NET_ACCEPT) {
        FUZZ_REQUIRE(memcmp(&msg, &keep, sizeof msg) == 0);
        FUZZ_REQUIRE(memcmp(&prev, &keep, sizeof prev) == 0);
        FUZZ_REQUIRE(memcmp(&meta, &keep_meta, sizeof meta) == 0);
        return;
    }
    FUZZ_REQUIRE(meta.has_prev || memcmp(&prev, &keep, sizeof prev) == 0);
    FUZZ_REQUIRE(dkf_net_encode_node_msg(re, sizeof re, &len, &msg, &prev, &meta) == 0);
    FUZZ_REQUIRE(dkf_net_decode_node_msg(re, len, &ex, &msg2, &prev2, &meta2, NULL) ==
                 DKF_NET_ACCEPT);
    FUZZ_REQUIRE(memcmp(&msg, &msg2, sizeof msg) == 0);
    FUZZ_REQUIRE(memcmp(&prev, &prev2, sizeof prev) == 0);
    FUZZ_REQUIRE(memcmp(&meta, &meta2, sizeof meta) == 0);
}

/* Before a decode: no rejection counted, out filled with 0xa5 bytes (a
 * decoder that refuses must leave them), keep and again the same. */
static void poison(dkf_net_rejects_t *rej, void *out, void *keep, void *again, size_t size)
{
    memset(rej, 0, sizeof *rej);
    memset(out, 0xa5, size);
    memcpy(keep, out, size);
    memcpy(again, out, size);
}

/* The decode / untouched / re-encode checks of one codec.h type T whose
 * decoder is dkf_net_decode_<name>(buf, len, &ex, &out, &rej). */
#define FUZZ_NET_TYPE(fn, T, name)                                                  \
    static void fn(const uint8_t *d, size_t n)                                      \
    {                                                                               \
        static T out, keep, again;                                                  \
        const dkf_net_expect_t ex = fuzz_net_expect();                              \
        dkf_net_rejects_t rej;                                                      \
        dkf_net_verdict_t v;                                                        \
        size_t len;                                                                 \
        poison(&rej, &out, &keep, &again, sizeof out);                              \
        v = dkf_net_decode_##name(d, n, &ex, &out, &rej);                           \
        if (!accepted(&rej, v, &out, &keep, sizeof out)) return;                    \
        FUZZ_REQUIRE(dkf_net_encode_##name(re, sizeof re, &len, &out) == 0);        \
        require_same_bytes(d, n, len);                                              \
        FUZZ_REQUIRE(dkf_net_decode_##name(re, len, &ex, &again, NULL) ==           \
                     DKF_NET_ACCEPT);                                               \
        FUZZ_REQUIRE(memcmp(&out, &again, sizeof out) == 0);                        \
    }

FUZZ_NET_TYPE(meas, dkf_net_meas_t, meas)
FUZZ_NET_TYPE(truth, dkf_net_truth_t, truth)
FUZZ_NET_TYPE(fused, dkf_net_fused_t, fused)

static void status(const uint8_t *d, size_t n)
{
    static dkf_net_status_t out, keep, again;
    dkf_net_rejects_t rej;
    dkf_net_verdict_t v;
    size_t len;
    poison(&rej, &out, &keep, &again, sizeof out);
    static const dkf_net_from_t node1 = {1, DKF_NET_ROLE_NODE, 1},
                                centre = {1, DKF_NET_ROLE_FUSION, -1};
    v = dkf_net_decode_status(d, n, NULL, &out, &rej);
    if (!accepted(&rej, v, &out, &keep, sizeof out)) return;
    /* with a known sender, only a status that names it is taken */
    FUZZ_REQUIRE((dkf_net_decode_status(d, n, &node1, &again, NULL) == DKF_NET_ACCEPT) ==
                 (out.role == DKF_NET_ROLE_NODE && out.id == 1));
    FUZZ_REQUIRE((dkf_net_decode_status(d, n, &centre, &again, NULL) == DKF_NET_ACCEPT) ==
                 (out.role == DKF_NET_ROLE_FUSION && out.id == -1));
    again = keep;
    /* the detail is a C string that fits (truncated if it did not) */
    FUZZ_REQUIRE(memchr(out.detail, '\0', sizeof out.detail) != NULL);
    FUZZ_REQUIRE(dkf_net_encode_status(re, sizeof re, &len, &out) == 0);
    FUZZ_REQUIRE(dkf_net_decode_status(re, len, NULL, &again, NULL) == DKF_NET_ACCEPT);
    FUZZ_REQUIRE(memcmp(&out, &again, sizeof out) == 0);
}

static void tw(const uint8_t *d, size_t n, int alg)
{
    static dkf_net_tw_pkt_t out, keep, again;
    const dkf_net_twa_scn_t c = fuzz_net_tw_scn(alg);
    dkf_net_rejects_t rej;
    dkf_net_verdict_t v;
    size_t len;
    poison(&rej, &out, &keep, &again, sizeof out);
    /* the channel: none (any node), or node 1's */
    v = dkf_net_twa_decode(d, n, &c, n % 2 ? 1 : -1, &out, &rej);
    if (!accepted(&rej, v, &out, &keep, sizeof out)) return;
    FUZZ_REQUIRE(out.len <= DKF_NET_TWA_MAX_PKT);
    FUZZ_REQUIRE(dkf_net_twa_encode(re, sizeof re, &len, &out) == 0);
#if !DKF_USE_FLOAT
    require_same_bytes(d, n, len);
#endif
    FUZZ_REQUIRE(dkf_net_twa_decode(re, len, &c, out.node, &again, NULL) == DKF_NET_ACCEPT);
    FUZZ_REQUIRE(memcmp(&out, &again, sizeof out) == 0);
}

/* A channel name as LCM hands it to a handler (NUL-terminated). */
static void channel(const uint8_t *d, size_t n)
{
    char name[DKF_NET_CHAN_LEN + 16], back[DKF_NET_CHAN_LEN];
    dkf_net_chan_id_t c;
    long node;
    if (n >= sizeof name) n = sizeof name - 1;
    memcpy(name, d, n);
    name[n] = '\0';
    c = dkf_net_chan_parse(name);
    FUZZ_REQUIRE(c.kind >= DKF_CHAN_NONE && c.kind <= DKF_CHAN_GRAPH);
    FUZZ_REQUIRE((c.kind == DKF_CHAN_MEAS || c.kind == DKF_CHAN_NODE || c.kind == DKF_CHAN_GRAPH)
                     ? c.id >= 0 && c.id <= DKF_NET_CHAN_MAX_ID
                     : c.id == -1);
    if (c.id >= 0) { /* one spelling per id: the name ends in exactly "_<id>" */
        const size_t len = strlen(name);
        const int w = snprintf(back, sizeof back, "_%ld", c.id);
        FUZZ_REQUIRE(w > 0 && (size_t)w <= len && strcmp(name + len - (size_t)w, back) == 0);
    }
    FUZZ_REQUIRE(dkf_net_chan_node_id(name) == (c.kind == DKF_CHAN_NODE ? c.id : -1));
    node = dkf_net_twa_chan_node(name, "DKF_TW");
    FUZZ_REQUIRE(node >= -1);
    if (node >= 0) { /* only the canonical spelling is accepted */
        dkf_net_twa_chan(back, "DKF_TW", (size_t)node);
        FUZZ_REQUIRE(strcmp(back, name) == 0);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const uint8_t *d = data + 1;
    size_t n;
    if (size == 0) return 0;
    n = size - 1;
    switch (data[0] % FUZZ_NET_NSEL) {
    case FUZZ_NET_NODE_MSG: node_msg(d, n); break;
    case FUZZ_NET_MEAS: meas(d, n); break;
    case FUZZ_NET_TRUTH: truth(d, n); break;
    case FUZZ_NET_FUSED: fused(d, n); break;
    case FUZZ_NET_STATUS: status(d, n); break;
    case FUZZ_NET_TW2: tw(d, n, 2); break;
    case FUZZ_NET_TW3: tw(d, n, 3); break;
    default: channel(d, n); break;
    }
    return 0;
}
