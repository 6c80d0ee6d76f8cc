/*
 * Self-tuning identifier for seed 002 (dkf/selftune.h, docs/design/selftune.md).
 * Seed 002 (Zhang) step 1 asks for "the recursion auxiliary variable
 * algorithm and the G-W-CLS algorithm" to identify A(q^-1), C(q^-1) and
 * sigma_w^2 of the example  A s(t) = C w(t-1),  y_i = s + eta + v_i,
 * P eta(t) = xi(t-1)  but gives neither; this is the correlation method of
 * docs/design/derivation-seed001-002.md (section 5), recursive with fixed memory:
 *   ybar = mean_i y_i,  r_s(k) = r_ybar(k) - r_eta(k) - delta_k0 sum sigma_vi^2 / L^2,
 *   r_s(k) + a_1 r_s(k-1) + ... + a_na r_s(k-na) = 0,  k > nc   (least squares)
 *   r_u(m) = sum_{i,j=0..na} a_i a_j r_s(m + j - i)   (u = A s = C w(t-1))
 *   r_u(0) = sigma_w^2 (1 + c_1^2),  r_u(1) = sigma_w^2 c_1   (invertible factor).
 */
#include "dkf/selftune.h"

#include "internal.h"

/* ---- storage ---------------------------------------------------------------- */

/* Storage layout (st_layout; its count is DKF_SELFTUNE_STORAGE_LEN, all of
 * it state): ring (K), mx, my, cm, reta (K + 1 each), p (np), acc
 * (na + nc + 1), raw (na + nc + 2). */
typedef struct {
    dkf_real_t *ring, *mx, *my, *cm, *reta, *p, *acc, *raw;
} st_layout_t;

/* Walks the storage in the order above; with base == NULL it only counts. */
static size_t st_layout(st_layout_t *S, dkf_real_t *base, size_t na, size_t np, size_t nc,
                        size_t K)
{
    size_t used = 0;
    DKF_TAKE(S->ring, K);
    DKF_TAKE(S->mx, K + 1);
    DKF_TAKE(S->my, K + 1);
    DKF_TAKE(S->cm, K + 1);
    DKF_TAKE(S->reta, K + 1);
    DKF_TAKE(S->p, np);
    DKF_TAKE(S->acc, na + nc + 1);
    DKF_TAKE(S->raw, na + nc + 2);
    return used;
}

static int orders_ok(size_t na, size_t np, size_t nc, size_t K)
{
    return na >= 1 && na <= DKF_SELFTUNE_MAX_NA && np <= DKF_SELFTUNE_MAX_NP && nc <= 1 &&
           nc < na && K >= na + nc && K <= DKF_SELFTUNE_MAX_LAG;
}

size_t dkf_selftune_storage_len(size_t na, size_t np, size_t nc, size_t K)
{
    st_layout_t S;
    if (!orders_ok(na, np, nc, K)) return 0;
    return st_layout(&S, NULL, na, np, nc, K);
}

/* ---- small numerics ------------------------------------------------------------ */

/* 1 if every root of z^n + a[0] z^(n-1) + ... + a[n-1] has |z| < radius
 * (Schur-Cohn step-down on the polynomial scaled to the unit circle:
 * b_i = a_i / radius^i; stable iff every reflection coefficient has
 * |k| < 1). n <= DKF_SELFTUNE_MAX_NA. NaN coefficients are not stable. */
static int roots_inside(const dkf_real_t *a, size_t n, dkf_real_t radius)
{
    dkf_real_t c[DKF_SELFTUNE_MAX_NA + 1], d[DKF_SELFTUNE_MAX_NA + 1], sc = DKF_R(1.0);
    size_t i, m;
    c[0] = DKF_R(1.0);
    for (i = 1; i <= n; ++i) {
        sc /= radius;
        c[i] = a[i - 1] * sc;
        if (!dkf__all_finite(&c[i], 1)) return 0;
    }
    for (m = n; m >= 1; --m) {
        const dkf_real_t k = c[m];
        dkf_real_t den;
        if (!(DKF_FABS(k) < DKF_R(1.0))) return 0;
        den = DKF_R(1.0) - k * k;
        for (i = 1; i < m; ++i) d[i] = (c[i] - k * c[m - i]) / den;
        for (i = 1; i < m; ++i) c[i] = d[i];
    }
    return 1;
}

