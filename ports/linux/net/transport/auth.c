/*
 * auth.c - authenticated datagrams (auth.h): key files, the trailer, the
 * channel rule and the replay window, over libsodium's HMAC-SHA-512-256.
 */
#define _POSIX_C_SOURCE 200809L /* fstat, mkdir, open flags */

#include "auth.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <sodium.h>

#include "chan.h"
#include "clock.h"
#include "util.h"

#define fail(err, errlen, ...) dkf_failf(err, errlen, -1, __VA_ARGS__)

#define NSLOTS (DKF_AUTH_MAX_KEYS + 1) /* node keys, then infra */
#define INFRA_SLOT DKF_AUTH_MAX_KEYS
#define HEADER 28                      /* the trailer before the tag */

typedef struct {
    uint64_t epoch, seq;
    int seen;
} last_t;

struct dkf_auth {
    uint32_t self;
    uint64_t epoch, seq;                       /* this process's own */
    int graph;                                 /* DKA2: a graph node's edge keys by peer */
    size_t npeers;                             /* graph: peers[0..npeers-1], ascending */
    uint32_t peers[DKF_AUTH_MAX_KEYS];
    /* each key's HMAC state after its two key blocks (ipad, opad): a MAC
     * then costs two SHA-512 blocks for a short message instead of four */
    crypto_auth_hmacsha512256_state keyed[NSLOTS];
    unsigned char have[NSLOTS];
    last_t last[4][NSLOTS];                    /* by the signer's role and the key */
    uint64_t count[DKF_AUTH_NVERDICTS];
};

const char *dkf_auth_verdict_str(dkf_auth_verdict_t v)
{
    static const char *const s[DKF_AUTH_NVERDICTS] = {
        "accepted", "no trailer", "unknown key", "foreign", "bad MAC", "replayed", "bad channel"};
    return (unsigned)v < DKF_AUTH_NVERDICTS ? s[v] : "?";
}

uint32_t dkf_auth_signer(int role, size_t index)
{
    return (uint32_t)role << 16 | (uint32_t)(index & 0xffffu);
}

/* ---- key files --------------------------------------------------------------------- */

static int hexval(char c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

int dkf_auth_parse_key(const char *text, size_t len, unsigned char key[DKF_AUTH_KEY_LEN])
{
    size_t i;
    if (text == NULL || !(len == 2 * DKF_AUTH_KEY_LEN ||
                          (len == 2 * DKF_AUTH_KEY_LEN + 1 && text[len - 1] == '\n')))
        return -1;
    for (i = 0; i < DKF_AUTH_KEY_LEN; ++i) {
        const int hi = hexval(text[2 * i]), lo = hexval(text[2 * i + 1]);
        if (hi < 0 || lo < 0) return -1;
        key[i] = (unsigned char)(hi << 4 | lo);
    }
    return 0;
}

int dkf_auth_read_key(const char *path, unsigned char key[DKF_AUTH_KEY_LEN], char *err,
                      size_t errlen)
{
    char text[2 * DKF_AUTH_KEY_LEN + 2];
    struct stat st;
    ssize_t got;
    int fd = open(path, O_RDONLY);
    if (fd < 0) return fail(err, errlen, "%s: cannot open: %s", path, strerror(errno));
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return fail(err, errlen, "%s: not a regular file", path);
    }
    if ((st.st_mode & 077) != 0) {
        close(fd);
        return fail(err, errlen, "%s: readable by group or others (mode %03o): refused; "
                    "chmod 600 it", path, (unsigned)(st.st_mode & 0777));
    }
    got = read(fd, text, sizeof text);
    close(fd);
    if (got < 0 || dkf_auth_parse_key(text, (size_t)got, key) != 0)
        return fail(err, errlen, "%s: not a key (64 hex digits and a newline)", path);
    return 0;
}

static void key_path(char *out, size_t len, const char *dir, size_t slot)
{
    if (slot == INFRA_SLOT)
        snprintf(out, len, "%s/infra.key", dir);
    else
        snprintf(out, len, "%s/node-%zu.key", dir, slot);
}

