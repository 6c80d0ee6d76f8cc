/*
 * dkf/selftune.h - self-tuning identifier for seed 002 (Zhang, "Distributed
 * fusion Kalman self-tuning filter"): the unknown signal model of the
 * sensors
 *   y_i(t) = s(t) + eta(t) + v_i(t),  i = 1..L                 (seed 002 example)
 *   A(q^-1) s(t)   = C(q^-1) w(t-1),  A = 1 + a_1 q^-1 + ... + a_na q^-na,
 *                                      C = 1 [+ c_1 q^-1]     (unknown, with sigma_w^2)
 *   P(q^-1) eta(t) = xi(t-1),          P = 1 + p_1 q^-1 + ... + p_np q^-np (known,
 *                                      with sigma_xi^2 and every sigma_vi^2)
 * identified recursively by the correlation method of docs/design/selftune.md
 * (the paper's step 1 names a "recursive auxiliary variable" and a
 * "G-W-CLS" algorithm but gives neither):
 *   ybar(t) = (1/L) sum_i y_i(t);
 *   r_ybar(k), k = 0..K: recursive sample autocovariances (a ring of the
 *     last K values of ybar, running means and co-moments per lag);
 *   r_s(k) = r_ybar(k) - r_eta(k) - delta_k0 sum_i sigma_vi^2 / L^2
 *     (r_eta: the stationary autocovariance of eta, solved once at init);
 *   (a_1..a_na): least squares on r_s(k) + sum_j a_j r_s(k-j) = 0,
 *     k = nc+1..K (the MA part of A s = C w(t-1) ends at lag nc);
 *   u = A s: r_u(0) = sigma_w^2 (1 + c_1^2), r_u(1) = sigma_w^2 c_1, whose
 *     invertible factor gives c_1 and sigma_w^2 (nc = 1), or
 *     sigma_w^2 = r_u(0) (nc = 0).
 * Guards (a failed guard keeps the previous accepted estimate): A-hat
 * stable with every root |z| < root_max (0.99), |r_u(1)/r_u(0)| <=
 * rho_max (0.499), sigma_w^2 >= sigma_w2_min (1e-3), a non-singular
 * least-squares problem, and t >= t_min (50).
 *
 * dkf_selftune_model turns an estimate into the observer-form model of
 * the seed's (1): x = [x_s; x_eta], n = na + max(np, 1),
 *   F = blkdiag(Phi_A, Phi_P), Phi_A = [-a | I; 0] (first column -a_1..-a_na,
 *   ones on the superdiagonal), Gamma = blkdiag([1; c_1; 0..], [1; 0..]),
 *   Q = Gamma diag(sigma_w^2, sigma_xi^2) Gamma^T,
 * H = (1 0..0 1 0..0) (s + eta), H_s = (1 0..0), for dkf/wfusion.h's
 * dkf_kf_dyn_t {F, Q}.
 *
 * Limits: na 1..DKF_SELFTUNE_MAX_NA (4), np 0..DKF_SELFTUNE_MAX_NP (4),
 * nc 0 or 1 with nc < na, lags K in [na + nc, DKF_SELFTUNE_MAX_LAG (32)].
 * Tested: the seed's example (na = 2, np = 2, nc = 1, K = 5) and the
 * closed-form and guard cases of tests/test_selftune.c.
 */
#ifndef DKF_SELFTUNE_H
#define DKF_SELFTUNE_H

#include <stddef.h>

#include "dkf/mat.h"

