/*
 * codec.c - wire messages <-> plain structs (codec.h).
 *
 * lcm-gen's decoders trust the array lengths they read (a negative or huge
 * length makes them allocate or copy out of bounds; an empty boolean array
 * makes them memcpy into lcm_malloc(0) == NULL), so every datagram of every
 * type goes through one path, wire_decode: wire_check walks the type's
 * layout table (the field order of its lcmtypes/<type>.lcm) over the bytes
 * -- fingerprint, every length field within the protocol's range and within
 * the datagram, every boolean 0 or 1, strings NUL-terminated, total size
 * exact -- and only then does the generated decoder run. LCM encodes
 * big-endian, one byte per boolean/int8, strings as int32 length (with the
 * NUL) + bytes. The tables follow the .lcm files; the round-trip tests in
 * net/tests/test_net_codec.c fail if they drift.
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
#include "dkf_lcm_tw_packet_t.h"

/* ---- the one checked path: wire layout, then lcm-gen's decoder ------------------ */

#define STATUS_MAX_DETAIL 4096 /* bytes of status_t.detail, with its NUL */

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

/* One field of a lcmtypes/<type>.lcm struct, in wire order. */
typedef enum {
    W_I8,     /* int8_t */
    W_BOOL,   /* boolean: one byte, 0 or 1 */
    W_I32,    /* int32_t */
    W_I64,    /* int64_t, double */
    W_COUNT,  /* int32_t array length, in [lo, hi]; kept in count[slot] */
    W_BOOLS,  /* boolean[count[slot]] */
    W_F64S,   /* double[count[slot]] */
    W_F64SQ,  /* double[count[slot]][count[slot]] */
    W_STRING  /* int32_t length in [lo, hi] (with the NUL), bytes, the last one NUL */
} wire_kind_t;

typedef struct {
    wire_kind_t kind;
    int slot;
    long lo, hi;
} wire_field_t;

#define WIRE_NSLOTS 2

typedef struct {
    int64_t (*hash)(void);       /* the fingerprint the datagram starts with */
    const wire_field_t *f;
    size_t nf;
    size_t size;                 /* of the generated struct */
    int (*decode)(const void *buf, int len, void *w); /* lcm-gen's, on the whole datagram */
    void (*cleanup)(void *w);
} wire_type_t;

/* A field of n bytes at b fits in room bytes: *used = n. */
static int wire_take(size_t n, size_t room, size_t *used)
{
    *used = n;
    return room >= n ? 0 : -1;
}

/* 0 and *used = the bytes field f takes at b (room bytes to the end of the
 * datagram), or -1 if it does not fit or breaks the protocol's limits. */
static int wire_field(const wire_field_t *f, const unsigned char *b, size_t room, long *count,
                      size_t *used)
{
    size_t i;
    long v;
    switch (f->kind) {
    case W_I8: return wire_take(1, room, used);
    case W_BOOL: return wire_take(1, room, used) == 0 && b[0] <= 1 ? 0 : -1;
    case W_I32: return wire_take(4, room, used);
    case W_I64: return wire_take(8, room, used);
    case W_COUNT:
    case W_STRING:
        if (room < 4) return -1;
        v = (long)be32(b);
        if (v < f->lo || v > f->hi) return -1;
        if (f->kind == W_COUNT) {
            count[f->slot] = v;
            return wire_take(4, room, used);
        }
        /* an LCM string's length counts its NUL, which must be its last byte */
        if (v < 1 || wire_take(4 + (size_t)v, room, used) != 0) return -1;
        return b[4 + v - 1] == '\0' ? 0 : -1;
    case W_BOOLS:
        /* lcm-gen copies it with memcpy into lcm_malloc(0) == NULL if empty */
        if (count[f->slot] == 0 || wire_take((size_t)count[f->slot], room, used) != 0) return -1;
        for (i = 0; i < *used; ++i)
            if (b[i] > 1) return -1;
        return 0;
    case W_F64S: return wire_take(8 * (size_t)count[f->slot], room, used);
    case W_F64SQ: return wire_take(8 * (size_t)count[f->slot] * (size_t)count[f->slot], room, used);
    }
    return -1;
}

