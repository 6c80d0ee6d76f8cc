/*
 * net.c - LCM transport with the URL safety rules of net.h.
 */
#define _DEFAULT_SOURCE /* ip_mreq, SO_RCVBUFFORCE, SCM_TIMESTAMP (Linux) */
#define _POSIX_C_SOURCE 200809L

#include "net.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <regex.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <lcm/lcm.h>

#include "auth.h"
#include "util.h"
#include "wire.h"

/* every error of this file: a message in err, -1 */
#define fail(err, errlen, ...) dkf_failf(err, errlen, -1, __VA_ARGS__)

#define DKF_NET_QUEUE 4096 /* messages a subscription may queue */
#define DKF_NET_RCVBUF (4 << 20) /* direct receive: the socket buffer asked for */

/* Split ports (dkf_net_split): lane 0 the URL's port P, lane 1 (P + 1) the
 * node messages, lane 2 + i (P + 2 + i) node i's measurements. */
#define LANE_NODE 1
#define LANE_MEAS 2
#define LANES (LANE_MEAS + DKF_NET_MAX_NODES)

struct dkf_net {
    lcm_t *lcm;            /* the URL's instance (lane 0) */
    lcm_t *lane[LANES];    /* split: an instance per lane, opened when first used */
    unsigned char read_lane[LANES]; /* split: a subscription reads this lane */
    int split;
    int scope;             /* DKF_NET_HOST or DKF_NET_LAN: how the lanes are opened */
    char url[128];         /* the URL, for the lanes' (split) */
    dkf_auth_t *auth;      /* NULL: unauthenticated (dkf_net_set_auth) */
    unsigned char *out;    /* message + trailer being published (auth only) */
    size_t out_cap;
    int subs;              /* number of subscriptions (bounded below) */
    struct sub {
        dkf_net_t *net;
        dkf_net_handler_t fn;
        void *user;
        int lane;          /* direct: the lane it reads */
        regex_t re;        /* direct: the anchored pattern (LCM's matching) */
    } sub[DKF_NET_MAX_NODES + 16]; /* dkf-net-local: one per node agent, the centre's, the sim's */
    /* direct receive (dkf_net_direct): a socket per lane read */
    int direct;
    int rx_fd[LANES];      /* valid where rx_open */
    unsigned char rx_open[LANES];
    int rx_next;           /* the lane to read first (round robin) */
    dkf_net_rx_t rx;
    unsigned char rx_buf[65536]; /* one datagram (UDP's largest: 65507) */
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

/* Checks the options after '?': ttl must appear exactly once, equal to 0,
 * in every scope (--lan's one hop is dkf_net_lcm_url's, never the URL's). */
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
                            "this host; for several hosts give --lan, which sends one hop: "
                            "docs/guide/network.md, Several hosts)", url);
        }
        opt = end ? end + 1 : NULL;
    }
    if (nttl != 1)
        return fail(err, errlen, "%s: refused: a udpm URL must say ttl=0 exactly once", url);
    return 0;
}

int dkf_net_check_url(const char *url, char *err, size_t errlen)
{
    return dkf_net_check_url_scope(url, DKF_NET_HOST, err, errlen);
}