/* Solves M x = b (n x n, row-major, n <= DKF_SELFTUNE_MAX_NP + 1) by
 * Gaussian elimination with partial pivoting, in place (M and b are
 * overwritten, x = b). Returns 0 if a pivot is zero. */
static int solve_small(dkf_real_t *M, dkf_real_t *b, size_t n)
{
    size_t i, j, k, piv;
    for (k = 0; k < n; ++k) {
        dkf_real_t big = DKF_FABS(M[k * n + k]);
        piv = k;
        for (i = k + 1; i < n; ++i)
            if (DKF_FABS(M[i * n + k]) > big) big = DKF_FABS(M[i * n + k]), piv = i;
        if (!(big > DKF_R(0.0))) return 0;
        if (piv != k) {
            dkf_real_t t;
            for (j = 0; j < n; ++j) t = M[k * n + j], M[k * n + j] = M[piv * n + j], M[piv * n + j] = t;
            t = b[k], b[k] = b[piv], b[piv] = t;
        }
        for (i = k + 1; i < n; ++i) {
            const dkf_real_t f = M[i * n + k] / M[k * n + k];
            for (j = k; j < n; ++j) M[i * n + j] -= f * M[k * n + j];
            b[i] -= f * b[k];
        }
    }
    for (k = n; k-- > 0;) {
        dkf_real_t v = b[k];
        for (j = k + 1; j < n; ++j) v -= M[k * n + j] * b[j];
        b[k] = v / M[k * n + k];
    }
    return 1;
}

/* r_eta(0..K) of P(q^-1) eta(t) = xi(t-1), P = 1 + p_1 q^-1 + ... (stable):
 * the delay does not change the autocovariance, so the Yule-Walker
 * equations of the AR(np) process hold,
 *   r(j) + sum_{i=1..np} p_i r(|j - i|) = sigma_xi^2 delta_j0,  j = 0..np,
 * a linear system in r(0..np), then r(k) = -sum_i p_i r(k - i), k > np. */
static int eta_autocov(dkf_real_t *r, const dkf_real_t *p, size_t np, dkf_real_t s2, size_t K)
{
    dkf_real_t M[(DKF_SELFTUNE_MAX_NP + 1) * (DKF_SELFTUNE_MAX_NP + 1)],
        b[DKF_SELFTUNE_MAX_NP + 1];
    const size_t n = np + 1;
    size_t i, j, k;
    for (j = 0; j < n * n; ++j) M[j] = DKF_R(0.0);
    for (j = 0; j < n; ++j) {
        M[j * n + j] += DKF_R(1.0);
        for (i = 1; i <= np; ++i) M[j * n + (j > i ? j - i : i - j)] += p[i - 1];
        b[j] = j == 0 ? s2 : DKF_R(0.0);
    }
    if (!solve_small(M, b, n)) return 0;
    for (k = 0; k <= K; ++k) {
        if (k <= np) {
            r[k] = b[k];
        } else {
            dkf_real_t v = DKF_R(0.0);
            for (i = 1; i <= np; ++i) v -= p[i - 1] * r[k - i];
            r[k] = v;
        }
    }
    return dkf__all_finite(r, K + 1);
}

/* ---- init -------------------------------------------------------------------- */

static int nonneg(dkf_real_t x) { return dkf__all_finite(&x, 1) && x >= DKF_R(0.0); }

dkf_status_t dkf_selftune_config_default(dkf_selftune_cfg_t *cfg)
{
    size_t j;
    DKF_CHECK_NULL(cfg);
    cfg->na = 2;
    cfg->np = 0;
    cfg->nc = 1;
    cfg->lags = 5;
    cfg->t_min = 50;
    cfg->L = 1;
    cfg->p = NULL;
    cfg->sigma_xi2 = DKF_R(0.0);
    cfg->sigma_v2 = NULL;
    cfg->root_max = DKF_R(0.99);
    cfg->rho_max = DKF_R(0.499);
    cfg->sigma_w2_min = DKF_R(1e-3);
    for (j = 0; j < DKF_SELFTUNE_MAX_NA; ++j) cfg->a0[j] = DKF_R(0.0);
    cfg->c0 = DKF_R(0.0);
    cfg->sigma_w2_0 = DKF_R(1.0);
    return DKF_OK;
}

