/*
 * dkf/wfusion.h - weighted fusion of local Kalman filters with their cross
 * covariances (seed 002, Zhang; corrections in docs/design/weighted-fusion.md).
 *
 * The model (seed 002 (1)-(3)), shared by every sensor i = 1..l:
 *   x(t+1) = F x(t) + w(t),   w ~ (0, Q)    (the paper's Phi, and Q = Gamma Qe Gamma^T)
 *   y_i(t) = H_i x(t) + v_i(t), v_i ~ (0, R_i), mutually uncorrelated
 *   s(t)   = Hs x(t)                          (the signal, Hs 1 x n)
 * given as dkf_kf_dyn_t {F, Q} and one dkf_kf_meas_t {H_i, R_i} per
 * sensor (dkf/kf.h), at every step (a self-tuning filter changes them).
 * PER SENSOR: m_i (dkf_wfusion_init's m[]), H_i, R_i and y_i may differ;
 * n, F, Q, Hs and the initial estimate (x0, P0) are common.
 *
 * Local filter i (Theorem 1) in the one-step form
 *   Sigma_i(t|t-1) = F P_i(t-1|t-1) F^T + Q
 *   K_i(t)   = Sigma_i(t|t-1) H_i^T (H_i Sigma_i(t|t-1) H_i^T + R_i)^{-1}
 *   Psi_i(t) = (I - K_i(t) H_i) F
 *   x_i(t|t) = Psi_i(t) x_i(t-1|t-1) + K_i(t) y_i(t)
 *   P_i(t|t) = J_i Sigma_i(t|t-1) J_i^T + K_i R_i K_i^T,  J_i = I - K_i H_i.
 * The gains do not depend on the data, so a fusion centre runs the same
 * recursion as the nodes (without their y) and knows every K_i and Psi_i.
 *
 * Cross covariances of the local errors, corrected (the paper prints
 * Gamma Qe Gamma^{-1} and drops two transposes; docs/design/weighted-fusion.md):
 *   P_ij(t|t) = Psi_i P_ij(t-1|t-1) Psi_j^T + J_i Q J_j^T + delta_ij K_i R_i K_i^T,
 * from x~_i(t) = Psi_i x~_i(t-1) + J_i w(t-1) - K_i v_i(t). With a common
 * initial estimate P_ij(0|0) = P0 for every pair.
 *
 * Fusion of the sensors present (x[i] != NULL), with S the matching
 * sub-block of the joint covariance (P_ij) and e the stacked identities:
 *   scalar weights (Theorem 2) on s:  P_S = (Hs P_ij Hs^T),
 *     w = e^T P_S^{-1} / (e^T P_S^{-1} e),  P_S0 = (e^T P_S^{-1} e)^{-1},
 *     s0 = sum_i w_i Hs x_i;
 *   matrix weights (Sun and Deng 2004) on x:
 *     [A_1 ... A_l] = (e^T S^{-1} e)^{-1} e^T S^{-1},  Pf = (e^T S^{-1} e)^{-1},
 *     xf = sum_i A_i x_i  (the paper's x_0, P_0).
 * Both are the solution of min tr(A S A^T) subject to sum_i A_i = I, i.e.
 * of the KKT system [[S, e], [e^T, 0]] [A^T; -Pf] = [0; I]. Where S is
 * singular (with a common initial estimate, the first steps: fewer driving
 * noises than n l) the fused estimate and Pf are still unique while the
 * weights may not be: the KKT system is then solved in the least-squares
 * sense (its pseudo-inverse: the minimum-norm weights) and `*_unique` is 0.
 */
#ifndef DKF_WFUSION_H
#define DKF_WFUSION_H

#include <stddef.h>

#include "dkf/kf.h"
#include "dkf/mat.h"
#include "dkf/mat_riccati.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- one local filter (a node) --------------------------------------------- */

/* The exact storage (reals) of a local filter with state n, measurement m. */
#define DKF_WFUSION_LOCAL_STORAGE_LEN(n, m) \
    (DKF_WFUSION_LOCAL_STATE_LEN(n, m) + DKF__WFUSION_LOCAL_SCRATCH(n, m))
/* Its leading reals that are state (x, P, Sp, K, Psi, J): a failed call
 * leaves them and the struct bit-identical. */
#define DKF_WFUSION_LOCAL_STATE_LEN(n, m) ((n) + 4 * (n) * (n) + (n) * (m))
#define DKF__WFUSION_LOCAL_SCRATCH(n, m) \
    (DKF_WFUSION_LOCAL_STATE_LEN(n, m) + 2 * (n) * (n) + 2 * (n) * (m) + 2 * (m) * (m) + \
     DKF__WFUSION_MAX(2 * ((n) + (m)) * (n) + (m) * (m), DKF_MAT_DARE_WORK(n, m)))
#define DKF__WFUSION_MAX(a, b) ((a) > (b) ? (a) : (b))

