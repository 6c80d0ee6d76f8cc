/*
 * Wire codec (codec.h): round trips of every message type, every rejection
 * path of the decoders (each counted once, outputs untouched), and the
 * length checks that keep lcm-gen's trusting decoders safe.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "codec.h"

#define MODEL ((int64_t)0x1234567890abcdefLL)

static unsigned char buf[DKF_NET_MAX_MSG];

static dkf_net_expect_t expect(void)
{
    static const size_t m[3] = {2, 3, 1};
    dkf_net_expect_t ex;
    ex.model_id = MODEL;
    ex.nnodes = 3;
    ex.node = -1;
    ex.n = 4;
    ex.m = m;
    ex.kmax = 50;
    return ex;
}

static void make_msg(dkf_diffkf_msg_t *m, dkf_net_meta_t *meta)
{
    size_t i;
    memset(m, 0, sizeof *m);
    m->node = 2;
    m->k = 17;
    m->n = 4;
    for (i = 0; i < 4; ++i) {
        m->xf[i] = (dkf_real_t)(0.1 * (double)i - 3.25);
        m->xp[i] = (dkf_real_t)(1e3 + (double)i / 7.0);
    }
    meta->utime = 1700000000123456LL;
    meta->model_id = MODEL;
    meta->seq = 41;
    meta->meas_utime = 1700000000000001LL;
    meta->epoch = 0;
    meta->k_start = 1;
    meta->has_prev = 0;
}

static size_t encode_msg(const dkf_diffkf_msg_t *m, const dkf_net_meta_t *meta)
{
    size_t len = 0;
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, m, NULL, meta), 0);
    return len;
}

/* Decodes buf[0..len) expecting verdict v; on rejection the outputs must be
 * untouched and exactly one rejection of kind v counted. */
static void expect_node_verdict(size_t len, const dkf_net_expect_t *ex, dkf_net_verdict_t v)
{
    dkf_diffkf_msg_t out, ref;
    dkf_net_meta_t meta, mref;
    dkf_net_rejects_t rej;
    memset(&out, 0x5a, sizeof out);
    memset(&meta, 0x5a, sizeof meta);
    ref = out;
    mref = meta;
    memset(&rej, 0, sizeof rej);
    assert_int_equal(dkf_net_decode_node_msg(buf, len, ex, &out, NULL, &meta, &rej), v);
    if (v != DKF_NET_ACCEPT) {
        assert_memory_equal(&out, &ref, sizeof out);
        assert_memory_equal(&meta, &mref, sizeof meta);
        assert_int_equal(rej.total, 1);
        assert_int_equal(rej.by[v], 1);
    } else {
        assert_int_equal(rej.total, 0);
    }
}

static void test_node_msg_round_trip(void **state)
{
    dkf_diffkf_msg_t m, out;
    dkf_net_meta_t meta, mo;
    dkf_net_expect_t ex = expect();
    size_t len;
    (void)state;
    make_msg(&m, &meta);
    len = encode_msg(&m, &meta);
    /* layout: fingerprint + 4 int64 + 3 int32 + 2n doubles, then epoch,
     * k_start, has_prev (1 byte), prev_k and 2n doubles */
    assert_int_equal(len, 8 + 4 * 8 + 3 * 4 + 2 * 4 * 8 + 4 + 4 + 1 + 4 + 2 * 4 * 8);
    memset(&out, 0, sizeof out);
    assert_int_equal(dkf_net_decode_node_msg(buf, len, &ex, &out, NULL, &mo, NULL), DKF_NET_ACCEPT);
    assert_int_equal(out.node, 2);
    assert_int_equal(out.k, 17);
    assert_int_equal(out.n, 4);
    /* the wire carries doubles: dkf_real_t values come back bit for bit */
    assert_memory_equal(out.xf, m.xf, 4 * sizeof(dkf_real_t));
    assert_memory_equal(out.xp, m.xp, 4 * sizeof(dkf_real_t));
    assert_true(mo.utime == meta.utime && mo.model_id == meta.model_id && mo.seq == meta.seq &&
                mo.meas_utime == meta.meas_utime && mo.epoch == 0 && mo.k_start == 1 &&
                mo.has_prev == 0);
    ex.node = 2; /* the channel's node */
    expect_node_verdict(len, &ex, DKF_NET_ACCEPT);
}

