/*
 * Checkpoints of the distributed Difference KF's fusion centre
 * (dkf/diffkf_fusion.h): the whole FC state into caller memory and back,
 * for rollback and replay (docs/design/diffkf-fusion.md §8).
 *
 * Layout (reals): a header of FC_CKPT_HEAD small integers (internal.h's
 * checkpoint header: each exact in any real type): tag, n, l, sum m_i,
 * sum p_i, k in DKF__CKPT_K_LEN 16-bit digits, started; then
 * dkf_diffkf_save of the central filter and of each replica, each node's
 * sync flag, and the recovered z, dz.
 */
#include "dkf/diffkf_fusion.h"

#include "diffkf_fusion_internal.h"
#include "internal.h"
#include "kernels.h"

#define FC_CKPT_TAG 17987 /* "FC" */
#define FC_CKPT_K 5       /* where k starts */
#define FC_CKPT_STARTED (FC_CKPT_K + DKF__CKPT_K_LEN)
#define FC_CKPT_HEAD (FC_CKPT_STARTED + 1)

size_t dkf_diffkf_fc_checkpoint_len(const dkf_diffkf_fc_t *fc)
{
    size_t i, len;
    if (fc == NULL || !fc->priv.ready) return 0;
    len = FC_CKPT_HEAD + dkf_diffkf_checkpoint_len(&fc->central) + fc->l + 2 * fc->ps;
    for (i = 0; i < fc->l; ++i) len += dkf_diffkf_checkpoint_len(&fc->nodes[i].rep);
    return len;
}

dkf_status_t dkf_diffkf_fc_save(const dkf_diffkf_fc_t *fc, dkf_real_t *buf, size_t len)
{
    size_t i, off = FC_CKPT_HEAD;
    DKF_CHECK_NULL(fc);
    DKF_CHECK_NULL(buf);
    if (!fc->priv.ready) return DKF_ERR_STATE;
    if (len < dkf_diffkf_fc_checkpoint_len(fc)) return DKF_ERR_CAPACITY;
    buf[0] = (dkf_real_t)FC_CKPT_TAG;
    buf[1] = (dkf_real_t)fc->n;
    buf[2] = (dkf_real_t)fc->l;
    buf[3] = (dkf_real_t)fc->ms;
    buf[4] = (dkf_real_t)fc->ps;
    dkf__ckpt_put_k(buf + FC_CKPT_K, fc->k);
    buf[FC_CKPT_STARTED] = (dkf_real_t)(fc->priv.started ? 1 : 0);
    DKF_TRY(dkf_diffkf_save(&fc->central, buf + off, len - off));
    off += dkf_diffkf_checkpoint_len(&fc->central);
    for (i = 0; i < fc->l; ++i) {
        DKF_TRY(dkf_diffkf_save(&fc->nodes[i].rep, buf + off, len - off));
        off += dkf_diffkf_checkpoint_len(&fc->nodes[i].rep);
    }
    for (i = 0; i < fc->l; ++i) buf[off++] = (dkf_real_t)(fc->nodes[i].sync ? 1 : 0);
    dkf__copy(buf + off, fc->nodes[0].z.data, 2 * fc->ps);
    return DKF_OK;
}

/* 1 if x is 0 or 1 (a flag). */
static int is_flag(dkf_real_t x) { return dkf__ckpt_is(x, 0) || dkf__ckpt_is(x, 1); }

dkf_status_t dkf_diffkf_fc_restore(dkf_diffkf_fc_t *fc, const dkf_real_t *buf, size_t len)
{
    size_t i, k = 0, off = FC_CKPT_HEAD;
    DKF_CHECK_NULL(fc);
    DKF_CHECK_NULL(buf);
    if (!fc->priv.ready) return DKF_ERR_STATE;
    if (len < dkf_diffkf_fc_checkpoint_len(fc)) return DKF_ERR_CAPACITY;
    /* validate everything before writing anything */
    if (!dkf__ckpt_is(buf[0], FC_CKPT_TAG)) return DKF_ERR_ARG;
    if (!dkf__ckpt_is(buf[1], fc->n) || !dkf__ckpt_is(buf[2], fc->l) ||
        !dkf__ckpt_is(buf[3], fc->ms) || !dkf__ckpt_is(buf[4], fc->ps))
        return DKF_ERR_DIM;
    DKF_TRY(dkf__ckpt_get_k(buf + FC_CKPT_K, &k));
    if (!is_flag(buf[FC_CKPT_STARTED])) return DKF_ERR_ARG;
    DKF_TRY(dkf_diffkf_checkpoint_check(&fc->central, buf + off, len - off));
    off += dkf_diffkf_checkpoint_len(&fc->central);
    for (i = 0; i < fc->l; ++i) {
        DKF_TRY(dkf_diffkf_checkpoint_check(&fc->nodes[i].rep, buf + off, len - off));
        off += dkf_diffkf_checkpoint_len(&fc->nodes[i].rep);
    }
    for (i = 0; i < fc->l; ++i)
        if (!is_flag(buf[off + i])) return DKF_ERR_ARG;
    if (!dkf__all_finite(buf + off + fc->l, 2 * fc->ps)) return DKF_ERR_NONFINITE;

    off = FC_CKPT_HEAD;
    (void)dkf_diffkf_restore(&fc->central, buf + off, len - off);
    off += dkf_diffkf_checkpoint_len(&fc->central);
    for (i = 0; i < fc->l; ++i) {
        (void)dkf_diffkf_restore(&fc->nodes[i].rep, buf + off, len - off);
        off += dkf_diffkf_checkpoint_len(&fc->nodes[i].rep);
    }
    for (i = 0; i < fc->l; ++i) fc->nodes[i].sync = dkf__ckpt_is(buf[off + i], 1);
    dkf__copy(fc->nodes[0].z.data, buf + off + fc->l, 2 * fc->ps);
    dkf__fc_refresh_saved(fc);
    fc->k = k;
    fc->priv.started = dkf__ckpt_is(buf[FC_CKPT_STARTED], 1);
    return DKF_OK;
}
