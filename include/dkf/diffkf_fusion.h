/*
 * dkf/diffkf_fusion.h - distributed Difference KF (seed 000 §4): a fusion
 * centre (FC) that rebuilds the centralized Difference-KF estimate exactly
 * from the nodes' local estimates (docs/design/diffkf-fusion.md).
 *
 * l sensors share the state x (n) and the dynamics (F_k, Q_k); sensor i has
 * its own (H^i, D^i, R^i) (m_i rows, p_i unknown inputs) and (B^i, Rd^i).
 * PER NODE: m_i, p_i (dkf_diffkf_fc_init's m[], p[]), H^i, D^i, R^i, B^i,
 * Rd^i, y^i and the local prior covariance may differ; n, F_k, Q_k and
 * the central prior are common.
 * Node i runs the local Difference KF (dkf/diffkf.h) on its own y^i and
 * sends, after each step k, the message {x^i_{k|k}, x^i_{k|k-1}}. The FC
 * knows every model and every local prior covariance. It replays each
 * local filter's data-independent recursion (J^i, L^i) on a replica, recovers
 *   dz^i_k = (K^i_k)^+ (x^i_{k|k} - x^i_{k|k-1}),     K^i_k = J^i_k (L^i_k)^{-1}
 *   z^i_k  = dz^i_k + M^i_k x^i_{k|k-1} + C^i_k (L^i_{k-1})^{-1} dz^i_{k-1}
 * (the last term is absent at the first step) and runs one step of the
 * centralized Difference KF - the ordinary Difference KF on the stacked
 * model - on z_k = [z^1_k; ...; z^l_k]. In exact arithmetic the result IS
 * the centralized estimate; it needs rank K^i_k = p_i (so p_i <= n), and
 * no condition on H (unlike the paper's literal formulas (30)-(36)).
 *
 * Every failing call leaves the FC (replicas, central filter, step count)
 * bit-identical and reports which condition failed for which node in a
 * dkf_diffkf_fc_fault_t.
 */
#ifndef DKF_DIFFKF_FUSION_H
#define DKF_DIFFKF_FUSION_H

#include <stddef.h>
#include <stdint.h>

#include "dkf/diffkf.h"
#include "dkf/mat.h"
#include "dkf/ui_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- the node message ---------------------------------------------------- */

/* What node `node` sends after its local step k: x^i_{k|k} and x^i_{k|k-1}
 * (2n numbers). x_{k|k-1} is sent because re-predicting it at the FC from
 * x_{k-1|k-1} is numerically unstable (docs/design/diffkf-fusion.md §2); the
 * covariances are not sent because the FC recomputes them. */
typedef struct {
    uint16_t node; /* sensor index i, 0-based */
    uint32_t k;    /* time of xf */
    uint16_t n;    /* state dimension: xf[0..n-1], xp[0..n-1] are valid */
    dkf_real_t xf[DKF_MAX_DIM]; /* x^i_{k|k} */
    dkf_real_t xp[DKF_MAX_DIM]; /* x^i_{k|k-1} */
} dkf_diffkf_msg_t;

/* Fills msg from node `node`'s local filter f after a completed step
 * (f->k >= 1): xf = f->xf, xp = f->xp (the prediction that step started
 * from; a pending two-phase step does not change either). DKF_ERR_STATE
 * before the first step; DKF_ERR_CAPACITY if f->k does not fit in 32 bits.
 * Entries n..DKF_MAX_DIM-1 are zero. */
dkf_status_t dkf_diffkf_msg_fill(dkf_diffkf_msg_t *msg, uint16_t node, const dkf_diffkf_t *f);

/* ---- the stacked (centralized) model ------------------------------------ */

/* H = [H^1; ...; H^l] (sum m_i x n), D = blkdiag(D^i) (sum m_i x sum p_i),
 * R = blkdiag(R^i) (sum m_i x sum m_i), from l per-sensor models; the
 * output views must have exactly these shapes (DKF_ERR_DIM otherwise).
 * Any of H, D, R may be NULL if not wanted. No alias. */
dkf_status_t dkf_diffkf_stack_meas(dkf_mat_t *H, dkf_mat_t *D, dkf_mat_t *R,
                                   const dkf_ui_meas_t *const meas[], size_t l);
/* B = blkdiag(B^i), Rd = blkdiag(Rd^i) (sum p_i square); either output may
 * be NULL (then the matching input array may be NULL too). No alias. */
