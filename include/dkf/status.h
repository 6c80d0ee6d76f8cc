/*
 * dkf/status.h - the one status type every dkf function returns.
 *
 * Zero is success; every error is negative. A function that returns an
 * error has left every caller-owned output and every filter state exactly
 * as it was before the call.
 */
#ifndef DKF_STATUS_H
#define DKF_STATUS_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    DKF_OK = 0,
    DKF_ERR_NULL = -1,           /* a required pointer argument is NULL */
    DKF_ERR_DIM = -2,            /* dimensions of the arguments do not agree */
    DKF_ERR_CAPACITY = -3,       /* larger than DKF_MAX_DIM or than the storage given */
    DKF_ERR_NONFINITE = -4,      /* NaN or infinity in an input */
    DKF_ERR_NOT_SPD = -5,        /* matrix must be symmetric positive definite */
    DKF_ERR_SINGULAR = -6,       /* matrix is (numerically) singular */
    DKF_ERR_RANK = -7,           /* a rank condition of the algorithm is violated */
    DKF_ERR_ALIAS = -8,          /* an output overlaps an input where that is not allowed */
    DKF_ERR_NO_CONVERGENCE = -9, /* an iterative method hit its iteration limit */
    DKF_ERR_STATE = -10,         /* call out of sequence (e.g. before init) */
    DKF_ERR_ARG = -11,           /* an argument is outside its domain */
    DKF_ERR_GRAPH = -12,         /* malformed graph, or a link that is not in it */
    DKF_ERR_WEIGHTS = -13,       /* weights not (row/doubly) stochastic or negative */
    DKF_ERR_MODEL = -14,         /* a user model callback reported failure (dkf/nl_model.h) */
    DKF_ERR_UNSTABLE = -15       /* no stabilising solution: a Riccati / Stein equation whose
                                  * closed loop has a mode on or outside the unit circle */
} dkf_status_t;

/* Short constant description of a status, e.g. "matrix not SPD".
 * Never NULL; unknown values give "unknown status". */
const char *dkf_status_str(dkf_status_t status);

#ifdef __cplusplus
}
#endif

#endif /* DKF_STATUS_H */
