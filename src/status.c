#include "dkf/status.h"

const char *dkf_status_str(dkf_status_t status)
{
    switch (status) {
    case DKF_OK: return "ok";
    case DKF_ERR_NULL: return "NULL argument";
    case DKF_ERR_DIM: return "dimension mismatch";
    case DKF_ERR_CAPACITY: return "capacity exceeded";
    case DKF_ERR_NONFINITE: return "non-finite input";
    case DKF_ERR_NOT_SPD: return "matrix not SPD";
    case DKF_ERR_SINGULAR: return "matrix singular";
    case DKF_ERR_RANK: return "rank condition violated";
    case DKF_ERR_ALIAS: return "output aliases input";
    case DKF_ERR_NO_CONVERGENCE: return "no convergence";
    case DKF_ERR_STATE: return "call out of sequence";
    case DKF_ERR_ARG: return "argument out of domain";
    case DKF_ERR_GRAPH: return "invalid graph";
    case DKF_ERR_WEIGHTS: return "weights not stochastic";
    case DKF_ERR_MODEL: return "model callback failed";
    case DKF_ERR_UNSTABLE: return "no stabilising solution";
    }
    return "unknown status";
}
