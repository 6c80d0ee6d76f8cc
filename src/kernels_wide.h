/*
 * src/kernels_wide.h - the kernels of a large stacked Difference KF
 * (docs/design/diffkf-fusion.md §9): the wide Cholesky, the whitening of the carry and its Gram matrix,
 * written once and compiled twice: by kernels.c for the baseline ISA and,
 * on x86-64 under GCC, by kernels_avx.c for AVX (chosen at run time,
 * kernels.h). The includer defines
 *   KW(name)     the instance's name for name (name##_base, name##_avx);
 *   KW_W         the widest column block (8, or 4 AVX vectors);
 *   KW_NN        its 2 x KW_W register block, nn_2x8's contract;
 *   KW_SOLVE     its 2 x KW_W forward-substitution block, solve_2x8's.
 * Every element is summed in the same order whatever the block widths (the
 * blocks only choose which elements share loads), and each lane of a vector
 * computes what the scalar code computes (no FMA: neither instance
 * contracts), so both instances return the same bits; test_kernels_wide
 * checks both against the textbook loops. Contracts: kernels.h. Not
 * installed; no include guard (included once per instance).
 */

/* Columns j .. j+w-1 (w = KW_W, 8, 4 or 1, j + w <= i) of rows i and k =
 * i+1 of the factor: the sums over l < j as one register block against T
 * (T(l, j..) = L(j.., l), contiguous), each then continued over l = j ..
 * c-1 from the columns just finished. The block's sums start at their
 * first product, the textbook's at +0: +0 + s is the textbook's value
 * whatever the signs of zero terms (a sum's sign of zero matters only
 * while every term so far is zero), so every element is inl_chol's. */
static void KW(chol_cols)(dkf_real_t *wi, dkf_real_t *wk, const dkf_real_t *ai,
                          const dkf_real_t *ak, const dkf_real_t *W, const dkf_real_t *T,
                          const dkf_real_t *inv, size_t n, size_t j, size_t w)
{
    dkf_real_t s[2 * KW_W];
    size_t c, l;
    for (c = 0; c < w; ++c) s[c] = s[KW_W + c] = DKF_R(0.0);
    if (j > 0) {
        if (w == KW_W)
            KW_NN(s, s + KW_W, wi, wk, 1, T + j, j, n);
        else if (w == 8)
            nn_2x8(s, s + KW_W, wi, wk, 1, T + j, j, n);
        else if (w == 4)
            nn_2x4(s, s + KW_W, wi, wk, 1, T + j, j, n);
        else
            nn_2x1(s, s + KW_W, wi, wk, 1, T + j, j, n);
    }
    for (c = 0; c < w; ++c) {
        const dkf_real_t *wc = W + (j + c) * n;
        dkf_real_t t0 = DKF_R(0.0) + s[c], t1 = DKF_R(0.0) + s[KW_W + c];
        for (l = j; l < j + c; ++l) {
            t0 += wi[l] * wc[l];
            t1 += wk[l] * wc[l];
        }
        wi[j + c] = (ai[j + c] - t0) * inv[j + c];
        wk[j + c] = (ak[j + c] - t1) * inv[j + c];
    }
}

/* dkf__chol_wide: rows two at a time, their columns in blocks of KW_W, 8,
 * 4 and 1 (chol_cols), the diagonal as inl_chol (chol_diag2); each
 * finished pair of rows is copied into T transposed. */
int KW(dkf__chol_wide)(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n,
                       dkf_real_t *T)
{
    static const size_t widths[3] = {KW_W, 8, 4};
    size_t i, j, l, b;
    for (i = 0; i + 1 < n; i += 2) {
        dkf_real_t *wi = W + i * n, *wk = wi + n;
        const dkf_real_t *ai = A + i * n, *ak = ai + n;
        for (b = 0, j = 0; b < 3; ++b)
            for (; j + widths[b] <= i; j += widths[b])
                KW(chol_cols)(wi, wk, ai, ak, W, T, inv, n, j, widths[b]);
        for (; j < i; ++j) KW(chol_cols)(wi, wk, ai, ak, W, T, inv, n, j, 1);
        if (chol_diag2(wi, wk, ai, ak, inv, n, i, 0) != 0) return -1;
        for (l = 0; l <= i; ++l) {
            T[l * n + i] = wi[l];
            T[l * n + i + 1] = wk[l];
        }
    }
    if (i < n) /* the last row of an odd n: inl_chol's */
        return inl_chol_last(W, inv, A, n, i);
    return 0;
}

/* Rows i and (if two) i+1 of the forward substitution L W = B (L = Lc,
 * p x p; B p x r, row-major) on the w = KW_W, 8 or 4 columns j..j+w-1,
 * the terms l from s0 (zeros before): both sums over l < i together, then
 * row i+1's last term, l = i, from the finished row i: the order of the
 * one-row loop (l ascending), the same bits. A lone last row writes its
 * second result to a scratch block. */
