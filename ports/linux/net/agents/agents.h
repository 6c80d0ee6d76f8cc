/*
 * agents.h - the simulator and a node as objects that live on one
 * dkf_net_t (host side; the fusion centres, objects of the same kind, are
 * centre.h's).
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

#include "codec.h"
#include "net.h"
#include "registry.h"
#include "report.h"
#include "scenario.h"

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
