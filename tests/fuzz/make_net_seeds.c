/*
 * make_net_seeds.c - writes the seed corpus of fuzz_net (tests/fuzz/corpus/net/):
 * one datagram of each type that the harness's receivers accept, and the
 * datagrams of the decoder bugs fixed in codec.c, each file
 * prefixed with its selector byte (fuzz_net.h).
 *
 * usage: make_net_seeds DIR    (cmake --build B --target make_net_seeds)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_net.h"

static unsigned char buf[DKF_NET_MAX_MSG + DKF_NET_TWA_MAX_MSG];
static const char *dir;

static void put(const char *name, int sel, const void *data, size_t len)
{
    char path[4096];
    FILE *f;
    unsigned char s = (unsigned char)sel;
    snprintf(path, sizeof path, "%s/%s", dir, name);
    f = fopen(path, "wb");
    if (f == NULL || fwrite(&s, 1, 1, f) != 1 || fwrite(data, 1, len, f) != len || fclose(f)) {
        fprintf(stderr, "make_net_seeds: cannot write %s\n", path);
        exit(1);
    }
}

/* The harness's receivers accept the seed (sel, data, len). */
static int accepted(int sel, const void *data, size_t len)
{
    static dkf_diffkf_msg_t msg;
    static dkf_net_meta_t meta;
    static dkf_net_meas_t m;
    static dkf_net_truth_t t;
    static dkf_net_fused_t f;
    static dkf_net_status_t st;
    static dkf_net_tw_pkt_t p;
    const dkf_net_expect_t ex = fuzz_net_expect();
    dkf_net_twa_scn_t c = fuzz_net_tw_scn(sel == FUZZ_NET_TW3 ? 3 : 2);
    dkf_net_verdict_t v;
    switch (sel) {
    case FUZZ_NET_NODE_MSG: v = dkf_net_decode_node_msg(data, len, &ex, &msg, NULL, &meta, NULL); break;
    case FUZZ_NET_MEAS: v = dkf_net_decode_meas(data, len, &ex, &m, NULL); break;
    case FUZZ_NET_TRUTH: v = dkf_net_decode_truth(data, len, &ex, &t, NULL); break;
    case FUZZ_NET_FUSED: v = dkf_net_decode_fused(data, len, &ex, &f, NULL); break;
    case FUZZ_NET_STATUS: v = dkf_net_decode_status(data, len, NULL, &st, NULL); break;
    default: v = dkf_net_twa_decode(data, len, &c, -1, &p, NULL); break;
    }
    return v == DKF_NET_ACCEPT;
}

/* A seed the receivers must accept. */
/* The seeds' envelope: one time, the model id, sequence number seq. */
static void set_meta(dkf_net_meta_t *meta, int64_t seq)
{
    meta->utime = 1700000000000000LL;
    meta->model_id = FUZZ_NET_MODEL_ID;
    meta->seq = seq;
}

static void put_ok(const char *name, int sel, const void *data, size_t len)
{
    if (!accepted(sel, data, len)) {
        fprintf(stderr, "make_net_seeds: %s is rejected\n", name);
        exit(1);
    }
    put(name, sel, data, len);
}

static void be32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

static void need(int ok)
{
    if (!ok) {
        fprintf(stderr, "make_net_seeds: an encoder refused a seed\n");
        exit(1);
    }
}

static void node_msgs(void)
{
    dkf_diffkf_msg_t msg, prev;
    dkf_net_meta_t meta;
    size_t i, len;
    memset(&msg, 0, sizeof msg);
    memset(&meta, 0, sizeof meta);
    msg.node = 1;
    msg.k = 7;
    msg.n = FUZZ_NET_N;
    for (i = 0; i < FUZZ_NET_N; ++i) {
        msg.xf[i] = (dkf_real_t)(0.5 * (double)i + 1.0);
        msg.xp[i] = (dkf_real_t)(-0.25 * (double)i);
    }
    prev = msg;
    prev.k = 6;
    set_meta(&meta, 6);
    meta.meas_utime = 1700000000000100LL;
    meta.epoch = 0;
    meta.k_start = 1;
    meta.has_prev = 1;
    need(dkf_net_encode_node_msg(buf, sizeof buf, &len, &msg, &prev, &meta) == 0);
    put_ok("node_msg_prev", FUZZ_NET_NODE_MSG, buf, len);
    meta.has_prev = 0;
    meta.k_start = 7;
    meta.epoch = 1;
    need(dkf_net_encode_node_msg(buf, sizeof buf, &len, &msg, NULL, &meta) == 0);
    put_ok("node_msg_epoch_start", FUZZ_NET_NODE_MSG, buf, len);
}

