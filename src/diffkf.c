/*
 * The Difference Kalman filter (dkf/diffkf.h): seed 000 Theorem 1 in the
 * corrected form of docs/design/derivation-seed000.md §3-4.
 *
 * Notation (library dimensions n state, m measurement, p input; A_k is the
 * paper's letter for the feedthrough, the API's meas->D, kept here and in
 * the names below so that the code reads beside the paper; G_k is the
 * paper's differencing matrix):
 *   G_k   = B_k^{-1} A_{k+1}^+                            p x m   (8)
 *   M_k   = G_k H_{k+1} F_k - A_k^+ H_k                   p x n   (11)
 *   Ru_k  = Cov(u_k) = G H Q H^T G^T + B^{-1} Rd B^{-T}
 *           + G R_{k+1} G^T + A_k^+ R_k A_k^{+T}          p x p   (14)
 *   S_k   = E[v_k u_k^T] = Q_k H_{k+1}^T G_k^T            n x p   (13)
 *   C_k   = E[u_k u_{k-1}^T] = -A_k^+ R_k G_{k-1}^T       p x p   (15, lag corrected)
 *   W_k   = (F_k J_k + S_k) L_k^{-1}                      n x p
 * Recursion for step k (docs/design/derivation-seed000.md §4, eqs (16)-(20)):
 *   dz_k  = z_k - M_k x_{k|k-1} - C_k L_{k-1}^{-1} dz_{k-1}               (18)
 *   J_k   = P_{k|k-1} M_k^T - W_{k-1} C_k^T                               (19)
 *   L_k   = M P M^T - M W_{k-1} C_k^T - C_k W_{k-1}^T M^T + Ru_k
 *           - C_k L_{k-1}^{-1} C_k^T                                       (20)
 *   x_{k|k} = x_{k|k-1} + K_k dz_k,  P_{k|k} = P_{k|k-1} - K_k J_k^T,  K = J L^{-1}
 *   x_{k+1|k} = F_k x_{k|k-1} + W_k dz_k                                  (16)
 *   P_{k+1|k} = F_k P_{k|k-1} F_k^T + Q_k - W_k L_k W_k^T                 (17)
 * (16)-(17) are the paper's prediction rewritten with W: F x_{k|k} + S L^{-1}
 * dz = F x_{k|k-1} + W dz, and F P_{k|k} F^T + Q - F J L^{-1} S^T - S L^{-1}
 * J^T F^T - S L^{-1} S^T = F P_{k|k-1} F^T + Q - (F J + S) L^{-1} (F J + S)^T.
 *
 * Everything but dz and the x's is data-independent, so a step is split
 * into a gain phase (covariances, gains, and what the next step carries)
 * and an update phase (the vectors). The gain phase writes only the
 * pending area; the update commits. Pseudo-inverses of A and inverses of B
 * are cached against a bitwise copy of the matrix they came from, so a
 * time-invariant model pays for one SVD in all. A call that computes a new
 * cache entry does so in scratch (the layout's pointer is redirected there
 * for the rest of the call) and stores it only when the call succeeds
 * (commit_caches), so a failed call leaves the caches as they were.
 */
#include "peel.h" /* first: before any definition */

#include "dkf/diffkf.h"

#include <stdint.h>
#include <string.h>

#include "diffkf_internal.h"
#include "internal.h"
#include "kernels.h"
#include "kernels_inline.h"

typedef struct {
    /* carried from step k-1 to step k; pc = the rows step k-1 kept (0
     * before the first step: no previous innovation), S' its selection */
    dkf_real_t *C;     /* C_k S'^T                                 p x pc */
    dkf_real_t *Vt;    /* Lc'^{-1}_{k-1} (C_k S'^T)^T              pc x p */
    dkf_real_t *W;     /* W'_{k-1}                                 n x pc */
    dkf_real_t *wzp;   /* Lc'^{-1}_{k-1} dz'_{k-1}                 pc     */
    dkf_real_t *ApH;   /* A_k^+ H_k                                p x n */
    dkf_real_t *ApRAp; /* A_k^+ R_k A_k^{+T}                       p x p */
    dkf_real_t *Apy;   /* A_k^+ y_k                                p     */
    /* caches: cAp = pinv(Alast), cBinv = inv(Blast) */
    dkf_real_t *Alast, *cAp, *Blast, *cBinv;
    /* the model inputs the model-only block (G, M, Ru, S, C_{k+1}, ...) was
     * last computed from: F, Q, B, Rd, H_{k+1}, A_{k+1}, R_{k+1}, and the
     * carried A_k^+ H_k, A_k^+ R_k A_k^{+T}; then the block itself */
    dkf_real_t *mF, *mQ, *mB, *mRd, *mH, *mA, *mR, *mApH, *mApRAp;
    dkf_real_t *oG, *oM, *oRu, *oS, *oGH, *oCn, *oApHn, *oApRApn;
    /* (everything above is DKF_DIFFKF_STATE_LEN; the pending area below is
     * state while a gain is pending) */
    /* pending: the gain phase of step k */
    dkf_real_t *G, *M, *Jn, *Ln, *Kn, *Wn, *Cn, *Vtn, *Pfn, *Ppn, *Fn, *ApHn, *ApRApn, *zc;
    /* pending: the row selection of step k (pk kept rows, pc = the previous
     * step's kept rows): Mk = S M, Ruk = S Ru S^T, Ck = S C_k S_{k-1}^T
     * (= S times the carried C), Vtk = the carried Vt S^T, Cnk = C_{k+1}
     * S^T; the Cholesky factor L'_k = Lc Lc^T and the reciprocals Li of
     * its diagonal, which the update whitens dz with */
    dkf_real_t *Mk, *Ruk, *Ck, *Vtk, *Cnk, *Lc, *Li;
    /* pending: fix[0] = 1 when this gain may serve the next step too (its
     * carried outputs are the carry it read, up to the steady tolerance:
     * dkf_diffkf_set_steady), fix[1] = 1 while the pending gain is such a
     * gain served again; a gain writes both 0 before anything else */
    dkf_real_t *fix;
    /* scratch; Apn, Binvn: a new A^+, B^{-1} until commit_caches */
    dkf_real_t *T1, *T2, *T3, *GH, *S, *Ru, *X, *Apn, *Binvn, *svdw, *invw;
    /* not storage: what this call computed anew, for commit_caches (the
     * cache entries, and the model inputs of a new model-only block) */
    dkf_real_t *Ap, *Binv;
    const dkf_mat_t *newA, *newB;
    const dkf_ui_dyn_t *new_dyn;
    const dkf_ui_meas_t *new_meas;
    /* not storage: the caller's word that B, Rd, H, D, R are bitwise the
     * inputs of the model memo (dkf__diffkf_gain_masked_memo) */
    int memo_same;
    /* scratch of the Joseph-type covariances (joseph_covariances); jX =
     * W'_{k-1} C'^T, from gain_core */
    dkf_real_t *jU, *jD, *jE, *jX, *jV, *jAX, *jS;
} layout_t;

/* Walks the storage in a fixed order; with base == NULL it only counts.
 * Forced inline: map_of's call, where base is known not to be NULL, then
 * folds every DKF_TAKE to one addition. */
DKF__INLINE size_t layout(layout_t *L, dkf_real_t *base, size_t n, size_t m, size_t p)
{
    size_t used = 0;
    DKF_TAKE(L->C, p * p);
    DKF_TAKE(L->Vt, p * p);
    DKF_TAKE(L->W, n * p);
    DKF_TAKE(L->wzp, p);
    DKF_TAKE(L->ApH, p * n);
    DKF_TAKE(L->ApRAp, p * p);
    DKF_TAKE(L->Apy, p);
    DKF_TAKE(L->Alast, m * p);
    DKF_TAKE(L->cAp, p * m);
    DKF_TAKE(L->Blast, p * p);
    DKF_TAKE(L->cBinv, p * p);
    DKF_TAKE(L->mF, n * n);
    DKF_TAKE(L->mQ, n * n);
    DKF_TAKE(L->mB, p * p);
    DKF_TAKE(L->mRd, p * p);
    DKF_TAKE(L->mH, m * n);
    DKF_TAKE(L->mA, m * p);
    DKF_TAKE(L->mR, m * m);
    DKF_TAKE(L->mApH, p * n);
    DKF_TAKE(L->mApRAp, p * p);
    DKF_TAKE(L->oG, p * m);
    DKF_TAKE(L->oM, p * n);
    DKF_TAKE(L->oRu, p * p);
    DKF_TAKE(L->oS, n * p);
    DKF_TAKE(L->oGH, p * n);
    DKF_TAKE(L->oCn, p * p);
    DKF_TAKE(L->oApHn, p * n);
    DKF_TAKE(L->oApRApn, p * p);
    DKF_TAKE(L->G, p * m);
    DKF_TAKE(L->M, p * n);
    DKF_TAKE(L->Jn, n * p);
    DKF_TAKE(L->Ln, p * p);
    DKF_TAKE(L->Kn, n * p);
    DKF_TAKE(L->Wn, n * p);
    DKF_TAKE(L->Cn, p * p);
    DKF_TAKE(L->Vtn, p * p);
    DKF_TAKE(L->Pfn, n * n);
    DKF_TAKE(L->Ppn, n * n);
    DKF_TAKE(L->Fn, n * n);
    DKF_TAKE(L->ApHn, p * n);
    DKF_TAKE(L->ApRApn, p * p);
    DKF_TAKE(L->zc, p);
    DKF_TAKE(L->Mk, p * n);
    DKF_TAKE(L->Ruk, p * p);
    DKF_TAKE(L->Ck, p * p);
    DKF_TAKE(L->Vtk, p * p);
    DKF_TAKE(L->Cnk, p * p);
    DKF_TAKE(L->Lc, p * p);
    DKF_TAKE(L->Li, p);
    DKF_TAKE(L->fix, 2);
    DKF_TAKE(L->T1, n * n);
    DKF_TAKE(L->T2, n * p);
    DKF_TAKE(L->T3, p * (n + m));
    DKF_TAKE(L->GH, p * n);
    DKF_TAKE(L->S, n * p);
    DKF_TAKE(L->Ru, p * p);
    DKF_TAKE(L->X, p * p);
    DKF_TAKE(L->Apn, p * m);
    DKF_TAKE(L->Binvn, p * p);
    DKF_TAKE(L->svdw, DKF_MAT_SVD_WORK(m, p));
    DKF_TAKE(L->invw, DKF_MAT_INV_WORK(p));
    DKF_TAKE(L->jU, n * n);
    DKF_TAKE(L->jD, n * n);
    DKF_TAKE(L->jE, n * n);
    DKF_TAKE(L->jX, n * p);
    DKF_TAKE(L->jV, p * n);
    DKF_TAKE(L->jAX, n * p);
    DKF_TAKE(L->jS, n * p);
    /* A^+ and B^{-1} of this call: the caches, or new ones in scratch */
    L->Ap = L->cAp;
    L->Binv = L->cBinv;
    L->newA = L->newB = NULL;
    L->new_dyn = NULL;
    L->new_meas = NULL;
    L->memo_same = 0;
    return used;
}

/* The start of the storage: the output views xf, Pf, xn, Pn, z, dz, J, L,
 * K, xp (their full p-row size), then `mem`, the layout above. */
typedef struct {
    dkf_real_t *xf, *Pf, *xn, *Pn, *z, *dz, *J, *L, *K, *xp;
    dkf_real_t *mem;
} outputs_t;

