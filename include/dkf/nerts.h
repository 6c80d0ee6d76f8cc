/*
 * dkf/nerts.h - single-node nonlinear joint state and unknown-input
 * filters of seed 001 (Ding, Xiao, Zhang 2014), with the corrections
 * docs/design/nerts.md lists.
 *
 *   x_{k+1} = f(x_k, d_k, u_k) + w_k,   w ~ N(0, Q_k)
 *   z_k     = h(x_k, d_k, u_k) + v_k,   v ~ N(0, R_k), R_k > 0
 *
 * given as a dkf_nl_model_t (dkf/nl_model.h; the paper's g, A, G, C, H are
 * h, Fx, Fd, Hx, Hd). d_k is arbitrary (no model, no prior); rank Hd = p
 * (full column rank) is required at every step. Four filters share one
 * filter type; the kind is fixed at init:
 *
 *   DKF_NERTS_NERTSF    Hsieh's NERTSF, EKF, covariance form (eqs 10-20)
 *   DKF_NERTS_NERTSIF   Algorithm 1, EKF, information form with the
 *                       corrected R-bar^{-1} = Pi(R-bar', Hd) (the printed
 *                       (I - Hd M)^{-1} of eqs 22/53 does not exist)
 *   DKF_NERTS_DNERTSF   Algorithm 2's cubature filter, covariance form
 *   DKF_NERTS_DNERTSIF  Algorithm 2, cubature, information form
 *
 * Covariance and information forms give the same estimates (up to
 * rounding); the cubature kinds equal the EKF kinds on a linear model.
 * p = 0 is allowed (no unknown input: seed 001's DF-CKF; with a linear
 * model NERTSIF is then dkf/info.h's information filter).
 *
 * A step in phases (the distributed filter, dkf/dfnerts.h, runs the
 * consensus between the second and the third):
 *   1. dkf_nerts_predict   time update from the posterior (x, Px, d, Pd,
 *                          Pxd) at k-1: x_pred, P_pred, and for the
 *                          information kinds Y_pred = P_pred^{-1},
 *                          y_pred = Y_pred x_pred.
 *   2. dkf_nerts_local     the local measurement statistics of z_k: z_hat,
 *                          nu, R_tilde, Pxz, C, Rbar, M, the input estimate
 *                          d_loc, Pd_loc, Pxd_loc, and for the information
 *                          kinds Rbar_inv and the contributions i, I.
 *   3. dkf_nerts_update    commits the filter's own measurement update
 *      or                  (covariance form: x = x_pred + L nu, Px =
 *                          P_pred - L Pxz^T, or its equal Joseph form with
 *                          DKF_JOSEPH; information form: Y = Y_pred
 *                          + I, y = y_pred + i, Px = Y^{-1}, x = Px y);
 *      dkf_nerts_commit_info commits a given (Y, y) (e.g. after consensus):
 *                          Px = Y^{-1}, x = Px y.
 *   Either commit also takes d = d_loc, Pd = Pd_loc, Pxd = Pxd_loc.
 * dkf_nerts_step does the three in one call. predict may be called in
 * any phase (it discards a step in progress); local needs a predict
 * before it (and may be repeated); a commit needs a local before it. A
 * call out of this order is DKF_ERR_STATE.
 *
 * Time index: after init f->k = 0; predict evaluates f at time f->k (the
 * step k -> k+1) and local evaluates h at f->k + 1; a commit increments
 * f->k. The model is an argument of each phase (it may differ between
 * calls, its n, m, p may not).
 *
 * Equations (docs/design/nerts.md; nu = y_diff(z, z_hat)):
 *   EKF (NERTSF / NERTSIF): Fx, Fd at (x, d); x_pred = f(x, d);
 *     P_pred = [Fx Fd] [[Px, Pxd], [Pxd^T, Pd]] [Fx Fd]^T + Q   (10)-(11)
 *     Hx, Hd at (x_pred, d); z_hat = h(x_pred, d) - Hd d;
 *     Pxz = P_pred Hx^T, R_tilde = Hx P_pred Hx^T + R            (12)
 *     C = Hx, Rbar = R.
 *   Cubature (DNERTSF / DNERTSIF): 2(n + p) points of N([x; d], joint
 *     covariance) through f: x_pred = mean, P_pred = sample cov + Q
 *     (38)-(42); Hd at (x_pred, d) (eq 44: callback or forward
 *     differences; not with p = 0, which needs no Jacobian); 2n points re-drawn from N(x_pred, P_pred),
 *     Z_l = h(x_l, d) - Hd d, z_hat = mean, Pzz, Pxz the sample (cross)
 *     covariances (43)-(47), R_tilde = Pzz + R (the printed (46) lacks
 *     + R); C = Pxz^T P_pred^{-1} (50),
 *     Rbar = R_tilde - Pxz^T P_pred^{-1} Pxz (53 without the singular
 *     factor).
 *   Both: M = (Hd^T R_tilde^{-1} Hd)^{-1} Hd^T R_tilde^{-1} (13),
 *     d_loc = M nu (14), Pd_loc = M R_tilde M^T (15),
 *     Pxd_loc = -Pxz M^T (20); covariance form K = Pxz R_tilde^{-1},
 *     L = K (I - Hd M) (16)-(17), x = x_pred + L nu, Px = P_pred - L Pxz^T
 *     (18)-(19); information form
 *     Rbar_inv = Pi(Rbar, Hd) = Rbar^{-1} - Rbar^{-1} Hd (Hd^T Rbar^{-1}
 *     Hd)^{-1} Hd^T Rbar^{-1}, i = C^T Rbar_inv (nu + C x_pred),
 *     I = C^T Rbar_inv C (31)-(32), (51)-(52), (56)-(57).
 *
 * Angle channels (bearings): through the model's y_diff (dkf/nl_model.h),
 * which must return a - b wrapped to [-pi, pi) in those channels. Every
 * innovation is nu = y_diff(z, z_hat), and the cubature kinds unwrap the
 * points' images around h(x_pred, d): Z_l = h_c + y_diff(h(x_l, d), h_c),
 * so a bearing near +-pi does not average to 0. With y_diff == NULL the
 * images are used as they are.
 * dkf_nerts_stack composes the sensors' y_diff.
 *
 * Statuses (the filter, its views and every output are bit-identical
 * after any error):
 *   DKF_ERR_MODEL      a callback returned non-zero
 *   DKF_ERR_NONFINITE  NaN/Inf in z, u, Q, R or in a callback's result, or
 *                      produced by the step
 *   DKF_ERR_NOT_SPD    R, R_tilde, P_pred, Rbar, Y not SPD, or the joint
 *                      covariance [[Px, Pxd], [Pxd^T, Pd]] a commit would
 *                      store is not positive definite (Algorithm 3 mixing a
 *                      consensus Px with local Pd, Pxd: note section 4 item 6)
 *   DKF_ERR_RANK       Hd not of full column rank p: a pivot of the
 *                      Cholesky factor of G = Hd^T R_tilde^{-1} Hd with
 *                      L_ii^2 <= 16 p eps G_ii (docs/design/nerts.md), or m < p
 *                      at init
 *   DKF_ERR_DIM        a model, Q, R, z, Y or y of the wrong size
 *   DKF_ERR_STATE      out of order (see above), or commit_info on a
 *                      covariance kind
 *   DKF_ERR_NULL, DKF_ERR_CAPACITY, DKF_ERR_ARG (unknown kind)
 */
