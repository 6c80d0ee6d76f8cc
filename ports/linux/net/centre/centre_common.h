/*
 * centre_common.h - what both fusion centres (fusion.c, wfusion_centre.c)
 * keep and do besides their fusion (host side): the scenario's sizes, the
 * LCM side (node messages in on <prefix>_NODE_<i>, fused steps out on
 * <prefix>_FUSED, the status on <prefix>_STATUS), the runtime of
 * fc_runtime.h with its deadlines and linger, the heartbeat, the journal
 * and the result document's record (fusion_result.h). A centre embeds a
 * dkf_net_centre_t and adds its estimates.
 */
#ifndef DKF_NET_CENTRE_COMMON_H
#define DKF_NET_CENTRE_COMMON_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <jansson.h>

#include "fc_runtime.h"
#include "fusion_result.h"
#include "net.h"
#include "report.h"
#include "scenario.h"

typedef struct {
    const char *who;              /* "fusion" or "wfusion": names the centre in notes */
    dkf_net_t *net;               /* NULL: no transport (nothing sent or subscribed) */
    const dkf_scenario_t *s;
    size_t l, n;                  /* nodes, state dimension */
    long N;                       /* steps */
    char prefix[DKF_NET_CHAN_LEN / 2];
    char chan_out[DKF_NET_CHAN_LEN];
    int64_t model_id, deadline_us;
    dkf_fcr_t *rt;                /* ring, epochs, deadlines, checkpoints, linger */
    FILE *journal;                /* one JSON line per computed step (NULL: none) */
    dkf_diffkf_msg_t in, in_prev; /* the message being decoded */
    dkf_net_counts_t c;
    int64_t seq, last_beat;
} dkf_net_centre_t;

/* The sizes, channels and model id of scenario s; deadline_us <= 0: the
 * default DKF_NET_DEADLINE_US. No runtime yet. */
void dkf_net_centre_init(dkf_net_centre_t *c, const char *who, dkf_net_t *net,
                         const dkf_scenario_t *s, const char *prefix, int64_t deadline_us);
/* The runtime over ops (user: the centre) with checkpoints of ckpt_size
 * bytes and a linger of two deadlines, at least DKF_NET_LINGER_US; then
 * the subscription to <prefix>_NODE_[0-9]+ (none without a transport).
 * 0, or -1 with err. */
int dkf_net_centre_start(dkf_net_centre_t *c, const dkf_fcr_ops_t *ops, void *user,
                         size_t ckpt_size, char *err, size_t errlen);
/* DKF_NET_RUNNING, DONE or FAILED as the runtime says. */
int dkf_net_centre_state(const dkf_net_centre_t *c);
/* The counters synced, then the status on <prefix>_STATUS (with a transport). */
void dkf_net_centre_report(dkf_net_centre_t *c);
/* Deadlines, then the report every heartbeat_us (<= 0: DKF_NET_HEARTBEAT_US). */
void dkf_net_centre_tick(dkf_net_centre_t *c, int64_t mono_us, int64_t heartbeat_us);
/* The journal's header into f (NULL: no journal); f stays the caller's. */
void dkf_net_centre_journal(dkf_net_centre_t *c, FILE *f);
/* A journal line of step st (NULL: no journal), for the centre's estimates,
 * then written and released by dkf_net_centre_journal_write. */
json_t *dkf_net_centre_journal_line(const dkf_net_centre_t *c, const dkf_fcr_step_t *st,
                                    int published);
void dkf_net_centre_journal_write(dkf_net_centre_t *c, const dkf_fcr_step_t *st, json_t *line);
/* Step st as a fused_t on <prefix>_FUSED from the centre's records (N x n,
 * N x n x n: row st->k - 1 is published). 0 or -1. */
int dkf_net_centre_publish(dkf_net_centre_t *c, const dkf_fcr_step_t *st, const double *xf,
                           const double *Pf, const double *xp, const double *Pp,
                           int64_t *utime);
/* The result document with the centre's outputs (reference stolen). */
json_t *dkf_net_centre_result(const dkf_net_centre_t *c, json_t *outputs);
/* len reals into doubles. */
void dkf_net_centre_to_double(double *dst, const dkf_real_t *src, size_t len);

#endif /* DKF_NET_CENTRE_COMMON_H */