static void edge_path(char *out, size_t len, const char *dir, size_t i, size_t j)
{
    snprintf(out, len, "%s/edge-%zu-%zu.key", dir, i < j ? i : j, i < j ? j : i);
}

static int write_key(const char *path, char *err, size_t errlen)
{
    unsigned char k[DKF_AUTH_KEY_LEN];
    char text[2 * DKF_AUTH_KEY_LEN + 1];
    size_t i;
    int fd = open(path, O_WRONLY | O_CREAT | O_EXCL, 0600), ok;
    if (fd < 0 && errno == EEXIST) return 0; /* kept */
    if (fd < 0) return fail(err, errlen, "%s: cannot create: %s", path, strerror(errno));
    randombytes_buf(k, sizeof k);
    for (i = 0; i < DKF_AUTH_KEY_LEN; ++i) snprintf(text + 2 * i, 3, "%02x", k[i]);
    text[2 * DKF_AUTH_KEY_LEN] = '\n';
    ok = write(fd, text, sizeof text) == (ssize_t)sizeof text;
    sodium_memzero(k, sizeof k);
    if (close(fd) != 0 || !ok) return fail(err, errlen, "%s: cannot write", path);
    return 0;
}

static int make_dir(const char *dir, size_t nodes, char *err, size_t errlen)
{
    if (nodes > DKF_AUTH_MAX_KEYS)
        return fail(err, errlen, "%zu nodes: at most %d keys", nodes, DKF_AUTH_MAX_KEYS);
    if (sodium_init() < 0) return fail(err, errlen, "libsodium: cannot initialise");
    if (mkdir(dir, 0700) != 0 && errno != EEXIST)
        return fail(err, errlen, "%s: cannot create: %s", dir, strerror(errno));
    return 0;
}

int dkf_auth_make_keys(const char *dir, size_t nodes, char *err, size_t errlen)
{
    char path[4096];
    size_t i;
    if (make_dir(dir, nodes, err, errlen) != 0) return -1;
    for (i = 0; i <= nodes; ++i) {
        key_path(path, sizeof path, dir, i == nodes ? INFRA_SLOT : i);
        if (write_key(path, err, errlen) != 0) return -1;
    }
    return 0;
}

int dkf_auth_make_edge_keys(const char *dir, size_t nodes, char *err, size_t errlen)
{
    char path[4096];
    size_t i, j;
    if (make_dir(dir, nodes, err, errlen) != 0) return -1;
    for (i = 0; i < nodes; ++i)
        for (j = i + 1; j < nodes; ++j) {
            edge_path(path, sizeof path, dir, i, j);
            if (write_key(path, err, errlen) != 0) return -1;
        }
    return 0;
}

/* ---- opening ----------------------------------------------------------------------- */

static void set_key(dkf_auth_t *a, size_t slot, const unsigned char key[DKF_AUTH_KEY_LEN])
{
    crypto_auth_hmacsha512256_init(&a->keyed[slot], key, DKF_AUTH_KEY_LEN);
    a->have[slot] = 1;
}

static dkf_auth_t *auth_new(uint32_t self, int64_t epoch)
{
    dkf_auth_t *a;
    if (sodium_init() < 0 || (a = calloc(1, sizeof *a)) == NULL) return NULL;
    a->self = self;
    a->epoch = (uint64_t)epoch;
    return a;
}