static void meas_truth_status(void)
{
    dkf_net_meas_t m;
    dkf_net_truth_t t;
    dkf_net_status_t st;
    size_t len;
    memset(&m, 0, sizeof m);
    set_meta(&m.meta, 2);
    m.node = 2;
    m.k = 3;
    m.m = fuzz_net_m[2];
    m.y[0] = 1.5;
    m.y[1] = -2.0;
    m.y[2] = 1e-3;
    need(dkf_net_encode_meas(buf, sizeof buf, &len, &m) == 0);
    put_ok("meas", FUZZ_NET_MEAS, buf, len);
    memset(&t, 0, sizeof t);
    t.meta = m.meta;
    t.k = 0;
    t.n = FUZZ_NET_N;
    t.x[0] = 1.0;
    t.x[3] = -4.0;
    need(dkf_net_encode_truth(buf, sizeof buf, &len, &t) == 0);
    put_ok("truth", FUZZ_NET_TRUTH, buf, len);
    memset(&st, 0, sizeof st);
    st.utime = 1700000000000000LL;
    st.model_id = FUZZ_NET_MODEL_ID;
    st.role = DKF_NET_ROLE_FUSION;
    st.id = -1;
    st.state = DKF_NET_RUNNING;
    st.k = 12;
    st.sent = 12;
    st.received = 36;
    snprintf(st.detail, sizeof st.detail, "node 2: message rejected: wrong model id");
    need(dkf_net_encode_status(buf, sizeof buf, &len, &st) == 0);
    put_ok("status", FUZZ_NET_STATUS, buf, len);
}

static void fused(void)
{
    static dkf_net_fused_t f;
    size_t i, len;
    unsigned char *nn;
    memset(&f, 0, sizeof f);
    set_meta(&f.meta, 4);
    f.k = 5;
    f.degraded = 1;
    f.revision = 1;
    f.nnodes = FUZZ_NET_NNODES;
    f.contributed[0] = 1;
    f.contributed[2] = 1;
    f.meas_utime_first = 1;
    f.meas_utime_last = 2;
    f.msg_utime_last = 3;
    f.n = FUZZ_NET_N;
    for (i = 0; i < FUZZ_NET_N; ++i) {
        f.xf[i] = (double)i;
        f.xp[i] = (double)i + 0.5;
        f.Pf[i * FUZZ_NET_N + i] = 2.0;
        f.Pp[i * FUZZ_NET_N + i] = 3.0;
    }
    need(dkf_net_encode_fused(buf, sizeof buf, &len, &f) == 0);
    put_ok("fused", FUZZ_NET_FUSED, buf, len);
    /* Fixed bug: zero nodes. nnodes is the int32 after the fingerprint,
     * utime, model_id, k, seq, status (8 + 8 + 8 + 4 + 8 + 1 bytes); cut
     * out contributed[3]. */
    nn = buf + 37;
    be32(nn, 0);
    memmove(nn + 4, nn + 4 + FUZZ_NET_NNODES, len - 41 - FUZZ_NET_NNODES);
    put("fused_zero_nodes", FUZZ_NET_FUSED, buf, len - FUZZ_NET_NNODES);
}

static void tw_packets(void)
{
    static dkf_net_tw_pkt_t p;
    size_t i, len;
    dkf_net_twa_scn_t c2 = fuzz_net_tw_scn(2), c3 = fuzz_net_tw_scn(3);
    memset(&p, 0, sizeof p);
    p.utime = 1700000000000000LL;
    p.model_id = c2.model_id;
    p.node = 1;
    p.k = 2;
    p.round = 0;
    p.kind = DKF_NET_TW_KIND_INFO;
    p.len = DKF_TW_PKT_LEN(c2.n);
    for (i = 0; i < p.len; ++i) p.v[i] = (dkf_real_t)((double)i * 0.125);
    need(dkf_net_twa_encode(buf, sizeof buf, &len, &p) == 0);
    put_ok("tw2_info", FUZZ_NET_TW2, buf, len);
    p.round = 1;
    p.kind = DKF_NET_TW_KIND_EST;
    p.len = c2.n;
    p.retransmit = 1;
    need(dkf_net_twa_encode(buf, sizeof buf, &len, &p) == 0);
    put_ok("tw2_est_retransmit", FUZZ_NET_TW2, buf, len);
    p.model_id = c3.model_id;
    p.round = 3;
    p.retransmit = 0;
    p.len = DKF_TW_PKT_LEN(c3.n);
    need(dkf_net_twa_encode(buf, sizeof buf, &len, &p) == 0);
    put_ok("tw3_est", FUZZ_NET_TW3, buf, len);
    p.round = 0;
    p.kind = DKF_NET_TW_KIND_DONE;
    p.k = (long)c3.steps + 1;
    p.len = 0;
    need(dkf_net_twa_encode(buf, sizeof buf, &len, &p) == 0);
    put_ok("tw3_done", FUZZ_NET_TW3, buf, len);
    /* Fixed bug: a 50-byte packet whose len (the int32 that ends the 42-byte
     * header) is 0x20000001; 8 bytes of v follow. */
    be32(buf + len - 4, 0x20000001u);
    memset(buf + len, 0x41, 8);
    put("tw_len_0x20000001", FUZZ_NET_TW3, buf, len + 8);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: make_net_seeds DIR\n");
        return 2;
    }
    dir = argv[1];
    node_msgs();
    meas_truth_status();
    fused();
    tw_packets();
    put("channel_tw", FUZZ_NET_CHANNEL, "DKF_TW_3", 8);
    put("channel_node", FUZZ_NET_CHANNEL, "DKF_NODE_2", 10);
    return 0;
}