dkf_status_t dkf_selftune_init(dkf_selftune_t *id, const dkf_selftune_cfg_t *cfg,
                               dkf_real_t *storage, size_t storage_len)
{
    dkf_selftune_t g; /* built aside: a failed init leaves *id as it was */
    st_layout_t S;
    dkf_real_t reta[DKF_SELFTUNE_MAX_LAG + 1], sv = DKF_R(0.0), Lr;
    size_t i, na, np, nc, K;
    DKF_CHECK_NULL(id);
    DKF_CHECK_NULL(cfg);
    DKF_CHECK_NULL(storage);
    na = cfg->na;
    np = cfg->np;
    nc = cfg->nc;
    K = cfg->lags;
    if (!orders_ok(na, np, nc, K) || cfg->t_min == 0 || cfg->L == 0) return DKF_ERR_ARG;
    if (np > 0 && cfg->p == NULL) return DKF_ERR_ARG;
    if (cfg->sigma_v2 == NULL) return DKF_ERR_ARG;
    if (!nonneg(cfg->sigma_xi2) || !nonneg(cfg->sigma_w2_0)) return DKF_ERR_ARG;
    if (!dkf__all_finite(&cfg->root_max, 1) || !(cfg->root_max > DKF_R(0.0)) ||
        !(cfg->root_max <= DKF_R(1.0)))
        return DKF_ERR_ARG;
    if (!dkf__all_finite(&cfg->rho_max, 1) || !(cfg->rho_max > DKF_R(0.0)) ||
        !(cfg->rho_max < DKF_R(0.5)))
        return DKF_ERR_ARG;
    if (!dkf__all_finite(&cfg->sigma_w2_min, 1) || !(cfg->sigma_w2_min > DKF_R(0.0)))
        return DKF_ERR_ARG;
    if (!dkf__all_finite(cfg->a0, na) || !dkf__all_finite(&cfg->c0, 1)) return DKF_ERR_ARG;
    if (np > 0 && (!dkf__all_finite(cfg->p, np) || !roots_inside(cfg->p, np, DKF_R(1.0))))
        return DKF_ERR_ARG;
    for (i = 0; i < cfg->L; ++i) {
        if (!nonneg(cfg->sigma_v2[i])) return DKF_ERR_ARG;
        sv += cfg->sigma_v2[i];
    }
    Lr = (dkf_real_t)cfg->L;
    sv = sv / (Lr * Lr); /* var of mean_i v_i(t): sum sigma_vi^2 / L^2 */
    if (!dkf__all_finite(&sv, 1)) return DKF_ERR_ARG;
    if (!eta_autocov(reta, cfg->p, np, cfg->sigma_xi2, K)) return DKF_ERR_ARG;
    if (storage_len < st_layout(&S, NULL, na, np, nc, K)) return DKF_ERR_CAPACITY;
    (void)st_layout(&S, storage, na, np, nc, K);
    g.priv.na = na;
    g.priv.np = np;
    g.priv.nc = nc;
    g.priv.K = K;
    g.priv.L = cfg->L;
    g.priv.t_min = cfg->t_min;
    g.priv.t = 0;
    g.priv.head = 0;
    g.priv.t_accepted = 0;
    g.priv.guard = DKF_SELFTUNE_GUARD_WARMUP;
    g.priv.inv_L = DKF_R(1.0) / Lr;
    g.priv.sv_term = sv;
    g.priv.sigma_xi2 = cfg->sigma_xi2;
    g.priv.root_max = cfg->root_max;
    g.priv.rho_max = cfg->rho_max;
    g.priv.sigma_w2_min = cfg->sigma_w2_min;
    g.priv.ring = S.ring;
    g.priv.mx = S.mx;
    g.priv.my = S.my;
    g.priv.cm = S.cm;
    g.priv.reta = S.reta;
    g.priv.p = S.p;
    g.priv.acc = S.acc;
    g.priv.raw = S.raw;
    for (i = 0; i < K; ++i) g.priv.ring[i] = DKF_R(0.0);
    for (i = 0; i <= K; ++i) g.priv.mx[i] = g.priv.my[i] = g.priv.cm[i] = DKF_R(0.0);
    for (i = 0; i <= K; ++i) g.priv.reta[i] = reta[i];
    for (i = 0; i < np; ++i) g.priv.p[i] = cfg->p[i];
    for (i = 0; i < na; ++i) g.priv.acc[i] = g.priv.raw[i] = cfg->a0[i];
    if (nc == 1) g.priv.acc[na] = g.priv.raw[na] = cfg->c0;
    g.priv.acc[na + nc] = g.priv.raw[na + nc] = cfg->sigma_w2_0;
    g.priv.raw[na + nc + 1] = DKF_R(0.0);
    *id = g;
    return DKF_OK;
}

