/*
 * dkf/diffkf.h - the Difference Kalman filter (seed 000, Ruan-Luo-Zhu 2018,
 * Theorem 1, with the corrections of docs/design/diffkf.md).
 *
 * Model: dkf/ui_model.h (state n, measurement m, unknown input p; D_k of
 * full column rank, B_k nonsingular; every matrix may change with k, the
 * dimensions may not).
 *
 * The unknown input d is never estimated: it is removed by differencing
 *   z_k = G_k y_{k+1} - D_k^+ y_k,   G_k = B_k^{-1} D_{k+1}^+          (8)
 *       = M_k x_k + u_k,             M_k = G_k H_{k+1} F_k - D_k^+ H_k   (10)-(11)
 * whose noise u_k is correlated with v_k and with u_{k-1}; the filter is
 * the optimal (MMSE given z) recursion for that model. It never needs d_0.
 *
 * ONE-STEP DELAY. z_k needs y_{k+1}, so the step that consumes y_{k+1}
 * yields x_{k|k} (xf, for time k) and the prediction x_{k+1|k} (xn, "next"). The
 * filter's field `k` is the time of xf. x_{k+1|k} uses the same data
 * y_1..y_{k+1} as an ordinary KF's x_{k+1|k+1}.
 *
 * Calls:
 *   dkf_diffkf_init    (x_{0|0}, P_{0|0}): k = 0
 *   dkf_diffkf_start   (F_0, Q_0, model at 1, y_1): predicts x_{1|0} and
 *                      stores y_1; no estimate for a new time yet
 *   dkf_diffkf_step    (dynamics at k, model at k+1, y_{k+1}), k = 1, 2, ...:
 *                      x_{k|k}, P_{k|k}, x_{k+1|k}, P_{k+1|k}; k advances
 * A step is also available in two phases for a fusion centre that knows the
 * differenced measurement z_k rather than y: dkf_diffkf_gain computes
 * everything that does not depend on data (M, J, L, K, ...), then
 * dkf_diffkf_update_z applies z_k. A failed call of any kind leaves the
 * struct and the first DKF_DIFFKF_STATE_LEN reals of the storage (the
 * estimates, everything carried between steps, and the caches)
 * bit-identical, with one exception: a failed dkf_diffkf_gain(_masked)
 * cancels a pending gain (pending = 0, pk = z.rows; docs/decisions.md
 * item 37: forming a gain aside would need a second pending area).
 * Every other check comes before the first write. dkf_diffkf_step
 * refuses to run while a gain is pending (DKF_ERR_STATE): complete it with
 * dkf_diffkf_update_z, or replace it with a new dkf_diffkf_gain.
 */
#ifndef DKF_DIFFKF_H
#define DKF_DIFFKF_H

#include <stddef.h>

#include "dkf/mat.h"
#include "dkf/ui_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reals of storage for dimensions (n, m, p). */
#define DKF_DIFFKF_STORAGE_LEN(n, m, p) \
    (3 * (n) + 2 * (n) * (n) + 2 * (p) + 2 * (n) * (p) + (p) * (p) /* outputs */ \
     + 4 * (n) * (n) + 12 * (n) * (p) + 16 * (p) * (p) + 4 * (m) * (p) + 4 * (p) + 2 \
     /* carried, caches of D^+ and B^{-1}, pending gain, row selection and data, scratch */ \
     + 2 * (n) * (n) + (n) * (p) + 3 * (p) * (p) + (m) * (p) + (m) * (n) + (m) * (m) \
     /* the model inputs of the memoised model-only block */ \
     + 2 * (m) * (p) + 4 * (n) * (p) + 4 * (p) * (p) \
     /* the memoised block, new D^+ and B^{-1} before they are cached */ \
     + DKF_MAT_SVD_WORK(m, p) + DKF_MAT_INV_WORK(p) \
     + 3 * (n) * (n) + 4 * (n) * (p) /* scratch of the Joseph-type covariances */)