#ifdef __cplusplus
extern "C" {
#endif

#define DKF_SELFTUNE_MAX_NA 4
#define DKF_SELFTUNE_MAX_NP 4
#define DKF_SELFTUNE_MAX_LAG 32

/* The storage for AR order na, known-noise order np, MA order nc and lags
 * K: the ring of K past ybar values; per lag 0..K the two running means,
 * the co-moment and r_eta; the P coefficients; the accepted and the last
 * raw estimate (na + nc + 1 reals each) and the raw rho. Everything is
 * state (a step needs no scratch beyond a few DKF_SELFTUNE_MAX_LAG-sized
 * stack vectors). */
#define DKF_SELFTUNE_STORAGE_LEN(na, np, nc, K) \
    ((K) + 4 * ((K) + 1) + (np) + 2 * ((na) + (nc) + 1) + 1)
#define DKF_SELFTUNE_STATE_LEN(na, np, nc, K) DKF_SELFTUNE_STORAGE_LEN(na, np, nc, K)

/* Why the current step's estimate was not accepted (dkf_selftune_est_t.guard). */
typedef enum {
    DKF_SELFTUNE_GUARD_NONE = 0,     /* accepted at this step */
    DKF_SELFTUNE_GUARD_WARMUP = 1,   /* t < t_min (or t <= K): not estimated yet */
    DKF_SELFTUNE_GUARD_SINGULAR = 2, /* the least-squares normal matrix is singular */
    DKF_SELFTUNE_GUARD_UNSTABLE = 3, /* a root of A-hat has |z| >= root_max */
    DKF_SELFTUNE_GUARD_RHO = 4,      /* |r_u(1) / r_u(0)| > rho_max (nc = 1) */
    DKF_SELFTUNE_GUARD_SIGMA = 5     /* r_u(0) <= 0 or sigma_w^2 < sigma_w2_min */
} dkf_selftune_guard_t;

typedef struct {
    size_t na;               /* AR order of A(q^-1), 1..DKF_SELFTUNE_MAX_NA */
    size_t np;               /* order of the known P(q^-1), 0..DKF_SELFTUNE_MAX_NP */
    size_t nc;               /* MA order of C(q^-1), 0 or 1, nc < na */
    size_t lags;             /* K: autocovariances r(0..K), K in [na + nc, MAX_LAG] */
    size_t t_min;            /* first step whose estimate is used (>= 1) */
    size_t L;                /* sensors (>= 1) */
    const dkf_real_t *p;     /* p_1..p_np of P(q^-1), stable (NULL if np = 0) */
    dkf_real_t sigma_xi2;    /* variance of xi (>= 0) */
    const dkf_real_t *sigma_v2; /* L sensor noise variances (>= 0) */
    dkf_real_t root_max;     /* stability guard radius, (0, 1] */
    dkf_real_t rho_max;      /* MA(1) guard, (0, 0.5) */
    dkf_real_t sigma_w2_min; /* floor of sigma_w^2, > 0 */
    /* the estimate held until one is accepted */
    dkf_real_t a0[DKF_SELFTUNE_MAX_NA]; /* a_1..a_na */
    dkf_real_t c0;           /* c_1 (ignored if nc = 0) */
    dkf_real_t sigma_w2_0;   /* sigma_w^2 (>= 0) */
} dkf_selftune_cfg_t;

typedef struct {
    size_t na, np, nc;
    dkf_real_t a[DKF_SELFTUNE_MAX_NA]; /* accepted a_1..a_na */
    dkf_real_t c1;                     /* accepted c_1 (0 if nc = 0) */
    dkf_real_t sigma_w2;               /* accepted sigma_w^2 */
    int ready;     /* 1: accepted at this step (t >= t_min, every guard passed) */
    dkf_selftune_guard_t guard; /* why not (DKF_SELFTUNE_GUARD_NONE if ready) */
    size_t t;          /* steps fed */
    size_t t_accepted; /* step of the accepted estimate, 0: the cfg's guesses */
    /* the step's raw (unguarded) estimate, valid when guard is not WARMUP
     * or SINGULAR */
    dkf_real_t a_raw[DKF_SELFTUNE_MAX_NA];
    dkf_real_t c1_raw, sigma_w2_raw, rho_raw;
} dkf_selftune_est_t;

typedef struct {
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        size_t na, np, nc, K, L, t_min;
        size_t t;          /* steps fed */
        size_t head;       /* ring index of the oldest stored ybar */
        size_t t_accepted;
        dkf_selftune_guard_t guard;
        dkf_real_t inv_L;       /* 1 / L */
        dkf_real_t sv_term;     /* sum_i sigma_vi^2 / L^2 */
        dkf_real_t sigma_xi2, root_max, rho_max, sigma_w2_min;
        dkf_real_t *ring;       /* K past ybar, ring[(head + j) % K] = ybar(t - K + j) */
        dkf_real_t *mx, *my, *cm; /* per lag k: mean of ybar(tau), of ybar(tau-k), co-moment */
        dkf_real_t *reta;       /* r_eta(0..K) */
        dkf_real_t *p;          /* p_1..p_np */
        dkf_real_t *acc;        /* accepted a_1..a_na, [c_1], sigma_w^2 */
        dkf_real_t *raw;        /* raw a_1..a_na, [c_1], sigma_w^2, rho */
    } priv;
} dkf_selftune_t;