/* ---- one step ------------------------------------------------------------------ */

/* The step's estimate from r_s(0..K): fills raw (na + nc + 2 reals: a,
 * [c_1], sigma_w^2, rho) as far as it gets and returns the first guard
 * that fails (NONE if every one passes). DKF_ERR_NONFINITE through *bad
 * if a result overflows. */
static dkf_selftune_guard_t estimate(const dkf_selftune_t *id, const dkf_real_t *rs,
                                     dkf_real_t *raw, int *bad)
{
    const size_t na = id->priv.na, nc = id->priv.nc, K = id->priv.K;
    dkf_real_t M[DKF_SELFTUNE_MAX_NA * DKF_SELFTUNE_MAX_NA], g[DKF_SELFTUNE_MAX_NA],
        phi[DKF_SELFTUNE_MAX_NA], al[DKF_SELFTUNE_MAX_NA + 1], ru0 = DKF_R(0.0),
        ru1 = DKF_R(0.0), dmax = DKF_R(0.0), c1 = DKF_R(0.0), rho = DKF_R(0.0), sw2;
    size_t i, j, k;
    *bad = 0;
    /* normal equations of r_s(k) = -sum_j a_j r_s(|k - j|), k = nc+1..K
     * (the rows of the extended Yule-Walker system of the ARMA signal) */
    for (i = 0; i < na * na; ++i) M[i] = DKF_R(0.0);
    for (i = 0; i < na; ++i) g[i] = DKF_R(0.0);
    for (k = nc + 1; k <= K; ++k) {
        for (j = 1; j <= na; ++j) phi[j - 1] = rs[k > j ? k - j : j - k];
        for (i = 0; i < na; ++i) {
            g[i] -= phi[i] * rs[k];
            for (j = 0; j < na; ++j) M[i * na + j] += phi[i] * phi[j];
        }
    }
    if (!dkf__all_finite(M, na * na) || !dkf__all_finite(g, na)) {
        *bad = 1;
        return DKF_SELFTUNE_GUARD_SINGULAR;
    }
    /* Cholesky M = R^T R in place (upper triangle), pivots below
     * 64 eps max diag(M) count as singular */
    for (i = 0; i < na; ++i)
        if (M[i * na + i] > dmax) dmax = M[i * na + i];
    for (j = 0; j < na; ++j) {
        dkf_real_t d = M[j * na + j];
        for (k = 0; k < j; ++k) d -= M[k * na + j] * M[k * na + j];
        if (!(d > DKF_R(64.0) * DKF_REAL_EPSILON * dmax)) return DKF_SELFTUNE_GUARD_SINGULAR;
        d = DKF_SQRT(d);
        M[j * na + j] = d;
        for (i = j + 1; i < na; ++i) {
            dkf_real_t v = M[j * na + i];
            for (k = 0; k < j; ++k) v -= M[k * na + j] * M[k * na + i];
            M[j * na + i] = v / d;
        }
    }
    for (j = 0; j < na; ++j) { /* R^T z = g */
        dkf_real_t v = g[j];
        for (k = 0; k < j; ++k) v -= M[k * na + j] * g[k];
        g[j] = v / M[j * na + j];
    }
    for (j = na; j-- > 0;) { /* R a = z */
        dkf_real_t v = g[j];
        for (k = j + 1; k < na; ++k) v -= M[j * na + k] * g[k];
        g[j] = v / M[j * na + j];
    }
    if (!dkf__all_finite(g, na)) {
        *bad = 1;
        return DKF_SELFTUNE_GUARD_SINGULAR;
    }
    for (i = 0; i < na; ++i) raw[i] = g[i];
    if (!roots_inside(g, na, id->priv.root_max)) return DKF_SELFTUNE_GUARD_UNSTABLE;
    /* u = A s: r_u(m) = sum_{i,j} a_i a_j r_s(|m + j - i|), a_0 = 1 */
    al[0] = DKF_R(1.0);
    for (i = 0; i < na; ++i) al[i + 1] = g[i];
    for (i = 0; i <= na; ++i)
        for (j = 0; j <= na; ++j) {
            const dkf_real_t w = al[i] * al[j];
            ru0 += w * rs[j > i ? j - i : i - j];
            if (nc == 1) ru1 += w * rs[1 + j > i ? 1 + j - i : i - 1 - j];
        }
    if (!dkf__all_finite(&ru0, 1) || !dkf__all_finite(&ru1, 1)) {
        *bad = 1;
        return DKF_SELFTUNE_GUARD_SIGMA;
    }
    raw[na + nc] = ru0;
    raw[na + nc + 1] = DKF_R(0.0);
    if (nc == 1) raw[na] = DKF_R(0.0);
    if (!(ru0 > DKF_R(0.0))) return DKF_SELFTUNE_GUARD_SIGMA;
    sw2 = ru0;
    if (nc == 1) {
        /* rho = c_1 / (1 + c_1^2); the invertible root |c_1| < 1 is
         * c_1 = 2 rho / (1 + sqrt(1 - 4 rho^2)) (no cancellation at rho ~ 0) */
        rho = ru1 / ru0;
        raw[na + nc + 1] = rho;
        if (!(DKF_FABS(rho) <= id->priv.rho_max)) return DKF_SELFTUNE_GUARD_RHO;
        c1 = DKF_R(2.0) * rho / (DKF_R(1.0) + DKF_SQRT(DKF_R(1.0) - DKF_R(4.0) * rho * rho));
        sw2 = ru0 / (DKF_R(1.0) + c1 * c1);
        raw[na] = c1;
    }
    raw[na + nc] = sw2;
    if (!(sw2 >= id->priv.sigma_w2_min)) return DKF_SELFTUNE_GUARD_SIGMA;
    return DKF_SELFTUNE_GUARD_NONE;
}

