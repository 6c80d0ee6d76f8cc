/*
 * chan.h - the names of the DKF network: who speaks (roles) and on which
 * channel (host side; docs/guide/network.md, "Channels" and "Authentication").
 *
 * Every channel of the protocol has exactly one spelling:
 *   <prefix>_MEAS_<i>   sensor i's measurements    (the simulator)
 *   <prefix>_NODE_<i>   node i's messages          (node i)
 *   <prefix>_FUSED      the fused estimates        (the fusion centre)
 *   <prefix>_TRUTH      the simulated truth        (the simulator)
 *   <prefix>_STATUS     every process's status     (each as itself)
 *   <prefix>_<i>        graph node i's packets     (graph node i)
 * where <i> is a node id written canonically: "0", or a digit 1-9 and at
 * most four more digits (no sign, no leading zero, at most 99999), and
 * <prefix> is not empty. A name that does not parse so (DKF_NODE_0001,
 * DKF_NODE_01, DKF_NODE_, DKF_MEAS_+1) is no channel of the protocol:
 * receivers refuse and count it, and authentication never signs or accepts
 * it. The parse reads from the end, so it needs no prefix; a graph prefix
 * ending in "_NODE" or "_MEAS" reads as that kind, with the same node.
 *
 * No dependencies: the transport (net.h), authentication (auth.h) and the
 * codec (codec.h) all take their names, and the largest number of nodes,
 * from here.
 */
#ifndef DKF_NET_CHAN_H
#define DKF_NET_CHAN_H

#include <stddef.h>

/* Roles of the processes (status_t.role on the wire; the signer of an
 * authenticated datagram is role << 16 | index, auth.h). */
enum {
    DKF_NET_ROLE_SIM = 0,
    DKF_NET_ROLE_NODE = 1,
    DKF_NET_ROLE_FUSION = 2,
    DKF_NET_ROLE_GRAPH = 3 /* a graph filter's node (dkf-tw-node) */
};

/* Who sent a message. With authentication the transport fills it from the
 * key that verified the datagram (auth.h), never from the channel or the
 * payload; without, it is unknown and a receiver has only the channel's
 * word (docs/guide/network.md, "Threat model"). */
typedef struct dkf_net_from {
    int known; /* 1: authenticated */
    int role;  /* DKF_NET_ROLE_* (known only) */
    long id;   /* NODE, GRAPH: the node id; SIM, FUSION: -1 */
} dkf_net_from_t;

/* 1 if from is NULL or unknown, or is exactly (role, id). */
int dkf_net_from_is(const dkf_net_from_t *from, int role, long id);

#define DKF_NET_CHAN_LEN 64
#define DKF_NET_PREFIX "DKF"
#define DKF_NET_CHAN_MAX_ID 99999L /* the largest id a channel name can carry */
/* Largest number of nodes a network can have (a fused message names each;
 * a DKF network's stacked sum m_i <= DKF_MAX_DIM bounds it too). */
#define DKF_NET_MAX_NODES 256

typedef enum {
    DKF_CHAN_NONE = 0, /* not a channel of the protocol */
    DKF_CHAN_MEAS,
    DKF_CHAN_NODE,
    DKF_CHAN_FUSED,
    DKF_CHAN_TRUTH,
    DKF_CHAN_STATUS,
    DKF_CHAN_GRAPH
} dkf_net_chan_kind_t;

typedef struct {
    dkf_net_chan_kind_t kind;
    long id; /* MEAS, NODE, GRAPH: the node id; else -1 */
} dkf_net_chan_id_t;

/* What channel names (kind NONE, id -1 for anything not spelled as above). */
dkf_net_chan_id_t dkf_net_chan_parse(const char *channel);

/* The node id of a <prefix>_NODE_<i> channel, or -1 (any other name, a
 * non-canonical id among them). */
long dkf_net_chan_node_id(const char *channel);

/* The node a message on a <prefix>_NODE_<i> channel comes from: known
 * from, the signer's node id (-1 if the signer is no node); unknown, the
 * channel's canonical id (-1 if it has none). */
long dkf_net_from_node(const dkf_net_from_t *from, const char *channel);

/* Writers of the names above (out has DKF_NET_CHAN_LEN bytes). */
void dkf_net_chan_meas(char *out, const char *prefix, size_t node);
void dkf_net_chan_node(char *out, const char *prefix, size_t node);
void dkf_net_chan(char *out, const char *prefix, const char *what); /* FUSED, TRUTH, STATUS */

#endif /* DKF_NET_CHAN_H */
