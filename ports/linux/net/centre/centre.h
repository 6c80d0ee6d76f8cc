/*
 * centre.h - the fusion centres as objects that live on one dkf_net_t, as
 * the agents of agents.h do (host side): the Difference KF's (fusion.c) and
 * seed 002's weighted fusion (wfusion_centre.c), both over the transport-free
 * runtime of fc_runtime.h. The timing of a run is agents.h's.
 */
#ifndef DKF_NET_CENTRE_H
#define DKF_NET_CENTRE_H

#include <stdint.h>
#include <stdio.h>

#include <jansson.h>

#include "fc_runtime.h"
#include "net.h"
#include "report.h"
#include "scenario.h"

#define DKF_NET_DEADLINE_US 1000000 /* default fusion deadline per step */
#define DKF_NET_WINDOW DKF_FCR_WINDOW /* steps the fusion centre buffers ahead (it
                                         follows the arrivals: docs/guide/network.md) */
#define DKF_NET_LINGER_US 1000000  /* after step N, a node still sending is waited for
                                       this long, or two deadlines if longer */
#define DKF_NET_CKPT DKF_FCR_CKPT  /* published steps a late payload can still revise */

/* ---- fusion centre ------------------------------------------------------------ */

typedef struct dkf_net_fusion dkf_net_fusion_t;

/* Fusion centre for scenario s: subscribes <prefix>_NODE_[0-9]+ and sets up
 * the core's dkf_diffkf_fc_t (start included). deadline_us: how long after
 * a step opens (the first payload of it or of a later step) it may wait for
 * the rest (0: the default). NULL + err (naming the core call and fault). */
dkf_net_fusion_t *dkf_net_fusion_create(dkf_net_t *net, const dkf_scenario_t *s,
                                        const char *prefix, int64_t deadline_us, char *err,
                                        size_t errlen);
void dkf_net_fusion_free(dkf_net_fusion_t *fu);
/* The core's steady gain (dkf_diffkf_fc_set_steady, docs/design/diffkf-fusion.md
 * §11) with tolerance tol; the result's counters.steady_gain_steps counts
 * the steps that reused it. -1 for a tol the core refuses, or a
 * weighted-fusion centre (it has no gain recursion to settle). */
int dkf_net_fusion_steady(dkf_net_fusion_t *fu, double tol);
/* Appends one JSON line per computed step to f (first computation and
 * every replay; flushed, so the results survive a killed process), after a
 * header line; f stays the caller's (NULL: no journal). docs/guide/network.md. */
void dkf_net_fusion_journal(dkf_net_fusion_t *fu, FILE *f);
/* Deadlines (publishes overdue steps DEGRADED) and the heartbeat. */
void dkf_net_fusion_tick(dkf_net_fusion_t *fu, int64_t mono_us, int64_t heartbeat_us);
void dkf_net_fusion_report(dkf_net_fusion_t *fu);
/* RUNNING until step N is published, then DONE. */
int dkf_net_fusion_state(const dkf_net_fusion_t *fu);
/* Last published step (0: none). */
long dkf_net_fusion_k(const dkf_net_fusion_t *fu);
const dkf_net_counts_t *dkf_net_fusion_counts(const dkf_net_fusion_t *fu);
/* The run so far as a JSON document (new reference; docs/guide/network.md):
 * k, outputs.fused.{xf,xp,Pf,Pp}, status, contributors, latency_us, counters. */
json_t *dkf_net_fusion_result(const dkf_net_fusion_t *fu);

/* ---- the weighted fusion centre (seed 002; wfusion_centre.c) ------------------------ */

/* dkf_net_fusion_create gives a scenario of seed 002's weighted fusion
 * (the layout DKF_SCN_LAYOUT_WFCASES; model: wf_model.h) to this centre, and every
 * dkf_net_fusion_* call above to its dkf_net_wfusion_* twin, so dkf-fusion
 * and dkf-net-local run either centre. The same runtime (fc_runtime.h);
 * step k: every gain and P_ij from the model, the payloads' x_i(k|k) fused
 * with scalar and matrix weights over the nodes present. net == NULL: no
 * transport (a test feeds dkf_fcr_receive through dkf_net_wfusion_runtime
 * and reads the result document). */
typedef struct dkf_net_wfusion dkf_net_wfusion_t;
dkf_net_wfusion_t *dkf_net_wfusion_create(dkf_net_t *net, const dkf_scenario_t *s,
                                          const char *prefix, int64_t deadline_us, char *err,
                                          size_t errlen);
void dkf_net_wfusion_free(dkf_net_wfusion_t *w);
void dkf_net_wfusion_journal(dkf_net_wfusion_t *w, FILE *f);
void dkf_net_wfusion_tick(dkf_net_wfusion_t *w, int64_t mono_us, int64_t heartbeat_us);
void dkf_net_wfusion_report(dkf_net_wfusion_t *w);
int dkf_net_wfusion_state(const dkf_net_wfusion_t *w);
long dkf_net_wfusion_k(const dkf_net_wfusion_t *w);
const dkf_net_counts_t *dkf_net_wfusion_counts(const dkf_net_wfusion_t *w);
dkf_fcr_t *dkf_net_wfusion_runtime(dkf_net_wfusion_t *w);
/* k, outputs.wfusion.{x0, P0, xp, Pp, s0, PS0, w, used, A_unique,
 * w_unique}, and the runtime's record (fusion_result.h). */
json_t *dkf_net_wfusion_result(const dkf_net_wfusion_t *w);

#endif /* DKF_NET_CENTRE_H */