/* 0 if buf holds exactly one message of type t within the protocol's
 * limits; count[] then holds its length fields. Every bound a table sets
 * is <= DKF_NET_MAX_NODES, DKF_NET_TW_MAX_LEN or STATUS_MAX_DETAIL, so no
 * size here overflows. */
static int wire_check(const wire_type_t *t, const unsigned char *b, size_t len, long *count)
{
    size_t pos = 8, i, used;
    if (b == NULL || len < 8 || len > 0x7fffffff || be64(b) != t->hash()) return -1;
    for (i = 0; i < t->nf; ++i) {
        if (wire_field(&t->f[i], b + pos, len - pos, count, &used) != 0) return -1;
        pos += used;
    }
    return pos == len ? 0 : -1;
}

/* The one path from wire bytes to a generated struct w (every decoder of
 * network input takes it): the layout check, then lcm-gen's decoder, which
 * must take every byte. 0 (then w is to be cleaned up with t->cleanup), or
 * -1: MALFORMED, nothing to clean up. */
static int wire_decode(const wire_type_t *t, const void *buf, size_t len, void *w, long *count)
{
    if (wire_check(t, buf, len, count) != 0) return -1;
    memset(w, 0, t->size);
    if (t->decode(buf, (int)len, w) != (int)len) {
        t->cleanup(w);
        return -1;
    }
    return 0;
}

/* lcm-gen's decoder and cleanup of type T as wire_type_t wants them. */
#define WIRE_GLUE(T)                                                                \
    static int decode_##T(const void *buf, int len, void *w)                        \
    {                                                                               \
        return dkf_lcm_##T##_decode(buf, 0, len, (dkf_lcm_##T *)w);                 \
    }                                                                               \
    static void cleanup_##T(void *w) { (void)dkf_lcm_##T##_decode_cleanup((dkf_lcm_##T *)w); }
WIRE_GLUE(node_msg_t)
WIRE_GLUE(measurement_t)
WIRE_GLUE(truth_t)
WIRE_GLUE(fused_t)
WIRE_GLUE(status_t)
WIRE_GLUE(tw_packet_t)