dkf_status_t dkf_selftune_update(dkf_selftune_t *id, const dkf_real_t y[])
{
    dkf_real_t mx[DKF_SELFTUNE_MAX_LAG + 1], my[DKF_SELFTUNE_MAX_LAG + 1],
        cm[DKF_SELFTUNE_MAX_LAG + 1], rs[DKF_SELFTUNE_MAX_LAG + 1],
        raw[DKF_SELFTUNE_MAX_NA + 3], yb = DKF_R(0.0);
    size_t i, k, K, t, nraw;
    dkf_selftune_guard_t guard = DKF_SELFTUNE_GUARD_WARMUP;
    DKF_CHECK_NULL(id);
    DKF_CHECK_NULL(y);
    if (id->priv.ring == NULL) return DKF_ERR_STATE;
    K = id->priv.K;
    if (!dkf__all_finite(y, id->priv.L)) return DKF_ERR_NONFINITE;
    for (i = 0; i < id->priv.L; ++i) yb += y[i];
    yb = yb / (dkf_real_t)id->priv.L; /* ybar(t) */
    if (!dkf__all_finite(&yb, 1)) return DKF_ERR_NONFINITE;
    t = id->priv.t + 1;
    /* pairs (ybar(t), ybar(t-k)) for lags k < t: running means and
     * co-moment, C_n = C_{n-1} + (x_n - mx_{n-1}) (y_n - my_n) */
    for (k = 0; k <= K; ++k) {
        mx[k] = id->priv.mx[k];
        my[k] = id->priv.my[k];
        cm[k] = id->priv.cm[k];
        if (k < t) {
            const dkf_real_t x = yb, z = k == 0 ? yb : id->priv.ring[(id->priv.head + K - k) % K],
                             n = (dkf_real_t)(t - k), dx = x - mx[k];
            mx[k] += dx / n;
            my[k] += (z - my[k]) / n;
            cm[k] += dx * (z - my[k]);
        }
    }
    if (!dkf__all_finite(mx, K + 1) || !dkf__all_finite(my, K + 1) ||
        !dkf__all_finite(cm, K + 1))
        return DKF_ERR_NONFINITE;
    nraw = id->priv.na + id->priv.nc + 2;
    for (i = 0; i < nraw; ++i) raw[i] = id->priv.raw[i];
    if (t >= id->priv.t_min && t > K) {
        int bad = 0;
        for (k = 0; k <= K; ++k) {
            rs[k] = cm[k] / (dkf_real_t)(t - k) - id->priv.reta[k];
            if (k == 0) rs[k] -= id->priv.sv_term;
        }
        if (!dkf__all_finite(rs, K + 1)) return DKF_ERR_NONFINITE;
        guard = estimate(id, rs, raw, &bad);
        if (bad || !dkf__all_finite(raw, nraw)) return DKF_ERR_NONFINITE;
    }
    /* commit */
    for (k = 0; k <= K; ++k) {
        id->priv.mx[k] = mx[k];
        id->priv.my[k] = my[k];
        id->priv.cm[k] = cm[k];
    }
    id->priv.ring[id->priv.head] = yb;
    id->priv.head = (id->priv.head + 1) % K;
    id->priv.t = t;
    for (i = 0; i < nraw; ++i) id->priv.raw[i] = raw[i];
    id->priv.guard = guard;
    if (guard == DKF_SELFTUNE_GUARD_NONE) {
        for (i = 0; i + 1 < nraw; ++i) id->priv.acc[i] = raw[i];
        id->priv.t_accepted = t;
    }
    return DKF_OK;
}

