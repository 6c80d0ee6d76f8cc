/*
 * net.c - LCM transport with the URL safety rules of net.h.
 */
#define _POSIX_C_SOURCE 200809L

#include "net.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <lcm/lcm.h>

#include "auth.h"
#include "codec.h" /* DKF_NET_MAX_NODES */
#include "util.h"

/* every error of this file: a message in err, -1 */
#define fail(err, errlen, ...) dkf_failf(err, errlen, -1, __VA_ARGS__)

#define DKF_NET_QUEUE 4096 /* messages a subscription may queue */

struct dkf_net {
    lcm_t *lcm;
    dkf_auth_t *auth;      /* NULL: unauthenticated (dkf_net_set_auth) */
    unsigned char *out;    /* message + trailer being published (auth only) */
    size_t out_cap;
    int subs;              /* number of subscriptions (bounded below) */
    struct sub {
        dkf_net_t *net;
        dkf_net_handler_t fn;
        void *user;
    } sub[DKF_NET_MAX_NODES + 16]; /* dkf-net-local: one per node agent, the centre's, the sim's */
};

/* Parses a decimal number in [lo, hi] from s[0..len-1]; -1 if not one. */
static long parse_dec(const char *s, size_t len, long lo, long hi)
{
    long v = 0;
    size_t i;
    if (len == 0 || len > 5 || (len > 1 && s[0] == '0')) return -1; /* canonical only */
    for (i = 0; i < len; ++i) {
        if (s[i] < '0' || s[i] > '9') return -1;
        v = v * 10 + (s[i] - '0');
    }
    return (v < lo || v > hi) ? -1 : v;
}

/* 0 if host[0..len-1] is a dotted quad a.b.c.d with a = 239. */
static int check_group(const char *host, size_t len)
{
    long part[4];
    size_t i = 0, start = 0, np = 0;
    for (i = 0; i <= len; ++i) {
        if (i == len || host[i] == '.') {
            if (np == 4) return -1;
            part[np] = parse_dec(host + start, i - start, 0, 255);
            if (part[np] < 0) return -1;
            ++np;
            start = i + 1;
        }
    }
    return (np == 4 && part[0] == 239) ? 0 : -1;
}

/* Checks the options after '?': ttl must appear exactly once, equal to 0. */
static int check_options(const char *url, const char *opt, char *err, size_t errlen)
{
    int nttl = 0;
    while (opt != NULL && *opt != '\0') {
        const char *end = strchr(opt, '&');
        size_t len = end ? (size_t)(end - opt) : strlen(opt);
        if (len >= 4 && strncmp(opt, "ttl=", 4) == 0) {
            ++nttl;
            if (len != 5 || opt[4] != '0')
                return fail(err, errlen, "%s: refused: ttl must be 0 (multicast must not leave "
                            "this host; docs/network.md)", url);
        }
        opt = end ? end + 1 : NULL;
    }
    if (nttl != 1)
        return fail(err, errlen, "%s: refused: a udpm URL must say ttl=0 exactly once", url);
    return 0;
}

int dkf_net_check_url(const char *url, char *err, size_t errlen)
{
    const char *host, *q, *colon, *hend;
    if (url == NULL) return fail(err, errlen, "(null): refused: no LCM URL");
    if (strcmp(url, "memq://") == 0) return 0;
    if (strncmp(url, "udpm://", 7) != 0)
        return fail(err, errlen, "%s: refused: only udpm:// (ttl=0) and memq:// are allowed", url);
    host = url + 7;
    q = strchr(host, '?');
    hend = q ? q : host + strlen(host);
    colon = memchr(host, ':', (size_t)(hend - host));
    if (check_group(host, (size_t)((colon ? colon : hend) - host)) != 0)
        return fail(err, errlen, "%s: refused: the multicast group must be an address in "
                    "239.0.0.0/8", url);
    if (colon != NULL && parse_dec(colon + 1, (size_t)(hend - colon - 1), 1, 65535) < 0)
        return fail(err, errlen, "%s: refused: bad port", url);
    return check_options(url, q ? q + 1 : NULL, err, errlen);
}