#define WIRE_TYPE(T, fields)                                                          \
    {                                                                                 \
        __dkf_lcm_##T##_get_hash, fields, sizeof fields / sizeof fields[0],           \
            sizeof(dkf_lcm_##T), decode_##T, cleanup_##T                              \
    }

/* The tables: one row per field of lcmtypes/<type>.lcm (after the 8-byte
 * fingerprint). No array of the protocol is empty, except v of a DONE
 * graph-filter packet (doubles: lcm-gen copies none). */
static const wire_field_t node_msg_fields[] = {
    {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0}, {W_I32, 0, 0, 0}, {W_I32, 0, 0, 0}, /* utime model_id node k */
    {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0},                                     /* seq meas_utime */
    {W_COUNT, 0, 1, DKF_NET_MAX_VEC}, {W_F64S, 0, 0, 0}, {W_F64S, 0, 0, 0},     /* n xf xp */
    {W_I32, 0, 0, 0}, {W_I32, 0, 0, 0}, {W_BOOL, 0, 0, 0}, {W_I32, 0, 0, 0}, /* epoch k_start has_prev prev_k */
    {W_F64S, 0, 0, 0}, {W_F64S, 0, 0, 0}};                                  /* prev_xf prev_xp */
static const wire_field_t measurement_fields[] = {
    {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0}, {W_I32, 0, 0, 0}, {W_I32, 0, 0, 0}, /* utime model_id node k */
    {W_I64, 0, 0, 0}, {W_COUNT, 0, 1, DKF_NET_MAX_VEC}, {W_F64S, 0, 0, 0}};     /* seq m y */
static const wire_field_t truth_fields[] = {
    {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0}, {W_I32, 0, 0, 0}, {W_I64, 0, 0, 0}, /* utime model_id k seq */
    {W_COUNT, 0, 1, DKF_NET_MAX_VEC}, {W_F64S, 0, 0, 0}};                       /* n x */
static const wire_field_t fused_fields[] = {
    {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0}, {W_I32, 0, 0, 0}, {W_I64, 0, 0, 0}, /* utime model_id k seq */
    {W_I8, 0, 0, 0}, {W_COUNT, 0, 1, DKF_NET_MAX_NODES}, {W_BOOLS, 0, 0, 0}, /* status nnodes contributed */
    {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0},                   /* meas_utime_first/last msg_utime_last */
    {W_COUNT, 1, 1, DKF_NET_MAX_VEC}, {W_F64S, 1, 0, 0}, {W_F64S, 1, 0, 0},     /* n xf xp */
    {W_F64SQ, 1, 0, 0}, {W_F64SQ, 1, 0, 0}, {W_I32, 0, 0, 0}};              /* Pf Pp revision */
static const wire_field_t status_fields[] = {
    {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0}, {W_I8, 0, 0, 0}, {W_I32, 0, 0, 0},  /* utime model_id role id */
    {W_I8, 0, 0, 0}, {W_I32, 0, 0, 0}, {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0},  /* state k sent received */
    {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0}, {W_STRING, 0, 1, STATUS_MAX_DETAIL}}; /* rejected missed detail */
static const wire_field_t tw_packet_fields[] = {
    {W_I64, 0, 0, 0}, {W_I64, 0, 0, 0}, {W_I32, 0, 0, 0}, {W_I32, 0, 0, 0}, /* utime model_id node k */
    {W_I32, 0, 0, 0}, {W_I8, 0, 0, 0}, {W_BOOL, 0, 0, 0},                   /* round kind retransmit */
    {W_COUNT, 0, 0, DKF_NET_TW_MAX_LEN}, {W_F64S, 0, 0, 0}};                /* len v */

static const wire_type_t node_msg_wire = WIRE_TYPE(node_msg_t, node_msg_fields);
static const wire_type_t measurement_wire = WIRE_TYPE(measurement_t, measurement_fields);
static const wire_type_t truth_wire = WIRE_TYPE(truth_t, truth_fields);
static const wire_type_t fused_wire = WIRE_TYPE(fused_t, fused_fields);
static const wire_type_t status_wire = WIRE_TYPE(status_t, status_fields);
static const wire_type_t tw_packet_wire = WIRE_TYPE(tw_packet_t, tw_packet_fields);

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
    case DKF_NET_REJ_SENDER: return "not its sender";
    default: return "unknown verdict";
    }
}

dkf_net_verdict_t dkf_net_reject(dkf_net_rejects_t *rej, dkf_net_verdict_t v)
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

/* The envelope of a message's wire struct w from the meta m (encoding). */
#define WIRE_PUT_META(w, m) ((w).utime = (m).utime, (w).model_id = (m).model_id, (w).seq = (m).seq)