/* The first DKF_DIFFKF_STATE_LEN(n, m, p) reals of the storage hold the
 * estimates and the step's views, the carry between steps, and the caches
 * of D^+, B^{-1} and the model-only block: every failed call leaves them
 * and the struct bit-identical (a failed dkf_diffkf_gain(_masked) also
 * sets pending = 0 and pk = z.rows, cancelling a pending gain). The next
 * reals, up to DKF_DIFFKF_STORAGE_LEN, are the pending gain (state while
 * f->pending, DKF_DIFFKF_PENDING_LEN) and scratch. */
#define DKF_DIFFKF_STATE_LEN(n, m, p) \
    (3 * (n) + 2 * (n) * (n) + 2 * (p) + 2 * (n) * (p) + (p) * (p) /* outputs */ \
     + 3 * (p) * (p) + 2 * (n) * (p) + 2 * (p) /* carry */ \
     + 2 * (m) * (p) + 2 * (p) * (p) /* D, B caches */ \
     + 2 * (n) * (n) + 5 * (n) * (p) + 6 * (p) * (p) + 2 * (m) * (p) + (m) * (n) + (m) * (m))
/* Private (for dkf/diffkf_fusion.h's sizes): the first
 * DKF__DIFFKF_CARRY_LEN(n, p) reals of the state are what a step rewrites
 * (the estimates, the step's views and the carry); the caches follow and
 * change only when cache_gen advances. */
#define DKF__DIFFKF_CARRY_LEN(n, p) \
    (3 * (n) + 2 * (n) * (n) + 2 * (p) + 2 * (n) * (p) + (p) * (p) /* outputs */ \
     + 3 * (p) * (p) + 2 * (n) * (p) + 2 * (p) /* carry */)
/* The pending gain: the DKF_DIFFKF_PENDING_LEN(n, m, p) reals after the
 * state, which a failed dkf_diffkf_update_z or a refused dkf_diffkf_step
 * leave bit-identical too. */
#define DKF_DIFFKF_PENDING_LEN(n, m, p) \
    ((p) * (m) + 6 * (n) * (p) + 9 * (p) * (p) + 3 * (n) * (n) + 2 * (p) + 2)

typedef struct {
    size_t n, m, p;
    size_t k;        /* time of xf and xp; xn is for k + 1 */
    size_t pk;       /* rows of z_k kept by the pending gain, or (none
                        pending) by the last completed step; p before the
                        first step. z, dz, J, L, K have pk rows/columns */
    size_t pc;       /* rows the last completed step kept (0 before the
                        first step): the columns of the carry */
    /* estimates */
    /* Names as everywhere in dkf (dkf-run's outputs, the golden vectors, the
     * node message): xp is x_{k|k-1}, xf is x_{k|k}; xn is the one-step-ahead
     * prediction x_{k+1|k} that the next step updates. */
    dkf_mat_t xf, Pf; /* x_{k|k}, P_{k|k} */
    dkf_mat_t xn, Pn; /* x_{k+1|k}, P_{k+1|k} */
    /* the last step's quantities (for inspection, tests, messages) */
    dkf_mat_t z;  /* z_k (its kept rows), pk x 1 */
    dkf_mat_t dz; /* innovation dz_k = z_k - z_{k|k-1}, pk x 1 */
    dkf_mat_t J;  /* J_k = E[x~_{k|k-1} dz_k^T], n x pk */
    dkf_mat_t L;  /* L_k = Cov(dz_k), pk x pk */
    dkf_mat_t K;  /* K_k = J_k L_k^{-1}, n x pk */
    dkf_mat_t xp;  /* x_{k|k-1}, n x 1: the prediction the last step updated
                      (xn before that step; a fusion-centre message sends it
                      with x_{k|k}) */
    int pending;     /* a dkf_diffkf_gain awaits dkf_diffkf_update_z */
    int steady;      /* the last completed step reused the settled gain
                        (dkf_diffkf_set_steady) */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *mem; /* everything else (carry, caches, scratch) */
        int ready;       /* dkf_diffkf_init done */
        int started;     /* dkf_diffkf_start done */
        int has_y;       /* D_k^+ y_k is stored, so dkf_diffkf_step can difference */
        /* caches of D^+, B^{-1} and the model-only block (valid flags): derived
         * data, changed only by a successful call */
        int d_cached, b_cached, model_cached;
        unsigned long cache_gen; /* counts the calls that wrote the caches: a copy
                                    of them taken at one value is current while
                                    the value holds (the fusion centre's snapshot) */
        dkf_real_t steady_tol;   /* dkf_diffkf_set_steady's tolerance; 0 = off */
    } priv;
} dkf_diffkf_t;

