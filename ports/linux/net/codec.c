/*
 * codec.c - wire messages <-> plain structs (codec.h).
 *
 * lcm-gen's decoders trust the array lengths they read (a negative or huge
 * length makes them allocate or copy out of bounds), so every message is
 * first checked here against the exact wire layout of its lcmtypes/<type>.lcm
 * definition: fingerprint, each length field in range, total size exact.
 * Only then does the generated decoder run. LCM encodes big-endian, one
 * byte per boolean/int8, strings as int32 length (with the NUL) + bytes.
 * The offsets below follow the field order of the .lcm files; the
 * round-trip tests in tests/test_net_codec.c fail if they drift.
 */
#include "codec.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf_lcm_fused_t.h"
#include "dkf_lcm_measurement_t.h"
#include "dkf_lcm_node_msg_t.h"
#include "dkf_lcm_status_t.h"
#include "dkf_lcm_truth_t.h"

/* ---- wire layout ------------------------------------------------------------ */

/* Offsets of the length fields (after the 8-byte fingerprint). */
#define NODE_MSG_N_OFF 48  /* utime model_id node k seq meas_utime | n */
#define NODE_MSG_HDR 52
#define NODE_MSG_MID 13    /* after xf[n] xp[n]: epoch k_start has_prev prev_k */
#define MEAS_M_OFF 40      /* utime model_id node k seq | m */
#define MEAS_HDR 44
#define TRUTH_N_OFF 36     /* utime model_id k seq | n */
#define TRUTH_HDR 40
#define FUSED_NN_OFF 37    /* utime model_id k seq status | nnodes */
#define FUSED_TAIL 28      /* after contributed[]: 3 x int64 + n */
#define FUSED_END 4        /* after the matrices: revision */
#define STATUS_LEN_OFF 66  /* utime model_id role id state k sent received rejected missed | len */
#define STATUS_MAX_DETAIL 4096

static int64_t be64(const unsigned char *p)
{
    uint64_t v = 0;
    int i;
    for (i = 0; i < 8; ++i) v = (v << 8) | p[i];
    return (int64_t)v;
}

static int32_t be32(const unsigned char *p)
{
    uint32_t v = ((uint32_t)p[0] << 24) | ((uint32_t)p[1] << 16) | ((uint32_t)p[2] << 8) | p[3];
    return (int32_t)v;
}

/* The fingerprint every encoded message starts with, from the generated
 * code's own (header-declared) hash functions. */
static int64_t hash_node_msg(void) { return __dkf_lcm_node_msg_t_get_hash(); }
static int64_t hash_meas(void) { return __dkf_lcm_measurement_t_get_hash(); }
static int64_t hash_truth(void) { return __dkf_lcm_truth_t_get_hash(); }
static int64_t hash_fused(void) { return __dkf_lcm_fused_t_get_hash(); }
static int64_t hash_status(void) { return __dkf_lcm_status_t_get_hash(); }

/* 0 if buf starts with fingerprint h and has at least hdr bytes. */
static int check_head(const unsigned char *b, size_t len, size_t hdr, int64_t h)
{
    return (b != NULL && len >= hdr && be64(b) == h) ? 0 : -1;
}

/* An array length read from the wire: in [0, cap], else -1. */
static long wire_count(const unsigned char *p, long cap)
{
    int32_t v = be32(p);
    return (v < 0 || v > cap) ? -1 : (long)v;
}

/* ---- verdicts ---------------------------------------------------------------- */

const char *dkf_net_verdict_str(dkf_net_verdict_t v)
{
    switch (v) {
    case DKF_NET_ACCEPT: return "accepted";
    case DKF_NET_REJ_MALFORMED: return "malformed";
    case DKF_NET_REJ_NODE: return "unknown node";
    case DKF_NET_REJ_MODEL: return "wrong model id";
    case DKF_NET_REJ_DIM: return "wrong dimension";
    case DKF_NET_REJ_STEP: return "step out of range";
    case DKF_NET_REJ_NONFINITE: return "non-finite number";
    default: return "unknown verdict";
    }
}