/* The meta of a decoded measurement, truth or fused estimate (no meas_utime). */
static void get_meta(dkf_net_meta_t *m, int64_t utime, int64_t model_id, int64_t seq)
{
    m->utime = utime;
    m->model_id = model_id;
    m->seq = seq;
    m->meas_utime = 0;
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
    double xf[DKF_NET_MAX_VEC], xp[DKF_NET_MAX_VEC], pf[DKF_NET_MAX_VEC], pp[DKF_NET_MAX_VEC];
    dkf_lcm_node_msg_t w;
    size_t i;
    if (msg->n == 0 || msg->n > DKF_NET_MAX_VEC || cap > 0x7fffffff) return -1;
    if (meta->has_prev && (prev == NULL || prev->n != msg->n)) return -1;
    for (i = 0; i < msg->n; ++i) {
        xf[i] = (double)msg->xf[i];
        xp[i] = (double)msg->xp[i];
        pf[i] = meta->has_prev ? (double)prev->xf[i] : 0.0;
        pp[i] = meta->has_prev ? (double)prev->xp[i] : 0.0;
    }
    WIRE_PUT_META(w, *meta);
    w.node = (int32_t)msg->node;
    w.k = (int32_t)msg->k;
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

void dkf_net_copy_node_msg(dkf_diffkf_msg_t *dst, const dkf_diffkf_msg_t *src)
{
    const size_t n = src->n < DKF_MAX_DIM ? src->n : DKF_MAX_DIM;
    dst->node = src->node;
    dst->k = src->k;
    dst->n = src->n;
    memcpy(dst->xf, src->xf, n * sizeof src->xf[0]);
    memcpy(dst->xp, src->xp, n * sizeof src->xp[0]);
}

void dkf_net_copy_node_payload(void *user, void *dst, const void *src)
{
    (void)user;
    dkf_net_copy_node_msg(dst, src);
}

dkf_net_verdict_t dkf_net_decode_node_msg(const void *buf, size_t len,
                                          const dkf_net_expect_t *ex, dkf_diffkf_msg_t *msg,
                                          dkf_diffkf_msg_t *prev, dkf_net_meta_t *meta,
                                          dkf_net_rejects_t *rej)
{
    dkf_lcm_node_msg_t w;
    dkf_net_verdict_t v;
    long count[WIRE_NSLOTS], n;
    if (wire_decode(&node_msg_wire, buf, len, &w, count) != 0)
        return dkf_net_reject(rej, DKF_NET_REJ_MALFORMED);
    n = count[0];
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
    return dkf_net_reject(rej, v);
}

/* ---- measurement ------------------------------------------------------------- */

int dkf_net_encode_meas(void *buf, size_t cap, size_t *len, const dkf_net_meas_t *meas)
{
    dkf_lcm_measurement_t w;
    if (meas->m == 0 || meas->m > DKF_NET_MAX_VEC || cap > 0x7fffffff) return -1;
    WIRE_PUT_META(w, meas->meta);
    w.node = (int32_t)meas->node;
    w.k = (int32_t)meas->k;
    w.m = (int32_t)meas->m;
    w.y = (double *)meas->y;
    return encoded(dkf_lcm_measurement_t_encode(buf, 0, (int)cap, &w), len);
}

dkf_net_verdict_t dkf_net_decode_meas(const void *buf, size_t len, const dkf_net_expect_t *ex,
                                      dkf_net_meas_t *meas, dkf_net_rejects_t *rej)
{
    dkf_lcm_measurement_t w;
    dkf_net_verdict_t v;
    long count[WIRE_NSLOTS], m;
    if (wire_decode(&measurement_wire, buf, len, &w, count) != 0)
        return dkf_net_reject(rej, DKF_NET_REJ_MALFORMED);
    m = count[0];
    v = check_envelope(ex, w.node, w.model_id, 0, 0, w.k);
    if (v == DKF_NET_ACCEPT && (ex->m == NULL || (size_t)w.m != ex->m[w.node]))
        v = DKF_NET_REJ_DIM;
    if (v == DKF_NET_ACCEPT && finite_all(w.y, (size_t)m)) v = DKF_NET_REJ_NONFINITE;
    if (v == DKF_NET_ACCEPT) {
        get_meta(&meas->meta, w.utime, w.model_id, w.seq);
        meas->node = (size_t)w.node;
        meas->k = w.k;
        meas->m = (size_t)m;
        memcpy(meas->y, w.y, (size_t)m * sizeof(double));
    }
    dkf_lcm_measurement_t_decode_cleanup(&w);
    return dkf_net_reject(rej, v);
}

/* ---- truth ------------------------------------------------------------------- */

int dkf_net_encode_truth(void *buf, size_t cap, size_t *len, const dkf_net_truth_t *t)
{
    dkf_lcm_truth_t w;
    if (t->n == 0 || t->n > DKF_NET_MAX_VEC || cap > 0x7fffffff) return -1;
    WIRE_PUT_META(w, t->meta);
    w.k = (int32_t)t->k;
    w.n = (int32_t)t->n;
    w.x = (double *)t->x;
    return encoded(dkf_lcm_truth_t_encode(buf, 0, (int)cap, &w), len);
}

dkf_net_verdict_t dkf_net_decode_truth(const void *buf, size_t len, const dkf_net_expect_t *ex,
                                       dkf_net_truth_t *t, dkf_net_rejects_t *rej)
{
    dkf_lcm_truth_t w;
    dkf_net_verdict_t v = DKF_NET_ACCEPT;
    long count[WIRE_NSLOTS], n;
    if (wire_decode(&truth_wire, buf, len, &w, count) != 0)
        return dkf_net_reject(rej, DKF_NET_REJ_MALFORMED);
    n = count[0];
    if (w.model_id != ex->model_id) v = DKF_NET_REJ_MODEL;
    else if ((size_t)n != ex->n) v = DKF_NET_REJ_DIM;
    else if (w.k < 0 || w.k > ex->kmax) v = DKF_NET_REJ_STEP;
    else if (finite_all(w.x, (size_t)n)) v = DKF_NET_REJ_NONFINITE;
    if (v == DKF_NET_ACCEPT) {
        get_meta(&t->meta, w.utime, w.model_id, w.seq);
        t->k = w.k;
        t->n = (size_t)n;
        memcpy(t->x, w.x, (size_t)n * sizeof(double));
    }
    dkf_lcm_truth_t_decode_cleanup(&w);
    return dkf_net_reject(rej, v);
}

/* ---- fused estimate ---------------------------------------------------------- */

int dkf_net_encode_fused(void *buf, size_t cap, size_t *len, const dkf_net_fused_t *f)
{
    dkf_lcm_fused_t w;
    int8_t contributed[DKF_NET_MAX_NODES];
    size_t i;
    if (f->n == 0 || f->n > DKF_NET_MAX_VEC || f->nnodes == 0 || f->nnodes > DKF_NET_MAX_NODES ||
        cap > 0x7fffffff)
        return -1;
    for (i = 0; i < f->nnodes; ++i) contributed[i] = f->contributed[i] ? 1 : 0;
    WIRE_PUT_META(w, f->meta);
    w.k = (int32_t)f->k;
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
        double *pf[DKF_NET_MAX_VEC], *pp[DKF_NET_MAX_VEC];
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
    dkf_lcm_fused_t w;
    dkf_net_verdict_t v = DKF_NET_ACCEPT;
    long count[WIRE_NSLOTS], nn, n;
    size_t i;
    if (wire_decode(&fused_wire, buf, len, &w, count) != 0)
        return dkf_net_reject(rej, DKF_NET_REJ_MALFORMED);
    nn = count[0];
    n = count[1];
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
        get_meta(&f->meta, w.utime, w.model_id, w.seq);
        f->k = w.k;
        f->degraded = w.status == DKF_LCM_FUSED_T_DEGRADED;
        f->revision = w.revision;
        f->nnodes = (size_t)nn;
        for (i = 0; i < (size_t)nn; ++i) f->contributed[i] = (unsigned char)w.contributed[i];
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
    return dkf_net_reject(rej, v);
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

dkf_net_verdict_t dkf_net_decode_status(const void *buf, size_t len, const dkf_net_from_t *from,
                                        dkf_net_status_t *st, dkf_net_rejects_t *rej)
{
    dkf_lcm_status_t w;
    long count[WIRE_NSLOTS];
    if (wire_decode(&status_wire, buf, len, &w, count) != 0)
        return dkf_net_reject(rej, DKF_NET_REJ_MALFORMED);
    if (!dkf_net_from_is(from, w.role, w.id)) {
        dkf_lcm_status_t_decode_cleanup(&w);
        return dkf_net_reject(rej, DKF_NET_REJ_SENDER);
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

/* ---- graph-filter packet (tw_agent.h's) --------------------------------------------- */

void dkf_net_tw_shape(const dkf_net_tw_expect_t *ex, size_t round, int *kind, size_t *len)
{
    const int info = round < ex->info_rounds;
    *kind = info ? DKF_NET_TW_KIND_INFO : DKF_NET_TW_KIND_EST;
    *len = info ? ex->info_len : ex->est_len;
}

int dkf_net_encode_tw(void *buf, size_t cap, size_t *len, const dkf_net_tw_pkt_t *p)
{
    double v[DKF_NET_TW_MAX_LEN];
    dkf_lcm_tw_packet_t w;
    size_t i;
    if (p->len > DKF_NET_TW_MAX_LEN || cap > 0x7fffffff) return -1;
    for (i = 0; i < p->len; ++i) v[i] = (double)p->v[i];
    w.utime = p->utime;
    w.model_id = p->model_id;
    w.node = (int32_t)p->node;
    w.k = (int32_t)p->k;
    w.round = (int32_t)p->round;
    w.kind = (int8_t)p->kind;
    w.retransmit = (int8_t)(p->retransmit != 0);
    w.len = (int32_t)p->len;
    w.v = v;
    return encoded(dkf_lcm_tw_packet_t_encode(buf, 0, (int)cap, &w), len);
}

/* The checks after the wire layout's, in codec.h's order. */
static dkf_net_verdict_t check_tw(const dkf_lcm_tw_packet_t *w, size_t len,
                                  const dkf_net_tw_expect_t *ex)
{
    int kind;
    size_t want;
    if (w->kind < 0 || w->kind > DKF_NET_TW_KIND_DONE) return DKF_NET_REJ_MALFORMED;
    if (w->node < 0 || (size_t)w->node >= ex->nnodes || (ex->node >= 0 && w->node != ex->node))
        return DKF_NET_REJ_NODE;
    if (w->model_id != ex->model_id) return DKF_NET_REJ_MODEL;
    if (w->kind == DKF_NET_TW_KIND_DONE) {
        if (len != 0) return DKF_NET_REJ_DIM;
        return (w->k == (long)ex->steps + 1 && w->round == 0) ? DKF_NET_ACCEPT
                                                               : DKF_NET_REJ_STEP;
    }
    if (w->round < 0 || (size_t)w->round >= ex->rounds) return DKF_NET_REJ_STEP;
    dkf_net_tw_shape(ex, (size_t)w->round, &kind, &want);
    if (len != want) return DKF_NET_REJ_DIM;
    if (w->k < 1 || (size_t)w->k > ex->steps || w->kind != kind) return DKF_NET_REJ_STEP;
    return finite_all(w->v, len) == 0 ? DKF_NET_ACCEPT : DKF_NET_REJ_NONFINITE;
}

dkf_net_verdict_t dkf_net_decode_tw(const void *buf, size_t len, const dkf_net_tw_expect_t *ex,
                                    dkf_net_tw_pkt_t *out, dkf_net_rejects_t *rej)
{
    dkf_lcm_tw_packet_t w;
    long count[WIRE_NSLOTS];
    dkf_net_verdict_t v;
    size_t i, n;
    if (wire_decode(&tw_packet_wire, buf, len, &w, count) != 0)
        return dkf_net_reject(rej, DKF_NET_REJ_MALFORMED);
    n = (size_t)count[0];
    v = check_tw(&w, n, ex);
    if (v == DKF_NET_ACCEPT) {
        out->utime = w.utime;
        out->model_id = w.model_id;
        out->node = w.node;
        out->k = w.k;
        out->round = w.round;
        out->kind = w.kind;
        out->retransmit = w.retransmit;
        out->len = n;
        for (i = 0; i < n; ++i) out->v[i] = (dkf_real_t)w.v[i]; /* n 0: w.v is NULL */
    }
    dkf_lcm_tw_packet_t_decode_cleanup(&w);
    return dkf_net_reject(rej, v);
}
