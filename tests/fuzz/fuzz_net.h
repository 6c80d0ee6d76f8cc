/*
 * fuzz_net.h - what the network-decoder harness (fuzz_net.c) expects, shared
 * with the program that writes its seed corpus (make_net_seeds.c).
 *
 * An input is one selector byte and then one datagram:
 *   byte 0 % FUZZ_NET_NSEL picks the decoder, bytes 1.. are its input.
 */
#ifndef DKF_FUZZ_NET_H
#define DKF_FUZZ_NET_H

#include <string.h>

#include "codec.h"
#include "tw_agent.h"

enum {
    FUZZ_NET_NODE_MSG = 0, /* dkf_net_decode_node_msg */
    FUZZ_NET_MEAS,         /* dkf_net_decode_meas */
    FUZZ_NET_TRUTH,        /* dkf_net_decode_truth */
    FUZZ_NET_FUSED,        /* dkf_net_decode_fused */
    FUZZ_NET_STATUS,       /* dkf_net_decode_status */
    FUZZ_NET_TW2,          /* dkf_net_twa_decode (dkf_net_decode_tw), Algorithm 2 receiver */
    FUZZ_NET_TW3,          /* dkf_net_twa_decode (dkf_net_decode_tw), Algorithm 3 (eta 2) */
    FUZZ_NET_CHANNEL,      /* dkf_net_chan_parse, dkf_net_twa_chan_node on a channel name */
    FUZZ_NET_NSEL
};

#define FUZZ_NET_MODEL_ID ((int64_t)0x0123456789abcdefLL)
#define FUZZ_NET_NNODES 3
#define FUZZ_NET_N 4
#define FUZZ_NET_KMAX 1000
static const size_t fuzz_net_m[FUZZ_NET_NNODES] = {2, 1, 3};

/* The receiver of every dkf_net_decode_*: any node's channel. */
static inline dkf_net_expect_t fuzz_net_expect(void)
{
    dkf_net_expect_t ex;
    ex.model_id = FUZZ_NET_MODEL_ID;
    ex.nnodes = FUZZ_NET_NNODES;
    ex.node = -1;
    ex.n = FUZZ_NET_N;
    ex.m = fuzz_net_m;
    ex.kmax = FUZZ_NET_KMAX;
    return ex;
}

/* A graph-filter receiver of algorithm alg (2, or 3 with eta 2): 4 nodes,
 * n = 3, 10 steps; only the fields dkf_net_twa_decode reads are set. */
static inline dkf_net_twa_scn_t fuzz_net_tw_scn(int alg)
{
    dkf_net_twa_scn_t c;
    memset(&c, 0, sizeof c);
    c.alg = alg;
    c.N = 4;
    c.n = 3;
    c.p = 1;
    c.steps = 10;
    c.eta = alg == 3 ? 2 : 0;
    c.rounds = alg == 3 ? 2 * c.eta : 2;
    c.model_id = FUZZ_NET_MODEL_ID + alg;
    return c;
}

#endif /* DKF_FUZZ_NET_H */