static dkf_net_verdict_t reject(dkf_net_rejects_t *rej, dkf_net_verdict_t v)
{
    if (rej != NULL && v != DKF_NET_ACCEPT) {
        ++rej->total;
        ++rej->by[v];
    }
    return v;
}

/* The checks common to node messages and measurements, in codec.h's order. */
static dkf_net_verdict_t check_envelope(const dkf_net_expect_t *ex, long node, int64_t model_id,
                                        long dim, size_t want_dim, long k)
{
    if (node < 0 || (size_t)node >= ex->nnodes || (ex->node >= 0 && node != ex->node))
        return DKF_NET_REJ_NODE;
    if (model_id != ex->model_id) return DKF_NET_REJ_MODEL;
    if (dim < 0 || (size_t)dim != want_dim) return DKF_NET_REJ_DIM;
    if (k < 1 || k > ex->kmax) return DKF_NET_REJ_STEP;
    return DKF_NET_ACCEPT;
}

/* 0 if every value is finite as a double and as a dkf_real_t. */
static int finite_all(const double *v, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) {
        const dkf_real_t r = (dkf_real_t)v[i];
        if (!isfinite(v[i]) || !isfinite(r)) return -1;
    }
    return 0;
}

static int encoded(int r, size_t *len)
{
    if (r < 0) return -1;
    *len = (size_t)r;
    return 0;
}

/* ---- node message ------------------------------------------------------------ */

int dkf_net_encode_node_msg(void *buf, size_t cap, size_t *len, const dkf_diffkf_msg_t *msg,
                            const dkf_diffkf_msg_t *prev, const dkf_net_meta_t *meta)
{
    double xf[DKF_MAX_DIM], xp[DKF_MAX_DIM], pf[DKF_MAX_DIM], pp[DKF_MAX_DIM];
    dkf_lcm_node_msg_t w;
    size_t i;
    if (msg->n == 0 || msg->n > DKF_MAX_DIM || cap > 0x7fffffff) return -1;
    if (meta->has_prev && (prev == NULL || prev->n != msg->n)) return -1;
    for (i = 0; i < msg->n; ++i) {
        xf[i] = (double)msg->xf[i];
        xp[i] = (double)msg->xp[i];
        pf[i] = meta->has_prev ? (double)prev->xf[i] : 0.0;
        pp[i] = meta->has_prev ? (double)prev->xp[i] : 0.0;
    }
    w.utime = meta->utime;
    w.model_id = meta->model_id;
    w.node = (int32_t)msg->node;
    w.k = (int32_t)msg->k;
    w.seq = meta->seq;
    w.meas_utime = meta->meas_utime;
    w.n = (int32_t)msg->n;
    w.xf = xf;
    w.xp = xp;
    w.epoch = (int32_t)meta->epoch;
    w.k_start = (int32_t)meta->k_start;
    w.has_prev = meta->has_prev ? 1 : 0;
    w.prev_k = meta->has_prev ? (int32_t)prev->k : 0;
    w.prev_xf = pf;
    w.prev_xp = pp;
    return encoded(dkf_lcm_node_msg_t_encode(buf, 0, (int)cap, &w), len);
}

/* The epoch fields of a decoded node message, after check_envelope. */
static dkf_net_verdict_t check_epoch(const dkf_lcm_node_msg_t *w, size_t n)
{
    if (w->epoch < 0) return DKF_NET_REJ_MALFORMED;
    if (w->k_start < 1 || w->k_start > w->k) return DKF_NET_REJ_STEP;
    if (w->has_prev && (w->prev_k != w->k - 1 || w->prev_k < w->k_start))
        return DKF_NET_REJ_STEP;
    if (finite_all(w->xf, n) || finite_all(w->xp, n)) return DKF_NET_REJ_NONFINITE;
    if (w->has_prev && (finite_all(w->prev_xf, n) || finite_all(w->prev_xp, n)))
        return DKF_NET_REJ_NONFINITE;
    return DKF_NET_ACCEPT;
}

static void to_core_msg(dkf_diffkf_msg_t *msg, long node, long k, size_t n, const double *xf,
                        const double *xp)
{
    size_t i;
    msg->node = (uint16_t)node;
    msg->k = (uint32_t)k;
    msg->n = (uint16_t)n;
    for (i = 0; i < n; ++i) {
        msg->xf[i] = (dkf_real_t)xf[i];
        msg->xp[i] = (dkf_real_t)xp[i];
    }
}