#ifndef DKF_NERTS_H
#define DKF_NERTS_H

#include <stddef.h>

#include "dkf/info.h"
#include "dkf/mat.h"
#include "dkf/nl_model.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    DKF_NERTS_NERTSF = 0,  /* EKF, covariance form */
    DKF_NERTS_NERTSIF = 1, /* EKF, information form (Algorithm 1) */
    DKF_NERTS_DNERTSF = 2, /* cubature, covariance form */
    DKF_NERTS_DNERTSIF = 3 /* cubature, information form (Algorithm 2) */
} dkf_nerts_kind_t;

/* Phases (f->phase). */
enum {
    DKF_NERTS_POSTERIOR = 0, /* after init or a commit */
    DKF_NERTS_PREDICTED = 1, /* after dkf_nerts_predict */
    DKF_NERTS_LOCAL = 2      /* after dkf_nerts_local */
};

/* Reals of the state region: the posterior (x, Px, d, Pd, Pxd), the
 * prediction (x_pred, P_pred, Y_pred, y_pred), the local statistics
 * (z_hat, nu, h_c, R_tilde, Pzz, Pxz, Hd, C, Rbar, Rbar_inv, M, d_loc,
 * Pd_loc, Pxd_loc, i, I) and the committed (Y, y); Fx, Fd, Hx beside. */