static void test_node_msg_rejections(void **state)
{
    dkf_diffkf_msg_t m;
    dkf_net_meta_t meta;
    dkf_net_expect_t ex = expect();
    size_t len, cut;
    (void)state;
    make_msg(&m, &meta);
    len = encode_msg(&m, &meta);
    /* truncated at every length, and one trailing byte */
    for (cut = 0; cut < len; ++cut) expect_node_verdict(cut, &ex, DKF_NET_REJ_MALFORMED);
    buf[len] = 0;
    expect_node_verdict(len + 1, &ex, DKF_NET_REJ_MALFORMED);
    /* fingerprint changed */
    buf[3] ^= 0x10;
    expect_node_verdict(len, &ex, DKF_NET_REJ_MALFORMED);
    buf[3] ^= 0x10;
    /* length field n (offset 48) negative, huge, or not matching the size */
    {
        static const unsigned char bad_n[][4] = {
            {0xff, 0xff, 0xff, 0xff}, {0x7f, 0xff, 0xff, 0xff}, {0, 0, 0, 3}, {0, 0, 0, 5}};
        unsigned char keep[4];
        size_t b;
        memcpy(keep, buf + 48, 4);
        for (b = 0; b < sizeof bad_n / sizeof bad_n[0]; ++b) {
            memcpy(buf + 48, bad_n[b], 4);
            expect_node_verdict(len, &ex, DKF_NET_REJ_MALFORMED);
        }
        memcpy(buf + 48, keep, 4);
    }
    expect_node_verdict(len, &ex, DKF_NET_ACCEPT);
    /* node outside 0..nnodes-1, and not the channel's node */
    m.node = 3;
    len = encode_msg(&m, &meta);
    expect_node_verdict(len, &ex, DKF_NET_REJ_NODE);
    m.node = 2;
    len = encode_msg(&m, &meta);
    ex.node = 1;
    expect_node_verdict(len, &ex, DKF_NET_REJ_NODE);
    ex.node = -1;
    /* model id */
    meta.model_id = MODEL + 1;
    len = encode_msg(&m, &meta);
    expect_node_verdict(len, &ex, DKF_NET_REJ_MODEL);
    meta.model_id = MODEL;
    /* dimension: a consistent message of another n */
    m.n = 3;
    len = encode_msg(&m, &meta);
    expect_node_verdict(len, &ex, DKF_NET_REJ_DIM);
    m.n = 4;
    /* step 0 and beyond kmax */
    m.k = 0;
    len = encode_msg(&m, &meta);
    expect_node_verdict(len, &ex, DKF_NET_REJ_STEP);
    m.k = 51;
    len = encode_msg(&m, &meta);
    expect_node_verdict(len, &ex, DKF_NET_REJ_STEP);
    m.k = 50;
    len = encode_msg(&m, &meta);
    expect_node_verdict(len, &ex, DKF_NET_ACCEPT);
    /* non-finite in xf or xp */
    m.xf[1] = (dkf_real_t)NAN;
    len = encode_msg(&m, &meta);
    expect_node_verdict(len, &ex, DKF_NET_REJ_NONFINITE);
    m.xf[1] = 0;
    m.xp[3] = (dkf_real_t)-INFINITY;
    len = encode_msg(&m, &meta);
    expect_node_verdict(len, &ex, DKF_NET_REJ_NONFINITE);
}

/* A double that is finite but overflows dkf_real_t (float build) is
 * non-finite for the receiver; in the double build it is accepted. */
static void test_node_msg_real_overflow(void **state)
{
    dkf_diffkf_msg_t m;
    dkf_net_meta_t meta;
    dkf_net_expect_t ex = expect();
    size_t len;
    (void)state;
    make_msg(&m, &meta);
    len = encode_msg(&m, &meta);
    {
        /* patch xf[0] (offset 52) on the wire to 1e300, big-endian */
        double v = 1e300;
        uint64_t bits;
        int i;
        memcpy(&bits, &v, sizeof bits);
        for (i = 0; i < 8; ++i) buf[52 + i] = (unsigned char)(bits >> (56 - 8 * i));
    }
    expect_node_verdict(len, &ex, DKF_USE_FLOAT ? DKF_NET_REJ_NONFINITE : DKF_NET_ACCEPT);
}

/* The fault-handling fields: a message of a restarted node (epoch 2 from
 * step 15) carrying its previous step's payload round-trips bit for bit;
 * inconsistent epoch fields, a bad flag and NaN in the previous payload
 * are rejected by reason with the outputs untouched. */
