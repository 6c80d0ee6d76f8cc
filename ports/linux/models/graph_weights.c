/*
 * graph_weights.c - a network scenario's mixing weights (graph_weights.h).
 */
#include "graph_weights.h"

#include <stdlib.h>

#include "util.h"

int dkf_host_graph_weights_bind(const dkf_scenario_t *s, const dkf_graph_t *g, int doubly,
                           dkf_real_t *w, int *dflt, char *err, size_t errlen)
{
    const dkf_scn_network_t *net = s->net;
    const char *key = doubly ? net->W_key : net->alpha_key;
    const size_t cnt = doubly ? net->nW : net->nalpha;
    const size_t *rc = doubly ? net->W_rc : net->alpha_rc;
    const double *v = doubly ? net->W_v : net->alpha_v;
    dkf_status_t st;
    size_t t;
    *dflt = key == NULL;
    if (key == NULL) {
        st = doubly ? dkf_graph_weights_metropolis(w, g) : dkf_graph_weights_uniform(w, g);
        if (st != DKF_OK)
            return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: graph: default %s weights failed: %s",
                             s->file, doubly ? "Metropolis" : "uniform", dkf_status_str(st));
        return DKF_EXIT_OK;
    }
    {
        size_t *ri = malloc((cnt ? cnt : 1) * sizeof *ri), *ci = malloc((cnt ? cnt : 1) * sizeof *ci);
        dkf_real_t *vv = malloc((cnt ? cnt : 1) * sizeof *vv);
        if (ri == NULL || ci == NULL || vv == NULL) {
            free(ri), free(ci), free(vv);
            return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
        }
        for (t = 0; t < cnt; ++t) {
            size_t pos;
            ri[t] = rc[2 * t];
            ci[t] = rc[2 * t + 1];
            vv[t] = (dkf_real_t)v[t];
            if (dkf_graph_find(&pos, g, ri[t], ci[t]) != DKF_OK) {
                free(ri), free(ci), free(vv);
                return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                                 "%s: %s: entry (%zu, %zu) is not a link of graph.edges", s->file,
                                 key, rc[2 * t], rc[2 * t + 1]);
            }
        }
        st = dkf_graph_weights_from_triplets(w, g, ri, ci, vv, cnt);
        free(ri), free(ci), free(vv);
    }
    if (st == DKF_OK)
        st = doubly ? dkf_graph_check_doubly_stochastic(g, w)
                    : dkf_graph_check_row_stochastic(g, w);
    if (st != DKF_OK)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: %s: %s (%s)", s->file, key,
                         st == DKF_ERR_WEIGHTS ? (doubly ? "not doubly stochastic and non-negative"
                                                         : "not row-stochastic and non-negative")
                                               : "invalid weights",
                         dkf_status_str(st));
    return DKF_EXIT_OK;
}
