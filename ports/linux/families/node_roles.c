/*
 * node_roles.c - what the families' sensor-node roles share (node_roles.h).
 */
#include "node_roles.h"

#include <stdio.h>

dkf_node_filter_t *dkf_host_node_created(dkf_node_filter_t *nf,
                                         void (*destroy)(dkf_node_filter_t *),
                                         const dkf_scenario_t *s, size_t id, const char *call,
                                         dkf_status_t st, char *err, size_t errlen)
{
    if (call != NULL && st == DKF_OK) return nf;
    if (call == NULL)
        snprintf(err, errlen, "node %zu: out of memory", id);
    else
        snprintf(err, errlen, "%s: node %zu: %s failed: %s (%d)", s->file, id, call,
                 dkf_status_str(st), (int)st);
    destroy(nf);
    return NULL;
}