/* Walks the outputs; with base == NULL it only counts. */
static size_t outputs_layout(outputs_t *o, dkf_real_t *base, size_t n, size_t p)
{
    size_t used = 0;
    DKF_TAKE(o->xf, n);
    DKF_TAKE(o->Pf, n * n);
    DKF_TAKE(o->xn, n);
    DKF_TAKE(o->Pn, n * n);
    DKF_TAKE(o->z, p);
    DKF_TAKE(o->dz, p);
    DKF_TAKE(o->J, n * p);
    DKF_TAKE(o->L, p * p);
    DKF_TAKE(o->K, n * p);
    DKF_TAKE(o->xp, n);
    o->mem = base != NULL ? base + used : NULL;
    return used;
}

static size_t outputs_len(size_t n, size_t p)
{
    outputs_t o;
    return outputs_layout(&o, NULL, n, p);
}

/* The storage map of an initialised f, written into *L (a step fills it
 * in place: no copy of the map); at literal sizes for the fixed ones. */
static void map_of(const dkf_diffkf_t *f, layout_t *L)
{
#define DIFFKF_MAP_FIXED(N, M, P) \
    if ((N) <= DKF_MAX_DIM && f->priv.mem != NULL && f->n == (N) && f->m == (M) && f->p == (P)) { \
        (void)layout(L, f->priv.mem, (N), (M), (P)); \
        return; \
    }
    DKF_DIFFKF_FIXED_SIZES(DIFFKF_MAP_FIXED)
#undef DIFFKF_MAP_FIXED
    if (f->priv.mem != NULL) /* always, once initialised */
        (void)layout(L, f->priv.mem, f->n, f->m, f->p);
    else
        (void)layout(L, NULL, f->n, f->m, f->p);
}

static layout_t mem_of(const dkf_diffkf_t *f)
{
    layout_t L;
    map_of(f, &L);
    return L;
}

dkf_status_t dkf_diffkf_init(dkf_diffkf_t *f, size_t n, size_t m, size_t p, dkf_real_t *storage,
                             size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0)
{
    dkf_diffkf_t g;
    outputs_t o;
    layout_t L;
    size_t len;
    DKF_CHECK_NULL(f);
    DKF_CHECK_NULL(storage);
    if (n == 0 || m == 0 || p == 0 || n > DKF_MAX_DIM || m > DKF_MAX_DIM || p > DKF_MAX_DIM)
        return DKF_ERR_CAPACITY;
    /* A has full column rank, so p <= m */
    if (p > m) return DKF_ERR_RANK;
    len = outputs_len(n, p) + layout(&L, NULL, n, m, p);
    if (storage_len < len) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    memset(&g, 0, sizeof g);
    g.n = n;
    g.m = m;
    g.p = p;
    (void)outputs_layout(&o, storage, n, p);
    dkf__view(&g.xf, n, 1, o.xf);
    dkf__view(&g.Pf, n, n, o.Pf);
    dkf__view(&g.xn, n, 1, o.xn);
    dkf__view(&g.Pn, n, n, o.Pn);
    dkf__view(&g.z, p, 1, o.z);
    dkf__view(&g.dz, p, 1, o.dz);
    dkf__view(&g.J, n, p, o.J);
    dkf__view(&g.L, p, p, o.L);
    dkf__view(&g.K, n, p, o.K);
    dkf__view(&g.xp, n, 1, o.xp);
    g.priv.mem = o.mem;
    L = mem_of(&g);
    /* P0 must be SPD (factored in scratch, which holds nothing yet) */
    if (dkf__chol(L.T1, L.T2, P0->data, n) != 0) return DKF_ERR_NOT_SPD;
    memset(storage, 0, len * sizeof *storage);
    dkf__copy(g.xf.data, x0->data, n);
    dkf__copy(g.Pf.data, P0->data, n * n);
    g.pk = p;
    g.priv.ready = 1;
    *f = g;
    return DKF_OK;
}

static dkf_status_t check_meas(const dkf_diffkf_t *f, const dkf_ui_meas_t *meas)
{
    DKF_CHECK_NULL(meas);
    DKF_TRY(dkf__check_input(meas->H, f->m, f->n));
    DKF_TRY(dkf__check_input(meas->D, f->m, f->p));
    return dkf__check_input(meas->R, f->m, f->m);
}

static dkf_status_t check_model_shapes(const dkf_diffkf_t *f, const dkf_ui_dyn_t *dyn,
                                       const dkf_ui_meas_t *meas)
{
    const size_t n = f->n, m = f->m, p = f->p;
    DKF_CHECK_NULL(dyn);
    DKF_CHECK_NULL(meas);
    DKF_TRY(dkf__check_shape(dyn->F, n, n));
    DKF_TRY(dkf__check_shape(dyn->Q, n, n));
    DKF_TRY(dkf__check_shape(dyn->B, p, p));
    DKF_TRY(dkf__check_shape(dyn->Rd, p, p));
    DKF_TRY(dkf__check_shape(meas->H, m, n));
    DKF_TRY(dkf__check_shape(meas->D, m, p));
    return dkf__check_shape(meas->R, m, m);
}

/* Finiteness of every model input (shapes already checked). */
static dkf_status_t check_model_finite(const dkf_ui_dyn_t *dyn, const dkf_ui_meas_t *meas)
{
    const dkf_mat_t *const all[] = {dyn->F, dyn->Q, dyn->B, dyn->Rd, meas->H, meas->D, meas->R};
    size_t i;
    for (i = 0; i < sizeof all / sizeof all[0]; ++i)
        if (!dkf__all_finite(all[i]->data, all[i]->rows * all[i]->cols)) return DKF_ERR_NONFINITE;
    return DKF_OK;
}

/* 1 if the n reals at a equal those at b bit for bit: memcmp, or at a
 * fixed size (fx) word by word, the XORs ORed together (no call and no
 * early exit for the few dozen reals the memo compares every step). */
#if DKF_USE_FLOAT
typedef uint32_t real_bits_t;
#else
typedef uint64_t real_bits_t;
#endif
typedef char real_bits_size_check[sizeof(real_bits_t) == sizeof(dkf_real_t) ? 1 : -1];

DKF__INLINE int same_bits(int fx, const dkf_real_t *a, const dkf_real_t *b, size_t n)
{
    real_bits_t diff = 0, u, v;
    size_t i;
    if (!fx) return memcmp(a, b, n * sizeof *a) == 0;
    for (i = 0; i < n; ++i) {
        memcpy(&u, a + i, sizeof u);
        memcpy(&v, b + i, sizeof v);
        diff |= u ^ v;
    }
    return diff == 0;
}

/* ---- A^+ and B^{-1} of a block-diagonal model ------------------------------
 * The stacked model of a fusion centre has block-diagonal A = blkdiag(A^i)
 * and B = blkdiag(B^i) (docs/design/diffkf-fusion.md §1), and the pseudo-inverse
 * or inverse of a block-diagonal matrix is the block diagonal of its
 * blocks'. pinv_cached and inverse_cached find such blocks in any A and B
 * (diag_blocks: contiguous diagonal blocks, exact zeros elsewhere) and
 * work block by block: sum_i (m_i p_i^2) instead of m p^2 for the SVD,
 * O(sum p_i^3) instead of O(p^3) for the LU. The conditions stay those of
 * the whole matrix: A's singular values are its blocks', and the rank
 * counts those above max(m, p) eps sigma_max (DKF_RANK_TOL_DEFAULT of A);
 * partial pivoting never leaves a block, so B's LU pivots are its blocks',
 * each tested against p eps max|B| (dkf_mat_lu's test on B). A matrix
 * without two such blocks, or with a block too large for the scratch,
 * takes the dense route. */

/* The contiguous diagonal blocks of A (r x c), found along the rows: block
 * b ends at row re[b] and column ce[b] (exclusive), and no row reaches a
 * column of another block; square: each block's rows and columns are the
 * same range. Trailing zero rows join the last block. Returns the number
 * of blocks, or 0 for fewer than two (or columns no block covers). */
static size_t diag_blocks(size_t *re, size_t *ce, const dkf_real_t *A, size_t r, size_t c,
                          int square)
{
    size_t lo[DKF_MAX_DIM], hi[DKF_MAX_DIM], i, nb = 0, chi = 0, c0 = 0;
    dkf__row_spans(lo, hi, A, r, c);
    for (i = r; i-- > 1;) /* lo[i] becomes the smallest first column of rows >= i */
        lo[i - 1] = lo[i] < lo[i - 1] ? lo[i] : lo[i - 1];
    for (i = 0; i < r; ++i) {
        size_t end;
        if (hi[i] > chi) chi = hi[i];
        end = square && i + 1 > chi ? i + 1 : chi;
        if (end > c0 && (i + 1 == r || lo[i + 1] >= end) && (!square || i + 1 == end)) {
            re[nb] = i + 1;
            ce[nb++] = end;
            c0 = end;
        }
    }
    if (nb == 0 || c0 != c) return 0;
    re[nb - 1] = r;
    return nb >= 2 ? nb : 0;
}

/* Ab (rows x cols, contiguous) = the block of A (row stride c) at (r0, c0). */
static void get_block(dkf_real_t *Ab, const dkf_real_t *A, size_t c, size_t r0, size_t c0,
                      size_t rows, size_t cols)
{
    size_t i;
    for (i = 0; i < rows; ++i) memcpy(Ab + i * cols, A + (r0 + i) * c + c0, cols * sizeof *Ab);
}

/* Apn = A^+ block by block (blocks re, ce of diag_blocks), the tolerance
 * of the whole A; *rank their ranks' sum. DKF_ERR_CAPACITY if a block
 * does not fit the scratch (the caller then goes dense). */
static dkf_status_t pinv_blocks(const layout_t *L, size_t *rank, const dkf_mat_t *A, size_t m,
                                size_t p, const size_t *re, const size_t *ce, size_t nb)
{
    const size_t t3len = (size_t)(L->GH - L->T3); /* T3 holds the block and its pinv */
    dkf_real_t sv[DKF_MAX_DIM], smax = DKF_R(0.0), tol;
    size_t b, pass, r0, c0, rb;
    for (b = 0, r0 = c0 = 0; b < nb; r0 = re[b], c0 = ce[b], ++b)
        if (2 * (re[b] - r0) * (ce[b] - c0) > t3len) return DKF_ERR_CAPACITY;
    memset(L->Apn, 0, p * m * sizeof *L->Apn);
    *rank = 0;
    for (pass = 0; pass < 2; ++pass)
        for (b = 0, r0 = c0 = 0; b < nb; r0 = re[b], c0 = ce[b], ++b) {
            const size_t mb = re[b] - r0, pb = ce[b] - c0;
            dkf_mat_t Ab = DKF_MAT(mb, pb, L->T3), Xb = DKF_MAT(pb, mb, L->T3 + mb * pb);
            get_block(L->T3, A->data, p, r0, c0, mb, pb);
            if (pass == 0) { /* sigma_max of A: the largest of its blocks' */
                DKF_TRY(dkf_mat_svd(NULL, sv, NULL, &Ab, L->svdw));
                if (sv[0] > smax) smax = sv[0];
                continue;
            }
            tol = (dkf_real_t)(m > p ? m : p) * DKF_REAL_EPSILON * smax;
            DKF_TRY(dkf_mat_pinv(&Xb, &rb, &Ab, tol, L->svdw));
            *rank += rb;
            dkf__put_block(L->Apn, m, c0, r0, Xb.data, pb, mb);
        }
    return DKF_OK;
}