int dkf_net_check_url_scope(const char *url, int scope, char *err, size_t errlen)
{
    const char *host, *q, *colon, *hend;
    if (url == NULL) return fail(err, errlen, "(null): refused: no LCM URL");
    if (scope != DKF_NET_HOST && scope != DKF_NET_LAN)
        return fail(err, errlen, "%s: refused: unknown scope %d", url, scope);
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

int dkf_net_lcm_url(const char *url, int scope, char *out, size_t outlen, char *err,
                    size_t errlen)
{
    const char *opt;
    if (dkf_net_check_url_scope(url, scope, err, errlen) != 0) return -1;
    if (strlen(url) >= outlen) return fail(err, errlen, "%s: URL too long", url);
    strcpy(out, url);
    if (scope != DKF_NET_LAN || (opt = strchr(out, '?')) == NULL) return 0;
    /* the one "ttl=0" option (checked above) becomes ttl=1: one hop */
    ++opt;
    while (strncmp(opt, "ttl=", 4) != 0) opt = strchr(opt, '&') + 1;
    out[opt - out + 4] = '1';
    return 0;
}

dkf_net_t *dkf_net_open(const char *url, char *err, size_t errlen)
{
    return dkf_net_open_scope(url, DKF_NET_HOST, err, errlen);
}

dkf_net_t *dkf_net_open_scope(const char *url, int scope, char *err, size_t errlen)
{
    dkf_net_t *net;
    char lcm_url[sizeof net->url];
    if (dkf_net_lcm_url(url, scope, lcm_url, sizeof lcm_url, err, errlen) != 0) return NULL;
    net = calloc(1, sizeof *net);
    if (net == NULL) {
        fail(err, errlen, "%s: out of memory", url);
        return NULL;
    }
    net->lcm = lcm_create(lcm_url);
    if (net->lcm == NULL) {
        free(net);
        fail(err, errlen, "%s: cannot open LCM (is there a multicast route? docs/guide/network.md)",
             url);
        return NULL;
    }
    net->lane[0] = net->lcm;
    net->scope = scope;
    snprintf(net->url, sizeof net->url, "%s", url);
    return net;
}

/* The port of a udpm URL (LCM's default 7667 when it names none), and in
 * *glen the length of its group. */
static long udpm_port(const char *url, size_t *glen)
{
    const char *host = url + 7, *q = strchr(host, '?');
    const char *hend = q ? q : host + strlen(host), *colon;
    colon = memchr(host, ':', (size_t)(hend - host));
    *glen = (size_t)((colon ? colon : hend) - host);
    return colon != NULL ? parse_dec(colon + 1, (size_t)(hend - colon - 1), 1, 65535) : 7667;
}

int dkf_net_split(dkf_net_t *net, char *err, size_t errlen)
{
    size_t glen;
    if (strncmp(net->url, "udpm://", 7) != 0 || strlen(net->url) + 2 >= sizeof net->url)
        return fail(err, errlen, "%s: split ports need a udpm:// URL of under 120 characters",
                    net->url);
    if (net->subs > 0) return fail(err, errlen, "split ports: set before any subscription");
    if (udpm_port(net->url, &glen) + LANES > 65535)
        return fail(err, errlen, "%s: split ports need the port + %d to stay below 65536",
                    net->url, LANES);
    net->split = 1;
    return 0;
}

int dkf_net_direct(dkf_net_t *net, char *err, size_t errlen)
{
    if (strncmp(net->url, "udpm://", 7) != 0)
        return fail(err, errlen, "%s: direct receive needs a udpm:// URL", net->url);
    if (net->subs > 0) return fail(err, errlen, "direct receive: set before any subscription");
    net->direct = 1;
    return 0;
}

dkf_net_rx_t dkf_net_rx(const dkf_net_t *net)
{
    dkf_net_rx_t rx = net->rx;
    rx.direct = net->direct;
    return rx;
}

/* The lane of a channel or subscription pattern: 0 unless split; -1 for a
 * pattern over several nodes' measurements (split: no single lane). */
static int lane_of(const dkf_net_t *net, const char *channel)
{
    const char *m;
    long i;
    if (!net->split) return 0;
    if (strstr(channel, "_NODE_") != NULL) return LANE_NODE;
    if ((m = strstr(channel, "_MEAS_")) == NULL) return 0;
    i = parse_dec(m + 6, strlen(m + 6), 0, DKF_NET_MAX_NODES - 1);
    return i < 0 ? -1 : LANE_MEAS + (int)i;
}

/* The instance of a lane, opened on first use (split): the URL with the
 * lane's port, checked again and opened as dkf_net_open_scope opens the
 * URL (its options, its ttl among them, are the URL's). NULL if LCM cannot
 * open it. */
static lcm_t *lane_lcm(dkf_net_t *net, int lane)
{
    char url[sizeof net->url + 8], lcm_url[sizeof url], err[DKF_NET_ERR_LEN];
    const char *q = strchr(net->url, '?');
    size_t glen;
    long port;
    if (net->lane[lane] != NULL) return net->lane[lane];
    port = udpm_port(net->url, &glen);
    snprintf(url, sizeof url, "%s%.*s:%ld%s", "udpm://", (int)glen, net->url + 7, port + lane,
             q ? q : ""); /* the URL's options: its ttl */
    if (dkf_net_lcm_url(url, net->scope, lcm_url, sizeof lcm_url, err, sizeof err) != 0)
        return NULL;
    net->lane[lane] = lcm_create(lcm_url);
    return net->lane[lane];
}

void dkf_net_close(dkf_net_t *net)
{
    int l;
    if (net == NULL) return;
    for (l = 0; l < LANES; ++l)
        if (net->rx_open[l]) close(net->rx_fd[l]);
    for (l = 0; net->direct && l < net->subs; ++l) regfree(&net->sub[l].re);
    for (l = 1; l < LANES; ++l)
        if (net->lane[l] != NULL) lcm_destroy(net->lane[l]);
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
    const size_t t = dkf_auth_trailer_len(net->auth);
    if (net->out_cap < len + t) {
        unsigned char *p = realloc(net->out, len + t);
        if (p == NULL) return NULL;
        net->out = p;
        net->out_cap = len + t;
    }
    memcpy(net->out, data, len);
    return dkf_auth_sign(net->auth, channel, data, len, net->out + len) == 0 ? net->out : NULL;
}

int dkf_net_publish(dkf_net_t *net, const char *channel, const void *data, size_t len)
{
    const int lane = lane_of(net, channel);
    lcm_t *lcm = lane < 0 ? NULL : lane_lcm(net, lane);
    const size_t t = net->auth != NULL ? dkf_auth_trailer_len(net->auth) : 0;
    if (len > 0x7fffffffu - t || lcm == NULL) return -1;
    if (net->auth != NULL) {
        if ((data = signed_copy(net, channel, data, len)) == NULL) return -1;
        len += t;
    }
    return lcm_publish(lcm, channel, data, (unsigned int)len) == 0 ? 0 : -1;
}

/* Hands a message to its handler; with authentication only an accepted
 * one, without its trailer (the others are counted by dkf_auth_verify). */
static void deliver(const struct sub *s, const char *channel, const void *data, size_t len,
                    int64_t recv_utime)
{
    dkf_net_from_t from = {0, -1, -1};
    if (s->net->auth != NULL &&
        dkf_auth_verify(s->net->auth, channel, data, len, &len, &from) != DKF_AUTH_ACCEPT)
        return;
    s->fn(channel, &from, data, len, recv_utime, s->user);
}

/* LCM's handler: deliver, with LCM's receive time (CLOCK_REALTIME) on
 * dkf_net_now_us's clock (clock.h: its test offset). */
static void dispatch(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    deliver(user, channel, rbuf->data, rbuf->data_size,
            rbuf->recv_utime + dkf_net_clock_offset_us());
}

/* Direct: the socket of a lane, opened on first use as LCM opens its
 * receive socket (SO_REUSEADDR, bound to the lane's port on every address,
 * member of the URL's group, kernel receive times) but with a buffer of
 * DKF_NET_RCVBUF bytes (forced where the process may: it is the only
 * buffer; LCM adds a ring of its own). 0, or -1 if it cannot be opened. */
static int direct_socket(dkf_net_t *net, int lane)
{
    char group[16];
    size_t glen;
    const long port = udpm_port(net->url, &glen) + lane;
    struct sockaddr_in addr;
    struct ip_mreq mreq;
    int fd, one = 1, size = DKF_NET_RCVBUF, got = 0;
    socklen_t sl = sizeof got;
    if (net->rx_open[lane]) return 0;
    if (glen >= sizeof group) return -1;
    memcpy(group, net->url + 7, glen);
    group[glen] = '\0';
    memset(&mreq, 0, sizeof mreq);
    memset(&addr, 0, sizeof addr);
    if (inet_pton(AF_INET, group, &mreq.imr_multiaddr) != 1) return -1;
    mreq.imr_interface.s_addr = htonl(INADDR_ANY);
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_ANY);
    addr.sin_port = htons((uint16_t)port);
    if ((fd = socket(AF_INET, SOCK_DGRAM, 0)) < 0) return -1;
    if (setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0 ||
        setsockopt(fd, SOL_SOCKET, SO_TIMESTAMP, &one, sizeof one) != 0 ||
        bind(fd, (const struct sockaddr *)&addr, sizeof addr) != 0 ||
        setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof mreq) != 0) {
        close(fd);
        return -1;
    }
    (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &size, sizeof size);
    if (getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &got, &sl) == 0 && got < size)
        (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &size, sizeof size);
    sl = sizeof got;
    if (getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &got, &sl) == 0 && got > 0)
        net->rx.rcvbuf = (unsigned long)got;
    net->rx_fd[lane] = fd;
    net->rx_open[lane] = 1;
    return 0;
}