typedef struct {
    size_t n, m;
    dkf_mat_t x;      /* x_i(t|t), n x 1 */
    dkf_mat_t P;      /* P_i(t|t) = P_ii(t|t), n x n */
    dkf_mat_t Sp;     /* Sigma_i(t|t-1) of the last step (after init: P0), n x n */
    dkf_mat_t K;      /* K_i(t) of the last step, n x m */
    dkf_mat_t Psi;    /* Psi_i(t) = (I - K_i H_i) F, n x n */
    dkf_mat_t J;      /* J_i(t) = I - K_i H_i, n x n */
    unsigned long t;  /* steps taken since init */
    int steady;       /* 1: K, Psi, J, P held at the steady state */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *work; /* scratch of one step */
        int ready;
    } priv;
} dkf_wfusion_local_t;

/* `name` and `name_storage`, storage class sc (the form of DKF_KF_DECLARE). */
#define DKF_WFUSION_LOCAL_DECLARE(sc, name, n, m) \
    sc dkf_real_t name##_storage[DKF_WFUSION_LOCAL_STORAGE_LEN(n, m)]; \
    sc dkf_wfusion_local_t name

/* Binds loc to storage and starts from x_i(0|0) = x0, P_i(0|0) = P0
 * (symmetric PSD). DKF_ERR_CAPACITY (n, m zero or above DKF_MAX_DIM, or
 * storage_len short), DKF_ERR_NONFINITE, DKF_ERR_NOT_SPD (P0 not PSD). */
dkf_status_t dkf_wfusion_local_init(dkf_wfusion_local_t *loc, size_t n, size_t m,
                                    dkf_real_t *storage, size_t storage_len,
                                    const dkf_mat_t *x0, const dkf_mat_t *P0);

/* One step t with the model dyn (from t-1 to t), meas = {H_i, R_i} and
 * y_i(t) (m x 1), the equations above; in steady mode only
 * x = Psi x + K y. y == NULL runs the gain recursion alone (what a fusion
 * centre does for a sensor it does not measure for). DKF_ERR_NOT_SPD
 * (H Sigma H^T + R not SPD, or an indefinite P), DKF_ERR_NONFINITE. */
dkf_status_t dkf_wfusion_local_step(dkf_wfusion_local_t *loc, const dkf_kf_dyn_t *dyn,
                                    const dkf_kf_meas_t *meas, const dkf_mat_t *y);

/* Switches loc to the steady filter: Sp = the DARE's stabilising solution
 * (dkf/mat_riccati.h), K, Psi, J and P from it; x is kept. Later steps
 * use these (the model must not change). DKF_ERR_UNSTABLE if there is
 * no stabilising solution, and dkf_mat_dare's other codes. */
dkf_status_t dkf_wfusion_local_steady(dkf_wfusion_local_t *loc, const dkf_kf_dyn_t *dyn,
                                      const dkf_kf_meas_t *meas);

/* ---- the fusion of l local filters ----------------------------------------- */

/* The exact storage of a fusion of l sensors with measurement dimensions
 * m[0..l-1], state n (0 if a dimension is 0 or n l + n > DKF_MAX_DIM);
 * DKF_WFUSION_STORAGE_LEN(n, l, m) is it for l equal sensors of dimension
 * m, and a bound for smaller ones. */
size_t dkf_wfusion_storage_len(size_t n, size_t l, const size_t m[]);
#define DKF_WFUSION_STORAGE_LEN(n, l, m) \
    ((l) * DKF_WFUSION_LOCAL_STORAGE_LEN(n, m) + DKF__WFUSION_OWN_LEN(n, l))
#define DKF__WFUSION_KKT(n, l) ((n) * (l) + (n))
#define DKF__WFUSION_OWN_LEN(n, l) \
    (2 * (n) * (l) * (n) * (l) + 2 * DKF__WFUSION_KKT(n, l) * DKF__WFUSION_KKT(n, l) + \
     2 * (l) * (l) + 2 * (l) + 2 * (n) * (n) * (l) + 3 * (n) + 2 * (n) * (n) + \
     DKF__WFUSION_KKT(n, l) * (n) + \
     DKF__WFUSION_MAX(DKF_MAT_PINV_WORK(DKF__WFUSION_KKT(n, l), DKF__WFUSION_KKT(n, l)), \
                      DKF_MAT_STEIN_WORK(n, n)))

typedef struct {
    size_t n, l;                 /* state, sensors */
    dkf_wfusion_local_t *nodes;  /* the l local filters (caller array, bound by init) */
    dkf_mat_t Pj;                /* joint covariance (P_ij(t|t)), n l x n l */
    dkf_mat_t Hs;                /* signal row, 1 x n */
    /* dkf_wfusion_fuse_scalar's results */
    dkf_mat_t PS;                /* (Hs P_ij Hs^T) of all sensors, l x l */
    dkf_mat_t w;                 /* weights, l x 1 (0 for an absent sensor) */
    dkf_real_t s0, PS0;          /* fused signal and its error variance */
    int w_unique;                /* 0: P_S of the present sensors singular, w min-norm */
    /* dkf_wfusion_fuse_matrix's results */
    dkf_mat_t A;                 /* [A_1 ... A_l], n x n l (0 blocks for absent sensors) */
    dkf_mat_t xf;                /* fused estimate, n x 1 */
    dkf_mat_t Pf;                /* its error covariance, n x n */
    int A_unique;                /* 0: the KKT system singular, A min-norm */
    size_t used;                 /* sensors present in the last fusion */
    unsigned long t;             /* steps taken since init */
    int steady;                  /* 1: every local filter and P_ij steady */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *work;
        int ready;
    } priv;
} dkf_wfusion_t;

