/*
 * agents.h - the simulator, a node and the fusion centre as objects that
 * live on one dkf_net_t (host side).
 *
 * Each agent subscribes its channels when created and does its work in the
 * LCM handlers, so any mix of agents can share one transport: the programs
 * dkf-sim, dkf-node and dkf-fusion run one agent each over UDP multicast;
 * the unit tests run all of them in one process over memq://. Each agent
 * has a tick (heartbeat, deadlines) that the owner calls between
 * dkf_net_handle calls with the monotonic time.
 *
 * Timing (docs/guide/network.md): the simulator publishes y^i_j for every sensor
 * i at j = 1..N+1. Node i starts its local Difference KF on y^i_1 (or, late
 * or restarted, on the first y^i_{k0} it gets) and, on y^i_{k+1}, completes
 * step k and publishes {x^i_{k|k}, x^i_{k|k-1}} with its previous step's
 * pair. The fusion centre fuses step k once every node's payload of step k
 * is there or given up on (the node sent a later step's, or fell silent), or,
 * when the step's deadline passes, publishes it DEGRADED: the centralized DKF
 * given the nodes' rows it could rebuild. A payload of a published step that
 * arrives later (within DKF_NET_CKPT steps) rolls the fusion centre back to a
 * checkpoint and replays (every replayed step is published again).
 */
#ifndef DKF_NET_AGENTS_H
#define DKF_NET_AGENTS_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <jansson.h>

#include "codec.h"
#include "fc_runtime.h"
#include "net.h"
#include "registry.h"
#include "scenario.h"

#define DKF_NET_HEARTBEAT_US 500000 /* default heartbeat period */
#define DKF_NET_DEADLINE_US 1000000 /* default fusion deadline per step */
#define DKF_NET_WINDOW DKF_FCR_WINDOW /* steps the fusion centre buffers ahead (it
                                         follows the arrivals: docs/guide/network.md) */
#define DKF_NET_LINGER_US 1000000  /* after step N, a node still sending is waited for
                                       this long, or two deadlines if longer */
#define DKF_NET_CKPT DKF_FCR_CKPT  /* published steps a late payload can still revise */

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

/* ---- node ------------------------------------------------------------------- */

typedef struct dkf_net_node dkf_net_node_t;

/* What a node does differently from the normal run (dkf-node's test
 * flags; docs/design/network.md, "Faults"). All zero: the normal node. */
typedef struct {
    double drop_pct;    /* drop this % of the outgoing messages */
    double dup_pct;     /* send this % twice */
    double reorder_pct; /* hold this % back until after the next message */
    uint64_t seed;      /* the draws (three per message) are reproducible from it */
    long exit_at;       /* > 0: stop dead at step exit_at, before its message */
    long join_at;       /* start on the first measurement y_j with j >= join_at */
    long epoch;         /* epoch of the first start (a restarted process: previous + 1) */
} dkf_net_faults_t;

/* Node `id` of scenario s (which must outlive the node and have passed
 * dkf_net_check_scenario) running filter f's node role (registry.h; the
 * dkf family's: dkf_registry_find("dkf")): subscribes <prefix>_MEAS_<id>.
 * NULL + err (also when f's family has no node role). */
dkf_net_node_t *dkf_net_node_create(dkf_net_t *net, const dkf_scenario_t *s,
                                    const dkf_filter_t *f, size_t id, const char *prefix,
                                    char *err, size_t errlen);
void dkf_net_node_free(dkf_net_node_t *nd);
/* Publishes a heartbeat if one is due (every heartbeat_us; 0: the default). */
void dkf_net_node_tick(dkf_net_node_t *nd, int64_t mono_us, int64_t heartbeat_us);
/* Publishes a status now (e.g. the final one). */
void dkf_net_node_report(dkf_net_node_t *nd);
/* DKF_NET_STARTING (no measurement yet), RUNNING, DONE (step N sent), FAILED. */
int dkf_net_node_state(const dkf_net_node_t *nd);
const char *dkf_net_node_error(const dkf_net_node_t *nd);
const dkf_net_counts_t *dkf_net_node_counts(const dkf_net_node_t *nd);
/* Sets the faults (before the first measurement). */
void dkf_net_node_faults(dkf_net_node_t *nd, const dkf_net_faults_t *fx);
/* 1 once --exit-at was reached (the process should end without a word). */
int dkf_net_node_exited(const dkf_net_node_t *nd);
/* The current epoch and its first step (0: not started). */
long dkf_net_node_epoch(const dkf_net_node_t *nd);
long dkf_net_node_k_start(const dkf_net_node_t *nd);
void dkf_net_node_fault_counts(const dkf_net_node_t *nd, int64_t *dropped, int64_t *duplicated,
                               int64_t *reordered);

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

/* ---- simulator ------------------------------------------------------------------ */

typedef struct dkf_net_sim dkf_net_sim_t;

/* Simulator for scenario s: publishes on <prefix>_MEAS_<i> and
 * <prefix>_TRUTH; listens to <prefix>_FUSED and <prefix>_STATUS. */
dkf_net_sim_t *dkf_net_sim_create(dkf_net_t *net, const dkf_scenario_t *s, const char *prefix,
                                  char *err, size_t errlen);
void dkf_net_sim_free(dkf_net_sim_t *sim);
/* Publishes every sensor's y_j and (if the scenario has it) x_j. 0 or -1. */
int dkf_net_sim_publish(dkf_net_sim_t *sim, long j);
/* The last measurement time to publish: N + 1. */
long dkf_net_sim_last(const dkf_net_sim_t *sim);
/* Largest fused step seen on <prefix>_FUSED or in the fusion centre's
 * status (its last published step; 0: none). */
long dkf_net_sim_fused_k(const dkf_net_sim_t *sim);
/* 1 when every node and the fusion centre has sent a status with the
 * simulator's model id and not FAILED; else 0 and, if why is given, a
 * one-line account of who is missing. */
int dkf_net_sim_ready(const dkf_net_sim_t *sim, char *why, size_t whylen);
/* Node i is not waited for by dkf_net_sim_ready (it may start late or
 * never). 0, or -1 if there is no node i. */
int dkf_net_sim_optional_node(dkf_net_sim_t *sim, size_t i);
/* 1 if some process reported FAILED or a different model id (why says which). */
int dkf_net_sim_trouble(const dkf_net_sim_t *sim, char *why, size_t whylen);
void dkf_net_sim_tick(dkf_net_sim_t *sim, int64_t mono_us, int64_t heartbeat_us);
void dkf_net_sim_report(dkf_net_sim_t *sim, int state);
const dkf_net_counts_t *dkf_net_sim_counts(const dkf_net_sim_t *sim);

#endif /* DKF_NET_AGENTS_H */