dkf_net_verdict_t dkf_net_decode_node_msg(const void *buf, size_t len,
                                          const dkf_net_expect_t *ex, dkf_diffkf_msg_t *msg,
                                          dkf_diffkf_msg_t *prev, dkf_net_meta_t *meta,
                                          dkf_net_rejects_t *rej)
{
    const unsigned char *b = buf;
    dkf_lcm_node_msg_t w;
    dkf_net_verdict_t v;
    long n;
    if (check_head(b, len, NODE_MSG_HDR, hash_node_msg()) != 0)
        return reject(rej, DKF_NET_REJ_MALFORMED);
    n = wire_count(b + NODE_MSG_N_OFF, DKF_MAX_DIM);
    if (n < 0 || len != NODE_MSG_HDR + NODE_MSG_MID + 32 * (size_t)n)
        return reject(rej, DKF_NET_REJ_MALFORMED);
    /* has_prev is an LCM boolean: one byte, 0 or 1 */
    if (b[NODE_MSG_HDR + 16 * (size_t)n + 8] > 1) return reject(rej, DKF_NET_REJ_MALFORMED);
    memset(&w, 0, sizeof w);
    if (dkf_lcm_node_msg_t_decode(buf, 0, (int)len, &w) != (int)len) {
        dkf_lcm_node_msg_t_decode_cleanup(&w);
        return reject(rej, DKF_NET_REJ_MALFORMED);
    }
    v = check_envelope(ex, w.node, w.model_id, w.n, ex->n, w.k);
    if (v == DKF_NET_ACCEPT) v = check_epoch(&w, (size_t)n);
    if (v == DKF_NET_ACCEPT) {
        to_core_msg(msg, w.node, w.k, (size_t)n, w.xf, w.xp);
        if (w.has_prev && prev != NULL)
            to_core_msg(prev, w.node, w.prev_k, (size_t)n, w.prev_xf, w.prev_xp);
        meta->utime = w.utime;
        meta->model_id = w.model_id;
        meta->seq = w.seq;
        meta->meas_utime = w.meas_utime;
        meta->epoch = w.epoch;
        meta->k_start = w.k_start;
        meta->has_prev = w.has_prev ? 1 : 0;
    }
    dkf_lcm_node_msg_t_decode_cleanup(&w);
    return reject(rej, v);
}

/* ---- measurement ------------------------------------------------------------- */

int dkf_net_encode_meas(void *buf, size_t cap, size_t *len, const dkf_net_meas_t *meas)
{
    dkf_lcm_measurement_t w;
    if (meas->m == 0 || meas->m > DKF_MAX_DIM || cap > 0x7fffffff) return -1;
    w.utime = meas->meta.utime;
    w.model_id = meas->meta.model_id;
    w.node = (int32_t)meas->node;
    w.k = (int32_t)meas->k;
    w.seq = meas->meta.seq;
    w.m = (int32_t)meas->m;
    w.y = (double *)meas->y;
    return encoded(dkf_lcm_measurement_t_encode(buf, 0, (int)cap, &w), len);
}

dkf_net_verdict_t dkf_net_decode_meas(const void *buf, size_t len, const dkf_net_expect_t *ex,
                                      dkf_net_meas_t *meas, dkf_net_rejects_t *rej)
{
    const unsigned char *b = buf;
    dkf_lcm_measurement_t w;
    dkf_net_verdict_t v;
    long m;
    if (check_head(b, len, MEAS_HDR, hash_meas()) != 0) return reject(rej, DKF_NET_REJ_MALFORMED);
    m = wire_count(b + MEAS_M_OFF, DKF_MAX_DIM);
    if (m < 0 || len != MEAS_HDR + 8 * (size_t)m) return reject(rej, DKF_NET_REJ_MALFORMED);
    memset(&w, 0, sizeof w);
    if (dkf_lcm_measurement_t_decode(buf, 0, (int)len, &w) != (int)len) {
        dkf_lcm_measurement_t_decode_cleanup(&w);
        return reject(rej, DKF_NET_REJ_MALFORMED);
    }
    v = check_envelope(ex, w.node, w.model_id, 0, 0, w.k);
    if (v == DKF_NET_ACCEPT && (ex->m == NULL || (size_t)w.m != ex->m[w.node]))
        v = DKF_NET_REJ_DIM;
    if (v == DKF_NET_ACCEPT && finite_all(w.y, (size_t)m)) v = DKF_NET_REJ_NONFINITE;
    if (v == DKF_NET_ACCEPT) {
        meas->meta.utime = w.utime;
        meas->meta.model_id = w.model_id;
        meas->meta.seq = w.seq;
        meas->meta.meas_utime = 0;
        meas->node = (size_t)w.node;
        meas->k = w.k;
        meas->m = (size_t)m;
        memcpy(meas->y, w.y, (size_t)m * sizeof(double));
    }
    dkf_lcm_measurement_t_decode_cleanup(&w);
    return reject(rej, v);
}