/* Binvn = B^{-1} block by block (square blocks ce of diag_blocks), each LU
 * pivot tested against p eps max|B|. DKF_ERR_CAPACITY as pinv_blocks. */
static dkf_status_t inverse_blocks(const layout_t *L, const dkf_mat_t *B, size_t p,
                                   const size_t *ce, size_t nb)
{
    const size_t t3len = (size_t)(L->GH - L->T3); /* T3 holds the block, its LU, its inverse */
    dkf_real_t amax = DKF_R(0.0), tol;
    size_t piv[DKF_MAX_DIM], b, c0, i;
    for (b = 0, c0 = 0; b < nb; c0 = ce[b], ++b)
        if (3 * (ce[b] - c0) * (ce[b] - c0) > t3len) return DKF_ERR_CAPACITY;
    for (i = 0; i < p * p; ++i) amax = DKF_FABS(B->data[i]) > amax ? DKF_FABS(B->data[i]) : amax;
    tol = ((dkf_real_t)p * DKF_REAL_EPSILON) * amax;
    memset(L->Binvn, 0, p * p * sizeof *L->Binvn);
    for (b = 0, c0 = 0; b < nb; c0 = ce[b], ++b) {
        const size_t pb = ce[b] - c0;
        dkf_mat_t Bb = DKF_MAT(pb, pb, L->T3), LU = DKF_MAT(pb, pb, L->T3 + pb * pb),
                  X = DKF_MAT(pb, pb, L->T3 + 2 * pb * pb);
        get_block(L->T3, B->data, p, c0, c0, pb, pb);
        DKF_TRY(dkf_mat_lu(&LU, piv, &Bb, L->invw));
        for (i = 0; i < pb; ++i)
            if (!(DKF_FABS(LU.data[i * pb + i]) > tol)) return DKF_ERR_SINGULAR;
        memset(X.data, 0, pb * pb * sizeof *X.data);
        for (i = 0; i < pb; ++i) X.data[i * pb + i] = DKF_R(1.0);
        DKF_TRY(dkf_mat_lu_solve(&X, &LU, piv, &X));
        dkf__put_block(L->Binvn, p, c0, c0, X.data, pb, pb);
    }
    return DKF_OK;
}

/* L->Ap = A^+ (p x m): the cache when A is bitwise the cached matrix,
 * else computed into scratch (L->Ap then points there until
 * commit_caches), block by block for a block-diagonal A. DKF_ERR_RANK
 * unless A has full column rank p. */
static dkf_status_t pinv_cached(const dkf_diffkf_t *f, layout_t *L, const dkf_mat_t *A)
{
    const size_t m = f->m, p = f->p;
    size_t rank = 0, re[DKF_MAX_DIM], ce[DKF_MAX_DIM], nb;
    dkf_mat_t Ap = DKF_MAT(p, m, L->Apn);
    if (f->priv.d_cached && same_bits(0, L->Alast, A->data, m * p)) return DKF_OK;
    nb = diag_blocks(re, ce, A->data, m, p, 0);
    if (nb == 0 || pinv_blocks(L, &rank, A, m, p, re, ce, nb) == DKF_ERR_CAPACITY)
        DKF_TRY(dkf_mat_pinv(&Ap, &rank, A, DKF_RANK_TOL_DEFAULT, L->svdw));
    if (rank != p) return DKF_ERR_RANK;
    L->Ap = L->Apn;
    L->newA = A;
    return DKF_OK;
}

/* L->Binv = B^{-1}, cached likewise (block by block for a block-diagonal
 * B). DKF_ERR_SINGULAR for singular B. */
static dkf_status_t inverse_cached(const dkf_diffkf_t *f, layout_t *L, const dkf_mat_t *B)
{
    const size_t p = f->p;
    size_t piv[DKF_MAX_DIM], re[DKF_MAX_DIM], ce[DKF_MAX_DIM], nb;
    dkf_mat_t Bi = DKF_MAT(p, p, L->Binvn);
    dkf_status_t st = DKF_ERR_CAPACITY;
    if (f->priv.b_cached && same_bits(0, L->Blast, B->data, p * p)) return DKF_OK;
    nb = diag_blocks(re, ce, B->data, p, p, 1);
    if (nb > 0) st = inverse_blocks(L, B, p, ce, nb);
    if (st == DKF_ERR_CAPACITY) st = dkf_mat_inverse(&Bi, B, piv, L->invw);
    DKF_TRY(st);
    L->Binv = L->Binvn;
    L->newB = B;
    return DKF_OK;
}

/* Stores what this call computed anew (pinv_cached, inverse_cached,
 * model_block_memo) in the caches; called once the call cannot fail any
 * more, and before the carry is overwritten (the model block's key holds
 * the carried A_k^+ H_k, A_k^+ R_k A_k^{+T}). */
DKF__INLINE void commit_caches(dkf_diffkf_t *f, const layout_t *L)
{
    const size_t n = f->n, m = f->m, p = f->p;
    if (L->newA != NULL || L->newB != NULL || L->new_dyn != NULL) f->priv.cache_gen += 1;
    if (L->newA != NULL) {
        dkf__copy(L->Alast, L->newA->data, m * p);
        dkf__copy(L->cAp, L->Apn, p * m);
        f->priv.d_cached = 1;
    }
    if (L->newB != NULL) {
        dkf__copy(L->Blast, L->newB->data, p * p);
        dkf__copy(L->cBinv, L->Binvn, p * p);
        f->priv.b_cached = 1;
    }
    if (L->new_dyn != NULL) {
        const dkf_ui_dyn_t *dyn = L->new_dyn;
        const dkf_ui_meas_t *meas = L->new_meas;
        dkf__copy(L->mF, dyn->F->data, n * n);
        dkf__copy(L->mQ, dyn->Q->data, n * n);
        dkf__copy(L->mB, dyn->B->data, p * p);
        dkf__copy(L->mRd, dyn->Rd->data, p * p);
        dkf__copy(L->mH, meas->H->data, m * n);
        dkf__copy(L->mA, meas->D->data, m * p);
        dkf__copy(L->mR, meas->R->data, m * m);
        dkf__copy(L->mApH, L->ApH, p * n);
        dkf__copy(L->mApRAp, L->ApRAp, p * p);
        dkf__copy(L->oG, L->G, p * m);
        dkf__copy(L->oM, L->M, p * n);
        dkf__copy(L->oRu, L->Ru, p * p);
        dkf__copy(L->oS, L->S, n * p);
        dkf__copy(L->oGH, L->GH, p * n);
        dkf__copy(L->oCn, L->Cn, p * p);
        dkf__copy(L->oApHn, L->ApHn, p * n);
        dkf__copy(L->oApRApn, L->ApRApn, p * p);
        f->priv.model_cached = 1;
    }
}

/* Out (r x r) += A X A^T, A r x c, X c x c symmetric (finite); tmp holds
 * r * c reals, lo and hi r entries. Only the upper triangle is formed; the
 * result is mirrored. Both products run over A's row spans (the stacked
 * model's blocks: exact zeros skipped, the dense values); an overflow in A
 * X is DKF_ERR_NONFINITE, as the dense A X A^T would be non-finite. */
static dkf_status_t add_congruence(dkf_real_t *Out, const dkf_real_t *A, const dkf_real_t *X,
                                   size_t r, size_t c, dkf_real_t *tmp, size_t *lo, size_t *hi)
{
    dkf__row_spans(lo, hi, A, r, c);
    dkf__mul_nn_spans(tmp, A, X, r, c, c, lo, hi);
    if (!dkf__all_finite(tmp, r * c)) return DKF_ERR_NONFINITE;
    dkf__mul_nt_sym_spans(Out, tmp, A, Out, r, c, lo, hi);
    return DKF_OK;
}

/* ---- kernels of the step, by size --------------------------------------------
 * The step's body (gain_core, update_core and what they call) is written
 * once and forced inline: the entry points expand it with the run-time
 * sizes (fx = 0: the blocked kernels of kernels.c) and, for the sizes of
 * DKF_DIFFKF_FIXED_SIZES, with literal sizes (fx = 1: the bodies of kernels_inline.h
 * expanded with constant trip counts, unrolled, no call or loop set-up on
 * 2-4-element rows). Both compute every element with the same operations
 * in the same order (dkf__mul_nt, dkf__mul_nt_sym and dkf__mul_vec sum each
 * element as one inl_dot chain, kernels.c), so they return the same bits. */
DKF__INLINE void k_mul_nn(int fx, dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B,
                          size_t r, size_t k, size_t c)
{
    if (fx)
        inl_mul_nn(C, A, B, r, k, c);
    else
        dkf__mul_nn(C, A, B, r, k, c);
}

DKF__INLINE void k_mul_nn_sym(int fx, dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B,
                              const dkf_real_t *D, size_t r, size_t k)
{
    if (fx)
        inl_mul_nn_sym(C, A, B, D, r, k);
    else
        dkf__mul_nn_sym(C, A, B, D, r, k);
}

/* C (r x c) = A B^T: element (i, j) = inl_dot(A_i, B_j, k) (dkf__mul_nt). */
DKF__INLINE void k_mul_nt(int fx, dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B,
                          size_t r, size_t k, size_t c)
{
    size_t i, j;
    if (!fx) {
        dkf__mul_nt(C, A, B, r, k, c);
        return;
    }
#if DKF__SIMD
    /* c a multiple of the vector length: B^T formed (k x c, contiguous
     * along j), and row i summed DKF__VL columns at a time, each lane from
     * +0 over l = 0, 1, ...: lane j adds A(i,l) B(j,l) in inl_dot's order */
    if (r >= 2 && c % DKF__VL == 0 && k * c <= 64) {
        dkf_real_t Bt[64];
        size_t l;
        inl_transpose(Bt, B, c, k);
        if (c == 2 * DKF__VL) { /* and each broadcast of A(i,l) feeds two vectors */
            for (i = 0; i + 2 <= r; i += 2) {
                dkf__vec_t s00 = {0}, s01 = {0}, s10 = {0}, s11 = {0};
                for (l = 0; l < k; ++l) {
                    const dkf__vec_t b0 = vload(Bt + l * c), b1 = vload(Bt + l * c + DKF__VL);
                    const dkf_real_t a0 = A[i * k + l], a1 = A[(i + 1) * k + l];
                    s00 += b0 * a0, s01 += b1 * a0;
                    s10 += b0 * a1, s11 += b1 * a1;
                }
                vstore(C + i * c, s00), vstore(C + i * c + DKF__VL, s01);
                vstore(C + (i + 1) * c, s10), vstore(C + (i + 1) * c + DKF__VL, s11);
            }
        } else {
            i = 0;
        }
        for (; i + 2 <= r; i += 2) /* two rows share each load of B^T */
            for (j = 0; j < c; j += DKF__VL) {
                dkf__vec_t s0 = {0}, s1 = {0};
                for (l = 0; l < k; ++l) {
                    const dkf__vec_t b = vload(Bt + l * c + j);
                    s0 += b * A[i * k + l];
                    s1 += b * A[(i + 1) * k + l];
                }
                vstore(C + i * c + j, s0);
                vstore(C + (i + 1) * c + j, s1);
            }
        for (; i < r; ++i)
            for (j = 0; j < c; j += DKF__VL) {
                dkf__vec_t sum = {0};
                for (l = 0; l < k; ++l) sum += vload(Bt + l * c + j) * A[i * k + l];
                vstore(C + i * c + j, sum);
            }
        return;
    }
#endif
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) C[i * c + j] = inl_dot(A + i * k, B + j * k, k);
}