static void KW(forward_rows)(dkf_real_t *B, const dkf_real_t *Lc, const dkf_real_t *inv,
                             size_t p, size_t r, size_t j, size_t s0, size_t i, size_t w)
{
    const int two = i + 1 < p;
    const dkf_real_t *li = Lc + i * p, *lk = two ? li + p : li;
    dkf_real_t *bi = B + i * r + j, *bk = bi + r, spare[KW_W];
    const dkf_real_t c = two ? li[p + i] : DKF_R(0.0), dk = two ? inv[i + 1] : DKF_R(1.0);
    const dkf_real_t *x = B + s0 * r + j;
    if (!two) {
        memcpy(spare, bi, w * sizeof *spare);
        bk = spare;
    }
    if (w == KW_W)
        KW_SOLVE(bi, bk, x, (ptrdiff_t)r, li + s0, lk + s0, 1, i - s0, inv[i], c, dk);
    else if (w == 8)
        solve_2x8(bi, bk, x, (ptrdiff_t)r, li + s0, lk + s0, 1, i - s0, inv[i], c, dk);
    else
        solve_2x4(bi, bk, x, (ptrdiff_t)r, li + s0, lk + s0, 1, i - s0, inv[i], c, dk);
}

/* dkf__whiten_spans: Out = Y^T, then the forward substitution of each
 * block of KW_W, 8 and 4 columns from the block's smallest lo, two rows at
 * a time (forward_rows), then the last columns one by one from their own
 * lo; each element's terms in inl_chol_forward's order (l ascending). */
void KW(dkf__whiten_spans)(dkf_real_t *Out, const dkf_real_t *Y, const dkf_real_t *Lc,
                           const dkf_real_t *inv, size_t r, size_t p, const size_t *lo)
{
    static const size_t widths[3] = {KW_W, 8, 4};
    size_t i, j = 0, l, b, q;
    dkf__transpose(Out, Y, r, p);
    for (b = 0; b < 3; ++b)
        for (; j + widths[b] <= r; j += widths[b]) {
            size_t s0 = lo[j];
            for (q = 1; q < widths[b]; ++q) s0 = lo[j + q] < s0 ? lo[j + q] : s0;
            for (i = s0; i < p; i += 2) KW(forward_rows)(Out, Lc, inv, p, r, j, s0, i, widths[b]);
        }
    for (; j < r; ++j)
        for (i = lo[j]; i < p; ++i) {
            const dkf_real_t *li = Lc + i * p;
            dkf_real_t t = Out[i * r + j];
            for (l = lo[j]; l < i; ++l) t -= li[l] * Out[l * r + j];
            Out[i * r + j] = t * inv[i];
        }
}

/* dkf__tn_self_spans: lo[j] = the first nonzero row of column j of A (k
 * for a zero column); the upper triangle two rows at a time in blocks of
 * KW_W, 8, 4, 2 and 1 columns, mirrored; each block's sums run from l0 =
 * max(min lo of its two rows, min lo of its columns), before which every
 * product of the block has a zero factor, in index order: inl_mul_tn_sym's
 * values (at most the sign of a zero differs). For a block-diagonal C,
 * lo[j] grows with j and this costs about r^2 k / 6 multiply-adds instead
 * of r^2 k / 2. */
void KW(dkf__tn_self_spans)(dkf_real_t *C, const dkf_real_t *A, size_t r, size_t k, size_t *lo)
{
    dkf_real_t s[2 * KW_W];
    size_t i, j, w, q, l;
    for (j = 0; j < r; ++j) {
        for (l = 0; l < k && A[l * r + j] == DKF_R(0.0); ++l) continue;
        lo[j] = l;
    }
    for (i = 0; i + 2 <= r; i += 2) {
        const size_t li = lo[i] < lo[i + 1] ? lo[i] : lo[i + 1];
        for (j = i; j < r; j += w) {
            size_t l0 = lo[j];
            w = r - j >= KW_W ? KW_W : r - j >= 8 ? 8 : r - j >= 4 ? 4 : r - j >= 2 ? 2 : 1;
            for (q = 1; q < w; ++q) l0 = lo[j + q] < l0 ? lo[j + q] : l0;
            l0 = l0 > li ? l0 : li;
            if (l0 >= k) {
                for (q = 0; q < 2 * w; ++q) s[q] = DKF_R(0.0);
            } else {
                const dkf_real_t *a = A + l0 * r;
                if (w == KW_W)
                    KW_NN(s, s + w, a + i, a + i + 1, r, a + j, k - l0, r);
                else if (w == 8)
                    nn_2x8(s, s + w, a + i, a + i + 1, r, a + j, k - l0, r);
                else if (w == 4)
                    nn_2x4(s, s + w, a + i, a + i + 1, r, a + j, k - l0, r);
                else if (w == 2)
                    block_2x2(s, s + w, a + i, a + i + 1, r, a + j, k - l0, r, j);
                else
                    nn_2x1(s, s + w, a + i, a + i + 1, r, a + j, k - l0, r);
            }
            put_sym_2xw(C + i * r + j, C + (i + 1) * r + j, C + j * r + i, zero_row, zero_row, s,
                        w, r, j == i);
        }
    }
    if (i < r) /* the last row of an odd count: its diagonal */
        C[i * r + i] =
            lo[i] < k ? nn_1x1(A + lo[i] * r + i, r, A + lo[i] * r + i, k - lo[i], r) : DKF_R(0.0);
}