dkf_auth_t *dkf_auth_open(const char *dir, uint32_t self, size_t nodes, char *err,
                          size_t errlen)
{
    char path[4096];
    const int role = (int)(self >> 16);
    const size_t index = self & 0xffffu;
    unsigned char key[DKF_AUTH_KEY_LEN];
    dkf_auth_t *a;
    size_t s;
    if (nodes > DKF_AUTH_MAX_KEYS || (role == DKF_NET_ROLE_NODE && index >= nodes) ||
        role < DKF_NET_ROLE_SIM || role > DKF_NET_ROLE_FUSION) {
        fail(err, errlen, "signer %u of a %zu-node network: no such key", (unsigned)self, nodes);
        return NULL;
    }
    if ((a = auth_new(self, dkf_net_now_us())) == NULL) {
        fail(err, errlen, "libsodium: cannot initialise, or out of memory");
        return NULL;
    }
    for (s = 0; s < NSLOTS; ++s) {
        const int wanted = role == DKF_NET_ROLE_NODE ? s == index : (s < nodes || s == INFRA_SLOT);
        if (!wanted) continue;
        key_path(path, sizeof path, dir, s);
        if (dkf_auth_read_key(path, key, err, errlen) != 0) {
            sodium_memzero(key, sizeof key);
            dkf_auth_free(a);
            return NULL;
        }
        set_key(a, s, key);
    }
    sodium_memzero(key, sizeof key);
    return a;
}

dkf_auth_t *dkf_auth_open_keys(uint32_t self, const unsigned char *keys,
                               const unsigned char *have, const unsigned char *infra,
                               int64_t epoch)
{
    dkf_auth_t *a = auth_new(self, epoch);
    size_t s;
    if (a == NULL) return NULL;
    for (s = 0; s < DKF_AUTH_MAX_KEYS && keys != NULL && have != NULL; ++s)
        if (have[s]) set_key(a, s, keys + s * DKF_AUTH_KEY_LEN);
    if (infra != NULL) set_key(a, INFRA_SLOT, infra);
    return a;
}

/* Graph node self's peer p gets the key: peers stay ascending, once each. */
static void add_peer(dkf_auth_t *a, size_t p, const unsigned char key[DKF_AUTH_KEY_LEN])
{
    size_t i;
    if (a->have[p]) return;
    set_key(a, p, key);
    for (i = a->npeers; i > 0 && a->peers[i - 1] > p; --i) a->peers[i] = a->peers[i - 1];
    a->peers[i] = (uint32_t)p;
    ++a->npeers;
}

dkf_auth_t *dkf_auth_open_edges(const char *dir, size_t self, const size_t *peers,
                                size_t npeers, char *err, size_t errlen)
{
    char path[4096];
    unsigned char key[DKF_AUTH_KEY_LEN];
    dkf_auth_t *a;
    size_t e;
    for (e = 0; e < npeers; ++e)
        if (peers[e] >= DKF_AUTH_MAX_KEYS) break;
    if (self >= DKF_AUTH_MAX_KEYS || e < npeers) {
        fail(err, errlen, "graph node %zu or a neighbour: at most %d nodes", self,
             DKF_AUTH_MAX_KEYS);
        return NULL;
    }
    if ((a = auth_new(dkf_auth_signer(DKF_NET_ROLE_GRAPH, self), dkf_net_now_us())) == NULL) {
        fail(err, errlen, "libsodium: cannot initialise, or out of memory");
        return NULL;
    }
    a->graph = 1;
    for (e = 0; e < npeers; ++e) {
        if (peers[e] == self) continue;
        edge_path(path, sizeof path, dir, self, peers[e]);
        if (dkf_auth_read_key(path, key, err, errlen) != 0) {
            sodium_memzero(key, sizeof key);
            dkf_auth_free(a);
            return NULL;
        }
        add_peer(a, peers[e], key);
    }
    sodium_memzero(key, sizeof key);
    return a;
}

dkf_auth_t *dkf_auth_open_edge_keys(size_t self, const unsigned char *keys,
                                    const unsigned char *have, int64_t epoch)
{
    dkf_auth_t *a;
    size_t p;
    if (self >= DKF_AUTH_MAX_KEYS ||
        (a = auth_new(dkf_auth_signer(DKF_NET_ROLE_GRAPH, self), epoch)) == NULL)
        return NULL;
    a->graph = 1;
    for (p = 0; p < DKF_AUTH_MAX_KEYS && keys != NULL && have != NULL; ++p)
        if (have[p] && p != self) add_peer(a, p, keys + p * DKF_AUTH_KEY_LEN);
    return a;
}