/* dkf__mul_nt_sym: the upper triangle A_i . B_j (+ D(i,j)), row by row,
 * mirrored; D may be C (D(i,j) is read before C(i,j) is written). */
DKF__INLINE void k_mul_nt_sym(int fx, dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B,
                              const dkf_real_t *D, size_t r, size_t k)
{
    size_t i, j;
    if (!fx) {
        dkf__mul_nt_sym(C, A, B, D, r, k);
        return;
    }
    for (i = 0; i < r; ++i) {
        dkf_real_t *ci = C + i * r;
        for (j = i; j < r; ++j) {
            const dkf_real_t v = inl_dot(A + i * k, B + j * k, k);
            ci[j] = D != NULL ? v + D[i * r + j] : v;
        }
        for (j = i + 1; j < r; ++j) C[j * r + i] = ci[j];
    }
}

/* y (r) = A x: y(i) = inl_dot(x, A_i, c) (dkf__mul_vec). */
DKF__INLINE void k_mul_vec(int fx, dkf_real_t *y, const dkf_real_t *A, const dkf_real_t *x,
                           size_t r, size_t c)
{
    size_t i;
    if (!fx) {
        dkf__mul_vec(y, A, x, r, c);
        return;
    }
    for (i = 0; i < r; ++i) y[i] = inl_dot(x, A + i * c, c);
}

DKF__INLINE void k_chol_solve(int fx, const dkf_real_t *Lc, const dkf_real_t *inv, dkf_real_t *B,
                              size_t n, size_t c)
{
    if (fx)
        inl_chol_solve(Lc, inv, B, n, c);
    else
        dkf__chol_solve(Lc, inv, B, n, c);
}

/* The Cholesky factor (inl_chol's bits): at run-time sizes the wide one,
 * with T (n x n scratch) its transposed copy. */
DKF__INLINE int k_chol(int fx, dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n,
                       dkf_real_t *T)
{
    return fx ? inl_chol(W, inv, A, n) : dkf__chol_wide(W, inv, A, n, T);
}

/* The PSD check of a covariance the step commits: every one is a mirrored
 * product or a difference of two, exactly symmetric, so the check's
 * symmetric variant gives the general check's verdict. */
DKF__INLINE int k_psd(int fx, dkf_real_t *W, const dkf_real_t *P, size_t n)
{
    return fx ? inl_psd_sym_within_rounding(W, P, n) : dkf__psd_sym_within_rounding(W, P, n);
}

/* 1 if the n reals at p are all finite (dkf__all_finite). */
DKF__INLINE int k_finite(int fx, const dkf_real_t *p, size_t n)
{
    return fx ? !inl_any_nonfinite(p, n) : dkf__all_finite(p, n);
}

/* d = a - b, d = a + b and d = -a elementwise, n reals (d may be a or b:
 * each vector is loaded before it is stored); on vectors at fixed sizes,
 * where the compiler cannot prove the storage map's arrays disjoint. Per
 * element the scalar operation, so the same bits. */
DKF__INLINE void k_sub(int fx, dkf_real_t *d, const dkf_real_t *a, const dkf_real_t *b, size_t n)
{
    size_t i;
    (void)fx; /* read only with DKF__SIMD */
#if DKF__SIMD
    if (fx && n % DKF__VL == 0) {
        for (i = 0; i < n; i += DKF__VL) vstore(d + i, vload(a + i) - vload(b + i));
        return;
    }
#endif
    for (i = 0; i < n; ++i) d[i] = a[i] - b[i];
}

DKF__INLINE void k_add(int fx, dkf_real_t *d, const dkf_real_t *a, const dkf_real_t *b, size_t n)
{
    size_t i;
    (void)fx; /* read only with DKF__SIMD */
#if DKF__SIMD
    if (fx && n % DKF__VL == 0) {
        for (i = 0; i < n; i += DKF__VL) vstore(d + i, vload(a + i) + vload(b + i));
        return;
    }
#endif
    for (i = 0; i < n; ++i) d[i] = a[i] + b[i];
}

DKF__INLINE void k_neg(int fx, dkf_real_t *d, size_t n)
{
    size_t i;
    (void)fx; /* read only with DKF__SIMD */
#if DKF__SIMD
    if (fx && n % DKF__VL == 0) {
        for (i = 0; i < n; i += DKF__VL) vstore(d + i, -vload(d + i));
        return;
    }
#endif
    for (i = 0; i < n; ++i) d[i] = -d[i];
}

/* Out (r x p) = Y L^{-1} for Y r x p and L = Lc Lc^T (L symmetric, so
 * Out^T = L^{-1} Y^T is one Cholesky solve); tmp holds r * p reals. */
DKF__INLINE void right_solve(int fx, dkf_real_t *Out, const dkf_real_t *Y, const dkf_real_t *Lc,
                             const dkf_real_t *inv, size_t r, size_t p, dkf_real_t *tmp)
{
    inl_transpose(tmp, Y, r, p);
    k_chol_solve(fx, Lc, inv, tmp, p, r);
    inl_transpose(Out, tmp, p, r);
}

/* The data-independent part of the next-step carry that depends only on
 * the model at k+1: A^+ H, A^+ R A^{+T} (pending copies), over A^+'s row
 * spans (lo, hi: p entries of scratch), as add_congruence; A^+ R stays in
 * T3. */
static dkf_status_t meas_products(const dkf_diffkf_t *f, const layout_t *L,
                                  const dkf_ui_meas_t *meas, dkf_real_t *ApH, dkf_real_t *ApRAp,
                                  size_t *lo, size_t *hi)
{
    const size_t n = f->n, m = f->m, p = f->p;
    dkf__row_spans(lo, hi, L->Ap, p, m);
    dkf__mul_nn_spans(ApH, L->Ap, meas->H->data, p, m, n, lo, hi);
    dkf__mul_nn_spans(L->T3, L->Ap, meas->R->data, p, m, m, lo, hi);
    if (!dkf__all_finite(L->T3, p * m)) return DKF_ERR_NONFINITE;
    dkf__mul_nt_sym_spans(ApRAp, L->T3, L->Ap, NULL, p, m, lo, hi);
    return DKF_OK;
}

dkf_status_t dkf_diffkf_start(dkf_diffkf_t *f, const dkf_mat_t *F0, const dkf_mat_t *Q0,
                              const dkf_ui_meas_t *meas1, const dkf_mat_t *y1)
{
    size_t n, p, lo[DKF_MAX_DIM], hi[DKF_MAX_DIM];
    layout_t L;
    DKF_CHECK_NULL(f);
    if (!f->priv.ready || f->priv.started) return DKF_ERR_STATE;
    n = f->n;
    p = f->p;
    if ((F0 == NULL) != (Q0 == NULL)) return DKF_ERR_NULL;
    if (F0 != NULL) {
        DKF_TRY(dkf__check_input(F0, n, n));
        DKF_TRY(dkf__check_input(Q0, n, n));
    }
    DKF_TRY(check_meas(f, meas1));
    if (y1 != NULL) DKF_TRY(dkf__check_input(y1, f->m, 1));
    map_of(f, &L);
    DKF_TRY(pinv_cached(f, &L, meas1->D));
    /* predict to the first measured time, into pending slots */
    if (F0 != NULL) {
        dkf__mul_vec(L.T2, F0->data, f->xf.data, n, n);
        dkf__mul_nn(L.T1, F0->data, f->Pf.data, n, n, n);
        dkf__mul_nt_sym(L.Ppn, L.T1, F0->data, Q0->data, n, n);
        if (!dkf__all_finite(L.Ppn, n * n) || !dkf__all_finite(L.T2, n)) return DKF_ERR_NONFINITE;
    }
    /* A_1^+ H_1, A_1^+ R_1 A_1^{+T}, A_1^+ y_1 into scratch: finite inputs
     * may overflow, and the carry is written only once nothing can fail */
    DKF_TRY(meas_products(f, &L, meas1, L.ApHn, L.ApRApn, lo, hi));
    if (y1 != NULL) dkf__mul_vec(L.T3, L.Ap, y1->data, p, f->m);
    if (!dkf__all_finite(L.ApHn, p * n) || !dkf__all_finite(L.ApRApn, p * p) ||
        (y1 != NULL && !dkf__all_finite(L.T3, p)))
        return DKF_ERR_NONFINITE;
    commit_caches(f, &L);
    dkf__copy(L.ApH, L.ApHn, p * n);
    dkf__copy(L.ApRAp, L.ApRApn, p * p);
    if (y1 != NULL) dkf__copy(L.Apy, L.T3, p);
    /* no previous innovation: every term with L_0^{-1} vanishes (an empty
     * carry, pc = 0; the zeros are for inspection only) */
    memset(L.C, 0, p * p * sizeof(dkf_real_t));
    memset(L.Vt, 0, p * p * sizeof(dkf_real_t));
    memset(L.W, 0, n * p * sizeof(dkf_real_t));
    memset(L.wzp, 0, p * sizeof(dkf_real_t));
    f->pc = 0;
    if (F0 != NULL) {
        dkf__copy(f->xn.data, L.T2, n);
        dkf__copy(f->Pn.data, L.Ppn, n * n);
    } else {
        dkf__copy(f->xn.data, f->xf.data, n);
        dkf__copy(f->Pn.data, f->Pf.data, n * n);
    }
    f->priv.started = 1;
    f->priv.has_y = y1 != NULL;
    return DKF_OK;
}

/* The part of a step that depends on the model only (not on P or data):
 * G, GH = G H_{k+1}, M, Ru, S, C_{k+1}, A_{k+1}^+ H_{k+1} and
 * A_{k+1}^+ R_{k+1} A_{k+1}^{+T}. */
static dkf_status_t model_block(const dkf_diffkf_t *f, layout_t *L_, const dkf_ui_dyn_t *dyn,
                                const dkf_ui_meas_t *meas_next)
{
    layout_t L;
    const size_t n = f->n, m = f->m, p = f->p;
    size_t i, lo[DKF_MAX_DIM], hi[DKF_MAX_DIM];
    DKF_TRY(pinv_cached(f, L_, meas_next->D));
    DKF_TRY(inverse_cached(f, L_, dyn->B));
    L = *L_;
    /* The products run over the row spans of B^{-1}, A^+ and G (block
     * diagonal in a stacked model; add_congruence): the skipped terms are
     * exact zeros times finite factors, so the values are the dense ones,
     * and where a factor is not finite the status is the dense one
     * (DKF_ERR_NONFINITE: A^+ here, the products' intermediates below). */
    if (!dkf__all_finite(L.Ap, p * m)) return DKF_ERR_NONFINITE;

    /* G = B^{-1} A_{k+1}^+; GH = G H_{k+1}; M = GH F - A_k^+ H_k      (8), (11) */
    dkf__row_spans(lo, hi, L.Binv, p, p);
    dkf__mul_nn_spans(L.G, L.Binv, L.Ap, p, p, m, lo, hi);
    dkf__row_spans(lo, hi, L.G, p, m);
    dkf__mul_nn_spans(L.GH, L.G, meas_next->H->data, p, m, n, lo, hi);
    dkf__mul_nn(L.M, L.GH, dyn->F->data, p, n, n);
    for (i = 0; i < p * n; ++i) L.M[i] -= L.ApH[i];

    /* Ru = GH Q GH^T + B^{-1} Rd B^{-T} + G R_{k+1} G^T + A_k^+ R_k A_k^{+T}  (14) */
    dkf__copy(L.Ru, L.ApRAp, p * p);
    DKF_TRY(add_congruence(L.Ru, L.GH, dyn->Q->data, p, n, L.T3, lo, hi));
    DKF_TRY(add_congruence(L.Ru, L.Binv, dyn->Rd->data, p, p, L.T3, lo, hi));
    DKF_TRY(add_congruence(L.Ru, L.G, meas_next->R->data, p, m, L.T3, lo, hi));

    /* S = Q H_{k+1}^T G^T = Q GH^T                                     (13) */
    dkf__mul_nt(L.S, dyn->Q->data, L.GH, n, n, p);

    /* the model products at k+1 that the next step will carry, and its
     * correlation C_{k+1} = -A_{k+1}^+ R_{k+1} G^T (15), from the A^+ R
     * that meas_products leaves in T3, over G's row spans */
    DKF_TRY(meas_products(f, &L, meas_next, L.ApHn, L.ApRApn, lo, hi));
    dkf__row_spans(lo, hi, L.G, p, m);
    dkf__mul_nt_spans(L.Cn, L.T3, L.G, p, m, p, lo, hi);
    for (i = 0; i < p * p; ++i) L.Cn[i] = -L.Cn[i];

    /* Finite inputs whose products overflow: refused here, whichever rows a
     * masked gain keeps, so the memo never holds a non-finite block. */
    if (!dkf__all_finite(L.G, p * m) || !dkf__all_finite(L.GH, p * n) ||
        !dkf__all_finite(L.M, p * n) || !dkf__all_finite(L.Ru, p * p) ||
        !dkf__all_finite(L.S, n * p) || !dkf__all_finite(L.Cn, p * p) ||
        !dkf__all_finite(L.ApHn, p * n) || !dkf__all_finite(L.ApRApn, p * p))
        return DKF_ERR_NONFINITE;
    return DKF_OK;
}