/* `name`, `name_nodes` (l local filters) and `name_storage` for l sensors
 * of measurement dimension at most m. */
#define DKF_WFUSION_DECLARE(sc, name, n, l, m) \
    sc dkf_real_t name##_storage[DKF_WFUSION_STORAGE_LEN(n, l, m)]; \
    sc dkf_wfusion_local_t name##_nodes[l]; \
    sc dkf_wfusion_t name

/* Binds fu and its l local filters (nodes[0..l-1], measurement dimensions
 * m[]) to storage; every filter starts from the common x0, P0, and
 * P_ij(0|0) = P0 for every pair. Hs is the 1 x n signal row (copied).
 * DKF_ERR_CAPACITY (n l + n > DKF_MAX_DIM, or storage short), and
 * dkf_wfusion_local_init's codes. */
dkf_status_t dkf_wfusion_init(dkf_wfusion_t *fu, size_t n, size_t l, const size_t m[],
                              dkf_wfusion_local_t nodes[], dkf_real_t *storage,
                              size_t storage_len, const dkf_mat_t *Hs, const dkf_mat_t *x0,
                              const dkf_mat_t *P0);

/* One step t: every local filter's step (meas[i] = {H_i, R_i}; y[i] its
 * measurement, or y == NULL for the gains alone: a centre whose estimates
 * come from the nodes), then every P_ij by the corrected recursion. In
 * steady mode P_ij stays. All or nothing: on an error no filter and no
 * P_ij has moved. */
dkf_status_t dkf_wfusion_step(dkf_wfusion_t *fu, const dkf_kf_dyn_t *dyn,
                              const dkf_kf_meas_t meas[], const dkf_mat_t y[]);

/* Steady state: every local filter steady (dkf_wfusion_local_steady) and
 * every P_ij the solution of the Stein equation
 * P_ij = Psi_i P_ij Psi_j^T + J_i Q J_j^T + delta_ij K_i R_i K_i^T. */
dkf_status_t dkf_wfusion_steady(dkf_wfusion_t *fu, const dkf_kf_dyn_t *dyn,
                                const dkf_kf_meas_t meas[]);

/* Scalar-weight fusion of the signal (Theorem 2) over the sensors with
 * x[i] != NULL (x == NULL: every local filter's own x_i(t|t)); fills PS,
 * w, s0, PS0, w_unique, used. DKF_ERR_ARG: no sensor present;
 * DKF_ERR_NOT_SPD: P_S of the present sensors indefinite beyond rounding;
 * DKF_ERR_NONFINITE: an x[i]. The results are written only on success. */
dkf_status_t dkf_wfusion_fuse_scalar(dkf_wfusion_t *fu, const dkf_mat_t *const x[]);

/* Matrix-weight fusion of x (Sun and Deng) over the same choice of
 * sensors; fills A, xf, Pf, A_unique, used. Codes as fuse_scalar (NOT_SPD
 * for the joint sub-block). */
dkf_status_t dkf_wfusion_fuse_matrix(dkf_wfusion_t *fu, const dkf_mat_t *const x[]);

/* Checkpoints, for a fusion centre's rollback and replay (the form of
 * dkf_diffkf_fc_save): dkf_wfusion_checkpoint_len(fu) reals (0 if fu is
 * NULL or not initialised) holding a header (a tag, n, l, every m_i, the
 * steady flag and t, the integers stored exactly as reals), every local
 * filter's step count and DKF_WFUSION_LOCAL_STATE_LEN reals, and the joint
 * covariance. The last fusion's results are not part of it (the next
 * fuse_* recomputes them). save: DKF_ERR_CAPACITY if len is short.
 * restore: DKF_ERR_ARG if the header is not this fusion's (another shape,
 * a corrupted integer), DKF_ERR_NONFINITE for a non-finite value, fu
 * unchanged on failure. After a restore, fu steps bit-identically to the
 * fusion that was saved. */
size_t dkf_wfusion_checkpoint_len(const dkf_wfusion_t *fu);
dkf_status_t dkf_wfusion_save(const dkf_wfusion_t *fu, dkf_real_t *buf, size_t len);
dkf_status_t dkf_wfusion_restore(dkf_wfusion_t *fu, const dkf_real_t *buf, size_t len);

#ifdef __cplusplus
}
#endif

#endif /* DKF_WFUSION_H */