void dkf_auth_free(dkf_auth_t *a)
{
    if (a == NULL) return;
    sodium_memzero(a->keyed, sizeof a->keyed);
    free(a);
}

/* ---- the channel rule ---------------------------------------------------------------- */

#define NOT_HERE (-1L) /* the signer may not speak on the channel */
#define NO_CHANNEL (-2L) /* the name is not a channel of the protocol */

/* The key slot signer must use on channel (auth.h's table), NOT_HERE or NO_CHANNEL. */
static long slot_for(const char *channel, uint32_t signer)
{
    const dkf_net_chan_id_t c = dkf_net_chan_parse(channel);
    const int role = (int)(signer >> 16);
    const long index = (long)(signer & 0xffffu);
    const int node = role == DKF_NET_ROLE_NODE && index < DKF_AUTH_MAX_KEYS;
    const int infra = (role == DKF_NET_ROLE_SIM || role == DKF_NET_ROLE_FUSION) && index == 0;
    switch (c.kind) {
    case DKF_CHAN_NODE: return node && index == c.id ? index : NOT_HERE;
    case DKF_CHAN_MEAS:
        return role == DKF_NET_ROLE_SIM && index == 0 && c.id < DKF_AUTH_MAX_KEYS ? c.id : NOT_HERE;
    case DKF_CHAN_FUSED: return role == DKF_NET_ROLE_FUSION && index == 0 ? INFRA_SLOT : NOT_HERE;
    case DKF_CHAN_TRUTH: return role == DKF_NET_ROLE_SIM && index == 0 ? INFRA_SLOT : NOT_HERE;
    case DKF_CHAN_STATUS: return node ? index : infra ? INFRA_SLOT : NOT_HERE;
    default: return NO_CHANNEL;
    }
}

/* The node id a graph channel carries (its canonical trailing number), or -1. */
static long graph_node_of(const char *channel)
{
    const dkf_net_chan_id_t c = dkf_net_chan_parse(channel);
    return c.id < DKF_AUTH_MAX_KEYS ? c.id : -1;
}

/* The sender a verified signer is (chan.h). */
static void sender_of(uint32_t signer, dkf_net_from_t *from)
{
    const int role = (int)(signer >> 16);
    if (from == NULL) return;
    from->known = 1;
    from->role = role;
    from->id = role == DKF_NET_ROLE_NODE || role == DKF_NET_ROLE_GRAPH ? (long)(signer & 0xffffu)
                                                                       : -1;
}

/* ---- trailer and MAC ----------------------------------------------------------------- */

static void put_be(unsigned char *p, uint64_t v, int bytes)
{
    int i;
    for (i = bytes - 1; i >= 0; --i, v >>= 8) p[i] = (unsigned char)(v & 0xffu);
}

static uint64_t get_be(const unsigned char *p, int bytes)
{
    uint64_t v = 0;
    int i;
    for (i = 0; i < bytes; ++i) v = v << 8 | p[i];
    return v;
}

/* HMAC-SHA-512-256 under the keyed state of a key, of
 * len(channel) (4 bytes, big-endian) || channel || msg || header[0..hlen-1]
 * (DKA1: the 28 bytes before the tag; DKA2: the fixed part and the peer). */
static void mac(const crypto_auth_hmacsha512256_state *keyed, const char *channel,
                const void *msg, size_t len, const unsigned char *header, size_t hlen,
                unsigned char tag[32])
{
    crypto_auth_hmacsha512256_state st = *keyed;
    unsigned char clen[4];
    const size_t cl = strlen(channel);
    put_be(clen, cl, 4);
    crypto_auth_hmacsha512256_update(&st, clen, sizeof clen);
    crypto_auth_hmacsha512256_update(&st, (const unsigned char *)channel, cl);
    crypto_auth_hmacsha512256_update(&st, msg, len);
    crypto_auth_hmacsha512256_update(&st, header, hlen);
    crypto_auth_hmacsha512256_final(&st, tag);
    sodium_memzero(&st, sizeof st);
}