/* Every model input is bitwise the one the memo was computed from. A hit
 * also proves the inputs finite: they equal inputs that were checked when
 * the block was computed. (n, m, p are f's, literals in gain_impl's
 * fixed-size call, fx = 1, which leaves the caller's memo_same aside.) */
DKF__INLINE int memo_hit(int fx, const dkf_diffkf_t *f, const layout_t *L, const dkf_ui_dyn_t *dyn,
                         const dkf_ui_meas_t *meas_next, size_t n, size_t m, size_t p)
{
    if (!f->priv.model_cached || !same_bits(fx, L->mF, dyn->F->data, n * n) ||
        !same_bits(fx, L->mQ, dyn->Q->data, n * n))
        return 0;
    if ((fx || !L->memo_same) &&
        (!same_bits(fx, L->mB, dyn->B->data, p * p) || !same_bits(fx, L->mRd, dyn->Rd->data, p * p) ||
         !same_bits(fx, L->mH, meas_next->H->data, m * n) ||
         !same_bits(fx, L->mA, meas_next->D->data, m * p) ||
         !same_bits(fx, L->mR, meas_next->R->data, m * m)))
        return 0;
    return same_bits(fx, L->mApH, L->ApH, p * n) && same_bits(fx, L->mApRAp, L->ApRAp, p * p);
}

/* The layout's block pointers at the memo. */
DKF__INLINE void memo_use(layout_t *L)
{
    L->G = L->oG;
    L->M = L->oM;
    L->Ru = L->oRu;
    L->S = L->oS;
    L->GH = L->oGH;
    L->Cn = L->oCn;
}

/* model_block, skipped when every model input is bitwise the one it was
 * last computed from (a time-invariant model then pays for it once): the
 * layout's block pointers then point at the memo, and the products the
 * update phase reads (possibly in a later call) are copied to the pending
 * area. A new block is computed into the working area and memoised by
 * commit_caches, so a failure part-way never touches the memo. */
DKF__INLINE dkf_status_t model_block_memo(int fx, const dkf_diffkf_t *f, layout_t *L,
                                          const dkf_ui_dyn_t *dyn, const dkf_ui_meas_t *meas_next,
                                          size_t n, size_t m, size_t p)
{
    if (memo_hit(fx, f, L, dyn, meas_next, n, m, p)) {
        memo_use(L);
        dkf__copy(L->ApHn, L->oApHn, p * n);
        dkf__copy(L->ApRApn, L->oApRApn, p * p);
        return DKF_OK;
    }
    DKF_TRY(check_model_finite(dyn, meas_next));
    {
        /* on a copy: L's address goes to no call, so step_fixed keeps its
         * map in registers (see there) */
        layout_t Lm = *L;
        DKF_TRY(model_block(f, &Lm, dyn, meas_next));
        *L = Lm;
    }
    L->new_dyn = dyn;
    L->new_meas = meas_next;
    return DKF_OK;
}

/* The kept rows of a selection: idx[0..pk-1] ascending; rows NULL = all. */
static size_t kept_rows(size_t *idx, const unsigned char *rows, size_t p)
{
    size_t i, pk = 0;
    for (i = 0; i < p; ++i)
        if (rows == NULL || rows[i] != 0) idx[pk++] = i;
    return pk;
}

/* The selected model of step k (S = the kept rows idx, S' = the previous
 * step's, already applied to the carry's columns):
 *   M' = S M,  Ru' = S Ru S^T,  C'_k = S (C_k S'^T),  Vt' = (carried Vt) S^T,
 *   C_{k+1} S^T (what the next step will carry, whitened).
 * With every row kept (pk = p, S = I) only M' and C_{k+1} S^T, which the
 * update reads, are copied (contiguously): the gain reads C'_k, Ru' and
 * Vt' from the carry and the model block themselves (sel_of). */
DKF__INLINE void select_rows(const layout_t *L, const size_t *idx, size_t n, size_t p, size_t pk,
                             size_t pc)
{
    size_t i, j;
    if (pk == p) {
        memcpy(L->Mk, L->M, p * n * sizeof *L->Mk);
        memcpy(L->Cnk, L->Cn, p * p * sizeof *L->Cnk);
        return;
    }
    for (i = 0; i < pk; ++i) {
        memcpy(L->Mk + i * n, L->M + idx[i] * n, n * sizeof *L->Mk);
        memcpy(L->Ck + i * pc, L->C + idx[i] * pc, pc * sizeof *L->Ck);
        for (j = 0; j < pk; ++j) L->Ruk[i * pk + j] = L->Ru[idx[i] * p + idx[j]];
    }
    for (i = 0; i < pc; ++i)
        for (j = 0; j < pk; ++j) L->Vtk[i * pk + j] = L->Vt[i * p + idx[j]];
    for (i = 0; i < p; ++i)
        for (j = 0; j < pk; ++j) L->Cnk[i * pk + j] = L->Cn[i * p + idx[j]];
}

/* C'_k, Ru' and Vt' of step k: select_rows' copies, or with every row
 * kept the arrays they would copy. */
typedef struct {
    const dkf_real_t *Ck, *Ruk, *Vtk;
} sel_t;

DKF__INLINE sel_t sel_of(const layout_t *L, size_t p, size_t pk)
{
    sel_t s;
    s.Ck = pk == p ? L->C : L->Ck;
    s.Ruk = pk == p ? L->Ru : L->Ruk;
    s.Vtk = pk == p ? L->Vt : L->Vtk;
    return s;
}

#if DKF_JOSEPH
/* Upper triangle (mirrored) of Pn = Ab (P Ab^T + Y Kb^T) + Kb (Sg Kb^T +
 * (Ab Y)^T - Sv^T) + D, i.e. the congruence
 *   [Ab, -Kb, I] [[P, X, 0], [X^T, Sg, Sv^T], [0, Sv, .]] [Ab, -Kb, I]^T
 * of a joint covariance, for Ab (n x n), Kb (n x pk), Y = -X (n x pk), Sg
 * (pk x pk, symmetric), Sv (n x pk, or NULL for 0) and D (n x n, only its
 * upper triangle counts: the sum is symmetric, its parts need not be).
 * (Y is the -X that gain_core has; negation is exact, so these are the
 * bits of the form in X.) U, E (n x n), V (pk x n), AX (n x pk) are
 * scratch. */
DKF__INLINE void joint_congruence(int fx, dkf_real_t *Pn, const dkf_real_t *Ab,
                                  const dkf_real_t *Kb, const dkf_real_t *P, const dkf_real_t *Y,
                                  const dkf_real_t *Sg, const dkf_real_t *Sv, const dkf_real_t *D,
                                  const layout_t *L, size_t n, size_t pk)
{
    size_t i, j;
    k_mul_nt(fx, L->jU, P, Ab, n, n, n); /* U = P Ab^T + Y Kb^T */
    k_mul_nt(fx, L->jE, Y, Kb, n, pk, n);
    k_add(fx, L->jU, L->jU, L->jE, n * n);
    k_mul_nt(fx, L->jV, Sg, Kb, pk, pk, n); /* V = Sg Kb^T + (Ab Y)^T - Sv^T */
    k_mul_nn(fx, L->jAX, Ab, Y, n, n, pk);
    if (Sv != NULL)
        for (i = 0; i < pk; ++i)
            for (j = 0; j < n; ++j) L->jV[i * n + j] += L->jAX[j * pk + i] - Sv[j * pk + i];
    else
        for (i = 0; i < pk; ++i)
            for (j = 0; j < n; ++j) L->jV[i * n + j] += L->jAX[j * pk + i];
    k_mul_nn_sym(fx, L->jE, Ab, L->jU, D, n, n);
    k_mul_nn_sym(fx, Pn, Kb, L->jV, L->jE, n, pk);
}

/* P_{k|k} and P_{k+1|k} in Joseph form (DKF_JOSEPH). With the prior error
 * e = x - x_{k|k-1} (covariance P), the part of u_k the previous
 * innovations do not explain, ut = u_k - C' L_{k-1}^{-1} dz_{k-1}
 * (covariance Sg = Ru' - C' L_{k-1}^{-1} C'^T, cross covariance X =
 * E[e ut^T] = -W'_{k-1} C'^T, so that J = P M'^T + X and L = M' P M'^T +
 * M' X + X^T M'^T + Sg: (19)-(20)) and dz = M' e + ut:
 *   x - x_{k|k}   = (I - K M') e - K ut,
 *   x_{k+1} - x_{k+1|k} = (F - W M') e - W ut + v_k,  E[v_k ut^T] = S',
 * so each covariance is a congruence of the joint covariance of (e, ut,
 * v_k) (joint_congruence), evaluated as written with A = I - K M' and
 * F - W M' formed: the Joseph form of the DKF for the gains computed.
 * P - K J^T and F P F^T + Q - (F J + S') W^T (DKF_JOSEPH=0, and the
 * Theorem-1 form) subtract from P, which loses the result's digits when
 * the data pin the state (docs/decisions.md item 17). Sg is in L.X, -X =
 * W'_{k-1} C'^T in L.jX (both from gain_core), the gains in L.Kn, L.Wn;
 * T1 is scratch. */