dkf_status_t dkf_diffkf_stack_input(dkf_mat_t *B, dkf_mat_t *Rd, const dkf_mat_t *const Bi[],
                                    const dkf_mat_t *const Rdi[], size_t l);

/* ---- the fusion centre --------------------------------------------------- */

/* Which condition made an FC call fail. */
typedef enum {
    DKF_DIFFKF_FC_NO_FAULT = 0,
    DKF_DIFFKF_FC_ARG,            /* bad l, dimension 0, NULL model matrix */
    DKF_DIFFKF_FC_STORAGE,        /* storage smaller than dkf_diffkf_fc_storage_len */
    DKF_DIFFKF_FC_INPUT_DIM,      /* p_i > n: z^i cannot be recovered from n-vectors */
    DKF_DIFFKF_FC_INPUT_MEAS,     /* p_i > m_i: D^i cannot have full column rank */
    DKF_DIFFKF_FC_STACK_CAPACITY, /* sum m_i or sum p_i above DKF_MAX_DIM */
    DKF_DIFFKF_FC_PRIOR,          /* a prior is non-finite, misshaped or not SPD */
    DKF_DIFFKF_FC_MODEL,          /* a model matrix is misshaped or non-finite */
    DKF_DIFFKF_FC_D_RANK,         /* D^i lacks full column rank */
    DKF_DIFFKF_FC_B_SINGULAR,     /* B^i is singular */
    DKF_DIFFKF_FC_L_NOT_SPD,      /* L_k of a replica (node) or of the central filter */
    DKF_DIFFKF_FC_K_RANK,         /* rank K^i_k < p_i: dz^i_k is not recoverable */
    DKF_DIFFKF_FC_NONFINITE,      /* overflow in the step */
    DKF_DIFFKF_FC_MSG_NODE,       /* msgs[i].node != i */
    DKF_DIFFKF_FC_MSG_STEP,       /* msgs[i].k is not the FC's next step */
    DKF_DIFFKF_FC_MSG_DIM,        /* msgs[i].n != n */
    DKF_DIFFKF_FC_MSG_NONFINITE,  /* NaN/Inf in msgs[i].xf or .xp */
    DKF_DIFFKF_FC_SEQUENCE        /* call out of order (step before start, ...) */
} dkf_diffkf_fc_cond_t;

/* Short constant description of a condition, e.g. "D rank" (the same
 * text for every host program). Never NULL; unknown values give
 * "unknown condition". */
const char *dkf_diffkf_fc_cond_str(dkf_diffkf_fc_cond_t which);

/* `node` for a fault that belongs to no single sensor (central filter,
 * storage, stacked dimensions). */
#define DKF_DIFFKF_FC_NO_NODE ((size_t)-1)

typedef struct {
    dkf_diffkf_fc_cond_t which;
    size_t node; /* sensor index, or DKF_DIFFKF_FC_NO_NODE */
} dkf_diffkf_fc_fault_t;

/* Sensor i's share of one FC call: the input dynamics (B^i_k, Rd^i_k) of
 * step k and the measurement model at k+1 (at 1 for dkf_diffkf_fc_start,
 * where Rd is not used and may be NULL). */
typedef struct {
    const dkf_mat_t *B;  /* B^i_k, p_i x p_i, nonsingular */
    const dkf_mat_t *Rd; /* Rd^i_k, p_i x p_i */
    dkf_ui_meas_t meas;  /* H^i (m_i x n), D^i (m_i x p_i), R^i (m_i x m_i) */
} dkf_diffkf_sensor_t;

/* One node's replica at the FC (caller-owned array of l). Read-only for
 * the caller after dkf_diffkf_fc_init. */
typedef struct {
    size_t m, p;
    dkf_diffkf_t rep;   /* local filter i's (J, L, K, ...) recursion; its x is
                           the node's reported x */
    dkf_mat_t z, dz; /* recovered z^i_k, dz^i_k (p x 1) of the last step (z is
                        z^i_k only if the node contributed; both 0 if its
                        message was absent) */
    int sync;        /* the replica carries node i's true dz^i_{k-1}: a
                        message of step k+1 will give the exact z^i_{k+1} */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_diffkf_t saved; /* rep as it was before the running call */
        dkf_real_t *store, *saved_store; /* rep's storage and its snapshot */
        size_t store_len;
    } priv;
} dkf_diffkf_fc_node_t;