/* `name` and `name_storage`, storage class sc (static, extern or empty):
 * the form of DKF_KF_DECLARE (dkf/kf.h). */
#define DKF_DIFFKF_DECLARE(sc, name, n, m, p) \
    sc dkf_real_t name##_storage[DKF_DIFFKF_STORAGE_LEN(n, m, p)]; \
    sc dkf_diffkf_t name

/* Binds f to storage and sets (x_{0|0}, P_{0|0}) = (x0, P0); P0 SPD. */
dkf_status_t dkf_diffkf_init(dkf_diffkf_t *f, size_t n, size_t m, size_t p, dkf_real_t *storage,
                             size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0);

/* Predicts x_{1|0} = F0 x_{0|0}, P_{1|0} = F0 P_{0|0} F0^T + Q0 and takes
 * the first measurement y_1 with its model. The first step has no previous
 * innovation (every term with L_0^{-1} is zero, docs/design/derivation-seed000.md §2).
 * With F0 = Q0 = NULL, (x0, P0) of init are taken as the prior
 * (x_{1|0}, P_{1|0}) of the first measured time instead (the general
 * start of the derivation (docs/design/derivation-seed000.md), k0 = the first measurement). */
dkf_status_t dkf_diffkf_start(dkf_diffkf_t *f, const dkf_mat_t *F0, const dkf_mat_t *Q0,
                              const dkf_ui_meas_t *meas1, const dkf_mat_t *y1);

/* One step of Theorem 1 with y_{k+1}: the dynamics at k and the model at
 * k+1. Statuses: DKF_ERR_RANK if D_{k+1} lacks full column rank,
 * DKF_ERR_SINGULAR if B_k is singular, DKF_ERR_NOT_SPD if L_k is not SPD
 * or P_{k|k}, P_{k+1|k} is not PSD within 4 n eps tr P (an indefinite Q,
 * R or Rd; both are Joseph-type forms with DKF_JOSEPH, docs/design/diffkf.md),
 * DKF_ERR_NONFINITE, DKF_ERR_DIM, DKF_ERR_STATE (before start, or while
 * a gain is pending). */
dkf_status_t dkf_diffkf_step(dkf_diffkf_t *f, const dkf_ui_dyn_t *dyn,
                             const dkf_ui_meas_t *meas_next, const dkf_mat_t *y_next);

/* Two-phase step. gain: everything of the step that does not depend on
 * data (M_k, Ru_k, S_k, J_k, L_k, K_k, G_k, C_{k+1}); afterwards f->J,
 * f->L, f->K are NOT yet updated: read them with dkf_diffkf_pending(). */
dkf_status_t dkf_diffkf_gain(dkf_diffkf_t *f, const dkf_ui_dyn_t *dyn,
                             const dkf_ui_meas_t *meas_next);
/* As dkf_diffkf_gain, for a step whose differenced measurement z_k is only
 * partly received: rows[j] != 0 keeps row j of z_k (p flags; NULL = all
 * rows). The step is the optimal (MMSE) estimate given every kept row so
 * far: Theorem 1 with a time-varying selection S_k (M' = S M,
 * Ru' = S Ru S^T, S' = S_cov S^T, C'_k = S_k C_k S_{k-1}^T with S_{k-1} the
 * previous step's selection; docs/design/diffkf-fusion.md §8). Afterwards f->pk is
 * the number of rows kept, and dkf_diffkf_update_z takes those pk rows of
 * z_k, in order; the step's z, dz, J, L, K views get pk rows/columns.
 * pk = 0 is a pure prediction: x_{k|k} = x_{k|k-1}, P_{k|k} = P_{k|k-1},
 * x_{k+1|k} = F x_{k|k-1}, P_{k+1|k} = F P F^T + Q, and the next step has
 * no previous innovation. With all rows kept the results are bit-identical
 * to dkf_diffkf_gain. */