DKF__INLINE void joseph_covariances(int fx, const dkf_diffkf_t *f, const layout_t *L,
                                    const dkf_ui_dyn_t *dyn, const size_t *idx, size_t n,
                                    size_t p, size_t pk)
{
    const dkf_real_t *const Q = dyn->Q->data, *const Sk = pk == p ? L->S : L->jS;
    size_t i, j;
    /* P_{k|k}: Ab = I - K M' */
    k_mul_nn(fx, L->T1, L->Kn, L->Mk, n, pk, n);
    k_neg(fx, L->T1, n * n);
    for (i = 0; i < n; ++i) L->T1[i * n + i] += DKF_R(1.0);
    joint_congruence(fx, L->Pfn, L->T1, L->Kn, f->Pn.data, L->jX, L->X, NULL, NULL, L, n, pk);
    /* P_{k+1|k}: Ab = F - W M', D = Q - S' W^T, S' = the kept columns of S
     * (S itself when every row is kept) */
    if (pk < p)
        for (i = 0; i < n; ++i)
            for (j = 0; j < pk; ++j) L->jS[i * pk + j] = L->S[i * p + idx[j]];
    k_mul_nn(fx, L->T1, L->Wn, L->Mk, n, pk, n);
    k_sub(fx, L->T1, dyn->F->data, L->T1, n * n);
    k_mul_nt(fx, L->jD, Sk, L->Wn, n, pk, n);
    k_sub(fx, L->jD, Q, L->jD, n * n);
    joint_congruence(fx, L->Ppn, L->T1, L->Wn, f->Pn.data, L->jX, L->X, Sk, L->jD, L, n, pk);
}
#endif

/* Ln = Ln - X - X^T - T3 on the upper triangle, mirrored (Ln, T3
 * symmetric, r x r): in 16 x 16 tiles, so that the transposed reads of X
 * and the mirrored writes stay in cache at large r; each element is the
 * row-by-row loop's. */
DKF__INLINE void assemble_L(dkf_real_t *Ln, const dkf_real_t *X, const dkf_real_t *T3, size_t r)
{
    size_t i0, j0, i, j;
    for (i0 = 0; i0 < r; i0 += 16)
        for (j0 = i0; j0 < r; j0 += 16) {
            const size_t i1 = i0 + 16 < r ? i0 + 16 : r, j1 = j0 + 16 < r ? j0 + 16 : r;
            for (i = i0; i < i1; ++i)
                for (j = j0 > i ? j0 : i; j < j1; ++j) {
                    const dkf_real_t v = Ln[i * r + j] - X[i * r + j] - X[j * r + i] - T3[i * r + j];
                    Ln[i * r + j] = v;
                    Ln[j * r + i] = v;
                }
        }
}

/* The gain phase on the storage map L (computed once per call chain), for
 * the pk rows idx of z_k (read only when pk < p: with every row kept idx
 * is 0 .. p-1, and a caller may pass NULL). Theorem 1 holds unchanged for
 * a time-varying selection (docs/design/diffkf-fusion.md §8): u'_k = S u_k is
 * correlated only with u'_{k-1}, E[u'_k u'_{k-1}^T] = S C_k S'^T and
 * E[v_k u'_k^T] = S_k S^T, so the recursion below is (19)-(20), (16)-(17)
 * with the primed blocks and every dimension p of the innovation replaced
 * by pk (pc for the carry). */
DKF__INLINE dkf_status_t gain_core(int fx, dkf_diffkf_t *f, const layout_t *L_,
                                   const dkf_ui_dyn_t *dyn, const size_t *idx, size_t n, size_t p,
                                   size_t pk, size_t pc)
{
    const layout_t *const L = L_;
    dkf_real_t *const inv = L->Li;
    size_t i, j, lo[DKF_MAX_DIM], hi[DKF_MAX_DIM];
    const sel_t sel = sel_of(L, p, pk);
    select_rows(L, idx, n, p, pk, pc);

    /* J = P M'^T - W'_{k-1} C'^T                                        (19);
     * at run-time sizes the products with C' run over each row's nonzero
     * span (row_spans: the fusion centre's block-diagonal C; exact zeros
     * skipped, so the same values; W' is finite, committed so) */
    if (!fx) dkf__row_spans(lo, hi, sel.Ck, pk, pc);
    k_mul_nt(fx, L->Jn, f->Pn.data, L->Mk, n, n, pk);
    if (fx) /* jX = W'_{k-1} C'^T, which joseph_covariances reads too */
        k_mul_nt(fx, L->jX, L->W, sel.Ck, n, pc, pk);
    else
        dkf__mul_nt_spans(L->jX, L->W, sel.Ck, n, pc, pk, lo, hi);
    k_sub(fx, L->Jn, L->Jn, L->jX, n * pk);

    /* L = M P M^T - X - X^T + Ru - C L_{k-1}^{-1} C^T, X = M W C^T (primed)
     * (20), as (M W) C^T: M (W C^T), from J's product, costs less at large
     * p but lost a factor 4 of float accuracy on test_diffkf_masked's
     * random models (1.2e-3 against 2.8e-4) */
    k_mul_nn(fx, L->T3, L->Mk, L->W, pk, n, pc); /* M W      */
    if (fx) {
        k_mul_nt(fx, L->X, L->T3, sel.Ck, pk, pc, pk); /* M W C^T  */
    } else {
        /* a non-finite M W made the dense M W C^T, hence L, non-finite */
        if (DKF__UNLIKELY(!dkf__all_finite(L->T3, pk * pc))) return DKF_ERR_NONFINITE;
        dkf__mul_nt_spans(L->X, L->T3, sel.Ck, pk, pc, pk, lo, hi);
    }
    k_mul_nn(fx, L->T3, L->Mk, f->Pn.data, pk, n, n);
    k_mul_nt_sym(fx, L->Ln, L->T3, L->Mk, sel.Ruk, pk, n); /* M P M^T + Ru */
    /* C' L'^{-1}_{k-1} C'^T = Vt'^T Vt' (symmetric as computed) */
    if (fx) {
        inl_mul_tn_sym(L->T3, sel.Vtk, sel.Vtk, NULL, pk, pc);
    } else {
        dkf__tn_self_spans(L->T3, sel.Vtk, pk, pc, lo);
    }
    assemble_L(L->Ln, L->X, L->T3, pk);
#if DKF_JOSEPH
    /* Sg = Ru' - C' L_{k-1}^{-1} C'^T (symmetric) into X, free now */
    for (i = 0; i < pk; ++i)
        for (j = 0; j < pk; ++j)
            L->X[i * pk + j] = sel.Ruk[i * pk + j] - L->T3[i * pk + j];
#endif
    /* an overflow (finite inputs, non-finite L) is not a definiteness question */
    if (DKF__UNLIKELY(!k_finite(fx, L->Ln, pk * pk))) return DKF_ERR_NONFINITE;
    /* T3 (free now, p (n + m) >= pk^2 reals) the wide Cholesky's scratch */
    if (DKF__UNLIKELY(k_chol(fx, L->Lc, inv, L->Ln, pk, L->T3) != 0)) return DKF_ERR_NOT_SPD;

    /* K = J L^{-1};  P_{k|k} = P - K J^T (upper triangle, mirrored; with
     * DKF_JOSEPH the Joseph form below replaces it, but for pk = 0, where
     * nothing is subtracted and the products below would have no terms) */
    right_solve(fx, L->Kn, L->Jn, L->Lc, inv, n, pk, L->T2);
    if (!DKF_JOSEPH || pk == 0) {
        k_mul_nt_sym(fx, L->Pfn, L->Kn, L->Jn, NULL, n, pk);
        for (i = 0; i < n * n; ++i) L->Pfn[i] = f->Pn.data[i] - L->Pfn[i];
    }

    /* W = (F J + S') L^{-1};  P_{k+1|k} = F P F^T + Q - (F J + S') W^T  (16)-(17),
     * S' = S_k S^T: the kept columns of S */
    k_mul_nn(fx, L->T3, dyn->F->data, L->Jn, n, n, pk); /* T3 has p(n+m) >= n p */
    if (pk == p) /* idx = 0, 1, ..., p-1 */
        k_add(fx, L->T3, L->T3, L->S, n * p);
    else
        for (i = 0; i < n; ++i)
            for (j = 0; j < pk; ++j) L->T3[i * pk + j] += L->S[i * p + idx[j]];
    right_solve(fx, L->Wn, L->T3, L->Lc, inv, n, pk, L->T2);
#if DKF_JOSEPH
    if (pk > 0) joseph_covariances(fx, f, L, dyn, idx, n, p, pk);
#endif
    if (!DKF_JOSEPH || pk == 0) {
        k_mul_nn(fx, L->T1, dyn->F->data, f->Pn.data, n, n, n);
        k_mul_nt_sym(fx, L->Ppn, L->T1, dyn->F->data, dyn->Q->data, n, n);
        k_mul_nt_sym(fx, L->T1, L->T3, L->Wn, NULL, n, pk);
        for (i = 0; i < n * n; ++i) L->Ppn[i] -= L->T1[i];
    }

    /* the whitened carry of the next step, Vt = Lc^{-1} (C_{k+1} S^T)^T:
     * with L'_k = Lc Lc^T, its C L^{-1} C^T is Vt^T Vt and its C L^{-1} dz
     * is Vt^T (Lc^{-1} dz), so one forward substitution replaces the
     * Cholesky solve (docs/design/diffkf-fusion.md §9) */
    if (fx) {
        inl_transpose(L->Vtn, L->Cnk, p, pk);
        inl_chol_forward(L->Lc, inv, L->Vtn, pk, p);
    } else {
        dkf__row_spans(lo, hi, L->Cnk, p, pk);
        dkf__whiten_spans(L->Vtn, L->Cnk, L->Lc, inv, p, pk, lo);
    }

    /* the correlated part of the predicted z: C' L'^{-1}_{k-1} dz'_{k-1} =
     * Vt'^T wz' = (wz'^T Vt')^T, wz' = Lc'^{-1}_{k-1} dz'_{k-1}: each zc[i]
     * summed over l ascending, along rows of Vt' */
    if (pc > 0)
        mul_nn_row1(L->zc, L->wzp, sel.Vtk, pc, pk);
    else
        for (i = 0; i < pk; ++i) L->zc[i] = DKF_R(0.0);
    memcpy(L->Fn, dyn->F->data, n * n * sizeof *L->Fn);

    if (DKF__UNLIKELY(!k_finite(fx, L->Kn, n * pk) || !k_finite(fx, L->Wn, n * pk) ||
                      !k_finite(fx, L->Vtn, p * pk)))
        return DKF_ERR_NONFINITE;
    /* both covariances PSD up to rounding (docs/decisions.md item 17); the
     * check refuses a NaN or Inf too, so they are scanned only if it fails */
    if (DKF__UNLIKELY(!k_psd(fx, L->T1, L->Pfn, n) || !k_psd(fx, L->T1, L->Ppn, n)))
        return k_finite(fx, L->Pfn, n * n) && k_finite(fx, L->Ppn, n * n) ? DKF_ERR_NOT_SPD
                                                                          : DKF_ERR_NONFINITE;
    f->pk = pk;
    f->pending = 1;
    return DKF_OK;
}

/* gain_core and update_core are also expanded at the sizes (n, m, p) of
 * DKF_DIFFKF_FIXED_SIZES (top of the file), for the steps that keep every
 * row once the carry is full (pk = pc = p): all others take the
 * run-time-size expansion. */

/* What a gain does before gain_core, once the model's shapes are checked:
 * the pending gain cancelled, the model-only block (model_block_memo). */
DKF__INLINE dkf_status_t gain_prelude(int fx, dkf_diffkf_t *f, layout_t *L,
                                      const dkf_ui_dyn_t *dyn, const dkf_ui_meas_t *meas_next,
                                      size_t n, size_t m, size_t p)
{
    f->pending = 0;
    L->fix[0] = L->fix[1] = DKF_R(0.0);
    return model_block_memo(fx, f, L, dyn, meas_next, n, m, p);
}

