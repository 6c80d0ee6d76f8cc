/*
 * status_text.c - the meaning of a failed core call (status_text.h). One
 * row per (call, status) whose header names the matrix; the phrases
 * follow the headers' words.
 */
#include "status_text.h"

#include <stdio.h>
#include <string.h>

typedef struct {
    const char *call; /* a prefix of the function name ("dkf_kf_" for all of kf.h) */
    dkf_status_t st;
    const char *matrix;
} row_t;

static const row_t rows[] = {
    {"dkf_kf_init", DKF_ERR_NOT_SPD, "the initial covariance P0 is not SPD"},
    {"dkf_kf_predict", DKF_ERR_NOT_SPD,
     "the predicted covariance F P F^T + Q is not PSD (Q indefinite)"},
    {"dkf_kf_update", DKF_ERR_NOT_SPD,
     "the innovation covariance S = H P H^T + R is not SPD, or the updated P is not PSD "
     "(R indefinite)"},
    {"dkf_info_init", DKF_ERR_NOT_SPD, "the initial covariance P0 is not SPD"},
    {"dkf_info_predict", DKF_ERR_NOT_SPD, "the predicted covariance F P F^T + Q is not SPD"},
    {"dkf_info_contribution", DKF_ERR_NOT_SPD, "the measurement noise covariance R is not SPD"},
    {"dkf_info_fuse", DKF_ERR_NOT_SPD, "the fused information matrix Y is not SPD"},
    {"dkf_diffkf_", DKF_ERR_RANK, "the feedthrough D_{k+1} lacks full column rank"},
    {"dkf_diffkf_", DKF_ERR_SINGULAR, "the input transition B_k is singular"},
    {"dkf_diffkf_", DKF_ERR_NOT_SPD, "the Difference KF's L_k is not SPD"},
    {"dkf_askf_init", DKF_ERR_NOT_SPD, "the initial covariance blockdiag(P00, Pd00) is not SPD"},
    {"dkf_askf_update", DKF_ERR_NOT_SPD,
     "the innovation covariance H^a P^a H^a^T + R is not SPD"},
    {"dkf_otskf_init", DKF_ERR_NOT_SPD, "the initial covariance P00 or Pd00 is not SPD"},
    {"dkf_otskf_predict", DKF_ERR_SINGULAR, "the input transition B_{k-1} is singular"},
    {"dkf_otskf_predict", DKF_ERR_NOT_SPD,
     "P^d_{k|k-1} = B P^d B^T + Rd is not SPD, or P^x, P^d not PSD (Q or Rd indefinite)"},
    {"dkf_otskf_update", DKF_ERR_RANK, "the feedthrough D_k lacks full column rank"},
    {"dkf_otskf_update", DKF_ERR_NOT_SPD,
     "the innovation covariance H P^x H^T + R (+ S P^d S^T) is not SPD"},
    {"dkf_uif_init", DKF_ERR_NOT_SPD, "the initial covariance P0 is not SPD"},
    {"dkf_uif_init", DKF_ERR_RANK, "the feedthrough D cannot have rank p (m < p)"},
    {"dkf_uif_step", DKF_ERR_NOT_SPD,
     "R~_k = H_k P_{k|k-1} H_k^T + R_k is not SPD, or P_{k|k}, P_{k|k-1} not PSD "
     "(Q or R indefinite)"},
    {"dkf_uif_step", DKF_ERR_RANK,
     "the input is not estimable: rank D_k < p (RTSF), Dbar^T R~^-1 Dbar singular (NRTSF-DF) "
     "or rank(H_k Gbar_{k-1}) < rank G_{k-1} (NRTSF)"},
    {"dkf_tw_node_init", DKF_ERR_RANK, "the input matrix G has more columns than rows (p > n)"},
    {"dkf_tw_net_init", DKF_ERR_RANK, "the input matrix G has more columns than rows (p > n)"},
    {"dkf_tw_", DKF_ERR_NOT_SPD,
     "a node's measurement noise R, Phi- or Psi, or the committed P is not SPD"},
    {"dkf_tw_", DKF_ERR_RANK,
     "S = G^T Pi G is not positive definite: rank(H G) < p over the nodes whose "
     "measurements reached it"},
    {"dkf_nerts_", DKF_ERR_NOT_SPD,
     "R, R_tilde, P_pred, Rbar or Y is not SPD, or the joint covariance [[Px, Pxd], "
     "[Pxd^T, Pd]] is not positive definite"},
    {"dkf_nerts_", DKF_ERR_RANK,
     "the input feedthrough Hd = dh/dd lacks full column rank p"},
    {"dkf_dfnerts_", DKF_ERR_NOT_SPD,
     "a node's R, R_tilde, P_pred, Rbar or Y, or the agreed information Y, is not SPD"},
    {"dkf_dfnerts_", DKF_ERR_RANK,
     "a node's input feedthrough Hd = dh/dd lacks full column rank p"},
    {"dkf_wfusion_init", DKF_ERR_NOT_SPD, "the initial covariance P0 is not PSD"},
    {"dkf_wfusion_step", DKF_ERR_NOT_SPD,
     "a local filter's innovation covariance H_i P H_i^T + R_i is not SPD"},
    {"dkf_wfusion_fuse_", DKF_ERR_NOT_SPD,
     "the fused covariance P_S (or the joint P_ij) of the sensors is indefinite"},
};

const char *dkf_host_status_text(char *out, size_t len, const char *call, dkf_status_t st)
{
    const char *name = call != NULL ? strstr(call, "dkf_") : NULL, *matrix = NULL;
    size_t i;
    for (i = 0; name != NULL && i < sizeof rows / sizeof rows[0] && matrix == NULL; ++i)
        if (rows[i].st == st && strncmp(name, rows[i].call, strlen(rows[i].call)) == 0)
            matrix = rows[i].matrix;
    if (st == DKF_ERR_NONFINITE)
        snprintf(out, len, "overflow (%d): every input is finite, a value computed from them "
                 "is not", (int)st);
    else if (matrix != NULL)
        snprintf(out, len, "%s (%d): %s", dkf_status_str(st), (int)st, matrix);
    else
        snprintf(out, len, "%s (%d)", dkf_status_str(st), (int)st);
    return out;
}
