/*
 * m4_node.h - a node role (family.h, dkf_node_ops_t) computed by the live
 * node image on an emulated Cortex-M4F: qemu-system-arm -M mps2-an386 runs
 * ports/cortex-m4's dkf_m4_live.elf, and each start and step of sensor i's
 * local Difference KF goes to it as one frame through a named pipe, its
 * answer (x_{k|k}, x_{k|k-1}) coming back through another (the protocol:
 * ports/cortex-m4/live_main.c; docs/decisions.md, decision 68).
 *
 * The role plugs into the node agent (agents.h, dkf_net_node_create)
 * exactly as the dkf family's own node role does, so the node message,
 * its signature, its epochs and restarts are dkf-node's: dkf-m4-bridge is
 * dkf-node with the filter's arithmetic done on the emulated processor.
 *
 *   dkf_m4_conf_t conf = {"qemu-system-arm", "dkf_m4_live.elf", 10.0, NULL};
 *   dkf_family_t fam; dkf_filter_t f;
 *   dkf_m4_filter(&conf, &fam, &f);
 *   nd = dkf_net_node_create(net, s, &f, id, prefix, err, sizeof err);
 *   ... run ...; dkf_m4_node_finish(conf.live, err, sizeof err);
 */
#ifndef DKF_NET_M4_NODE_H
#define DKF_NET_M4_NODE_H

#include <jansson.h>

#include "family.h"

typedef struct {
    const char *qemu;        /* the qemu-system-arm to run */
    const char *image;       /* dkf_m4_live.elf */
    double timeout_s;        /* the longest wait for the image's answer to a frame */
    dkf_node_filter_t *live; /* set by the role's create: the running image */
} dkf_m4_conf_t;

/* Fills *fam (the dkf family with the image as its node role) and *f (the
 * filter "m4" of that family, conf as its data); conf, fam and f must
 * outlive the node. */
void dkf_m4_filter(dkf_m4_conf_t *conf, dkf_family_t *fam, dkf_filter_t *f);

/* Ends the image's run: the end frame, its goodbye (the stack's
 * high-water mark) and its exit status 0. 0, or -1 with err. */
int dkf_m4_node_finish(dkf_node_filter_t *nf, char *err, size_t errlen);

/* {"k": [...], "xf": [[...]], "xp": [[...]], "stack_bytes": B} of every
 * message the image computed (stack_bytes after dkf_m4_node_finish, else
 * null). NULL if out of memory. */
json_t *dkf_m4_node_json(const dkf_node_filter_t *nf);

#endif /* DKF_NET_M4_NODE_H */