#define DKF__NERTS_OUT_LEN(n, m, p) \
    ((n) + (n) * (n) + (p) + (p) * (p) + (n) * (p)      /* posterior */ \
     + 2 * (n) + 3 * (n) * (n) + (n) * (p)             /* prediction, Fx, Fd */ \
     + 3 * (m) + 4 * (m) * (m) + (n) * (m) + (m) * (p) + 2 * (m) * (n) + (p) * (m) /* local */ \
     + (p) + (p) * (p) + (n) * (p) + (n) + (n) * (n) /* d_loc .. I */ \
     + (n) + (n) * (n) /* Y, y */)
/* The larger of two sizes. */
#define DKF__NERTS_MAX(a, b) ((a) > (b) ? (a) : (b))
/* Scratch of one phase: the results of a phase staged before they are
 * copied into the state (DKF__NERTS_OUT_LEN), cubature points (2 (n + p)
 * of n + p reals, and their images: 2 (n + p) x max(n, m)), factors and
 * products (8 max(n + p, m)^2) and vectors (8 max(n + p, m)), the
 * Jacobians' workspace, the contribution's workspace and an information
 * filter (dkf/info.h). */
#define DKF__NERTS_R(n, m, p) DKF__NERTS_MAX((n) + (p), (m))
#define DKF__NERTS_SCRATCH_LEN(n, m, p) \
    (DKF__NERTS_OUT_LEN(n, m, p) + 2 * ((n) + (p)) * ((n) + (p)) + \
     2 * ((n) + (p)) * DKF__NERTS_MAX(n, m) + \
     8 * DKF__NERTS_R(n, m, p) * DKF__NERTS_R(n, m, p) + 8 * DKF__NERTS_R(n, m, p) + \
     DKF_NL_JAC_WORK(n, m, p) + \
     DKF_INFO_CONTRIB_WORK(n, m) + DKF_INFO_STORAGE_LEN(n))

/* The first DKF_NERTS_STATE_LEN(n, m, p) reals of the storage hold every
 * view of dkf_nerts_t: a failed call leaves them and the struct
 * bit-identical. The rest is scratch. */
#define DKF_NERTS_STATE_LEN(n, m, p) DKF__NERTS_OUT_LEN(n, m, p)
/* Exact reals of storage for dimensions (n, m, p): init refuses one less. */
#define DKF_NERTS_STORAGE_LEN(n, m, p) \
    (DKF_NERTS_STATE_LEN(n, m, p) + DKF__NERTS_SCRATCH_LEN(n, m, p))

