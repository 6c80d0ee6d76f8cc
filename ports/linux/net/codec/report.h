/*
 * report.h - what every network process reports of itself (host side): its
 * counters and its status messages on <prefix>_STATUS (lcmtypes/status_t.lcm,
 * codec.h), every heartbeat period.
 */
#ifndef DKF_NET_REPORT_H
#define DKF_NET_REPORT_H

#include <stdint.h>

#include "codec.h"
#include "net.h"

#define DKF_NET_HEARTBEAT_US 500000 /* default heartbeat period */

/* Counters every agent keeps (published in its status messages). */
typedef struct {
    int64_t sent;      /* messages published (data, not status) */
    int64_t received;  /* data messages accepted */
    int64_t rejected;  /* data messages refused by validation */
    int64_t stale;     /* valid but late, duplicate or out of sequence */
    int64_t missed;    /* node: measurements never received (gaps); fusion: degraded steps */
    dkf_net_rejects_t why;
} dkf_net_counts_t;

/* Publishes a status message on <prefix>_STATUS. */
int dkf_net_publish_status(dkf_net_t *net, const char *prefix, const dkf_net_status_t *st);

#endif /* DKF_NET_REPORT_H */