/* ---- truth ------------------------------------------------------------------- */

int dkf_net_encode_truth(void *buf, size_t cap, size_t *len, const dkf_net_truth_t *t)
{
    dkf_lcm_truth_t w;
    if (t->n == 0 || t->n > DKF_MAX_DIM || cap > 0x7fffffff) return -1;
    w.utime = t->meta.utime;
    w.model_id = t->meta.model_id;
    w.k = (int32_t)t->k;
    w.seq = t->meta.seq;
    w.n = (int32_t)t->n;
    w.x = (double *)t->x;
    return encoded(dkf_lcm_truth_t_encode(buf, 0, (int)cap, &w), len);
}

dkf_net_verdict_t dkf_net_decode_truth(const void *buf, size_t len, const dkf_net_expect_t *ex,
                                       dkf_net_truth_t *t, dkf_net_rejects_t *rej)
{
    const unsigned char *b = buf;
    dkf_lcm_truth_t w;
    dkf_net_verdict_t v = DKF_NET_ACCEPT;
    long n;
    if (check_head(b, len, TRUTH_HDR, hash_truth()) != 0) return reject(rej, DKF_NET_REJ_MALFORMED);
    n = wire_count(b + TRUTH_N_OFF, DKF_MAX_DIM);
    if (n < 0 || len != TRUTH_HDR + 8 * (size_t)n) return reject(rej, DKF_NET_REJ_MALFORMED);
    memset(&w, 0, sizeof w);
    if (dkf_lcm_truth_t_decode(buf, 0, (int)len, &w) != (int)len) {
        dkf_lcm_truth_t_decode_cleanup(&w);
        return reject(rej, DKF_NET_REJ_MALFORMED);
    }
    if (w.model_id != ex->model_id) v = DKF_NET_REJ_MODEL;
    else if ((size_t)n != ex->n) v = DKF_NET_REJ_DIM;
    else if (w.k < 0 || w.k > ex->kmax) v = DKF_NET_REJ_STEP;
    else if (finite_all(w.x, (size_t)n)) v = DKF_NET_REJ_NONFINITE;
    if (v == DKF_NET_ACCEPT) {
        t->meta.utime = w.utime;
        t->meta.model_id = w.model_id;
        t->meta.seq = w.seq;
        t->meta.meas_utime = 0;
        t->k = w.k;
        t->n = (size_t)n;
        memcpy(t->x, w.x, (size_t)n * sizeof(double));
    }
    dkf_lcm_truth_t_decode_cleanup(&w);
    return reject(rej, v);
}

/* ---- fused estimate ---------------------------------------------------------- */