static void test_node_msg_epoch_and_prev(void **state)
{
    dkf_diffkf_msg_t m, pv, out, outp;
    dkf_net_meta_t meta, mo;
    dkf_net_expect_t ex = expect();
    const size_t hp = 52 + 2 * 4 * 8 + 8; /* has_prev's offset for n = 4 */
    size_t len, i;
    (void)state;
    make_msg(&m, &meta);
    pv = m;
    pv.k = 16;
    for (i = 0; i < 4; ++i) {
        pv.xf[i] = (dkf_real_t)(-0.5 * (double)i);
        pv.xp[i] = (dkf_real_t)(0.25 + (double)i);
    }
    meta.epoch = 2;
    meta.k_start = 15;
    meta.has_prev = 1;
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta), 0);
    memset(&out, 0, sizeof out);
    memset(&outp, 0, sizeof outp);
    assert_int_equal(dkf_net_decode_node_msg(buf, len, &ex, &out, &outp, &mo, NULL), DKF_NET_ACCEPT);
    assert_int_equal(mo.epoch, 2);
    assert_int_equal(mo.k_start, 15);
    assert_int_equal(mo.has_prev, 1);
    assert_int_equal(outp.k, 16);
    assert_int_equal(outp.node, 2);
    assert_int_equal(outp.n, 4);
    assert_memory_equal(outp.xf, pv.xf, 4 * sizeof(dkf_real_t));
    assert_memory_equal(outp.xp, pv.xp, 4 * sizeof(dkf_real_t));
    assert_memory_equal(out.xf, m.xf, 4 * sizeof(dkf_real_t));
    /* has_prev must be a boolean */
    buf[hp] = 2;
    expect_node_verdict(len, &ex, DKF_NET_REJ_MALFORMED);
    buf[hp] = 1;
    /* a previous payload that is not of step k-1, or older than the epoch */
    pv.k = 15;
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta), 0);
    expect_node_verdict(len, &ex, DKF_NET_REJ_STEP);
    pv.k = 16;
    meta.k_start = 17;
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta), 0);
    expect_node_verdict(len, &ex, DKF_NET_REJ_STEP); /* also k_start = k with a prev */
    meta.k_start = 18;
    meta.has_prev = 0;
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, NULL, &meta), 0);
    expect_node_verdict(len, &ex, DKF_NET_REJ_STEP); /* k_start after k */
    meta.k_start = 0;
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, NULL, &meta), 0);
    expect_node_verdict(len, &ex, DKF_NET_REJ_STEP);
    meta.k_start = 17; /* the first message of an epoch has no previous payload */
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, NULL, &meta), 0);
    expect_node_verdict(len, &ex, DKF_NET_ACCEPT);
    meta.epoch = -1;
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, NULL, &meta), 0);
    expect_node_verdict(len, &ex, DKF_NET_REJ_MALFORMED);
    meta.epoch = 2;
    meta.k_start = 15;
    meta.has_prev = 1;
    pv.xp[3] = (dkf_real_t)NAN;
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, &pv, &meta), 0);
    expect_node_verdict(len, &ex, DKF_NET_REJ_NONFINITE);
    /* without has_prev the (zero) previous arrays are not looked at */
    meta.has_prev = 0;
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, NULL, &meta), 0);
    expect_node_verdict(len, &ex, DKF_NET_ACCEPT);
    /* the encoder refuses a previous payload it is not given */
    meta.has_prev = 1;
    assert_int_equal(dkf_net_encode_node_msg(buf, sizeof buf, &len, &m, NULL, &meta), -1);
}