dkf_net_t *dkf_net_open(const char *url, char *err, size_t errlen)
{
    dkf_net_t *net;
    if (dkf_net_check_url(url, err, errlen) != 0) return NULL;
    net = calloc(1, sizeof *net);
    if (net == NULL) {
        fail(err, errlen, "%s: out of memory", url);
        return NULL;
    }
    net->lcm = lcm_create(url);
    if (net->lcm == NULL) {
        free(net);
        fail(err, errlen, "%s: cannot open LCM (is there a multicast route? docs/network.md)",
             url);
        return NULL;
    }
    return net;
}

void dkf_net_close(dkf_net_t *net)
{
    if (net == NULL) return;
    lcm_destroy(net->lcm);
    dkf_auth_free(net->auth);
    free(net->out);
    free(net);
}

void dkf_net_set_auth(dkf_net_t *net, dkf_auth_t *auth)
{
    if (net->auth != auth) dkf_auth_free(net->auth);
    net->auth = auth;
}

const dkf_auth_t *dkf_net_auth(const dkf_net_t *net) { return net->auth; }

/* data + its trailer in net->out; NULL if memory is short or the process
 * holds no key for channel. */
static const unsigned char *signed_copy(dkf_net_t *net, const char *channel, const void *data,
                                        size_t len)
{
    if (net->out_cap < len + DKF_AUTH_TRAILER) {
        unsigned char *p = realloc(net->out, len + DKF_AUTH_TRAILER);
        if (p == NULL) return NULL;
        net->out = p;
        net->out_cap = len + DKF_AUTH_TRAILER;
    }
    memcpy(net->out, data, len);
    return dkf_auth_sign(net->auth, channel, data, len, net->out + len) == 0 ? net->out : NULL;
}

int dkf_net_publish(dkf_net_t *net, const char *channel, const void *data, size_t len)
{
    if (len > 0x7fffffffu - DKF_AUTH_TRAILER) return -1;
    if (net->auth != NULL) {
        if ((data = signed_copy(net, channel, data, len)) == NULL) return -1;
        len += DKF_AUTH_TRAILER;
    }
    return lcm_publish(net->lcm, channel, data, (unsigned int)len) == 0 ? 0 : -1;
}

/* Hands a datagram to its handler; with authentication only an accepted
 * one, without its trailer (the others are counted by dkf_auth_verify). */
static void dispatch(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    const struct sub *s = user;
    size_t len = rbuf->data_size;
    if (s->net->auth != NULL &&
        dkf_auth_verify(s->net->auth, channel, rbuf->data, rbuf->data_size, &len) !=
            DKF_AUTH_ACCEPT)
        return;
    s->fn(channel, rbuf->data, len, rbuf->recv_utime, s->user);
}

int dkf_net_subscribe(dkf_net_t *net, const char *channel_regex, dkf_net_handler_t handler,
                      void *user)
{
    struct sub *s;
    lcm_subscription_t *h;
    if (net->subs >= (int)(sizeof net->sub / sizeof net->sub[0])) return -1;
    s = &net->sub[net->subs];
    s->net = net;
    s->fn = handler;
    s->user = user;
    h = lcm_subscribe(net->lcm, channel_regex, dispatch, s);
    if (h == NULL) return -1;
    /* LCM drops messages beyond a subscription's queue (30 by default); a
     * burst of one message per node at every step must never be cut. */
    lcm_subscription_set_queue_capacity(h, DKF_NET_QUEUE);
    ++net->subs;
    return 0;
}

int dkf_net_handle(dkf_net_t *net, int timeout_ms)
{
    int r = lcm_handle_timeout(net->lcm, timeout_ms < 0 ? 0 : timeout_ms);
    if (r < 0) return -1;
    return r > 0 ? 1 : 0;
}

int dkf_net_drain(dkf_net_t *net, int timeout_ms)
{
    int count = 0, r = dkf_net_handle(net, timeout_ms);
    while (r == 1) {
        ++count;
        r = dkf_net_handle(net, 0);
    }
    return r < 0 ? -1 : count;
}

static int64_t clock_us(clockid_t id)
{
    struct timespec ts;
    clock_gettime(id, &ts);
    return (int64_t)ts.tv_sec * 1000000 + (int64_t)(ts.tv_nsec / 1000);
}

int64_t dkf_net_now_us(void) { return clock_us(CLOCK_REALTIME); }
int64_t dkf_net_mono_us(void) { return clock_us(CLOCK_MONOTONIC); }