int dkf_net_encode_fused(void *buf, size_t cap, size_t *len, const dkf_net_fused_t *f)
{
    dkf_lcm_fused_t w;
    int8_t contributed[DKF_NET_MAX_NODES];
    size_t i;
    if (f->n == 0 || f->n > DKF_MAX_DIM || f->nnodes > DKF_NET_MAX_NODES || cap > 0x7fffffff)
        return -1;
    for (i = 0; i < f->nnodes; ++i) contributed[i] = f->contributed[i] ? 1 : 0;
    w.utime = f->meta.utime;
    w.model_id = f->meta.model_id;
    w.k = (int32_t)f->k;
    w.seq = f->meta.seq;
    w.status = f->degraded ? DKF_LCM_FUSED_T_DEGRADED : DKF_LCM_FUSED_T_COMPLETE;
    w.nnodes = (int32_t)f->nnodes;
    w.contributed = contributed;
    w.meas_utime_first = f->meas_utime_first;
    w.meas_utime_last = f->meas_utime_last;
    w.msg_utime_last = f->msg_utime_last;
    w.n = (int32_t)f->n;
    w.xf = (double *)f->xf;
    w.xp = (double *)f->xp;
    w.revision = (int32_t)f->revision;
    /* LCM's double[n][n] is an array of row pointers */
    {
        double *pf[DKF_MAX_DIM], *pp[DKF_MAX_DIM];
        for (i = 0; i < f->n; ++i) {
            pf[i] = (double *)f->Pf + i * f->n;
            pp[i] = (double *)f->Pp + i * f->n;
        }
        w.Pf = pf;
        w.Pp = pp;
        return encoded(dkf_lcm_fused_t_encode(buf, 0, (int)cap, &w), len);
    }
}

dkf_net_verdict_t dkf_net_decode_fused(const void *buf, size_t len, const dkf_net_expect_t *ex,
                                       dkf_net_fused_t *f, dkf_net_rejects_t *rej)
{
    const unsigned char *b = buf;
    dkf_lcm_fused_t w;
    dkf_net_verdict_t v = DKF_NET_ACCEPT;
    long nn, n;
    size_t i, hdr;
    if (check_head(b, len, FUSED_NN_OFF + 4, hash_fused()) != 0)
        return reject(rej, DKF_NET_REJ_MALFORMED);
    nn = wire_count(b + FUSED_NN_OFF, DKF_NET_MAX_NODES);
    if (nn < 0) return reject(rej, DKF_NET_REJ_MALFORMED);
    hdr = FUSED_NN_OFF + 4 + (size_t)nn + FUSED_TAIL;
    if (len < hdr) return reject(rej, DKF_NET_REJ_MALFORMED);
    n = wire_count(b + hdr - 4, DKF_MAX_DIM);
    if (n < 0 || len != hdr + 8 * (2 * (size_t)n + 2 * (size_t)n * (size_t)n) + FUSED_END)
        return reject(rej, DKF_NET_REJ_MALFORMED);
    memset(&w, 0, sizeof w);
    if (dkf_lcm_fused_t_decode(buf, 0, (int)len, &w) != (int)len) {
        dkf_lcm_fused_t_decode_cleanup(&w);
        return reject(rej, DKF_NET_REJ_MALFORMED);
    }
    if ((size_t)nn != ex->nnodes) v = DKF_NET_REJ_NODE;
    else if (w.model_id != ex->model_id) v = DKF_NET_REJ_MODEL;
    else if ((size_t)n != ex->n) v = DKF_NET_REJ_DIM;
    else if (w.k < 1 || w.k > ex->kmax) v = DKF_NET_REJ_STEP;
    else if (w.status != DKF_LCM_FUSED_T_COMPLETE && w.status != DKF_LCM_FUSED_T_DEGRADED)
        v = DKF_NET_REJ_MALFORMED;
    else if (w.revision < 0)
        v = DKF_NET_REJ_MALFORMED;
    for (i = 0; v == DKF_NET_ACCEPT && i < (size_t)n; ++i)
        if (finite_all(w.Pf[i], (size_t)n) || finite_all(w.Pp[i], (size_t)n))
            v = DKF_NET_REJ_NONFINITE;
    if (v == DKF_NET_ACCEPT && (finite_all(w.xf, (size_t)n) || finite_all(w.xp, (size_t)n)))
        v = DKF_NET_REJ_NONFINITE;
    if (v == DKF_NET_ACCEPT) {
        f->meta.utime = w.utime;
        f->meta.model_id = w.model_id;
        f->meta.seq = w.seq;
        f->meta.meas_utime = 0;
        f->k = w.k;
        f->degraded = w.status == DKF_LCM_FUSED_T_DEGRADED;
        f->revision = w.revision;
        f->nnodes = (size_t)nn;
        for (i = 0; i < (size_t)nn; ++i) f->contributed[i] = w.contributed[i] ? 1 : 0;
        f->meas_utime_first = w.meas_utime_first;
        f->meas_utime_last = w.meas_utime_last;
        f->msg_utime_last = w.msg_utime_last;
        f->n = (size_t)n;
        memcpy(f->xf, w.xf, (size_t)n * sizeof(double));
        memcpy(f->xp, w.xp, (size_t)n * sizeof(double));
        for (i = 0; i < (size_t)n; ++i) {
            memcpy(f->Pf + i * (size_t)n, w.Pf[i], (size_t)n * sizeof(double));
            memcpy(f->Pp + i * (size_t)n, w.Pp[i], (size_t)n * sizeof(double));
        }
    }
    dkf_lcm_fused_t_decode_cleanup(&w);
    return reject(rej, v);
}