static void test_meas_round_trip_and_rejections(void **state)
{
    dkf_net_meas_t y, out, ref;
    dkf_net_expect_t ex = expect();
    dkf_net_rejects_t rej;
    size_t len, cut, full;
    (void)state;
    memset(&y, 0, sizeof y);
    y.meta.utime = 99;
    y.meta.model_id = MODEL;
    y.meta.seq = 7;
    y.node = 1;
    y.k = 51; /* measurements run to N+1 */
    y.m = 3;
    y.y[0] = 1.5;
    y.y[1] = -2.25;
    y.y[2] = 1e-300;
    ex.kmax = 51;
    assert_int_equal(dkf_net_encode_meas(buf, sizeof buf, &len, &y), 0);
    assert_int_equal(len, 8 + 3 * 8 + 3 * 4 + 3 * 8);
    full = len;
    memset(&out, 0, sizeof out);
    assert_int_equal(dkf_net_decode_meas(buf, len, &ex, &out, NULL), DKF_NET_ACCEPT);
    assert_int_equal(out.node, 1);
    assert_int_equal(out.k, 51);
    assert_int_equal(out.m, 3);
    assert_memory_equal(out.y, y.y, 3 * sizeof(double));
    assert_int_equal(out.meta.seq, 7);
    assert_int_equal(out.meta.utime, 99);
    memset(&rej, 0, sizeof rej);
    memset(&out, 0x77, sizeof out);
    ref = out;
    for (cut = 0; cut < len; ++cut)
        assert_int_equal(dkf_net_decode_meas(buf, cut, &ex, &out, &rej), DKF_NET_REJ_MALFORMED);
    assert_int_equal(rej.by[DKF_NET_REJ_MALFORMED], len);
    /* a node message is not a measurement */
    {
        dkf_diffkf_msg_t m;
        dkf_net_meta_t meta;
        size_t l2;
        make_msg(&m, &meta);
        l2 = encode_msg(&m, &meta);
        assert_int_equal(dkf_net_decode_meas(buf, l2, &ex, &out, &rej), DKF_NET_REJ_MALFORMED);
    }
    /* wrong m for that node (node 1 has m = 3) */
    y.m = 2;
    assert_int_equal(dkf_net_encode_meas(buf, sizeof buf, &len, &y), 0);
    assert_int_equal(dkf_net_decode_meas(buf, len, &ex, &out, &rej), DKF_NET_REJ_DIM);
    y.m = 3;
    y.node = 5;
    assert_int_equal(dkf_net_encode_meas(buf, sizeof buf, &len, &y), 0);
    assert_int_equal(dkf_net_decode_meas(buf, len, &ex, &out, &rej), DKF_NET_REJ_NODE);
    y.node = 1;
    y.meta.model_id = 0;
    assert_int_equal(dkf_net_encode_meas(buf, sizeof buf, &len, &y), 0);
    assert_int_equal(dkf_net_decode_meas(buf, len, &ex, &out, &rej), DKF_NET_REJ_MODEL);
    y.meta.model_id = MODEL;
    y.k = 52;
    assert_int_equal(dkf_net_encode_meas(buf, sizeof buf, &len, &y), 0);
    assert_int_equal(dkf_net_decode_meas(buf, len, &ex, &out, &rej), DKF_NET_REJ_STEP);
    y.k = 2;
    y.y[2] = NAN;
    assert_int_equal(dkf_net_encode_meas(buf, sizeof buf, &len, &y), 0);
    assert_int_equal(dkf_net_decode_meas(buf, len, &ex, &out, &rej), DKF_NET_REJ_NONFINITE);
    assert_memory_equal(&out, &ref, sizeof out);
    /* every truncation, the node message and the five field checks */
    assert_int_equal(rej.total, full + 1 + 5);
}

static void test_truth_round_trip(void **state)
{
    dkf_net_truth_t t, out;
    dkf_net_expect_t ex = expect();
    size_t len;
    (void)state;
    memset(&t, 0, sizeof t);
    t.meta.model_id = MODEL;
    t.k = 0; /* the truth starts at k = 0 */
    t.n = 4;
    t.x[3] = 42.5;
    assert_int_equal(dkf_net_encode_truth(buf, sizeof buf, &len, &t), 0);
    assert_int_equal(dkf_net_decode_truth(buf, len, &ex, &out, NULL), DKF_NET_ACCEPT);
    assert_int_equal(out.k, 0);
    assert_true(out.x[3] == 42.5);
    assert_int_equal(dkf_net_decode_truth(buf, len - 1, &ex, &out, NULL), DKF_NET_REJ_MALFORMED);
    t.x[0] = INFINITY;
    assert_int_equal(dkf_net_encode_truth(buf, sizeof buf, &len, &t), 0);
    assert_int_equal(dkf_net_decode_truth(buf, len, &ex, &out, NULL), DKF_NET_REJ_NONFINITE);
}