typedef struct {
    size_t n, l, ms, ps; /* ms = sum m_i, ps = sum p_i */
    size_t k;            /* time of central.xf (0 before the first step) */
    dkf_diffkf_fc_node_t *nodes;
    dkf_diffkf_t central; /* the Difference KF on the stacked model: its xf, Pf,
                             xn, Pn are the fused estimates; z, dz stacked */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_mat_t H, D, R, B, Rd; /* the stacked model of the running call */
        dkf_real_t *central_store; /* central's storage (its first DKF_DIFFKF_STATE_LEN
                                      reals are state) */
        dkf_real_t *cache_snap;    /* state: a copy of its caches (its state after
                                      the carry), refreshed when they change */
        dkf_real_t *pend; /* scratch: the running call's z, dz (2 sum p_i) */
        dkf_real_t *Kp;   /* (K^i)^+, p_max x n */
        dkf_real_t *work; /* SVD / LU / rank workspace */
        size_t work_len;
        int ready, started;
        int stacked; /* H, D, R (1), and B, Rd too (2), hold a stacking completed
                        by a successful call (zeros outside the blocks), 0: none */
    } priv;
} dkf_diffkf_fc_t;

/* Reals of storage the FC needs for state dimension n and l sensors of
 * dimensions m[i], p[i]; 0 if a dimension is 0, above DKF_MAX_DIM, or the
 * stacked dimensions exceed DKF_MAX_DIM. */
size_t dkf_diffkf_fc_storage_len(size_t n, size_t l, const size_t m[], const size_t p[]);
/* The state part of that storage: its first dkf_diffkf_fc_state_len reals
 * (each replica's storage, the recovered z, dz, a copy of the central
 * filter's caches and its first DKF_DIFFKF_STATE_LEN(n, sum m_i, sum p_i)
 * reals); the rest is
 * scratch any call may overwrite. Every failed call that takes the FC
 * leaves these reals, *fc and nodes[0..l-1] bit-identical. 0 where
 * dkf_diffkf_fc_storage_len is 0. */
size_t dkf_diffkf_fc_state_len(size_t n, size_t l, const size_t m[], const size_t p[]);

/* Private (the sizing of src/diffkf_fusion.c, here for the macros below):
 * the workspace for a sensor (m, p), the largest of the SVD of K^i
 * (n x p) and of A^i (m x p), the LU of B^i (LU + work) and the Cholesky
 * factor of a prior (factor + work). */
#define DKF__DIFFKF_FC_MAX(a, b) ((a) > (b) ? (a) : (b))
#define DKF__DIFFKF_FC_WORK(n, m, p) \
    DKF__DIFFKF_FC_MAX(DKF__DIFFKF_FC_MAX(DKF_MAT_PINV_WORK(n, p), DKF_MAT_RANK_WORK(m, p)), \
                       DKF__DIFFKF_FC_MAX((p) * (p) + DKF_MAT_LU_WORK(p), \
                                          (n) * (n) + DKF_MAT_CHOL_WORK(n)))

/* dkf_diffkf_fc_storage_len for l sensors that all have dimensions
 * (m, p): exact for them (dkf_diffkf_fc_init accepts no less), and an
 * upper bound for l sensors with m_i <= m, p_i <= p (every term grows with
 * m_i and p_i). */
#define DKF_DIFFKF_FC_STORAGE_LEN(n, l, m, p) \
    (2 * (l) * DKF_DIFFKF_STORAGE_LEN(n, m, p) + DKF_DIFFKF_STORAGE_LEN(n, (l) * (m), (l) * (p)) \
     + DKF_DIFFKF_STATE_LEN(n, (l) * (m), (l) * (p)) - DKF__DIFFKF_CARRY_LEN(n, (l) * (p)) \
     + (l) * (m) * ((n) + (l) * (p) + (l) * (m)) + 2 * (l) * (p) * (l) * (p) \
     + 4 * (l) * (p) + (p) * (n) + DKF__DIFFKF_FC_WORK(n, m, p))

/* An upper bound of dkf_diffkf_fc_storage_len for l sensors with
 * m_i <= mx, p_i <= px, for static declarations. */