/* ---- status ------------------------------------------------------------------ */

int dkf_net_encode_status(void *buf, size_t cap, size_t *len, const dkf_net_status_t *st)
{
    dkf_lcm_status_t w;
    char detail[sizeof st->detail];
    if (cap > 0x7fffffff) return -1;
    memcpy(detail, st->detail, sizeof detail);
    detail[sizeof detail - 1] = '\0';
    w.utime = st->utime;
    w.model_id = st->model_id;
    w.role = (int8_t)st->role;
    w.id = st->id;
    w.state = (int8_t)st->state;
    w.k = (int32_t)st->k;
    w.sent = st->sent;
    w.received = st->received;
    w.rejected = st->rejected;
    w.missed = st->missed;
    w.detail = detail;
    return encoded(dkf_lcm_status_t_encode(buf, 0, (int)cap, &w), len);
}

dkf_net_verdict_t dkf_net_decode_status(const void *buf, size_t len, dkf_net_status_t *st,
                                        dkf_net_rejects_t *rej)
{
    const unsigned char *b = buf;
    dkf_lcm_status_t w;
    long sl;
    if (check_head(b, len, STATUS_LEN_OFF + 4, hash_status()) != 0)
        return reject(rej, DKF_NET_REJ_MALFORMED);
    sl = wire_count(b + STATUS_LEN_OFF, STATUS_MAX_DETAIL);
    /* the string's length counts its NUL, which must be its last byte */
    if (sl < 1 || len != STATUS_LEN_OFF + 4 + (size_t)sl || b[len - 1] != 0)
        return reject(rej, DKF_NET_REJ_MALFORMED);
    memset(&w, 0, sizeof w);
    if (dkf_lcm_status_t_decode(buf, 0, (int)len, &w) != (int)len) {
        dkf_lcm_status_t_decode_cleanup(&w);
        return reject(rej, DKF_NET_REJ_MALFORMED);
    }
    st->utime = w.utime;
    st->model_id = w.model_id;
    st->role = w.role;
    st->id = w.id;
    st->state = w.state;
    st->k = w.k;
    st->sent = w.sent;
    st->received = w.received;
    st->rejected = w.rejected;
    st->missed = w.missed;
    snprintf(st->detail, sizeof st->detail, "%s", w.detail);
    dkf_lcm_status_t_decode_cleanup(&w);
    return DKF_NET_ACCEPT;
}

/* ---- channels ---------------------------------------------------------------- */

void dkf_net_chan_meas(char *out, const char *prefix, size_t node)
{
    snprintf(out, DKF_NET_CHAN_LEN, "%s_MEAS_%zu", prefix, node);
}

void dkf_net_chan_node(char *out, const char *prefix, size_t node)
{
    snprintf(out, DKF_NET_CHAN_LEN, "%s_NODE_%zu", prefix, node);
}

void dkf_net_chan(char *out, const char *prefix, const char *what)
{
    snprintf(out, DKF_NET_CHAN_LEN, "%s_%s", prefix, what);
}

long dkf_net_chan_index(const char *channel)
{
    const char *p = strrchr(channel, '_');
    long v = 0;
    if (p == NULL || p[1] == '\0') return -1;
    for (++p; *p != '\0'; ++p) {
        if (*p < '0' || *p > '9' || v > 100000) return -1;
        v = v * 10 + (*p - '0');
    }
    return v;
}