static void test_fused_round_trip_and_rejections(void **state)
{
    static dkf_net_fused_t f, out;
    dkf_net_expect_t ex = expect();
    size_t len, i, cut;
    (void)state;
    memset(&f, 0, sizeof f);
    f.meta.model_id = MODEL;
    f.meta.seq = 3;
    f.k = 12;
    f.degraded = 1;
    f.nnodes = 3;
    f.contributed[0] = 1;
    f.contributed[2] = 1;
    f.meas_utime_first = 10;
    f.meas_utime_last = 20;
    f.msg_utime_last = 30;
    f.n = 4;
    for (i = 0; i < 4; ++i) {
        f.xf[i] = (double)i;
        f.xp[i] = -(double)i;
    }
    for (i = 0; i < 16; ++i) {
        f.Pf[i] = 1.0 / (1.0 + (double)i);
        f.Pp[i] = 2.0 + (double)i;
    }
    assert_int_equal(dkf_net_encode_fused(buf, sizeof buf, &len, &f), 0);
    f.revision = 3;
    assert_int_equal(dkf_net_encode_fused(buf, sizeof buf, &len, &f), 0);
    assert_int_equal(len, 8 + 8 + 8 + 4 + 8 + 1 + 4 + 3 + 3 * 8 + 4 + 8 * (8 + 32) + 4);
    assert_int_equal(dkf_net_decode_fused(buf, len, &ex, &out, NULL), DKF_NET_ACCEPT);
    assert_int_equal(out.k, 12);
    assert_int_equal(out.degraded, 1);
    assert_int_equal(out.revision, 3);
    assert_int_equal(out.nnodes, 3);
    assert_int_equal(out.contributed[0], 1);
    assert_int_equal(out.contributed[1], 0);
    assert_int_equal(out.contributed[2], 1);
    assert_int_equal(out.meas_utime_first, 10);
    assert_int_equal(out.msg_utime_last, 30);
    assert_memory_equal(out.Pf, f.Pf, 16 * sizeof(double));
    assert_memory_equal(out.Pp, f.Pp, 16 * sizeof(double));
    assert_memory_equal(out.xp, f.xp, 4 * sizeof(double));
    for (cut = 0; cut < len; ++cut)
        assert_int_equal(dkf_net_decode_fused(buf, cut, &ex, &out, NULL), DKF_NET_REJ_MALFORMED);
    /* status byte (offset 36) outside {COMPLETE, DEGRADED} */
    buf[36] = 7;
    assert_int_equal(dkf_net_decode_fused(buf, len, &ex, &out, NULL), DKF_NET_REJ_MALFORMED);
    /* nnodes (offset 37) negative */
    buf[37] = 0xff;
    assert_int_equal(dkf_net_decode_fused(buf, len, &ex, &out, NULL), DKF_NET_REJ_MALFORMED);
    ex.nnodes = 2;
    assert_int_equal(dkf_net_encode_fused(buf, sizeof buf, &len, &f), 0);
    assert_int_equal(dkf_net_decode_fused(buf, len, &ex, &out, NULL), DKF_NET_REJ_NODE);
    ex.nnodes = 3;
    f.Pp[5] = NAN;
    assert_int_equal(dkf_net_encode_fused(buf, sizeof buf, &len, &f), 0);
    assert_int_equal(dkf_net_decode_fused(buf, len, &ex, &out, NULL), DKF_NET_REJ_NONFINITE);
}

static void test_status_round_trip(void **state)
{
    dkf_net_status_t st, out;
    size_t len;
    (void)state;
    memset(&st, 0, sizeof st);
    st.model_id = MODEL;
    st.role = DKF_NET_ROLE_NODE;
    st.id = 4;
    st.state = DKF_NET_FAILED;
    st.k = 9;
    st.sent = 8;
    st.rejected = 2;
    strcpy(st.detail, "node 4: step k=9: dkf_diffkf_step failed");
    assert_int_equal(dkf_net_encode_status(buf, sizeof buf, &len, &st), 0);
    assert_int_equal(len, 70 + strlen(st.detail) + 1);
    assert_int_equal(dkf_net_decode_status(buf, len, NULL, &out, NULL), DKF_NET_ACCEPT);
    assert_int_equal(out.role, DKF_NET_ROLE_NODE);
    assert_int_equal(out.id, 4);
    assert_int_equal(out.state, DKF_NET_FAILED);
    assert_int_equal(out.k, 9);
    assert_int_equal(out.sent, 8);
    assert_string_equal(out.detail, st.detail);
    /* the string must end with its NUL; its length must fit the message */
    buf[len - 1] = 'x';
    assert_int_equal(dkf_net_decode_status(buf, len, NULL, &out, NULL), DKF_NET_REJ_MALFORMED);
    buf[len - 1] = 0;
    buf[66] = 0x80; /* length field negative */
    assert_int_equal(dkf_net_decode_status(buf, len, NULL, &out, NULL), DKF_NET_REJ_MALFORMED);
    assert_int_equal(dkf_net_decode_status(buf, 10, NULL, &out, NULL), DKF_NET_REJ_MALFORMED);
}