#define DKF_DIFFKF_FC_STORAGE_MAX(n, l, mx, px) \
    (2 * (l) * DKF_DIFFKF_STORAGE_LEN(n, mx, px) + DKF_DIFFKF_STORAGE_LEN(n, (l) * (mx), (l) * (px)) \
     + DKF_DIFFKF_STATE_LEN(n, (l) * (mx), (l) * (px)) - DKF__DIFFKF_CARRY_LEN(n, (l) * (px)) \
     + (l) * (mx) * ((n) + (l) * (mx) + (l) * (px)) + 2 * (l) * (px) * (l) * (px) \
     + 4 * (l) * (px) + (px) * (n) + 2 * ((n) + (mx)) * ((n) + (mx)) + 2 * ((n) + (mx)))

/* Declares a fusion centre `name`, its node array `name_nodes` (l) and
 * storage `name_storage` for l sensors with m_i <= mx, p_i <= px
 * (DKF_DIFFKF_FC_STORAGE_LEN(n, l, mx, px) reals), all with the storage
 * class sc: the form of DKF_KF_DECLARE (dkf/kf.h). */
#define DKF_DIFFKF_FC_DECLARE(sc, name, n, l, mx, px) \
    sc dkf_real_t name##_storage[DKF_DIFFKF_FC_STORAGE_LEN(n, l, mx, px)]; \
    sc dkf_diffkf_fc_node_t name##_nodes[l]; \
    sc dkf_diffkf_fc_t name

/* Set-up: binds fc to nodes[0..l-1] and storage; the central filter starts
 * from (x0, P0) and replica i from P0_local[i] (the prior covariance node i
 * uses; NULL entries or a NULL array mean P0). The replicas' x is never
 * used. Checks p_i <= n, p_i <= m_i, the stacked dimensions, storage and
 * priors. On failure *fault names the condition and the node. */
dkf_status_t dkf_diffkf_fc_init(dkf_diffkf_fc_t *fc, dkf_diffkf_fc_node_t nodes[], size_t l,
                                size_t n, const size_t m[], const size_t p[], dkf_real_t *storage,
                                size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0,
                                const dkf_mat_t *const P0_local[], dkf_diffkf_fc_fault_t *fault);

/* Start (as every node's dkf_diffkf_start): the prediction to time 1 with
 * (F0, Q0) and the measurement models at 1, sensors[i].meas. Checks D^i_1
 * full column rank and B^i_1 (sensors[i].B, the B of step 1) nonsingular. */
dkf_status_t dkf_diffkf_fc_start(dkf_diffkf_fc_t *fc, const dkf_mat_t *F0, const dkf_mat_t *Q0,
                                 const dkf_diffkf_sensor_t sensors[], dkf_diffkf_fc_fault_t *fault);

/* Step k = fc->k + 1: F, Q = F_k, Q_k; sensors[i] = (B^i_k, Rd^i_k,
 * model^i at k+1); msgs[i] = node i's message of step k. Afterwards
 * fc->central holds the fused x_{k|k}, P_{k|k}, x_{k+1|k}, P_{k+1|k}.
 * Statuses (with *fault): message node -> DKF_ERR_ARG, step -> DKF_ERR_STATE,
 * n -> DKF_ERR_DIM, NaN/Inf -> DKF_ERR_NONFINITE (all before anything is
 * computed); rank K^i_k < p_i -> DKF_ERR_RANK (K_RANK); D^i_{k+1} rank ->
 * DKF_ERR_RANK (D_RANK); B^i_k singular -> DKF_ERR_SINGULAR; L_k not SPD ->
 * DKF_ERR_NOT_SPD. */
dkf_status_t dkf_diffkf_fc_step(dkf_diffkf_fc_t *fc, const dkf_mat_t *F, const dkf_mat_t *Q,
                                const dkf_diffkf_sensor_t sensors[], const dkf_diffkf_msg_t msgs[],
                                dkf_diffkf_fc_fault_t *fault);

/* The steady gain (dkf_diffkf_set_steady) for the central filter and
 * every replica: with tol > 0 and a time-invariant model, once the
 * covariance recursion has settled to tol, a step with every node present
 * and in sync reuses the last gains and costs O(N) work plus O(p^2) for
 * the central carry instead of O(p^3) (docs/design/diffkf-fusion.md §11 measures
 * the cost and the distance to the recomputed centre). 0 (the default)
 * is off; DKF_ERR_ARG unless 0 <= tol < 1; DKF_ERR_STATE before init.
 * With it on, a checkpoint restore recomputes the gains, so the steps
 * after it agree with the saved centre's to the tolerance, not bitwise. */
dkf_status_t dkf_diffkf_fc_set_steady(dkf_diffkf_fc_t *fc, dkf_real_t tol);