typedef struct {
    size_t n, m, p;
    dkf_nerts_kind_t kind;
    size_t k;  /* commits since init */
    int phase; /* DKF_NERTS_POSTERIOR, _PREDICTED or _LOCAL */
    /* posterior after the last commit (the prior at init) */
    dkf_mat_t x;   /* x_{k|k}, n x 1 */
    dkf_mat_t Px;  /* P_{x,k|k}, n x n */
    dkf_mat_t d;   /* d_hat_k, p x 1 (p = 0: data NULL, rows 0) */
    dkf_mat_t Pd;  /* P_{d,k|k}, p x p */
    dkf_mat_t Pxd; /* P_{xd,k|k} = E[(x - x_hat)(d - d_hat)^T], n x p */
    /* prediction (valid in phases PREDICTED and LOCAL) */
    dkf_mat_t x_pred, P_pred; /* x_{k|k-1}, P_{x,k|k-1} */
    dkf_mat_t Y_pred, y_pred; /* P_pred^{-1}, Y_pred x_pred (information kinds) */
    dkf_mat_t Fx, Fd;         /* EKF kinds: df/dx (n x n), df/dd (n x p) at (x, d), eqs 6-7 */
    /* local statistics of the last dkf_nerts_local (phase LOCAL) */
    dkf_mat_t z_hat;    /* predicted measurement (input part removed), m x 1 */
    dkf_mat_t nu;       /* innovation y_diff(z, z_hat), m x 1 */
    dkf_mat_t h_c;      /* h(x_pred, d) (cubature: the images' unwrap centre), m x 1 */
    dkf_mat_t Hx;       /* dh/dx at (x_pred, d) (the paper's C_k, eq 8), m x n;
                         * the cubature kinds compute it with Hd, so not when p = 0 */
    dkf_mat_t R_tilde;  /* m x m */
    dkf_mat_t Pzz;      /* cubature sample covariance (EKF: Hx P_pred Hx^T), m x m */
    dkf_mat_t Pxz;      /* n x m */
    dkf_mat_t Hd;       /* dh/dd at (x_pred, d) (the paper's H, H_hat), m x p */
    dkf_mat_t C;        /* Hx (EKF) or Pxz^T P_pred^{-1} (cubature), m x n */
    dkf_mat_t Rbar;     /* R (EKF) or R_tilde - Pxz^T P_pred^{-1} Pxz, m x m */
    dkf_mat_t Rbar_inv; /* Pi(Rbar, Hd), m x m (information kinds) */
    dkf_mat_t M;        /* input gain, p x m */
    dkf_mat_t d_loc, Pd_loc, Pxd_loc; /* the input estimate of z_k, p x 1, p x p, n x p */
    dkf_mat_t i, I;     /* information contributions, n x 1, n x n (information kinds) */
    /* information after the last commit (information kinds) */
    dkf_mat_t Y, y; /* n x n, n x 1 */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *mem;
        int ready;
    } priv;
} dkf_nerts_t;

/* `name` and `name_storage`, storage class sc (static, extern or empty):
 * the form of DKF_KF_DECLARE (dkf/kf.h). */
#define DKF_NERTS_DECLARE(sc, name, n, m, p) \
    sc dkf_real_t name##_storage[DKF_NERTS_STORAGE_LEN(n, m, p)]; \
    sc dkf_nerts_t name

/* Binds f to storage (storage_len >= DKF_NERTS_STORAGE_LEN(n, m, p)) and
 * sets the posterior x = x0 (n x 1), Px = P0 (n x n), d = d0 (p x 1),
 * Pd = Pd0 (p x p), Pxd = Pxd0 (n x p); with p = 0 d0, Pd0, Pxd0 must be
 * NULL. The joint covariance [[P0, Pxd0], [Pxd0^T, Pd0]] must be positive
 * definite (DKF_ERR_NOT_SPD). DKF_ERR_RANK if m < p, DKF_ERR_ARG for an
 * unknown kind, DKF_ERR_CAPACITY for n = 0, m = 0, a size above
 * DKF_MAX_DIM or too little storage. The prior is formed and checked in
 * the scratch part of storage: a failed init writes neither *f nor the
 * state part, so one refused over a live filter leaves it as it was. */
dkf_status_t dkf_nerts_init(dkf_nerts_t *f, dkf_nerts_kind_t kind, size_t n, size_t m, size_t p,
                            dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                            const dkf_mat_t *P0, const dkf_mat_t *d0, const dkf_mat_t *Pd0,
                            const dkf_mat_t *Pxd0);

