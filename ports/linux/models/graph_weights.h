/*
 * graph_weights.h - a network scenario's mixing weights on its graph
 * (host side): the file's triplets or the library default, checked. The
 * seed-003 runner (tw_run.c) and the graph agents (net/tw_agent.c) bind
 * their weights through it, so the two cannot disagree.
 */
#ifndef DKF_HOST_GRAPH_WEIGHTS_H
#define DKF_HOST_GRAPH_WEIGHTS_H

#include <stddef.h>

#include "dkf/graph.h"
#include "scenario.h"

/* w (g->nnz, the CSR order of g) = the network's W (doubly = 1; default
 * Metropolis, dkf_graph_weights_metropolis) or alpha (doubly = 0; default
 * uniform), checked doubly / row stochastic and non-negative; *dflt = 1
 * when the file gave none. DKF_EXIT_OK, or DKF_EXIT_USAGE (an entry off
 * the graph, weights that fail the check, out of memory) / DKF_EXIT_RUN
 * (the default failed) with "FILE: KEY: problem" in err. */
int dkf_host_graph_weights_bind(const dkf_scenario_t *s, const dkf_graph_t *g, int doubly,
                           dkf_real_t *w, int *dflt, char *err, size_t errlen);

#endif /* DKF_HOST_GRAPH_WEIGHTS_H */
