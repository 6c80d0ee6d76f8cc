/*
 * net.h - the thin LCM transport of the network processes (host side).
 *
 * The core never sees LCM: dkf-sim, dkf-node and dkf-fusion talk through
 * this layer, which hands raw message bytes to codec.h. It opens only URLs
 * that cannot leave the machine by default:
 *
 *   memq://                               in-process queue (unit tests)
 *   udpm://239.x.y.z[:port]?...ttl=0...   UDP multicast in 239.0.0.0/8
 *                                          (administratively scoped) with
 *                                          TTL 0 (never routed off the host)
 *
 * Every other provider, a udpm group outside 239.0.0.0/8, and a udpm URL
 * whose ttl is missing or not 0 are refused, in every scope. In scope
 * DKF_NET_LAN (the programs' --lan, which also requires authentication:
 * docs/guide/network.md, "Several hosts"; docs/decisions.md, items 65 and
 * 78) the same ttl=0 URL is opened with ttl=1: one hop, the local segment,
 * never routed. No URL a user writes says more than ttl=0.
 * Integer returns: 0 success, -1 failure with a one-line message in err.
 */
#ifndef DKF_NET_H
#define DKF_NET_H

#include <stddef.h>
#include <stdint.h>

#include "chan.h"
#include "clock.h" /* dkf_net_now_us, dkf_net_mono_us */

#define DKF_NET_DEFAULT_URL "udpm://239.255.76.67:7667?ttl=0"
#define DKF_NET_ERR_LEN 256

typedef struct dkf_net dkf_net_t;

/* Raw-message handler: channel, its sender (chan.h: with authentication
 * the signer whose key verified the datagram, else unknown), payload,
 * receive time (us since epoch). */
typedef void (*dkf_net_handler_t)(const char *channel, const dkf_net_from_t *from,
                                  const void *data, size_t len, int64_t recv_utime, void *user);

/* Where a URL may reach (see above). */
#define DKF_NET_HOST 0 /* this host only: udpm ttl=0 */
#define DKF_NET_LAN 1  /* the local segment too: the ttl=0 URL opened with ttl=1 */

/* 0 if url is allowed in scope DKF_NET_HOST (see above), else -1 with the
 * reason in err. */
int dkf_net_check_url(const char *url, char *err, size_t errlen);
/* The same in scope DKF_NET_HOST or DKF_NET_LAN (any other is refused). */
int dkf_net_check_url_scope(const char *url, int scope, char *err, size_t errlen);
/* The URL LCM is given for url in scope (url checked first): url itself, or
 * in scope DKF_NET_LAN with its ttl=0 made ttl=1. 0, or -1 with err. */
int dkf_net_lcm_url(const char *url, int scope, char *out, size_t outlen, char *err,
                    size_t errlen);

/* Checks url (scope DKF_NET_HOST), then creates the LCM instance. NULL +
 * err on failure. */
dkf_net_t *dkf_net_open(const char *url, char *err, size_t errlen);
/* The same in scope DKF_NET_HOST or DKF_NET_LAN (split ports' lanes are
 * checked in it too). */
dkf_net_t *dkf_net_open_scope(const char *url, int scope, char *err, size_t errlen);
void dkf_net_close(dkf_net_t *net);

/* Split ports (udpm only; before any subscription): the node messages
 * ("*_NODE_*") travel on the URL's port + 1 and node i's measurements
 * ("*_MEAS_<i>") on port + 2 + i, everything else on the URL's port, so a
 * process wakes only for the datagrams of the channels it reads (LCM
 * delivers every datagram of a port to every socket on it and filters
 * channels in user space). Every process of a run must agree; a
 * subscription to several nodes' measurements is refused then. A monitor
 * or logger on the URL alone sees only the last group (docs/guide/network.md,
 * "Split ports"). 0, or -1 with the reason in err. */
int dkf_net_split(dkf_net_t *net, char *err, size_t errlen);

/* Direct receive (udpm only; before any subscription): the process reads
 * its subscriptions' multicast sockets itself (wire.h) instead of through
 * LCM's receive thread and its pipe, so a datagram wakes one thread, not
 * two (docs/guide/network.md, "Direct receive"). Publishing stays lcm_publish;
 * handlers see the same channel, payload and kernel receive time. LCM
 * fragments (messages over 65 KB) and malformed datagrams are dropped and
 * counted. Works with and without split ports. 0, or -1 with err. */
int dkf_net_direct(dkf_net_t *net, char *err, size_t errlen);

/* What direct receive read (direct: whether it is on): datagrams, and of
 * them those dropped as LCM fragments, malformed, or of no subscribed
 * channel; rcvbuf is a socket's kernel buffer in bytes as Linux reports it
 * (double what was asked for, for its bookkeeping). All 0 without it. */
typedef struct {
    int direct;
    unsigned long datagrams, fragments, malformed, unmatched, rcvbuf;
} dkf_net_rx_t;
dkf_net_rx_t dkf_net_rx(const dkf_net_t *net);

struct dkf_auth; /* auth.h */

/* From now on every datagram published carries auth's trailer, and only
 * datagrams that auth accepts reach the handlers, with the verified signer
 * as their sender (docs/guide/network.md, "Authentication"). net takes auth over (dkf_net_close frees it); NULL
 * turns authentication off. */
void dkf_net_set_auth(dkf_net_t *net, struct dkf_auth *auth);
/* The authenticator set, or NULL (its counters: auth.h). */
const struct dkf_auth *dkf_net_auth(const dkf_net_t *net);

/* Publishes len bytes on channel (with the trailer if authenticating). 0 or -1. */
int dkf_net_publish(dkf_net_t *net, const char *channel, const void *data, size_t len);

/* Subscribes handler to channels matching the regular expression
 * (LCM anchors it: "DKF_NODE_[0-9]+" matches whole names). 0 or -1. */
int dkf_net_subscribe(dkf_net_t *net, const char *channel_regex, dkf_net_handler_t handler,
                      void *user);

/* Dispatches at most one message, waiting up to timeout_ms (0: poll).
 * 1 a message was handled, 0 timeout, -1 error. */
int dkf_net_handle(dkf_net_t *net, int timeout_ms);

/* Dispatches every message already queued (waiting at most timeout_ms for
 * the first); returns how many were handled, or -1. */
int dkf_net_drain(dkf_net_t *net, int timeout_ms);

#endif /* DKF_NET_H */
