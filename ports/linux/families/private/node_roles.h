/*
 * node_roles.h - the families' sensor-node roles (family.h,
 * dkf_node_ops_t; private to the families layer): each in its own file,
 * named in its family's table.
 */
#ifndef DKF_HOST_NODE_ROLES_H
#define DKF_HOST_NODE_ROLES_H

#include "family.h"

/* The dkf family's (est_diffkf_node.c): the local Difference KF. */
extern const dkf_node_ops_t dkf_host_diffkf_node_ops;
/* The wfusion family's (est_wfusion_node.c): seed 002's local Kalman filter. */
extern const dkf_node_ops_t dkf_host_wfusion_node_ops;

/* The end of a node role's create: nf when call is not NULL and st is
 * DKF_OK. Otherwise nf is destroyed (destroy(nf)) and NULL is returned
 * with err "FILE: node ID: CALL failed: STATUS (CODE)", or with call NULL
 * (a failed allocation) "node ID: out of memory". */
dkf_node_filter_t *dkf_host_node_created(dkf_node_filter_t *nf,
                                         void (*destroy)(dkf_node_filter_t *),
                                         const dkf_scenario_t *s, size_t id, const char *call,
                                         dkf_status_t st, char *err, size_t errlen);

#endif /* DKF_HOST_NODE_ROLES_H */