/* ---- outputs ------------------------------------------------------------------- */

dkf_status_t dkf_selftune_estimate(const dkf_selftune_t *id, dkf_selftune_est_t *est)
{
    dkf_selftune_est_t e;
    size_t i, na, nc;
    DKF_CHECK_NULL(id);
    DKF_CHECK_NULL(est);
    if (id->priv.ring == NULL) return DKF_ERR_STATE;
    na = id->priv.na;
    nc = id->priv.nc;
    for (i = 0; i < DKF_SELFTUNE_MAX_NA; ++i) e.a[i] = e.a_raw[i] = DKF_R(0.0);
    e.na = na;
    e.np = id->priv.np;
    e.nc = nc;
    for (i = 0; i < na; ++i) e.a[i] = id->priv.acc[i], e.a_raw[i] = id->priv.raw[i];
    e.c1 = nc == 1 ? id->priv.acc[na] : DKF_R(0.0);
    e.c1_raw = nc == 1 ? id->priv.raw[na] : DKF_R(0.0);
    e.sigma_w2 = id->priv.acc[na + nc];
    e.sigma_w2_raw = id->priv.raw[na + nc];
    e.rho_raw = id->priv.raw[na + nc + 1];
    e.guard = id->priv.guard;
    e.ready = id->priv.guard == DKF_SELFTUNE_GUARD_NONE;
    e.t = id->priv.t;
    e.t_accepted = id->priv.t_accepted;
    *est = e;
    return DKF_OK;
}

dkf_status_t dkf_selftune_autocov(const dkf_selftune_t *id, dkf_real_t r[], size_t len)
{
    size_t k;
    DKF_CHECK_NULL(id);
    DKF_CHECK_NULL(r);
    if (id->priv.ring == NULL) return DKF_ERR_STATE;
    if (len < id->priv.K + 1) return DKF_ERR_CAPACITY;
    for (k = 0; k <= id->priv.K; ++k)
        r[k] = k < id->priv.t ? id->priv.cm[k] / (dkf_real_t)(id->priv.t - k) : DKF_R(0.0);
    return DKF_OK;
}

dkf_status_t dkf_selftune_noise_autocov(const dkf_selftune_t *id, dkf_real_t r[], size_t len)
{
    size_t k;
    DKF_CHECK_NULL(id);
    DKF_CHECK_NULL(r);
    if (id->priv.ring == NULL) return DKF_ERR_STATE;
    if (len < id->priv.K + 1) return DKF_ERR_CAPACITY;
    for (k = 0; k <= id->priv.K; ++k) r[k] = id->priv.reta[k];
    return DKF_OK;
}

