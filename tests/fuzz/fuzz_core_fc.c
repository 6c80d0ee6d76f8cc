/*
 * fuzz_core_fc - the Difference-KF fusion centre (dkf/diffkf_fusion.h):
 * init for l <= 3 sensors, then up to 16 calls: start, steps, degraded
 * steps (byte-chosen present[]), node restarts (node and k_start chosen,
 * so some are out of range or out of sequence), the steady gain switched
 * on and off, checkpoint saves and
 * restores of byte-edited checkpoints, all on byte-edited models and
 * messages (node, step, n, any real in x_{k|k}, x_{k|k-1}). Property: a
 * failed call leaves *fc, nodes[0..l-1] and the first
 * dkf_diffkf_fc_state_len reals of storage byte-identical; after a
 * successful call the replicas' and the central filter's state is finite
 * and the fused P_{k|k}, P_{k+1|k} are exactly symmetric (when the prior
 * was and no edited checkpoint was restored).
 */
#include "dkf/diffkf_fusion.h"
#include "fuzz_core.h"

#define NMAX 4
#define LMAX 3
#define MMAX 3
#define PMAX 3

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Finite estimates, carries and caches; symmetric fused covariances. */
static void check_ok(const dkf_diffkf_fc_t *fc, int sym)
{
    const dkf_diffkf_t *c = &fc->central;
    size_t i;
    for (i = 0; i < fc->l; ++i) {
        const dkf_diffkf_fc_node_t *nd = &fc->nodes[i];
        fz_finite(nd->priv.store, DKF_DIFFKF_STATE_LEN(fc->n, nd->m, nd->p));
        fz_finite(nd->z.data, nd->p);
        fz_finite(nd->dz.data, nd->p);
    }
    fz_finite(fc->priv.central_store, DKF_DIFFKF_STATE_LEN(c->n, c->m, c->p));
    fz_symmetric(c->Pf.data, c->n, sym);
    fz_symmetric(c->Pn.data, c->n, sym);
}