/* The kernel's receive time of a datagram (SO_TIMESTAMP, as LCM reports
 * it), or now if the message carries none, on dkf_net_now_us's clock. */
static int64_t recv_time(struct msghdr *mh)
{
    struct cmsghdr *c;
    struct timeval tv;
    for (c = CMSG_FIRSTHDR(mh); c != NULL; c = CMSG_NXTHDR(mh, c))
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMP &&
            c->cmsg_len >= CMSG_LEN(sizeof tv)) {
            memcpy(&tv, CMSG_DATA(c), sizeof tv);
            return (int64_t)tv.tv_sec * 1000000 + (int64_t)tv.tv_usec +
                   dkf_net_clock_offset_us();
        }
    return dkf_net_now_us();
}

/* Direct: reads one datagram of a lane, if one is waiting, and delivers
 * its message to every subscription of the lane whose pattern matches.
 * 1 delivered, 2 read but dropped (counted in net->rx), 0 none, -1 error. */
static int read_one(dkf_net_t *net, int lane)
{
    union {
        struct cmsghdr h;
        char b[CMSG_SPACE(sizeof(struct timeval))];
    } ctl;
    struct iovec iov;
    struct msghdr mh;
    dkf_wire_msg_t m;
    dkf_wire_verdict_t v;
    ssize_t got;
    int64_t t;
    int i, hit = 0;
    iov.iov_base = net->rx_buf;
    iov.iov_len = sizeof net->rx_buf;
    memset(&mh, 0, sizeof mh);
    mh.msg_iov = &iov;
    mh.msg_iovlen = 1;
    mh.msg_control = ctl.b;
    mh.msg_controllen = sizeof ctl.b;
    got = recvmsg(net->rx_fd[lane], &mh, MSG_DONTWAIT);
    if (got < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR ? 0 : -1;
    ++net->rx.datagrams;
    t = recv_time(&mh);
    v = (mh.msg_flags & MSG_TRUNC) ? DKF_WIRE_BAD : dkf_wire_parse(net->rx_buf, (size_t)got, &m);
    if (v != DKF_WIRE_OK) {
        if (v == DKF_WIRE_FRAGMENT) ++net->rx.fragments;
        else ++net->rx.malformed;
        return 2;
    }
    for (i = 0; i < net->subs; ++i)
        if (net->sub[i].lane == lane && regexec(&net->sub[i].re, m.channel, 0, NULL, 0) == 0) {
            deliver(&net->sub[i], m.channel, m.data, m.len, t);
            hit = 1;
        }
    if (!hit) ++net->rx.unmatched;
    return hit ? 1 : 2;
}

/* Direct: one message of the lanes read (round robin over them), waiting
 * up to timeout_ms; at most DKF_NET_DROP_BUDGET dropped datagrams are read
 * before the clock is looked at again, so a flood cannot hold the caller
 * past its timeout. 1, 0 (timeout) or -1. */
#define DKF_NET_DROP_BUDGET 1024
static int handle_direct(dkf_net_t *net, int timeout_ms)
{
    struct pollfd fd[LANES];
    int lane[LANES], n = 0, l, i, r, budget = DKF_NET_DROP_BUDGET;
    const int64_t end = dkf_net_mono_us() + (int64_t)(timeout_ms > 0 ? timeout_ms : 0) * 1000;
    int64_t left;
    for (l = 0; l < LANES; ++l)
        if (net->rx_open[l]) {
            fd[n].fd = net->rx_fd[l];
            fd[n].events = POLLIN;
            lane[n++] = l;
        }
    for (;;) {
        int dropped = 0;
        for (i = 0; i < n; ++i) {
            const int at = (net->rx_next + i) % n;
            r = read_one(net, lane[at]);
            if (r < 0) return -1;
            if (r == 1) {
                net->rx_next = (at + 1) % n;
                return 1;
            }
            dropped |= r == 2;
        }
        if (dropped && --budget > 0) continue;
        left = end - dkf_net_mono_us();
        if (left <= 0) return 0;
        if (!dropped && poll(fd, (nfds_t)n, (int)((left + 999) / 1000)) < 0 && errno != EINTR)
            return -1;
    }
}

/* Direct: s (filled but for its pattern) becomes the next subscription:
 * LCM anchors a pattern at both ends, so "^(" pattern ")$" in POSIX
 * extended syntax (dkf's patterns: names and [0-9]+). 0 or -1. */
static int subscribe_direct(dkf_net_t *net, struct sub *s, const char *channel_regex)
{
    char pat[DKF_WIRE_MAX_CHANNEL * 4 + 8];
    if (s->lane < 0 || strlen(channel_regex) > sizeof pat - 5 || direct_socket(net, s->lane) != 0)
        return -1;
    snprintf(pat, sizeof pat, "^(%s)$", channel_regex);
    if (regcomp(&s->re, pat, REG_EXTENDED | REG_NOSUB) != 0) return -1;
    net->read_lane[s->lane] = 1;
    ++net->subs;
    return 0;
}

int dkf_net_subscribe(dkf_net_t *net, const char *channel_regex, dkf_net_handler_t handler,
                      void *user)
{
    struct sub *s;
    lcm_subscription_t *h;
    const int lane = lane_of(net, channel_regex);
    lcm_t *lcm = lane < 0 || net->direct ? NULL : lane_lcm(net, lane);
    if (net->subs >= (int)(sizeof net->sub / sizeof net->sub[0])) return -1;
    s = &net->sub[net->subs];
    s->net = net;
    s->fn = handler;
    s->user = user;
    s->lane = lane;
    if (net->direct) return subscribe_direct(net, s, channel_regex);
    if (lcm == NULL) return -1;
    h = lcm_subscribe(lcm, channel_regex, dispatch, s);
    if (h == NULL) return -1;
    net->read_lane[lane] = 1;
    /* LCM drops messages beyond a subscription's queue (30 by default); a
     * burst of one message per node at every step must never be cut. */
    lcm_subscription_set_queue_capacity(h, DKF_NET_QUEUE);
    ++net->subs;
    return 0;
}

/* Split: one message of the first lane that has one ready (a poll of
 * every lane read, 0 ms), else, after waiting up to timeout_ms for any of
 * their sockets, of the first that has one then. */
static int handle_lanes(dkf_net_t *net, int timeout_ms)
{
    struct pollfd fd[LANES];
    int lane[LANES], n = 0, l, pass, r;
    for (l = 0; l < LANES; ++l)
        if (net->read_lane[l]) {
            fd[n].fd = lcm_get_fileno(net->lane[l]);
            fd[n].events = POLLIN;
            lane[n++] = l;
        }
    for (pass = 0; pass < 2; ++pass) {
        for (l = 0; l < n; ++l) {
            r = lcm_handle_timeout(net->lane[lane[l]], 0);
            if (r != 0) return r < 0 ? -1 : 1;
        }
        if (pass == 1 || timeout_ms <= 0) break; /* (with no lane read, poll sleeps) */
        r = poll(fd, (nfds_t)n, timeout_ms);
        if (r <= 0) return r < 0 && errno != EINTR ? -1 : 0;
    }
    return 0;
}

int dkf_net_handle(dkf_net_t *net, int timeout_ms)
{
    int r;
    if (net->direct) return handle_direct(net, timeout_ms);
    if (net->split) return handle_lanes(net, timeout_ms);
    r = lcm_handle_timeout(net->lcm, timeout_ms < 0 ? 0 : timeout_ms);
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