/* chan.h: every name the writers make parses back to its kind and id; a
 * name that is not canonical is no channel (NONE), so no two names are one
 * sender's channel. */
static void test_channels(void **state)
{
    static const struct {
        const char *name;
        dkf_net_chan_kind_t kind;
        long id;
    } cases[] = {
        {"DKF_MEAS_11", DKF_CHAN_MEAS, 11},   {"X_NODE_0", DKF_CHAN_NODE, 0},
        {"A_B_NODE_255", DKF_CHAN_NODE, 255}, {"DKF_NODE_99999", DKF_CHAN_NODE, 99999},
        {"DKF_FUSED", DKF_CHAN_FUSED, -1},    {"DKF_TRUTH", DKF_CHAN_TRUTH, -1},
        {"DKF_STATUS", DKF_CHAN_STATUS, -1},  {"DKF_TW_7", DKF_CHAN_GRAPH, 7},
        {"DKF_TW_0", DKF_CHAN_GRAPH, 0},
        /* not canonical, or not a channel of the protocol */
        {"DKF_NODE_0001", DKF_CHAN_NONE, -1}, {"DKF_NODE_01", DKF_CHAN_NONE, -1},
        {"DKF_NODE_00", DKF_CHAN_NONE, -1},   {"DKF_NODE_", DKF_CHAN_NONE, -1},
        {"DKF_NODE_1x", DKF_CHAN_NONE, -1},   {"DKF_NODE_+1", DKF_CHAN_NONE, -1},
        {"DKF_NODE_-1", DKF_CHAN_NONE, -1},   {"DKF_NODE_100000", DKF_CHAN_NONE, -1},
        {"DKF_MEAS_007", DKF_CHAN_NONE, -1},  {"DKF_TW_017", DKF_CHAN_NONE, -1},
        {"DKF_FUSED_", DKF_CHAN_NONE, -1},    {"DKF_FUSEDX", DKF_CHAN_NONE, -1},
        {"_STATUS", DKF_CHAN_NONE, -1},       {"_1", DKF_CHAN_NONE, -1},
        {"NODE_1", DKF_CHAN_GRAPH, 1},        {"_NODE_1", DKF_CHAN_GRAPH, 1},
        {"DKF", DKF_CHAN_NONE, -1},           {"", DKF_CHAN_NONE, -1},
        {"DKF_STATUS ", DKF_CHAN_NONE, -1},   {"DKF_NODE_ 1", DKF_CHAN_NONE, -1}};
    char c[DKF_NET_CHAN_LEN];
    size_t i;
    (void)state;
    for (i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        const dkf_net_chan_id_t got = dkf_net_chan_parse(cases[i].name);
        if (got.kind != cases[i].kind || got.id != cases[i].id)
            fail_msg("%s: kind %d id %ld, want %d %ld", cases[i].name, (int)got.kind, got.id,
                     (int)cases[i].kind, cases[i].id);
        assert_int_equal(dkf_net_chan_node_id(cases[i].name),
                         cases[i].kind == DKF_CHAN_NODE ? cases[i].id : -1);
    }
    assert_int_equal(dkf_net_chan_parse(NULL).kind, DKF_CHAN_NONE);
    dkf_net_chan_meas(c, "DKF", 11);
    assert_string_equal(c, "DKF_MEAS_11");
    dkf_net_chan_node(c, "X", 0);
    assert_string_equal(c, "X_NODE_0");
    dkf_net_chan(c, "DKF", "FUSED");
    assert_string_equal(c, "DKF_FUSED");
    /* every id a writer makes parses back to itself, and only its own spelling does */
    for (i = 0; i < 1000; ++i) {
        dkf_net_chan_node(c, "DKF", i);
        assert_int_equal(dkf_net_chan_node_id(c), (long)i);
        snprintf(c, sizeof c, "DKF_NODE_0%zu", i);
        assert_int_equal(dkf_net_chan_node_id(c), -1);
    }
    assert_string_equal(dkf_net_verdict_str(DKF_NET_REJ_MODEL), "wrong model id");
    assert_string_equal(dkf_net_verdict_str(DKF_NET_REJ_SENDER), "not its sender");
}

/* ---- every length field of every type ---------------------------------------- */

enum { T_NODE, T_MEAS, T_TRUTH, T_FUSED, T_STATUS, T_NTYPES };

/* Decodes with decoder `type` into outputs prefilled with 0x5a and checks
 * that a rejection leaves them untouched. */
