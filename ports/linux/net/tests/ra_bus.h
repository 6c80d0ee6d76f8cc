/*
 * ra_bus.h - an in-memory network for round agents (round_agent.h) in one
 * test process: a publication of node `from` reaches every other node of
 * from's graph row, in publication order; the clock is the caller's. A
 * node's deliveries can be held back (hold[i] = 1) and released later in
 * their order, as a receive queue that a descheduled process drains late.
 * Header-only (test helpers for test_round_agent and test_df_agent).
 */
#ifndef DKF_TEST_RA_BUS_H
#define DKF_TEST_RA_BUS_H

#include <stdlib.h>
#include <string.h>

#include "round_agent.h"

#define RA_BUS_MAX_NODES 64

typedef struct ra_msg {
    size_t from, to, len;
    unsigned char data[DKF_RA_MAX_MSG];
    struct ra_msg *next;
} ra_msg_t;

typedef struct ra_bus ra_bus_t;

/* The send callback's user data: one per node. */
typedef struct {
    ra_bus_t *bus;
    size_t id;
} ra_port_t;

struct ra_bus {
    size_t N;
    const size_t *row[RA_BUS_MAX_NODES]; /* node i's graph row (itself included) */
    size_t deg[RA_BUS_MAX_NODES];
    dkf_ra_t *agent[RA_BUS_MAX_NODES];   /* NULL: the node is not running */
    ra_port_t port[RA_BUS_MAX_NODES];
    unsigned char hold[RA_BUS_MAX_NODES]; /* 1: deliveries to the node wait (ra_bus_release) */
    ra_msg_t *head, *tail;
    ra_msg_t *held, *held_tail;          /* held deliveries, oldest first */
    unsigned long rejected;              /* deliveries an agent refused */
};

static int ra_bus_send(void *user, const void *data, size_t len)
{
    const ra_port_t *pt = (const ra_port_t *)user;
    ra_bus_t *b = pt->bus;
    size_t e;
    for (e = 0; e < b->deg[pt->id]; ++e) {
        ra_msg_t *m;
        if (b->row[pt->id][e] == pt->id) continue;
        if ((m = (ra_msg_t *)calloc(1, sizeof *m)) == NULL) return -1;
        memcpy(m->data, data, len);
        m->from = pt->id;
        m->to = b->row[pt->id][e];
        m->len = len;
        if (b->tail) b->tail->next = m;
        else b->head = m;
        b->tail = m;
    }
    return 0;
}

/* Options for node i: the bus's send, deadlines in microseconds. */
static dkf_ra_opts_t ra_bus_opts(ra_bus_t *b, size_t i, int64_t round_us, int64_t start_us,
                                 int64_t retry_us)
{
    dkf_ra_opts_t o;
    b->port[i].bus = b;
    b->port[i].id = i;
    o.send = ra_bus_send;
    o.user = &b->port[i];
    o.round_timeout_us = round_us;
    o.start_timeout_us = start_us;
    o.retry_us = retry_us;
    return o;
}

/* Delivers everything queued and polls every running agent, the clock
 * moving by tick per pass, until every agent is FINISHED or FAILED or the
 * clock reaches until. Returns the final time. */
static int64_t ra_bus_run(ra_bus_t *b, int64_t now, int64_t tick, int64_t until)
{
    size_t i;
    for (; now < until; now += tick) {
        int busy = 0;
        while (b->head != NULL) {
            ra_msg_t *m = b->head;
            b->head = m->next;
            if (b->head == NULL) b->tail = NULL;
            if (b->hold[m->to]) {
                m->next = NULL;
                if (b->held_tail) b->held_tail->next = m;
                else b->held = m;
                b->held_tail = m;
                continue;
            }
            if (b->agent[m->to] != NULL &&
                dkf_ra_receive(b->agent[m->to], (long)m->from, m->data, m->len, now) !=
                    DKF_NET_ACCEPT)
                ++b->rejected;
            free(m);
        }
        for (i = 0; i < b->N; ++i) {
            int st;
            if (b->agent[i] == NULL) continue;
            st = dkf_ra_poll(b->agent[i], now);
            if (st == DKF_RA_RUNNING || st == DKF_RA_LINGER) busy = 1;
        }
        if (!busy) break;
    }
    return now;
}

/* Node i's deliveries flow again: the held ones come first, before
 * everything queued since (deliveries to a node still held are held again). */
static inline void ra_bus_release(ra_bus_t *b, size_t i)
{
    b->hold[i] = 0;
    if (b->held == NULL) return;
    b->held_tail->next = b->head;
    if (b->head == NULL) b->tail = b->held_tail;
    b->head = b->held;
    b->held = b->held_tail = NULL;
}

#endif /* DKF_TEST_RA_BUS_H */