/* Phase 1, the time update k-1 -> k with f's model, the known input
 * u_{k-1} (model->q reals; NULL when q = 0) and Q (n x n, symmetric PSD).
 * Writes x_pred, P_pred (and Y_pred, y_pred for the information kinds). */
dkf_status_t dkf_nerts_predict(dkf_nerts_t *f, const dkf_nl_model_t *model, const dkf_real_t *u,
                               const dkf_mat_t *Q);

/* Phase 2, the local measurement statistics of z (m x 1) with R (m x m,
 * SPD) and the known input u_k (NULL when q = 0). Writes the local views
 * (z_hat ... I); the posterior is not changed. */
dkf_status_t dkf_nerts_local(dkf_nerts_t *f, const dkf_nl_model_t *model, const dkf_real_t *u,
                             const dkf_mat_t *R, const dkf_mat_t *z);

/* Phase 3, the filter's own measurement update from the local statistics
 * (covariance or information form by kind); then d = d_loc, Pd = Pd_loc,
 * Pxd = Pxd_loc, k += 1. Information kinds also store Y, y. */
dkf_status_t dkf_nerts_update(dkf_nerts_t *f);

/* Phase 3 with a given information pair (information kinds only):
 * Y (n x n, SPD, symmetrised on the way in) and y (n x 1), e.g. after
 * consensus (Algorithm 3): Px = Y^{-1}, x = Px y, d = d_loc, Pd = Pd_loc,
 * Pxd = Pxd_loc, k += 1. DKF_ERR_NOT_SPD if Y is not SPD or the joint
 * covariance [[Px, Pxd_loc], [Pxd_loc^T, Pd_loc]] is not positive
 * definite. Y and y are copied before anything is written, so they may
 * be any arrays, f's own views (f->Y, f->y, f->Y_pred, ...) included. */
dkf_status_t dkf_nerts_commit_info(dkf_nerts_t *f, const dkf_mat_t *Y, const dkf_mat_t *y);

/* The three phases in one call: predict with (u_prev, Q), local with
 * (u, R, z), update. Fails as a whole: on an error the filter is as it
 * was before the call. */
dkf_status_t dkf_nerts_step(dkf_nerts_t *f, const dkf_nl_model_t *model, const dkf_real_t *u_prev,
                            const dkf_mat_t *Q, const dkf_real_t *u, const dkf_mat_t *R,
                            const dkf_mat_t *z);

/* ---- stacked sensors (CF-DNERTSF) -------------------------------------- */

/* The context of a stacked model: `count` sensor models of one system
 * (same n, p, q; sensors[0]'s f and f_jac are the stacked model's
 * dynamics), measured together as z = [z_1; ...; z_count]
 * (m = sum m_j <= DKF_MAX_DIM). Caller-owned; it must outlive the model.
 * PER SENSOR: m_j, h, h_jac and y_diff (angle channels) may differ; n, p,
 * q and the dynamics are common (the other sensors' f is never called:
 * the caller makes sure it is sensors[0]'s). */
typedef struct {
    const dkf_nl_model_t *sensors;
    size_t count;
} dkf_nerts_stack_t;

/* Fills *out with the stacked model over st = {sensors, count}: h is the
 * sensors' h one after another, h_jac their h_jac stacked (NULL unless
 * every sensor has one: forward differences of the stacked h), y_diff
 * each sensor's y_diff (or plain subtraction) on its block (NULL when no
 * sensor has one), ctx = st. The stacked R is blkdiag(R_1, ...), the
 * caller's. DKF_ERR_DIM if the sensors' n, p or q differ, DKF_ERR_CAPACITY
 * for count = 0 or m > DKF_MAX_DIM, DKF_ERR_NULL. *out is written only on
 * success. */
dkf_status_t dkf_nerts_stack(dkf_nl_model_t *out, dkf_nerts_stack_t *st,
                             const dkf_nl_model_t *sensors, size_t count);

#ifdef __cplusplus
}
#endif

#endif /* DKF_NERTS_H */