dkf_status_t dkf_diffkf_gain_masked(dkf_diffkf_t *f, const dkf_ui_dyn_t *dyn,
                                    const dkf_ui_meas_t *meas_next, const unsigned char *rows);
/* Views of the pending M'_k (pk x n), K_k (n x pk), and C'_k L'_{k-1}^{-1} dz'_{k-1}
 * (pk x 1, the correlated part of the predicted z: zero at the first step
 * and after a step that kept no row), valid after a successful
 * dkf_diffkf_gain(_masked). */
dkf_status_t dkf_diffkf_pending(const dkf_diffkf_t *f, dkf_mat_t *M, dkf_mat_t *K,
                                dkf_mat_t *zcorr);
/* Applies z_k (its f->pk kept rows, pk x 1) to the pending gain and
 * completes the step. With pk = 0, z may be NULL (or a 0 x 1 view). y_next
 * may be NULL; if given, D_{k+1}^+ y_{k+1} is stored so that a later
 * dkf_diffkf_step can difference against it. */
dkf_status_t dkf_diffkf_update_z(dkf_diffkf_t *f, const dkf_mat_t *z, const dkf_mat_t *y_next);

/* The steady gain, for a time-invariant model: with tol > 0, a step
 * whose P_{k+1|k}, W_k and whitened carry Vt each moved by at most tol
 * relative to their largest entry (max |new - old| <= tol max |old|),
 * with every row kept in it and the step before, settles the gain; while
 * the model (every matrix, bitwise) stays the same and every row is kept,
 * the following steps reuse that gain and apply only their data (the
 * cost of dkf_diffkf_update_z plus one p x p product, instead of the
 * O(n^3 + p^3) gain). Any other step, a model change, a restore or a
 * masked row computes the gain afresh. The estimates then differ from the
 * recomputed ones by the gain's motion below tol (the recursion converges
 * to a fixed point up to rounding; docs/design/diffkf-fusion.md §11 measures it).
 * tol = 0 (the default after init) is off: every step computes its gain.
 * DKF_ERR_ARG unless 0 <= tol < 1; DKF_ERR_STATE before init. */
dkf_status_t dkf_diffkf_set_steady(dkf_diffkf_t *f, dkf_real_t tol);

/* Sets the time index k of xf. A filter (re)started at an absolute time
 * k_start (dkf_diffkf_init + dkf_diffkf_start with F0 = Q0 = NULL) counts
 * from 0; dkf_diffkf_set_time(f, k_start - 1) after the start makes its
 * steps, and the messages of dkf/diffkf_fusion.h, carry absolute times. */
dkf_status_t dkf_diffkf_set_time(dkf_diffkf_t *f, size_t k);

/* Checkpoints: everything a later step depends on (estimates, the last
 * step's views, the carry, k and the start flags) into caller memory, and
 * back, for rollback and replay. A checkpoint is
 * dkf_diffkf_checkpoint_len(f) reals (0 if f is NULL or not initialised):
 * a header of small integers (a tag, n, m, p, k as four 16-bit digits,
 * the view size, the carry size, the flags; exact in float too), then the
 * state verbatim. A pending gain is not saved; restore cancels it. Restore
 * needs a filter initialised with the same (n, m, p) (its storage binding
 * is kept); after it the filter steps bit-identically to the one saved.
 * check validates a checkpoint without applying it: DKF_ERR_CAPACITY (too
 * short), DKF_ERR_ARG (tag or header field not a valid integer),
 * DKF_ERR_DIM (other dimensions), DKF_ERR_NONFINITE. */
size_t dkf_diffkf_checkpoint_len(const dkf_diffkf_t *f);
dkf_status_t dkf_diffkf_save(const dkf_diffkf_t *f, dkf_real_t *buf, size_t len);
dkf_status_t dkf_diffkf_checkpoint_check(const dkf_diffkf_t *f, const dkf_real_t *buf,
                                         size_t len);
dkf_status_t dkf_diffkf_restore(dkf_diffkf_t *f, const dkf_real_t *buf, size_t len);

#ifdef __cplusplus
}
#endif

#endif /* DKF_DIFFKF_H */