/* `name` and `name_storage`, storage class sc (the form of DKF_KF_DECLARE). */
#define DKF_SELFTUNE_DECLARE(sc, name, na, np, nc, K) \
    sc dkf_real_t name##_storage[DKF_SELFTUNE_STORAGE_LEN(na, np, nc, K)]; \
    sc dkf_selftune_t name

/* The seed's example with its defaults: na = 2, np = 0 (set np, p,
 * sigma_xi2, L, sigma_v2), nc = 1, K = 5, t_min = 50, root_max = 0.99,
 * rho_max = 0.499, sigma_w2_min = 1e-3, guesses a = 0, c_1 = 0,
 * sigma_w^2 = 1. */
dkf_status_t dkf_selftune_config_default(dkf_selftune_cfg_t *cfg);

/* Storage length for cfg's orders (0 if they are out of range). */
size_t dkf_selftune_storage_len(size_t na, size_t np, size_t nc, size_t K);

/* Binds id to storage and computes r_eta(0..K) from P and sigma_xi^2
 * (Yule-Walker: a small linear solve). DKF_ERR_ARG for a configuration
 * outside the limits above (including a P with a root |z| >= 1, NaN/Inf
 * or a negative variance), DKF_ERR_CAPACITY for storage_len below
 * DKF_SELFTUNE_STORAGE_LEN. */
dkf_status_t dkf_selftune_init(dkf_selftune_t *id, const dkf_selftune_cfg_t *cfg,
                               dkf_real_t *storage, size_t storage_len);

/* One time step with the L measurements y[0..L-1]: updates the
 * autocovariances and, from t >= t_min, estimates and applies the guards.
 * DKF_ERR_NONFINITE for NaN/Inf in y or an overflow of the statistics,
 * the object untouched. */
dkf_status_t dkf_selftune_update(dkf_selftune_t *id, const dkf_real_t y[]);

/* The accepted estimate, the guard of the last step, the raw estimate. */
dkf_status_t dkf_selftune_estimate(const dkf_selftune_t *id, dkf_selftune_est_t *est);

/* r_ybar(0..K) (r[0..K], K = cfg lags) of the steps fed so far: for lag k
 * and t > k steps, (1/(t-k)) sum_{tau=k+1..t} (ybar(tau) - mx_k)(ybar(tau-k)
 * - my_k), mx_k and my_k the means of the two factors over the same pairs;
 * 0 for t <= k. */
dkf_status_t dkf_selftune_autocov(const dkf_selftune_t *id, dkf_real_t r[], size_t len);

/* r_eta(0..K) computed at init into r[0..K]. */
dkf_status_t dkf_selftune_noise_autocov(const dkf_selftune_t *id, dkf_real_t r[], size_t len);

/* The observer-form model of est (its a, c1, sigma_w2; id's P and
 * sigma_xi^2): F and Q, n x n with n = na + max(np, 1). DKF_ERR_DIM for
 * another shape, DKF_ERR_ARG if est's orders are not id's; F, Q written
 * only on success. */
dkf_status_t dkf_selftune_model(const dkf_selftune_t *id, const dkf_selftune_est_t *est,
                                dkf_mat_t *F, dkf_mat_t *Q);

/* n = na + max(np, 1), the model's state dimension. */
dkf_status_t dkf_selftune_model_dim(const dkf_selftune_t *id, size_t *n);

#ifdef __cplusplus
}
#endif

#endif /* DKF_SELFTUNE_H */