static dkf_net_verdict_t decode_type(int type, const unsigned char *b, size_t len)
{
    static dkf_diffkf_msg_t msg, prev;
    static dkf_net_meta_t meta;
    static dkf_net_meas_t meas;
    static dkf_net_truth_t truth;
    static dkf_net_fused_t fused;
    static dkf_net_status_t st;
    static unsigned char keep[sizeof(dkf_net_fused_t)];
    const dkf_net_expect_t ex = expect();
    dkf_net_verdict_t v;
    void *out[T_NTYPES] = {&msg, &meas, &truth, &fused, &st};
    size_t size[T_NTYPES] = {sizeof msg, sizeof meas, sizeof truth, sizeof fused, sizeof st};
    memset(out[type], 0x5a, size[type]);
    memset(keep, 0x5a, sizeof keep);
    switch (type) {
    case T_NODE: v = dkf_net_decode_node_msg(b, len, &ex, &msg, &prev, &meta, NULL); break;
    case T_MEAS: v = dkf_net_decode_meas(b, len, &ex, &meas, NULL); break;
    case T_TRUTH: v = dkf_net_decode_truth(b, len, &ex, &truth, NULL); break;
    case T_FUSED: v = dkf_net_decode_fused(b, len, &ex, &fused, NULL); break;
    default: v = dkf_net_decode_status(b, len, NULL, &st, NULL); break;
    }
    if (v != DKF_NET_ACCEPT) assert_memory_equal(out[type], keep, size[type]);
    return v;
}

/* A valid message of `type` in buf (the expectations of expect()); its
 * length, and the offsets of its int32 length fields in off[] (*noff). */
static size_t encode_type(int type, size_t *off, size_t *noff)
{
    static dkf_net_fused_t f;
    dkf_diffkf_msg_t msg;
    dkf_net_meta_t meta;
    dkf_net_meas_t m;
    dkf_net_truth_t t;
    dkf_net_status_t st;
    size_t len = 0;
    *noff = 1;
    switch (type) {
    case T_NODE:
        make_msg(&msg, &meta);
        len = encode_msg(&msg, &meta);
        off[0] = 48;
        break;
    case T_MEAS:
        memset(&m, 0, sizeof m);
        m.meta.model_id = MODEL;
        m.node = 1;
        m.k = 3;
        m.m = 3;
        assert_int_equal(dkf_net_encode_meas(buf, sizeof buf, &len, &m), 0);
        off[0] = 40;
        break;
    case T_TRUTH:
        memset(&t, 0, sizeof t);
        t.meta.model_id = MODEL;
        t.n = 4;
        assert_int_equal(dkf_net_encode_truth(buf, sizeof buf, &len, &t), 0);
        off[0] = 36;
        break;
    case T_FUSED:
        memset(&f, 0, sizeof f);
        f.meta.model_id = MODEL;
        f.k = 1;
        f.nnodes = 3;
        f.n = 4;
        assert_int_equal(dkf_net_encode_fused(buf, sizeof buf, &len, &f), 0);
        off[0] = 37;                 /* nnodes */
        off[1] = 37 + 4 + 3 + 3 * 8; /* n, after contributed[3] and three int64 */
        *noff = 2;
        break;
    default:
        memset(&st, 0, sizeof st);
        strcpy(st.detail, "ok");
        assert_int_equal(dkf_net_encode_status(buf, sizeof buf, &len, &st), 0);
        off[0] = 66; /* the string's length */
        break;
    }
    assert_int_equal(decode_type(type, buf, len), DKF_NET_ACCEPT);
    return len;
}

static void put_be32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

static uint32_t get_be32(const unsigned char *p)
{
    return ((uint32_t)p[0] << 24) | ((uint32_t)p[1] << 16) | ((uint32_t)p[2] << 8) | p[3];
}

/* Every truncation, a trailing byte, and every length field set to a value
 * the datagram does not hold (negative, huge, one more or less, beyond the
 * protocol's limit): MALFORMED, outputs untouched, no sanitizer report. */
