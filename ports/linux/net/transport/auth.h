/*
 * auth.h - authenticated datagrams of the DKF network (host side, libsodium;
 * docs/guide/network.md, "Authentication"; docs/decisions.md, item 24).
 *
 * Every datagram an authenticating process publishes is the LCM message
 * followed by a trailer of DKF_AUTH_TRAILER bytes (big-endian):
 *
 *   "DKA1" | signer u32 | key id u32 | epoch u64 | seq u64 | tag[32]
 *
 * tag = HMAC-SHA-512-256 (crypto_auth) under key `key id` of
 *   len(channel) u32 | channel | message | the trailer's first 28 bytes.
 * signer = role << 16 | index (DKF_NET_ROLE_SIM/NODE/FUSION of chan.h;
 * index = the node id for a node, 0 otherwise). Key i (0..255) is node i's,
 * shared by node i and the infrastructure (dkf-sim, dkf-fusion); key
 * DKF_AUTH_KEY_INFRA is the infrastructure's alone. The channel, parsed
 * canonically (chan.h), fixes who may speak on it with which key:
 *   <prefix>_NODE_<i>   node i, key i        <prefix>_MEAS_<i>  dkf-sim, key i
 *   <prefix>_FUSED      dkf-fusion, infra    <prefix>_TRUTH     dkf-sim, infra
 *   <prefix>_STATUS     node i with key i, or dkf-sim / dkf-fusion with infra
 * and nobody may sign or be accepted on any other name (`bad channel`): a
 * node's key signs only node i's own channels and its status. A receiver
 * learns the sender from the verified signer alone (dkf_auth_verify's
 * `from`), and checks that a payload which names a sender names that one.
 * epoch is the sender's start time (us); (epoch, seq) must be newer than the
 * last accepted of that signer and key: strictly larger seq in the same
 * epoch, or a larger epoch (a restarted process).
 *
 * Graph filters (dkf-tw-node, docs/guide/network.md "Authentication"): every
 * edge {i, j} of the graph has its own key, held by i and j only
 * (edge-<i>-<j>.key, i < j), and node l's datagram on "<prefix>_<l>"
 * carries one tag per neighbour, so that each neighbour checks the tag
 * under the key it shares with l and no neighbour can speak for l to
 * another. Its trailer (the fixed part last, so a receiver finds it from
 * the datagram's end):
 *
 *   count x (peer u32 | tag[32]) | "DKA2" | signer u32 | epoch u64 | seq u64 | count u32
 *
 * tag for peer r = HMAC-SHA-512-256 under edge key {l, r} of
 *   len(channel) u32 | channel | message | the last 28 bytes | r u32.
 * signer = DKF_NET_ROLE_GRAPH << 16 | l; the channel's canonical trailing
 * number (chan.h) must be l. A process authenticates either the DKA1 way or the DKA2 way, never
 * both, and refuses the other's trailer as `no trailer`.
 *
 * Integer returns: 0 success, -1 failure with a one-line message in err.
 */
#ifndef DKF_NET_AUTH_H
#define DKF_NET_AUTH_H

#include <stddef.h>
#include <stdint.h>

#include "chan.h"

#define DKF_AUTH_TRAILER 60
#define DKF_AUTH_KEY_LEN 32
#define DKF_AUTH_MAX_KEYS 256           /* node keys 0..255 */
#define DKF_AUTH_KEY_INFRA 0xffffffffu  /* the infrastructure's key id */
#define DKF_AUTH_EDGE_HEADER 28         /* DKA2: the fixed part */
#define DKF_AUTH_EDGE_ENTRY 36          /* DKA2: one (peer, tag) */

typedef enum {
    DKF_AUTH_ACCEPT = 0,
    DKF_AUTH_REJ_FORMAT,   /* shorter than a trailer, or not "DKA1" (an unauthenticated sender) */
    DKF_AUTH_REJ_NO_KEY,   /* a key id this process does not hold */
    DKF_AUTH_REJ_FOREIGN,  /* signer or key not the channel's (a node speaking for another) */
    DKF_AUTH_REJ_MAC,      /* the tag does not verify (forged or altered) */
    DKF_AUTH_REJ_REPLAY,   /* (epoch, seq) not newer than the last accepted */
    DKF_AUTH_REJ_CHANNEL,  /* not a channel of the protocol, canonically spelled (chan.h) */
    DKF_AUTH_NVERDICTS
} dkf_auth_verdict_t;

typedef struct dkf_auth dkf_auth_t;

