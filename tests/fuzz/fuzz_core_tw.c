/*
 * fuzz_core_tw - the Talebi-Werner node (dkf/tw.h): init, then up to 24
 * info packets, local steps (on the packet, or a byte-edited one),
 * commits (of the local estimate, or of byte-given x and packed P) and
 * centralized steps over 1-3 sensors, on byte-edited models (fuzz_core.h,
 * fz_run).
 * Property: a failed call leaves the struct and DKF_TW_NODE_STATE_LEN
 * reals of storage byte-identical, and the pending step while one is
 * pending (a failed local or central step too); a failed packet leaves
 * the packet untouched; after a successful call the state is finite and
 * P is exactly symmetric.
 */
#include "dkf/tw.h"
#include "fuzz_core.h"

#define NMAX 4
#define PMAX 3
#define MMAX 3

static dkf_real_t st[DKF_TW_NODE_STORAGE_LEN(NMAX, MMAX, PMAX)];
static dkf_real_t pkt[DKF_TW_PKT_LEN(NMAX)], info[DKF_TW_PKT_LEN(NMAX)];
static dkf_real_t xs[NMAX], Ps[DKF_TW_PKT_LEN(NMAX)];
static fz_mat_t x0, P0, A, B, Sv, H[3], Sw[3], y[3];
static dkf_kf_meas_t sn[3];
static dkf_mat_t ys[3];
static dkf_uif_dyn_t md = {.F = &A.v, .G = &B.v, .Q = &Sv.v};
static dkf_tw_node_t nd;
static size_t n, p, m, len, blk;
static int sym, have_pkt;

static void decode(fz_t *z)
{
    n = fz_dim(z, NMAX);
    p = fz_dim(z, PMAX);
    m = fz_dim(z, MMAX);
    len = DKF_TW_PKT_LEN(n);
    blk = DKF_TW_NODE_STATE_LEN(n, p) - n - n * n;
    have_pkt = 0;
    sym = fz_kf_prior(z, &x0, &P0, n);
}

static dkf_status_t init(void)
{
    return dkf_tw_node_init(&nd, n, m, p, st, DKF_TW_NODE_STORAGE_LEN(n, m, p), &x0.v, &P0.v);
}

/* The model and 3 sensors at their defaults, then byte-chosen edits. */
static void edited_model(fz_t *z)
{
    fz_mat_t *const md_m[] = {&A, &B, &Sv},
                    *const sn_m[] = {&H[0], &Sw[0], &y[0], &H[1], &Sw[1], &y[1], &H[2], &Sw[2], &y[2]};
    size_t i;
    fz_set(&A, n, n, DKF_R(0.9), DKF_R(0.05));
    fz_set(&B, n, p, DKF_R(1.0), DKF_R(0.0));
    fz_set(&Sv, n, n, DKF_R(0.1), DKF_R(0.0));
    for (i = 0; i < 3; ++i) {
        fz_set(&H[i], m, n, DKF_R(1.0), DKF_R(0.1));
        fz_set(&Sw[i], m, m, DKF_R(0.5), DKF_R(0.0));
        fz_set(&y[i], m, 1, DKF_R(0.3), DKF_R(0.3));
        sn[i].H = &H[i].v, sn[i].R = &Sw[i].v;
    }
    fz_edit(z, md_m, 3);
    fz_edit(z, sn_m, 9);
    for (i = 0; i < 3; ++i) ys[i] = y[i].v;
}

static dkf_status_t op(fz_t *z, uint8_t code, fz_snap_t *s)
{
    const size_t ns = 1 + (size_t)(code >> 4) % 3;
    size_t i;
    fz_regions_clear(s);
    fz_region(s, &nd, sizeof nd);
    fz_region(s, st, (DKF_TW_NODE_STATE_LEN(n, p) + (nd.pending ? blk : 0)) * sizeof(dkf_real_t));
    edited_model(z);
    switch (code % 4) {
    case 0: /* an info packet: the packet is untouched on failure */
        fz_region(s, pkt, sizeof pkt);
        fz_take(s);
        if (fz_after(s, dkf_tw_meas_packet(pkt, &nd, &sn[0], &ys[0],
                                            code & 8 ? fz_real(z) : DKF_R(1.0)))) {
            fz_finite(pkt, len);
            have_pkt = 1;
        }
        return FZ_SKIP;
    case 1: /* the local step (over a pending one too) */
        if (!have_pkt) return FZ_SKIP;
        memcpy(info, pkt, len * sizeof *info);
        if (code & 8) info[fz_byte(z) % len] = fz_real(z);
        fz_take(s);
        return dkf_tw_node_local(&nd, &md, info, NULL);
    case 2: /* commit the local estimate, or a given x and packed P */
        for (i = 0; i < n; ++i) xs[i] = fz_real(z);
        for (i = 0; i < len - n; ++i) Ps[i] = DKF_R(0.0);
        for (i = 0; i < n; ++i) Ps[i * n - i * (i - 1) / 2] = DKF_R(1.0); /* identity, packed */
        if (code & 16) Ps[fz_byte(z) % (len - n)] = fz_real(z);
        fz_take(s);
        return dkf_tw_node_commit(&nd, code & 8 ? xs : NULL, code & 32 ? Ps : NULL);
    default:
        fz_take(s);
        return dkf_tw_central_step(&nd, &md, sn, ys, ns);
    }
}

static void ok(void)
{
    fz_finite(st, DKF_TW_NODE_STATE_LEN(n, p));
    fz_symmetric(nd.P.data, n, sym);
}

FZ_HARNESS(nd, NULL)