/* The steady gain (dkf_diffkf_set_steady): the pending gain serves this
 * step again when the last step settled it (fix), every row is kept and
 * the model is the memo's (the one the pending gain was computed from: a
 * memo miss clears fix before it writes). The carry is then what that
 * gain carried on: only a commit writes it (and sets fix), and init and
 * restore clear fix or the memo; P_{k+1|k}, which the caller can reach
 * through f->Pn, is compared. Only the data term zc is new. 1 if it did;
 * called only with the steady gain on (f->priv.steady_tol > 0). */
static int gain_reuse(dkf_diffkf_t *f, layout_t *L, const dkf_ui_dyn_t *dyn,
                      const dkf_ui_meas_t *meas_next, size_t pk)
{
    const size_t n = f->n, m = f->m, p = f->p;
    if (L->fix[0] == DKF_R(0.0) || pk != p || f->pc != p ||
        !memo_hit(0, f, L, dyn, meas_next, n, m, p) || !same_bits(0, f->Pn.data, L->Ppn, n * n))
        return 0;
    memo_use(L);
    mul_nn_row1(L->zc, L->wzp, L->Vt, p, p);
    L->fix[1] = DKF_R(1.0);
    f->pk = p;
    f->pending = 1;
    return 1;
}

static dkf_status_t gain_impl(dkf_diffkf_t *f, layout_t *L, const dkf_ui_dyn_t *dyn,
                              const dkf_ui_meas_t *meas_next, const size_t *idx, size_t pk)
{
    const size_t n = f->n, m = f->m, p = f->p, pc = f->pc;
    DKF_TRY(check_model_shapes(f, dyn, meas_next));
    if (f->priv.steady_tol > DKF_R(0.0) && gain_reuse(f, L, dyn, meas_next, pk)) return DKF_OK;
#define DIFFKF_MEMO_FIXED(N, M, P) \
    if ((N) <= DKF_MAX_DIM && n == (N) && m == (M) && p == (P)) \
        DKF_TRY(gain_prelude(1, f, L, dyn, meas_next, (N), (M), (P))); \
    else
    DKF_DIFFKF_FIXED_SIZES(DIFFKF_MEMO_FIXED)
#undef DIFFKF_MEMO_FIXED
    DKF_TRY(gain_prelude(0, f, L, dyn, meas_next, n, m, p));
#define DIFFKF_GAIN_FIXED(N, M, P) \
    if ((N) <= DKF_MAX_DIM && n == (N) && p == (P) && pk == (P) && pc == (P)) \
        return gain_core(1, f, L, dyn, idx, (N), (P), (P), (P));
    DKF_DIFFKF_FIXED_SIZES(DIFFKF_GAIN_FIXED)
#undef DIFFKF_GAIN_FIXED
    return gain_core(0, f, L, dyn, idx, n, p, pk, pc);
}

/* (diffkf_internal.h) */
dkf_status_t dkf__diffkf_gain_masked_memo(dkf_diffkf_t *f, const dkf_ui_dyn_t *dyn,
                                          const dkf_ui_meas_t *meas_next, const unsigned char *rows,
                                          int memo_same)
{
    size_t idx[DKF_MAX_DIM], pk;
    dkf_status_t st;
    layout_t L;
    DKF_CHECK_NULL(f);
    if (!f->priv.ready || !f->priv.started) return DKF_ERR_STATE;
    pk = kept_rows(idx, rows, f->p);
    map_of(f, &L);
    L.memo_same = memo_same;
    st = gain_impl(f, &L, dyn, meas_next, idx, pk);
    /* no gain pending (also when the failure came before gain_impl could
     * cancel it): pk describes the last completed step again */
    if (st != DKF_OK) {
        f->pending = 0;
        f->pk = f->z.rows;
        return st;
    }
    commit_caches(f, &L);
    return DKF_OK;
}

dkf_status_t dkf_diffkf_gain_masked(dkf_diffkf_t *f, const dkf_ui_dyn_t *dyn,
                                    const dkf_ui_meas_t *meas_next, const unsigned char *rows)
{
    return dkf__diffkf_gain_masked_memo(f, dyn, meas_next, rows, 0);
}

dkf_status_t dkf_diffkf_gain(dkf_diffkf_t *f, const dkf_ui_dyn_t *dyn,
                             const dkf_ui_meas_t *meas_next)
{
    return dkf_diffkf_gain_masked(f, dyn, meas_next, NULL);
}

dkf_status_t dkf_diffkf_pending(const dkf_diffkf_t *f, dkf_mat_t *M, dkf_mat_t *K,
                                dkf_mat_t *zcorr)
{
    layout_t L;
    DKF_CHECK_NULL(f);
    if (!f->pending) return DKF_ERR_STATE;
    map_of(f, &L);
    if (M != NULL) M->rows = f->pk, M->cols = f->n, M->data = L.Mk;
    if (K != NULL) K->rows = f->n, K->cols = f->pk, K->data = L.Kn;
    if (zcorr != NULL) zcorr->rows = f->pk, zcorr->cols = 1, zcorr->data = L.zc;
    return DKF_OK;
}

/* max |a - b| <= tol max |b| over len reals (finite). */
static int within(const dkf_real_t *a, const dkf_real_t *b, size_t len, dkf_real_t tol)
{
    dkf_real_t d = DKF_R(0.0), s = DKF_R(0.0);
    size_t i;
    for (i = 0; i < len; ++i) {
        const dkf_real_t e = DKF_FABS(a[i] - b[i]), v = DKF_FABS(b[i]);
        d = e > d ? e : d;
        s = v > s ? v : s;
    }
    return d <= tol * s;
}

/* Whether the pending gain (pk rows), about to be committed, settles the
 * recursion for dkf_diffkf_set_steady: every row kept after a step that
 * kept every row, the same C_{k+1}, and P_{k+1|k}, W and Vt each within
 * the steady tolerance of the ones the gain read. */
static int settles(const dkf_diffkf_t *f, const layout_t *L, size_t n, size_t p, size_t pk)
{
    const dkf_real_t tol = f->priv.steady_tol;
    return pk == p && f->pc == p && same_bits(0, L->C, L->Cnk, p * p) &&
           within(L->Ppn, f->Pn.data, n * n, tol) && within(L->Wn, L->W, n * p, tol) &&
           within(L->Vtn, L->Vt, p * p, tol);
}

/* Commits the pending gain (pk rows): the covariances, the step's J, L,
 * K views, the carry of the next step and the model products it keys on. */
DKF__INLINE void commit_gain(dkf_diffkf_t *f, const layout_t *L, size_t n, size_t p, size_t pk)
{
    memcpy(f->Pf.data, L->Pfn, (n * n) * sizeof(dkf_real_t));
    memcpy(f->Pn.data, L->Ppn, (n * n) * sizeof(dkf_real_t));
    memcpy(f->J.data, L->Jn, (n * pk) * sizeof(dkf_real_t));
    memcpy(f->L.data, L->Ln, (pk * pk) * sizeof(dkf_real_t));
    memcpy(f->K.data, L->Kn, (n * pk) * sizeof(dkf_real_t));
    f->z.rows = pk;
    f->dz.rows = pk;
    f->J.cols = pk;
    f->L.rows = pk;
    f->L.cols = pk;
    f->K.cols = pk;
    memcpy(L->C, L->Cnk, (p * pk) * sizeof(dkf_real_t));
    memcpy(L->Vt, L->Vtn, (p * pk) * sizeof(dkf_real_t));
    memcpy(L->W, L->Wn, (n * pk) * sizeof(dkf_real_t));
    f->pc = pk;
    memcpy(L->ApH, L->ApHn, (p * n) * sizeof(dkf_real_t));
    memcpy(L->ApRAp, L->ApRApn, (p * p) * sizeof(dkf_real_t));
}

/* The update phase on the storage map L; z (f->pk reals) and y_next
 * already checked; steady = the steady gain is on (f->priv.steady_tol > 0). */
DKF__INLINE dkf_status_t update_core(int fx, int steady, dkf_diffkf_t *f, const layout_t *L_,
                                     const dkf_real_t *zk, const dkf_mat_t *y_next, size_t n,
                                     size_t m, size_t p, size_t pk)
{
    const layout_t *const L = L_;
    /* dz, wz (pk), xf, xn (n) side by side: one finiteness scan */
    dkf_real_t v[4 * DKF_MAX_DIM], apy[DKF_MAX_DIM];
    dkf_real_t *const dz = v, *const wz = v + pk, *const xf = v + 2 * pk, *const xn = xf + n;
    size_t i;
    const int reused = steady && L->fix[1] != DKF_R(0.0);
    int settled;
    /* dz = z - M x_{k|k-1} - C L^{-1} dz_{k-1}                          (18) */
    k_mul_vec(fx, dz, L->Mk, f->xn.data, pk, n);
    for (i = 0; i < pk; ++i) dz[i] = zk[i] - dz[i] - L->zc[i];
    /* x_{k|k} = x_{k|k-1} + K dz;  x_{k+1|k} = F x_{k|k-1} + W dz */
    k_mul_vec(fx, xf, L->Kn, dz, n, pk);
    k_mul_vec(fx, xn, L->Fn, f->xn.data, n, n);
    for (i = 0; i < n; ++i) {
        xf[i] += f->xn.data[i];
        xn[i] += inl_dot(L->Wn + i * pk, dz, pk);
    }
    /* the whitened innovation the next step's zcorr needs: wz = Lc^{-1} dz */
    memcpy(wz, dz, pk * sizeof *wz);
    inl_tri_lower_solve_vec(L->Lc, L->Li, wz, pk);
    if (DKF__UNLIKELY(!k_finite(fx, v, 2 * pk + 2 * n))) return DKF_ERR_NONFINITE;
    /* A_k^+ y_k, the next step's z term, before anything is committed: an
     * overflow of finite inputs is NONFINITE with the filter untouched
     * (fuzz_core_diffkf found it committed as inf) */
    if (y_next != NULL) {
        k_mul_vec(fx, apy, L->Ap, y_next->data, p, m);
        if (DKF__UNLIKELY(!k_finite(fx, apy, p))) return DKF_ERR_NONFINITE;
    }

    /* the steady gain: may this gain serve the next step too? (a reused
     * one does: its covariances, gains and carry are already committed) */
    settled = steady && (reused || settles(f, L, n, p, pk));
    /* commit: caches (a one-phase step's), estimates, the step's
     * quantities (pk rows), and the carry */
    commit_caches(f, L);
    memcpy(f->xp.data, f->xn.data, (n) * sizeof(dkf_real_t));
    memcpy(f->xf.data, xf, (n) * sizeof(dkf_real_t));
    memcpy(f->xn.data, xn, (n) * sizeof(dkf_real_t));
    memcpy(f->z.data, zk, (pk) * sizeof(dkf_real_t));
    memcpy(f->dz.data, dz, (pk) * sizeof(dkf_real_t));
    memcpy(L->wzp, wz, (pk) * sizeof(dkf_real_t));
    if (!reused) commit_gain(f, L, n, p, pk);
    if (steady) L->fix[0] = settled ? DKF_R(1.0) : DKF_R(0.0); /* else 0 since the gain */
    f->steady = reused;
    f->priv.has_y = y_next != NULL;
    if (y_next != NULL) memcpy(L->Apy, apy, p * sizeof(dkf_real_t));
    f->k += 1;
    f->pending = 0;
    return DKF_OK;
}