static void test_length_fields_every_type(void **state)
{
    static const uint32_t bad[] = {0xffffffffu, 0x80000000u, 0x7fffffffu, 0x20000001u,
                                   0x10000000u, 4097u, DKF_NET_MAX_VEC + 1u, DKF_NET_MAX_NODES + 1u};
    static unsigned char orig[DKF_NET_MAX_MSG];
    int type;
    (void)state;
    for (type = 0; type < T_NTYPES; ++type) {
        size_t off[2], noff, len = encode_type(type, off, &noff), cut, j, i;
        memcpy(orig, buf, len);
        for (cut = 0; cut < len; ++cut)
            assert_int_equal(decode_type(type, buf, cut), DKF_NET_REJ_MALFORMED);
        buf[len] = 0;
        assert_int_equal(decode_type(type, buf, len + 1), DKF_NET_REJ_MALFORMED);
        for (j = 0; j < noff; ++j) {
            const uint32_t c = get_be32(orig + off[j]);
            for (i = 0; i < sizeof bad / sizeof bad[0] + 2; ++i) {
                memcpy(buf, orig, len);
                put_be32(buf + off[j], i < 2 ? c + 1 - 2 * (uint32_t)i : bad[i - 2]);
                assert_int_equal(decode_type(type, buf, len), DKF_NET_REJ_MALFORMED);
            }
        }
    }
}

/* Removes count bytes at offset at from buf[0..len); the new length. */
static size_t cut_out(size_t len, size_t at, size_t count)
{
    memmove(buf + at, buf + at + count, len - at - count);
    return len - count;
}

/* A message whose array is empty and whose size matches: the protocol has
 * no empty array (n, m, nnodes >= 1), and lcm-gen's decoder would copy a
 * boolean[0] with memcpy(NULL, ..., 0) (UBSan under double-asan). */
static void test_zero_length_arrays(void **state)
{
    size_t off[2], noff, len;
    (void)state;
    /* fused with zero nodes: nnodes = 0, contributed[] removed */
    len = encode_type(T_FUSED, off, &noff);
    put_be32(buf + off[0], 0);
    len = cut_out(len, off[0] + 4, 3);
    assert_int_equal(decode_type(T_FUSED, buf, len), DKF_NET_REJ_MALFORMED);
    /* fused with n = 0: xf, xp, Pf, Pp removed (2*4 + 2*16 doubles) */
    len = encode_type(T_FUSED, off, &noff);
    put_be32(buf + off[1], 0);
    len = cut_out(len, off[1] + 4, 8 * (8 + 32));
    assert_int_equal(decode_type(T_FUSED, buf, len), DKF_NET_REJ_MALFORMED);
    /* node message, measurement, truth with an empty state / measurement */
    len = encode_type(T_NODE, off, &noff);
    put_be32(buf + off[0], 0);
    len = cut_out(len, off[0] + 4, 8 * 8);         /* xf[4], xp[4] */
    len = cut_out(len, off[0] + 4 + 13, 8 * 8);    /* prev_xf[4], prev_xp[4] */
    assert_int_equal(decode_type(T_NODE, buf, len), DKF_NET_REJ_MALFORMED);
    len = encode_type(T_MEAS, off, &noff);
    put_be32(buf + off[0], 0);
    assert_int_equal(decode_type(T_MEAS, buf, cut_out(len, off[0] + 4, 3 * 8)),
                     DKF_NET_REJ_MALFORMED);
    len = encode_type(T_TRUTH, off, &noff);
    put_be32(buf + off[0], 0);
    assert_int_equal(decode_type(T_TRUTH, buf, cut_out(len, off[0] + 4, 4 * 8)),
                     DKF_NET_REJ_MALFORMED);
    /* the encoder makes no fused message without nodes */
    {
        static dkf_net_fused_t f;
        memset(&f, 0, sizeof f);
        f.n = 4;
        assert_int_equal(dkf_net_encode_fused(buf, sizeof buf, &len, &f), -1);
    }
}

/* A boolean is one byte, 0 or 1: contributed[] too. */
static void test_fused_contributed_flag(void **state)
{
    size_t off[2], noff, len = encode_type(T_FUSED, off, &noff);
    (void)state;
    buf[off[0] + 4 + 1] = 2;
    assert_int_equal(decode_type(T_FUSED, buf, len), DKF_NET_REJ_MALFORMED);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_node_msg_round_trip),
        cmocka_unit_test(test_node_msg_epoch_and_prev),
        cmocka_unit_test(test_node_msg_rejections),
        cmocka_unit_test(test_node_msg_real_overflow),
        cmocka_unit_test(test_meas_round_trip_and_rejections),
        cmocka_unit_test(test_truth_round_trip),
        cmocka_unit_test(test_fused_round_trip_and_rejections),
        cmocka_unit_test(test_status_round_trip),
        cmocka_unit_test(test_channels),
        cmocka_unit_test(test_length_fields_every_type),
        cmocka_unit_test(test_zero_length_arrays),
        cmocka_unit_test(test_fused_contributed_flag),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
