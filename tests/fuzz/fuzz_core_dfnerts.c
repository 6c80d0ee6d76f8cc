/*
 * fuzz_core_dfnerts - one node of seed 001's consensus network
 * (dkf/dfnerts.h): a kind (NERTSIF, DNERTSIF, or a covariance / invalid
 * one), a variant (PAPER, JOINT, or an invalid one), dimensions with
 * p = 0 .. 2, init on byte-edited priors, then up to 24 node calls (local,
 * mix, commit, cancel, restart, rejoin: in any order, so out of sequence
 * and over a pending step too) on the lin_x_sin_d model of
 * tests/nerts_fixture.h with byte-edited model matrices, Q, R, z, scale,
 * rounds over the node's own packet and a byte-edited neighbour packet
 * with byte-chosen weights, restarts on byte-edited priors and rejoins
 * from a byte-edited packet (the node's own while a step is pending, else
 * y = 1/2, Y = I) with byte-edited d0, Pd0 (fuzz_core.h).
 * Property: a failed call leaves the struct, DKF_DFNERTS_NODE_STATE_LEN
 * reals of storage and, while a step is pending, the pending step
 * (DKF_DFNERTS_NODE_PENDING_LEN reals from DKF_DFNERTS_NODE_PENDING_AT)
 * byte-identical; after a successful call the state is finite and Px is
 * exactly symmetric.
 */
#include "dkf/dfnerts.h"
#include "fuzz_core.h"
#include "../nerts_fixture.h"

#define NMAX 4
#define MMAX 4
#define PMAX 2
#define PKT DKF_DFNERTS_PKT_MAX(NMAX, PMAX)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The default prior (x0, P0, d0, Pd0, Pxd0), then byte-chosen edits. */
static void edited_prior(fz_t *z, fz_mat_t *const prior[5], size_t n, size_t p)
{
    fz_nerts_prior(prior, n, p);
    fz_edit(z, prior, 5);
}

/* A rejoin's packet into out: the node's current one while a step is
 * pending, else y = 1/2, Y = I (q = nd->q, packed as dkf/dfnerts.h);
 * with code & 64 one byte-chosen entry takes a byte-chosen real. */
static void rejoin_packet(fz_t *z, uint8_t code, const dkf_dfnerts_node_t *nd, dkf_real_t *out)
{
    const size_t q = nd->q;
    size_t e;
    if (nd->pending) {
        memcpy(out, nd->pkt, nd->pkt_len * sizeof *out);
    } else {
        for (e = 0; e < nd->pkt_len; ++e) out[e] = DKF_R(0.0);
        for (e = 0; e < q; ++e) {
            out[e] = DKF_R(0.5);
            out[q + e * q - e * (e - 1) / 2] = DKF_R(1.0);
        }
    }
    if (code & 64) out[fz_byte(z) % nd->pkt_len] = fz_real(z);
}