size_t dkf_auth_trailer_len(const dkf_auth_t *a)
{
    return a->graph ? DKF_AUTH_EDGE_HEADER + DKF_AUTH_EDGE_ENTRY * a->npeers : DKF_AUTH_TRAILER;
}

/* The fixed part and a peer id, as DKA2's MAC takes them. */
static void edge_input(unsigned char in[DKF_AUTH_EDGE_HEADER + 4], const unsigned char *fixed,
                       uint32_t peer)
{
    memcpy(in, fixed, DKF_AUTH_EDGE_HEADER);
    put_be(in + DKF_AUTH_EDGE_HEADER, peer, 4);
}

static int sign_edges(dkf_auth_t *a, const char *channel, const void *msg, size_t len,
                      unsigned char *trailer)
{
    const size_t self = a->self & 0xffffu;
    unsigned char *fixed = trailer + DKF_AUTH_EDGE_ENTRY * a->npeers,
                  in[DKF_AUTH_EDGE_HEADER + 4];
    size_t e;
    if (a->npeers == 0 || graph_node_of(channel) != (long)self) return -1;
    memcpy(fixed, "DKA2", 4);
    put_be(fixed + 4, a->self, 4);
    put_be(fixed + 8, a->epoch, 8);
    put_be(fixed + 16, ++a->seq, 8);
    put_be(fixed + 24, a->npeers, 4);
    for (e = 0; e < a->npeers; ++e) {
        unsigned char *entry = trailer + DKF_AUTH_EDGE_ENTRY * e;
        put_be(entry, a->peers[e], 4);
        edge_input(in, fixed, a->peers[e]);
        mac(&a->keyed[a->peers[e]], channel, msg, len, in, sizeof in, entry + 4);
    }
    return 0;
}

int dkf_auth_sign(dkf_auth_t *a, const char *channel, const void *msg, size_t len,
                  unsigned char *trailer)
{
    long s;
    if (a->graph) return sign_edges(a, channel, msg, len, trailer);
    s = slot_for(channel, a->self);
    if (s < 0 || !a->have[s]) return -1;
    memcpy(trailer, "DKA1", 4);
    put_be(trailer + 4, a->self, 4);
    put_be(trailer + 8, s == INFRA_SLOT ? DKF_AUTH_KEY_INFRA : (uint64_t)s, 4);
    put_be(trailer + 12, a->epoch, 8);
    put_be(trailer + 20, ++a->seq, 8);
    mac(&a->keyed[s], channel, msg, len, trailer, HEADER, trailer + HEADER);
    return 0;
}

/* (epoch, seq) newer than the last accepted in l: then it becomes the last. */
static int newer(last_t *l, uint64_t epoch, uint64_t seq)
{
    if (l->seen && (epoch < l->epoch || (epoch == l->epoch && seq <= l->seq))) return 0;
    l->seen = 1;
    l->epoch = epoch;
    l->seq = seq;
    return 1;
}

static dkf_auth_verdict_t judge(dkf_auth_t *a, const char *channel, const unsigned char *d,
                                size_t len, size_t *msg_len, dkf_net_from_t *from)
{
    const unsigned char *t;
    unsigned char tag[32];
    uint32_t signer, key_id;
    uint64_t epoch, seq;
    long s;
    last_t *l;
    if (len < DKF_AUTH_TRAILER) return DKF_AUTH_REJ_FORMAT;
    t = d + len - DKF_AUTH_TRAILER;
    if (memcmp(t, "DKA1", 4) != 0) return DKF_AUTH_REJ_FORMAT;
    signer = (uint32_t)get_be(t + 4, 4);
    key_id = (uint32_t)get_be(t + 8, 4);
    epoch = get_be(t + 12, 8);
    seq = get_be(t + 20, 8);
    s = slot_for(channel, signer);
    if (s == NO_CHANNEL) return DKF_AUTH_REJ_CHANNEL;
    if (s < 0 || (s == INFRA_SLOT ? key_id != DKF_AUTH_KEY_INFRA : key_id != (uint32_t)s))
        return DKF_AUTH_REJ_FOREIGN;
    if (!a->have[s]) return DKF_AUTH_REJ_NO_KEY;
    mac(&a->keyed[s], channel, d, len - DKF_AUTH_TRAILER, t, HEADER, tag);
    if (sodium_memcmp(tag, t + HEADER, sizeof tag) != 0) return DKF_AUTH_REJ_MAC;
    l = &a->last[signer >> 16][s]; /* the role is 0..2: slot_for accepted it */
    if (!newer(l, epoch, seq)) return DKF_AUTH_REJ_REPLAY;
    *msg_len = len - DKF_AUTH_TRAILER;
    sender_of(signer, from);
    return DKF_AUTH_ACCEPT;
}

