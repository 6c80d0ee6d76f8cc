/*
 * df_agent.h - one node of seed 001's consensus network (dkf/dfnerts.h:
 * DF-DNERTSIF, DF-CKF and the joint-information variant) as an agent that
 * exchanges packets only with its neighbours (host side; dkf-tw-node
 * --filter df_dnertsif runs one over LCM, docs/guide/network.md "Graph filters
 * over LCM").
 *
 * The rounds are round_agent.h's: step k is T_p rounds; round 0's packet is
 * the node's prior information [y_pred | packed Y_pred] after its own
 * cubature time update and local statistics (dkf_dfnerts_node_local), each
 * round mixes the neighbours' packets with the node's row of W
 * (dkf_dfnerts_node_mix: the first round adds s times the node's own
 * contribution), and the last round commits (dkf_dfnerts_node_commit). The
 * packets travel as lcmtypes/tw_packet_t.lcm, kind INFO, every round the
 * same length DKF_DFNERTS_PKT_LEN(q).
 *
 * Exactness: with every packet received, a node computes exactly what
 * dkf_dfnerts_net_step computes for it (the same calls on the same packets
 * in row order: bit for bit; test_df_agent).
 *
 * A missing neighbour (given up after the round timeout, round_agent.h):
 * the node's own packet stands in for it, so the row still sums to 1 and
 * the mix stays an average (w_lj x_l); the step is recorded degraded with
 * the missing node. A node whose commit fails (e.g. Algorithm 3's mixed
 * joint covariance not positive definite: DKF_ERR_NOT_SPD) stops with the
 * status named and is left as before the step.
 */
#ifndef DKF_NET_DF_AGENT_H
#define DKF_NET_DF_AGENT_H

#include <stddef.h>

#include <jansson.h>

#include "dkf/dfnerts.h"
#include "registry.h"
#include "round_agent.h"
#include "scenario.h"

typedef struct dkf_df_agent dkf_df_agent_t;

/* Node id of the network case s (nonlinear cases layout) running filter f
 * (df_dnertsif, df_ckf or df_dnertsif_joint: the registry's check is run
 * first). NULL + a one-line err. s and f must outlive the agent. */
dkf_df_agent_t *dkf_df_agent_new(const dkf_filter_t *f, const dkf_scenario_t *s, size_t id,
                                 const dkf_ra_opts_t *o, char *err, size_t errlen);
void dkf_df_agent_free(dkf_df_agent_t *a);

/* Its rounds with the neighbours (start, receive, poll, state, counters). */
dkf_ra_t *dkf_df_agent_rounds(dkf_df_agent_t *a);
/* The node (its filter's posterior after the last committed step). */
const dkf_dfnerts_node_t *dkf_df_agent_node(const dkf_df_agent_t *a);
/* The 64-bit id every node of one run agrees on (the packets carry it). */
int64_t dkf_df_agent_model_id(const dkf_df_agent_t *a);

/* The result document: {node, filter, model_id, real, N, steps, Tp, scale,
 * neighbours[], k[], x[], Px[], d[], degraded[], missing[][], counters{}}. */
json_t *dkf_df_agent_result(const dkf_df_agent_t *a);

#endif /* DKF_NET_DF_AGENT_H */