static dkf_status_t update_impl(dkf_diffkf_t *f, const layout_t *L, const dkf_real_t *zk,
                                const dkf_mat_t *y_next)
{
    const size_t n = f->n, m = f->m, p = f->p, pk = f->pk;
    const int steady = f->priv.steady_tol > DKF_R(0.0);
#define DIFFKF_UPDATE_FIXED(N, M, P) \
    if ((N) <= DKF_MAX_DIM && n == (N) && m == (M) && p == (P) && pk == (P)) \
        return update_core(1, steady, f, L, zk, y_next, (N), (M), (P), (P));
    DKF_DIFFKF_FIXED_SIZES(DIFFKF_UPDATE_FIXED)
#undef DIFFKF_UPDATE_FIXED
    return update_core(0, steady, f, L, zk, y_next, n, m, p, pk);
}

dkf_status_t dkf_diffkf_update_z(dkf_diffkf_t *f, const dkf_mat_t *z, const dkf_mat_t *y_next)
{
    static const dkf_real_t empty[1] = {DKF_R(0.0)};
    layout_t L;
    DKF_CHECK_NULL(f);
    if (!f->pending) return DKF_ERR_STATE;
    if (f->pk == 0) {
        /* a pure prediction: no datum; a given z must be empty */
        if (z != NULL && (z->rows != 0 || z->cols != 1)) return DKF_ERR_DIM;
    } else {
        DKF_TRY(dkf__check_input(z, f->pk, 1));
    }
    if (y_next != NULL) DKF_TRY(dkf__check_input(y_next, f->m, 1));
    map_of(f, &L);
    return update_impl(f, &L, f->pk == 0 ? empty : z->data, y_next);
}

/* z_k = G y_{k+1} - A_k^+ y_k                                        (8) */
DKF__INLINE void z_of(int fx, dkf_real_t *z, const layout_t *L, const dkf_real_t *y_next,
                      size_t m, size_t p)
{
    size_t i;
    k_mul_vec(fx, z, L->G, y_next, p, m);
    for (i = 0; i < p; ++i) z[i] -= L->Apy[i];
}

/* dkf_diffkf_step at a size (n, m, p) of DKF_DIFFKF_FIXED_SIZES (literals)
 * with a full carry (pc = p, every row kept): gain_impl's and
 * update_impl's bodies in one function, on a storage map that is a local
 * whose address no call receives (model_block_memo gives model_block a
 * copy; the rest is inline). The compiler then keeps each of the map's
 * addresses as mem + a constant instead of storing some 70 pointers and
 * loading them back: 4203 -> 3824 instructions per step on seed 000
 * Example 1 (double, callgrind, 2026-12-05). Unused in a build whose
 * DKF_DIFFKF_FIXED_SIZES is empty, which Clang would report. */
#if defined(__GNUC__)
__attribute__((unused))
#endif
DKF__INLINE dkf_status_t step_fixed(dkf_diffkf_t *f, const dkf_ui_dyn_t *dyn,
                                    const dkf_ui_meas_t *meas_next, const dkf_mat_t *y_next,
                                    size_t n, size_t m, size_t p)
{
    dkf_real_t z[DKF_MAX_DIM];
    layout_t L;
    (void)layout(&L, f->priv.mem, n, m, p);
    DKF_TRY(check_model_shapes(f, dyn, meas_next));
    DKF_TRY(gain_prelude(1, f, &L, dyn, meas_next, n, m, p));
    DKF_TRY(gain_core(1, f, &L, dyn, NULL, n, p, p, p));
    z_of(1, z, &L, y_next->data, m, p);
    return update_core(1, 0, f, &L, z, y_next, n, m, p, p); /* steady gain off */
}

dkf_status_t dkf_diffkf_step(dkf_diffkf_t *f, const dkf_ui_dyn_t *dyn,
                             const dkf_ui_meas_t *meas_next, const dkf_mat_t *y_next)
{
    dkf_real_t z[DKF_MAX_DIM];
    dkf_status_t st;
    layout_t L;
    DKF_CHECK_NULL(f);
    /* a pending gain awaits dkf_diffkf_update_z (or a new gain): a step
     * would have to discard it */
    if (!f->priv.ready || !f->priv.started || !f->priv.has_y || f->pending) return DKF_ERR_STATE;
    DKF_TRY(dkf__check_input(y_next, f->m, 1));
#define DIFFKF_STEP_FIXED(N, M, P) \
    if ((N) <= DKF_MAX_DIM && f->n == (N) && f->m == (M) && f->p == (P) && f->pc == (P) && \
        f->priv.steady_tol <= DKF_R(0.0)) \
        st = step_fixed(f, dyn, meas_next, y_next, (N), (M), (P)); \
    else
    DKF_DIFFKF_FIXED_SIZES(DIFFKF_STEP_FIXED)
#undef DIFFKF_STEP_FIXED
    {
        map_of(f, &L);
        st = gain_impl(f, &L, dyn, meas_next, NULL, f->p); /* every row kept */
        if (st == DKF_OK) {
            z_of(0, z, &L, y_next->data, f->m, f->p);
            st = update_impl(f, &L, z, y_next);
        }
    }
    /* nothing was pending, and nothing is: pk describes the last completed
     * step, as before the call */
    if (st != DKF_OK) {
        f->pending = 0;
        f->pk = f->z.rows;
    }
    return st;
}

dkf_status_t dkf_diffkf_set_steady(dkf_diffkf_t *f, dkf_real_t tol)
{
    DKF_CHECK_NULL(f);
    if (!f->priv.ready) return DKF_ERR_STATE;
    if (!(tol >= DKF_R(0.0) && tol < DKF_R(1.0))) return DKF_ERR_ARG; /* NaN too */
    f->priv.steady_tol = tol;
    return DKF_OK;
}

dkf_status_t dkf_diffkf_set_time(dkf_diffkf_t *f, size_t k)
{
    DKF_CHECK_NULL(f);
    if (!f->priv.ready) return DKF_ERR_STATE;
    f->k = k;
    return DKF_OK;
}

/* ---- checkpoints ------------------------------------------------------------
 * Layout (reals): a header of CKPT_HEAD small integers (internal.h's
 * checkpoint header: each exact in any real type): tag, n, m, p, k in
 * DKF__CKPT_K_LEN 16-bit digits, the last step's kept rows (the views'
 * size), the carry's columns pc, flags (started, has_y); then the output
 * views and the carry, verbatim (they are contiguous at the start of the
 * storage, up to the caches: layout()). */
#define CKPT_TAG 17479 /* "DF" + 1: the carry is whitened (Vt, wz) */
#define CKPT_K 4       /* where k starts */
#define CKPT_HEAD (CKPT_K + DKF__CKPT_K_LEN + 3)

/* The reals a checkpoint holds: the output views and the carry, up to the
 * caches (diffkf_internal.h). */
size_t dkf__diffkf_carry_len(const dkf_diffkf_t *f)
{
    const layout_t L = mem_of(f);
    return (size_t)(L.Alast - f->xf.data);
}

/* (diffkf_internal.h) */
int dkf__diffkf_memo(const dkf_diffkf_t *f, const dkf_real_t **H, const dkf_real_t **D,
                     const dkf_real_t **R, const dkf_real_t **B, const dkf_real_t **Rd)
{
    const layout_t L = mem_of(f);
    if (!f->priv.model_cached) return 0;
    *H = L.mH;
    *D = L.mA;
    *R = L.mR;
    *B = L.mB;
    *Rd = L.mRd;
    return 1;
}

size_t dkf_diffkf_checkpoint_len(const dkf_diffkf_t *f)
{
    return f != NULL && f->priv.ready ? CKPT_HEAD + dkf__diffkf_carry_len(f) : 0;
}

dkf_status_t dkf_diffkf_save(const dkf_diffkf_t *f, dkf_real_t *buf, size_t len)
{
    dkf_real_t *const tail = buf + CKPT_K + DKF__CKPT_K_LEN;
    DKF_CHECK_NULL(f);
    DKF_CHECK_NULL(buf);
    if (!f->priv.ready) return DKF_ERR_STATE;
    if (len < dkf_diffkf_checkpoint_len(f)) return DKF_ERR_CAPACITY;
    buf[0] = (dkf_real_t)CKPT_TAG;
    buf[1] = (dkf_real_t)f->n;
    buf[2] = (dkf_real_t)f->m;
    buf[3] = (dkf_real_t)f->p;
    dkf__ckpt_put_k(buf + CKPT_K, f->k);
    tail[0] = (dkf_real_t)f->z.rows;
    tail[1] = (dkf_real_t)f->pc;
    tail[2] = (dkf_real_t)((f->priv.started ? 1 : 0) + (f->priv.has_y ? 2 : 0));
    dkf__copy(buf + CKPT_HEAD, f->xf.data, dkf__diffkf_carry_len(f));
    return DKF_OK;
}

/* The header's fields after k: the views' rows, pc and the flags. */
typedef struct {
    size_t pk, pc, flags;
} ckpt_tail_t;

static int ckpt_tail(const dkf_diffkf_t *f, const dkf_real_t *buf, ckpt_tail_t *t)
{
    const dkf_real_t *const tail = buf + CKPT_K + DKF__CKPT_K_LEN;
    return dkf__ckpt_int(tail[0], f->p, &t->pk) && dkf__ckpt_int(tail[1], f->p, &t->pc) &&
           dkf__ckpt_int(tail[2], 3, &t->flags);
}

dkf_status_t dkf_diffkf_checkpoint_check(const dkf_diffkf_t *f, const dkf_real_t *buf,
                                         size_t len)
{
    ckpt_tail_t t;
    size_t k = 0;
    DKF_CHECK_NULL(f);
    DKF_CHECK_NULL(buf);
    if (!f->priv.ready) return DKF_ERR_STATE;
    if (len < dkf_diffkf_checkpoint_len(f)) return DKF_ERR_CAPACITY;
    if (!dkf__ckpt_is(buf[0], CKPT_TAG)) return DKF_ERR_ARG;
    if (!dkf__ckpt_is(buf[1], f->n) || !dkf__ckpt_is(buf[2], f->m) || !dkf__ckpt_is(buf[3], f->p))
        return DKF_ERR_DIM;
    DKF_TRY(dkf__ckpt_get_k(buf + CKPT_K, &k));
    if (!ckpt_tail(f, buf, &t)) return DKF_ERR_ARG;
    if (!dkf__all_finite(buf + CKPT_HEAD, dkf__diffkf_carry_len(f))) return DKF_ERR_NONFINITE;
    return DKF_OK;
}

dkf_status_t dkf_diffkf_restore(dkf_diffkf_t *f, const dkf_real_t *buf, size_t len)
{
    ckpt_tail_t t;
    size_t k = 0;
    DKF_TRY(dkf_diffkf_checkpoint_check(f, buf, len));
    (void)dkf__ckpt_get_k(buf + CKPT_K, &k);
    (void)ckpt_tail(f, buf, &t);
    dkf__copy(f->xf.data, buf + CKPT_HEAD, dkf__diffkf_carry_len(f));
    f->k = k;
    f->pk = t.pk;
    f->z.rows = t.pk;
    f->dz.rows = t.pk;
    f->J.cols = t.pk;
    f->L.rows = t.pk;
    f->L.cols = t.pk;
    f->K.cols = t.pk;
    f->pc = t.pc;
    f->priv.started = (t.flags & 1u) != 0;
    f->priv.has_y = (t.flags & 2u) != 0;
    /* a pending gain belongs to the abandoned state; the caches are keyed
     * on their inputs and would stay valid, but recomputing them is cheap
     * and gives the same bits */
    f->pending = 0;
    f->priv.d_cached = f->priv.b_cached = f->priv.model_cached = 0;
    return DKF_OK;
}
