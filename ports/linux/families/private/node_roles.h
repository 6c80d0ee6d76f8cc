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

#endif /* DKF_HOST_NODE_ROLES_H */