/* DKA2 at a graph node (auth.h): the entry addressed to it, under the key
 * it shares with the channel's node. */
static dkf_auth_verdict_t judge_edges(dkf_auth_t *a, const char *channel, const unsigned char *d,
                                      size_t len, size_t *msg_len, dkf_net_from_t *from)
{
    const unsigned char *fixed, *entry = NULL;
    unsigned char tag[32], in[DKF_AUTH_EDGE_HEADER + 4];
    const uint32_t self = a->self & 0xffffu;
    uint32_t signer;
    uint64_t count, e;
    size_t body;
    long l;
    if (len < DKF_AUTH_EDGE_HEADER) return DKF_AUTH_REJ_FORMAT;
    fixed = d + len - DKF_AUTH_EDGE_HEADER;
    count = get_be(fixed + 24, 4);
    if (memcmp(fixed, "DKA2", 4) != 0 || count > DKF_AUTH_MAX_KEYS ||
        (len - DKF_AUTH_EDGE_HEADER) / DKF_AUTH_EDGE_ENTRY < count)
        return DKF_AUTH_REJ_FORMAT;
    body = len - DKF_AUTH_EDGE_HEADER - (size_t)count * DKF_AUTH_EDGE_ENTRY;
    signer = (uint32_t)get_be(fixed + 4, 4);
    if ((l = graph_node_of(channel)) < 0) return DKF_AUTH_REJ_CHANNEL;
    if (signer >> 16 != DKF_NET_ROLE_GRAPH || (signer & 0xffffu) != (uint32_t)l ||
        (uint32_t)l == self)
        return DKF_AUTH_REJ_FOREIGN;
    for (e = 0; e < count && entry == NULL; ++e)
        if (get_be(d + body + DKF_AUTH_EDGE_ENTRY * e, 4) == self)
            entry = d + body + DKF_AUTH_EDGE_ENTRY * e;
    if (entry == NULL || !a->have[l]) return DKF_AUTH_REJ_NO_KEY;
    edge_input(in, fixed, self);
    mac(&a->keyed[l], channel, d, body, in, sizeof in, tag);
    if (sodium_memcmp(tag, entry + 4, sizeof tag) != 0) return DKF_AUTH_REJ_MAC;
    if (!newer(&a->last[DKF_NET_ROLE_GRAPH][l], get_be(fixed + 8, 8), get_be(fixed + 16, 8)))
        return DKF_AUTH_REJ_REPLAY;
    *msg_len = body;
    sender_of(signer, from);
    return DKF_AUTH_ACCEPT;
}

dkf_auth_verdict_t dkf_auth_verify(dkf_auth_t *a, const char *channel, const void *dgram,
                                   size_t len, size_t *msg_len, dkf_net_from_t *from)
{
    const dkf_auth_verdict_t v = a->graph ? judge_edges(a, channel, dgram, len, msg_len, from)
                                          : judge(a, channel, dgram, len, msg_len, from);
    ++a->count[v];
    return v;
}

const uint64_t *dkf_auth_counts(const dkf_auth_t *a) { return a->count; }