/* "accepted", "no trailer", "unknown key", "foreign", "bad MAC", "replayed",
 * "bad channel". */
const char *dkf_auth_verdict_str(dkf_auth_verdict_t v);

/* signer id of a role (DKF_NET_ROLE_*) and index. */
uint32_t dkf_auth_signer(int role, size_t index);

/* Writes DIR/node-<i>.key (i < nodes) and DIR/infra.key: fresh random keys,
 * mode 0600, DIR created 0700 if missing; an existing key file is kept. */
int dkf_auth_make_keys(const char *dir, size_t nodes, char *err, size_t errlen);

/* Reads one key file: 64 hex digits and an optional newline, nothing else,
 * not readable by group or others. 0 or -1. */
int dkf_auth_read_key(const char *path, unsigned char key[DKF_AUTH_KEY_LEN], char *err,
                      size_t errlen);

/* Parses a key file's bytes (the check of dkf_auth_read_key without the
 * file; the fuzz harness's entry). 0 or -1. */
int dkf_auth_parse_key(const char *text, size_t len, unsigned char key[DKF_AUTH_KEY_LEN]);

/* The keys of a process that signs as `self`: node i holds key i; dkf-sim
 * and dkf-fusion hold infra.key and node-<i>.key of every i < nodes. Epoch:
 * now. NULL with the reason in err (a key file missing or unreadable, no
 * libsodium). */
dkf_auth_t *dkf_auth_open(const char *dir, uint32_t self, size_t nodes, char *err,
                          size_t errlen);
/* The same with the keys given (tests, fuzzing): key i of keys[i] for
 * have[i] != 0 (i < DKF_AUTH_MAX_KEYS; keys holds DKF_AUTH_MAX_KEYS x
 * DKF_AUTH_KEY_LEN bytes), infra if infra != NULL. */
dkf_auth_t *dkf_auth_open_keys(uint32_t self, const unsigned char *keys,
                               const unsigned char *have, const unsigned char *infra,
                               int64_t epoch);
void dkf_auth_free(dkf_auth_t *a);

/* Writes DIR/edge-<i>-<j>.key for every i < j < nodes (a graph filter's
 * keys: nodes (nodes - 1) / 2 files), like dkf_auth_make_keys. */
int dkf_auth_make_edge_keys(const char *dir, size_t nodes, char *err, size_t errlen);
/* The keys of graph node `self` (< DKF_AUTH_MAX_KEYS): the edge key it
 * shares with each of its peers (its neighbours; self and repeats
 * ignored), read from DIR. Epoch: now. NULL with the reason in err. */
dkf_auth_t *dkf_auth_open_edges(const char *dir, size_t self, const size_t *peers,
                                size_t npeers, char *err, size_t errlen);
/* The same with the keys given (tests, fuzzing): the key shared with peer
 * p is keys + p * DKF_AUTH_KEY_LEN for have[p] != 0. */
dkf_auth_t *dkf_auth_open_edge_keys(size_t self, const unsigned char *keys,
                                    const unsigned char *have, int64_t epoch);

/* Bytes dkf_auth_sign appends: DKF_AUTH_TRAILER, or for a graph node
 * DKF_AUTH_EDGE_HEADER + DKF_AUTH_EDGE_ENTRY per peer. */
size_t dkf_auth_trailer_len(const dkf_auth_t *a);

/* The trailer (dkf_auth_trailer_len(a) bytes) of msg[0..len-1] on channel,
 * signed with the key(s) this process must use there; advances seq. 0, or
 * -1 (no such key held, or a graph node off its own channel). */
int dkf_auth_sign(dkf_auth_t *a, const char *channel, const void *msg, size_t len,
                  unsigned char *trailer);

/* Checks a received datagram (message + trailer) on channel (a graph
 * node's: the tag addressed to it, under the key of the channel's node; no
 * tag for it, or that node no neighbour, is `unknown key`); on ACCEPT
 * *msg_len is the message's length, *from (may be NULL) the signer whose
 * key verified it, and the replay state advances. Every other verdict
 * changes nothing but the counters. */
dkf_auth_verdict_t dkf_auth_verify(dkf_auth_t *a, const char *channel, const void *dgram,
                                   size_t len, size_t *msg_len, dkf_net_from_t *from);

/* Datagrams judged, by verdict (DKF_AUTH_NVERDICTS entries). */
const uint64_t *dkf_auth_counts(const dkf_auth_t *a);

#endif /* DKF_NET_AUTH_H */