/* ---- degraded steps (docs/design/diffkf-fusion.md §8) ------------------------------ */

/* As dkf_diffkf_fc_step with some node messages absent (present[i] == 0;
 * msgs[i] is then ignored; present == NULL means all present). Node i's
 * z^i_k is recovered iff its message of step k is present AND its replica
 * is in sync (nodes[i].sync: its message of k-1 was present, or it
 * (re)started at k); otherwise its rows are masked out of the central step
 * (dkf_diffkf_gain_masked), which is then the optimal estimate given the
 * data received. A present node that is out of sync still has dz^i_k
 * recovered, so it is in sync again at k+1; an absent node's replica keeps
 * its data-independent recursion going and goes out of sync.
 * contributed[i] (may be NULL; written only on success) = 1 iff z^i_k
 * entered the fused estimate. fc->central.z/dz then hold the contributing
 * nodes' rows only (central.pk of them). With every node present and in
 * sync the result is bit-identical to dkf_diffkf_fc_step. Checks and
 * statuses as dkf_diffkf_fc_step (messages of absent nodes are not
 * checked, nor is rank K^i_k of an absent node). */
dkf_status_t dkf_diffkf_fc_step_partial(dkf_diffkf_fc_t *fc, const dkf_mat_t *F, const dkf_mat_t *Q,
                                        const dkf_diffkf_sensor_t sensors[],
                                        const dkf_diffkf_msg_t msgs[], const unsigned char present[],
                                        unsigned char contributed[], dkf_diffkf_fc_fault_t *fault);

/* Node `node` restarted its local filter at time k_start as
 * dkf_diffkf_init(x_any, P_prior) + dkf_diffkf_start(F0 = NULL, Q0 = NULL,
 * its model at k_start, y^i_{k_start}) (+ dkf_diffkf_set_time(k_start - 1)
 * so that its messages carry absolute times). P_prior is the prior
 * covariance of x_{k_start} it used (the scenario's P00_local[i] by
 * convention; the node's x prior does not matter to the FC). The FC
 * restarts the replica likewise and marks it in sync: the node's first
 * message after the restart is that of step k_start. Call it after
 * dkf_diffkf_fc_start and before the step k_start, i.e. k_start = fc->k + 1
 * (else DKF_ERR_STATE, SEQUENCE). sensor_at_kstart->meas is the model at
 * k_start (B, Rd are not used and may be NULL). A node that starts late is
 * a restart with k_start > 1. Faults: node >= l -> DKF_ERR_ARG (ARG);
 * P_prior -> PRIOR; meas -> MODEL / D_RANK. The FC is unchanged on
 * failure. */
dkf_status_t dkf_diffkf_fc_restart_node(dkf_diffkf_fc_t *fc, size_t node, size_t k_start,
                                        const dkf_mat_t *P_prior,
                                        const dkf_diffkf_sensor_t *sensor_at_kstart,
                                        dkf_diffkf_fc_fault_t *fault);

/* Checkpoints of the whole FC state (the central filter, the replicas,
 * the sync flags, the recovered z/dz, k and the start flag) into caller
 * memory, and back, for rollback and replay. A checkpoint is
 * dkf_diffkf_fc_checkpoint_len(fc) reals (0 if fc is NULL or not
 * initialised): a header of small integers (tag, n, l, sum m_i, sum p_i, k
 * as four 16-bit digits, started), then dkf_diffkf_save of the central
 * filter and of each replica, each node's sync flag, and the recovered
 * z, dz. Restore needs an FC initialised with the same dimensions (the
 * storage binding is kept); it validates the whole buffer before writing
 * anything (DKF_ERR_CAPACITY, DKF_ERR_ARG, DKF_ERR_DIM, DKF_ERR_NONFINITE as
 * dkf_diffkf_checkpoint_check; the FC is unchanged on failure). After a
 * restore the FC steps bit-identically to the FC that was saved. */
size_t dkf_diffkf_fc_checkpoint_len(const dkf_diffkf_fc_t *fc);
dkf_status_t dkf_diffkf_fc_save(const dkf_diffkf_fc_t *fc, dkf_real_t *buf, size_t len);
dkf_status_t dkf_diffkf_fc_restore(dkf_diffkf_fc_t *fc, const dkf_real_t *buf, size_t len);

#ifdef __cplusplus
}
#endif

#endif /* DKF_DIFFKF_FUSION_H */