/* The model matrix b (r x c, edited) into the model's doubles. */
static void to_model(double *dst, const fz_mat_t *b, size_t r, size_t c)
{
    size_t i;
    for (i = 0; i < r * c; ++i) dst[i] = (double)b->d[i];
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static dkf_real_t st[DKF_DFNERTS_NODE_STORAGE_LEN(NMAX, MMAX, PMAX)];
    static dkf_real_t own[PKT], other[PKT];
    static fz_snap_t snap;
    static fz_mat_t x0, P0, d0, Pd0, Pxd0, A, B, C, H, Q, R, zz;
    static lxs_t c;
    static const dkf_nerts_kind_t kinds[4] = {DKF_NERTS_DNERTSIF, DKF_NERTS_NERTSIF,
                                              DKF_NERTS_DNERTSF, (dkf_nerts_kind_t)9};
    fz_mat_t *const init_m[] = {&x0, &P0, &d0, &Pd0, &Pxd0};
    fz_mat_t *const step_m[] = {&A, &B, &C, &H, &Q, &R, &zz};
    fz_t z = {data, size, 0};
    dkf_dfnerts_node_t nd;
    dkf_nl_model_t md;
    dkf_status_t s;
    size_t n, m, p, op, sl;
    const dkf_nerts_kind_t kind = kinds[fz_byte(&z) % 4];
    const dkf_dfnerts_variant_t variant = (dkf_dfnerts_variant_t)(fz_byte(&z) % 3);
    n = fz_dim(&z, NMAX);
    m = fz_dim(&z, MMAX);
    p = fz_byte(&z) % (PMAX + 1);
    const int jac = fz_byte(&z) & 1;
    sl = DKF_DFNERTS_NODE_STATE_LEN(n, m, p);
    memset(&nd, 0, sizeof nd);
    edited_prior(&z, init_m, n, p);
    fz_regions_clear(&snap);
    fz_region(&snap, &nd, sizeof nd);
    fz_take(&snap);
    s = dkf_dfnerts_node_init(&nd, kind, variant, n, m, p, st,
                              DKF_DFNERTS_NODE_STORAGE_LEN(n, m, p), &x0.v, &P0.v,
                              p > 0 ? &d0.v : NULL, p > 0 ? &Pd0.v : NULL,
                              p > 0 ? &Pxd0.v : NULL);
    if (!fz_after(&snap, s)) return 0;
    memset(&c, 0, sizeof c);
    c.n = n, c.m = m, c.p = p;
    md = lxs_model(&c, jac);
    for (op = 0; op < 24 && fz_more(&z); ++op) {
        const uint8_t code = fz_byte(&z), fault = (uint8_t)((code >> 3) % 8);
        fz_set(&A, n, n, DKF_R(0.9), DKF_R(0.05));
        fz_set(&B, n, p, DKF_R(0.5), DKF_R(0.1));
        fz_set(&C, m, n, DKF_R(1.0), DKF_R(0.2));
        fz_set(&H, m, p, DKF_R(1.0), DKF_R(0.0));
        fz_set(&Q, n, n, DKF_R(0.1), DKF_R(0.0));
        fz_set(&R, m, m, DKF_R(0.5), DKF_R(0.0));
        fz_set(&zz, m, 1, DKF_R(0.3), DKF_R(0.3));
        fz_edit(&z, step_m, 7);
        to_model(c.A, &A, n, n);
        to_model(c.B, &B, n, p);
        to_model(c.C, &C, m, n);
        to_model(c.H, &H, m, p);
        c.fail_f = fault == 1;
        c.fail_h = fault == 2;
        c.nan_h = fault == 3;
        c.linear = fault == 4;
        fz_regions_clear(&snap);
        fz_region(&snap, &nd, sizeof nd);
        fz_region(&snap, st, sl * sizeof *st);
        if (nd.pending)
            fz_region(&snap, st + DKF_DFNERTS_NODE_PENDING_AT(n, m, p),
                      DKF_DFNERTS_NODE_PENDING_LEN(n, m, p) * sizeof *st);
        fz_take(&snap);
        switch (code % 6) {
        case 0: {
            const dkf_real_t scale = fault == 5 ? fz_real(&z) : DKF_R(1.0) + (dkf_real_t)(code >> 7);
            s = dkf_dfnerts_node_local(&nd, &md, NULL, &Q.v, NULL, &R.v, &zz.v, scale, NULL);
            break;
        }
        case 1: { /* a round: own packet and an edited copy, byte weights */
            const dkf_real_t *in[2] = {own, other};
            dkf_real_t w[2];
            if (nd.pending) {
                memcpy(own, nd.pkt, nd.pkt_len * sizeof *own);
                memcpy(other, nd.pkt, nd.pkt_len * sizeof *own);
                if (code & 64) other[fz_byte(&z) % nd.pkt_len] = fz_real(&z);
            }
            w[0] = code & 128 ? fz_real(&z) : DKF_R(0.5);
            w[1] = DKF_R(1.0) - w[0];
            s = dkf_dfnerts_node_mix(&nd, in, w, 1 + (size_t)((code >> 6) & 1), NULL);
            break;
        }
        case 2: s = dkf_dfnerts_node_commit(&nd); break;
        case 3: s = dkf_dfnerts_node_cancel(&nd); break;
        case 4: /* a new prior, as the posterior of a byte-chosen step */
            edited_prior(&z, init_m, n, p);
            s = dkf_dfnerts_node_restart(&nd, fz_byte(&z), &x0.v, &P0.v, p > 0 ? &d0.v : NULL,
                                         p > 0 ? &Pd0.v : NULL, p > 0 ? &Pxd0.v : NULL);
            break;
        default: { /* a prior from a packet and (PAPER) the caller's d0, Pd0 */
            fz_mat_t *const input_m[] = {&d0, &Pd0};
            rejoin_packet(&z, code, &nd, own);
            fz_set(&d0, p, 1, DKF_R(0.2), DKF_R(0.2));
            fz_set(&Pd0, p, p, DKF_R(0.5), DKF_R(0.0));
            fz_edit(&z, input_m, 2);
            s = dkf_dfnerts_node_rejoin(&nd, fz_byte(&z), fault == 7 ? NULL : own,
                                        p > 0 ? &d0.v : NULL, p > 0 ? &Pd0.v : NULL);
            break;
        }
        }
        if (fz_after(&snap, s)) {
            fz_finite(st, sl);
            fz_symmetric(nd.f.Px.data, n, 1);
        }
        if (nd.pending) fz_finite(nd.pkt, nd.pkt_len);
    }
    return 0;
}