dkf_status_t dkf_selftune_model_dim(const dkf_selftune_t *id, size_t *n)
{
    DKF_CHECK_NULL(id);
    DKF_CHECK_NULL(n);
    if (id->priv.ring == NULL) return DKF_ERR_STATE;
    *n = id->priv.na + (id->priv.np > 0 ? id->priv.np : 1);
    return DKF_OK;
}

dkf_status_t dkf_selftune_model(const dkf_selftune_t *id, const dkf_selftune_est_t *est,
                                dkf_mat_t *F, dkf_mat_t *Q)
{
    dkf_real_t gam[2 * DKF_SELFTUNE_MAX_NA + 1], e[DKF_SELFTUNE_MAX_NA + 3],
        qs[DKF_SELFTUNE_MAX_NA * DKF_SELFTUNE_MAX_NA];
    size_t n, na, ne, i, j;
    DKF_CHECK_NULL(id);
    DKF_CHECK_NULL(est);
    if (id->priv.ring == NULL) return DKF_ERR_STATE;
    na = id->priv.na;
    ne = id->priv.np > 0 ? id->priv.np : 1;
    n = na + ne;
    DKF_TRY(dkf__check_shape(F, n, n));
    DKF_TRY(dkf__check_shape(Q, n, n));
    DKF_CHECK_NO_ALIAS(F, Q);
    if (est->na != na || est->np != id->priv.np || est->nc != id->priv.nc) return DKF_ERR_ARG;
    for (i = 0; i < na; ++i) e[i] = est->a[i];
    e[na] = est->c1;
    e[na + 1] = est->sigma_w2;
    if (!dkf__all_finite(e, na + 2)) return DKF_ERR_NONFINITE;
    if (!(est->sigma_w2 >= DKF_R(0.0))) return DKF_ERR_ARG;
    /* Gamma's two columns, stacked: column 1 (w) = [1; c_1; 0..] over the
     * signal block, column 2 (xi) = [1; 0..] over the eta block */
    for (i = 0; i < n; ++i) gam[i] = DKF_R(0.0);
    gam[0] = DKF_R(1.0);
    if (id->priv.nc == 1) gam[1] = est->c1;
    /* the signal block of Q first (an overflow of sigma_w^2 c_1^2 is
     * NONFINITE, F and Q untouched) */
    for (i = 0; i < na; ++i)
        for (j = i; j < na; ++j)
            qs[i * na + j] = qs[j * na + i] = (gam[i] * est->sigma_w2) * gam[j];
    if (!dkf__all_finite(qs, na * na)) return DKF_ERR_NONFINITE;
    /* F = blkdiag(Phi_A, Phi_P): first column -a (resp. -p, or 0 if np = 0),
     * ones on the superdiagonal of each block */
    for (i = 0; i < n * n; ++i) F->data[i] = DKF_R(0.0);
    for (i = 0; i < na; ++i) {
        F->data[i * n] = -est->a[i];
        if (i + 1 < na) F->data[i * n + i + 1] = DKF_R(1.0);
    }
    for (i = 0; i < ne; ++i) {
        F->data[(na + i) * n + na] = id->priv.np > 0 ? -id->priv.p[i] : DKF_R(0.0);
        if (i + 1 < ne) F->data[(na + i) * n + na + i + 1] = DKF_R(1.0);
    }
    /* Q = Gamma diag(sigma_w^2, sigma_xi^2) Gamma^T: blkdiag(sigma_w^2 g g^T,
     * sigma_xi^2 e_1 e_1^T), entry i <= j (g_i sigma^2) g_j, mirrored (exactly
     * symmetric) */
    for (i = 0; i < n * n; ++i) Q->data[i] = DKF_R(0.0);
    for (i = 0; i < na; ++i)
        for (j = 0; j < na; ++j) Q->data[i * n + j] = qs[i * na + j];
    Q->data[na * n + na] = id->priv.sigma_xi2;
    return DKF_OK;
}
