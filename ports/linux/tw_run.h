/*
 * tw_run.h - the seed-003 filters (dkf/tw.h: Talebi-Werner Algorithms 1, 2,
 * 3) over a steps-layout network scenario, with the whole graph simulated
 * in process by dkf_tw_net_* (host side, used by dkf-run).
 *
 * The graph comes from graph.edges (graph.neighbours_incl_self is
 * informational); alpha_diffusion[_sparse] and W_consensus[_sparse] from
 * the file or, when absent, the library's uniform alpha = 1/|N_l| and
 * Metropolis W (note §2's defaults). Steps start at n = 1.
 *
 * Recorded per step under the vectors' names (alg2/alg3: one entry per
 * node, [N][...]):
 *   alg1: x P z phi Phi phi_post Phi_post S G
 *   alg2: x P z psi Q phi_post Phi_post S G
 *   alg3: x P z Ups vphi psi Ploc phi_post Phi_post S G
 * and, when the file has truth, metrics per step (extra keys):
 *   mse_x[i], mse_z[i]  mean over nodes of the squared error of component i
 *                       (z against z_prev: the step that takes y_n estimates
 *                       z_{n-1})
 *   nees                mean over nodes of e^T P^-1 e / n
 *   spread_x[i]         RMS over nodes of x_l,i - mean_l x_l,i
 *   range_x[i]          max over nodes of x_l,i minus the min
 * and for alg2/alg3 the gap to Algorithm 1 run alongside on the same data:
 *   gap_x, gap_z        mean over nodes of ||x_l - x_alg1||^2, ||z_l - z_alg1||^2
 *   gap_x_rel_max       max over nodes of ||x_l - x_alg1|| / ||x_alg1||
 *   gap_x_vec_rule      max over nodes of max_i |x_l,i - x_alg1,i| / max(1, max_i |x_alg1,i|)
 *                       (the golden-vector comparison rule with Alg 1 as reference)
 */
#ifndef DKF_HOST_TW_RUN_H
#define DKF_HOST_TW_RUN_H

#include <stddef.h>

#include <jansson.h>

#include "scenario.h"
#include "util.h"

typedef struct {
    int alg;        /* 1, 2, 3 */
    long eta;       /* alg 3: >= 0 overrides the file's eta; -1: the file's */
    int no_nodes;   /* 1: record only the metrics, not the per-node arrays */
} dkf_twrun_opts_t;

typedef struct {
    size_t N, E, steps;
    size_t eta;                   /* alg 3 */
    int W_default, alpha_default; /* 1: weights computed (not in the file) */
    double reals_per_node_step;   /* broadcast by a node per step (alg 1: sent to the centre) */
    double broadcasts_per_node_step;
    double rmse_x, rmse_z;        /* root mean over steps, nodes, components (NaN: no truth) */
    double gap_x_rel_max;         /* alg 2/3: max over steps and nodes */
    double gap_x_vec_rule;        /* alg 2/3: max over steps, nodes of the vector rule */
} dkf_twrun_summary_t;

/* "tw1".."tw3" -> 1..3; 0 if unknown. */
int dkf_twrun_alg(const char *name);

/* Runs every step; series receives the per-step lists (NULL: nothing).
 * Returns DKF_EXIT_OK or DKF_EXIT_USAGE / DKF_EXIT_RUN with a one-line
 * message in err. */
int dkf_twrun(const dkf_scenario_t *s, const dkf_twrun_opts_t *o, json_t *series,
              dkf_twrun_summary_t *sum, char *err, size_t errlen);

#endif /* DKF_HOST_TW_RUN_H */