/* Messages of the FC's next step, then up to 3 byte-chosen edits. */
static void make_msgs(fz_t *z, dkf_diffkf_msg_t msgs[], const dkf_diffkf_fc_t *fc, size_t l,
                      size_t n)
{
    size_t i, j, k, edits;
    for (i = 0; i < l; ++i) {
        memset(&msgs[i], 0, sizeof msgs[i]);
        msgs[i].node = (uint16_t)i;
        msgs[i].k = (uint32_t)(fc->k + 1);
        msgs[i].n = (uint16_t)n;
        for (j = 0; j < n; ++j) {
            msgs[i].xp[j] = DKF_R(0.1) * (dkf_real_t)(j + 1);
            msgs[i].xf[j] = msgs[i].xp[j] + DKF_R(0.05) * (dkf_real_t)(i + 1);
        }
    }
    edits = fz_byte(z) % 4;
    for (k = 0; k < edits && fz_more(z); ++k) {
        dkf_diffkf_msg_t *g = &msgs[fz_byte(z) % l];
        const uint8_t kind = fz_byte(z);
        switch (kind % 6) {
        case 0: g->node = (uint16_t)(fz_byte(z) % (LMAX + 1)); break;
        case 1: g->k = (uint32_t)((int64_t)g->k + (int)(fz_byte(z) % 5) - 2); break;
        case 2: g->n = (uint16_t)(fz_byte(z) % (NMAX + 2)); break;
        case 3: g->xf[fz_byte(z) % n] = fz_real(z); break;
        case 4: g->xp[fz_byte(z) % n] = fz_real(z); break;
        default: /* xf = xp: no innovation */
            memcpy(g->xf, g->xp, sizeof g->xf);
            break;
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static dkf_real_t st[DKF_DIFFKF_FC_STORAGE_MAX(NMAX, LMAX, MMAX, PMAX)];
    static dkf_real_t ck[DKF_DIFFKF_FC_STORAGE_MAX(NMAX, LMAX, MMAX, PMAX)];
    static dkf_diffkf_fc_node_t nodes[LMAX];
    static fz_snap_t snap;
    static fz_mat_t x0, P0, Pl;
    static fz_ui_t u[LMAX];
    static dkf_diffkf_msg_t msgs[LMAX];
    fz_mat_t *const init_m[] = {&x0, &P0, &Pl};
    fz_t z = {data, size, 0};
    dkf_diffkf_fc_t fc;
    dkf_diffkf_sensor_t sensors[LMAX];
    const dkf_mat_t *P0_local[LMAX];
    unsigned char present[LMAX], contributed[LMAX];
    dkf_diffkf_fc_fault_t fault;
    size_t n, l, m[LMAX], p[LMAX], op, i, cklen = 0, len;
    dkf_status_t s;
    int sym;
    n = fz_dim(&z, NMAX);
    l = fz_dim(&z, LMAX);
    for (i = 0; i < l; ++i) {
        m[i] = fz_dim(&z, MMAX);
        p[i] = fz_dim(&z, PMAX);
    }
    memset(&fc, 0, sizeof fc);
    memset(nodes, 0, sizeof nodes);
    fz_set(&x0, n, 1, DKF_R(0.5), DKF_R(0.5));
    fz_set(&P0, n, n, DKF_R(1.0), DKF_R(0.1));
    fz_set(&Pl, n, n, DKF_R(2.0), DKF_R(0.0));
    fz_edit(&z, init_m, 3);
    /* a non-symmetric prior is accepted (one triangle is read): then no
     * symmetry is promised */
    sym = P0.v.data == NULL || fz_is_symmetric(P0.v.data, P0.v.rows);
    for (i = 0; i < l; ++i) P0_local[i] = (fz_byte(&z) & 1) ? &Pl.v : NULL;
    len = dkf_diffkf_fc_storage_len(n, l, m, p);
    FZ_CHECK(len <= sizeof st / sizeof st[0]);
    if (len > 0 && (fz_byte(&z) & 7) == 0) len -= 1; /* too short */
    fz_regions_clear(&snap);
    fz_region(&snap, &fc, sizeof fc);
    fz_region(&snap, nodes, sizeof nodes);
    fz_take(&snap);
    s = dkf_diffkf_fc_init(&fc, nodes, l, n, m, p, st, len, &x0.v, &P0.v,
                           (fz_byte(&z) & 1) ? P0_local : NULL, &fault);
    if (!fz_after(&snap, s)) return 0;
    for (op = 0; op < 16 && fz_more(&z); ++op) {
        const uint8_t code = fz_byte(&z);
        const size_t pick = fz_byte(&z) % l;
        fz_regions_clear(&snap);
        fz_region(&snap, &fc, sizeof fc);
        fz_region(&snap, nodes, l * sizeof nodes[0]);
        fz_region(&snap, st, dkf_diffkf_fc_state_len(n, l, m, p) * sizeof(dkf_real_t));
        for (i = 0; i < l; ++i) {
            fz_ui_default(&u[i], n, m[i], p[i]);
            sensors[i].B = &u[i].B.v;
            sensors[i].Rd = &u[i].Rd.v;
            sensors[i].meas = u[i].meas;
            present[i] = (unsigned char)((code >> (3 + i)) & 1);
        }
        /* F, Q are sensor 0's; one sensor's model takes the edits */
        fz_ui_edit(&z, &u[0], 1);
        if (pick != 0) fz_ui_edit(&z, &u[pick], 1);
        fz_ui_edit(&z, &u[pick], 0);
        switch (code % 6) {
        case 0:
            fz_take(&snap);
            s = dkf_diffkf_fc_start(&fc, &u[0].F.v, &u[0].Q.v, sensors, &fault);
            break;
        case 1:
        case 2:
            make_msgs(&z, msgs, &fc, l, n);
            fz_take(&snap);
            s = dkf_diffkf_fc_step(&fc, &u[0].F.v, &u[0].Q.v, sensors, msgs, &fault);
            break;
        case 3:
            make_msgs(&z, msgs, &fc, l, n);
            fz_take(&snap);
            s = dkf_diffkf_fc_step_partial(&fc, &u[0].F.v, &u[0].Q.v, sensors, msgs,
                                           code & 64 ? NULL : present, contributed, &fault);
            break;
        case 4: {
            /* the prior: the default, or one with the edits of Q */
            const size_t node = (code & 64) ? l : pick;
            const size_t k_start = fc.k + 1 + (size_t)((code >> 3) & 1) - (size_t)((code >> 4) & 1);
            fz_take(&snap);
            s = dkf_diffkf_fc_restart_node(&fc, node, k_start,
                                           (code & 32) ? &u[0].Q.v : &P0.v, &sensors[pick],
                                           &fault);
            break;
        }
        default: /* the steady gain on (tol 0.5: it settles often) or off; or save a
                  checkpoint, or restore a byte-edited one */
            if ((code & 192) == 192) {
                FZ_CHECK(dkf_diffkf_fc_set_steady(
                             &fc, fc.central.priv.steady_tol > 0 ? DKF_R(0.0) : DKF_R(0.5)) == DKF_OK);
                continue;
            }
            if (code & 8) {
                cklen = dkf_diffkf_fc_checkpoint_len(&fc);
                FZ_CHECK(cklen <= sizeof ck / sizeof ck[0]);
                FZ_CHECK(dkf_diffkf_fc_save(&fc, ck, cklen) == DKF_OK);
                continue;
            }
            len = fz_ckpt_restore_len(&z, code, ck, cklen, &sym);
            if (len == 0) continue;
            fz_take(&snap);
            s = dkf_diffkf_fc_restore(&fc, ck, len);
            break;
        }
        if (fz_after(&snap, s)) check_ok(&fc, sym);
    }
    return 0;
}
