/*
 * fusion.c - the seed-000 fusion centre (centre.h, docs/design/network.md
 * "Faults"): the core's dkf_diffkf_fc_t (dkf_diffkf_fc_step_partial: the
 * centralized DKF given the nodes' rows it can rebuild) as the fusion of a
 * dkf_fcr_t runtime (fc_runtime.h: payload ring, epochs, deadlines,
 * checkpoints, rollback/replay, linger), on LCM: node messages come in on
 * <prefix>_NODE_<i>, fused steps go out on <prefix>_FUSED.
 *
 * Node i's z^i_k can be rebuilt from its payloads (dkf_diffkf_msg_t: x^i_{k|k},
 * x^i_{k|k-1}) of steps k and k-1 (or of k alone at the first step of an
 * epoch); the core's replicas of the nodes' filters are the state that the
 * runtime checkpoints (dkf_diffkf_fc_save / _restore) and restarts
 * (dkf_diffkf_fc_restart_node).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "centre.h"
#include "centre_common.h"
#include "dkf/diffkf_fusion.h"
#include "fc_runtime.h"
#include "fusion_result.h"
#include "model.h"

/* What is recorded of every step's estimate (for the result file). */
typedef struct {
    double *xf, *xp, *Pf, *Pp; /* N x n, N x n x n: the latest computation */
} record_t;

struct dkf_net_fusion {
    dkf_net_wfusion_t *wf;        /* a weighted-fusion scenario: that centre, and nothing below */
    dkf_net_centre_t b;           /* scenario, LCM, runtime, journal, counters */
    dkf_sensor_model_t *md;          /* l per-sensor models of the running step */
    dkf_diffkf_sensor_t *sens;    /* l, pointing into md */
    dkf_diffkf_fc_t fc;
    dkf_diffkf_fc_node_t *fcn;
    dkf_real_t *fc_store;
    dkf_real_t *P0_local;         /* l x n x n: the priors of node (re)starts */
    size_t ck_len;                /* reals of one dkf_diffkf_fc_save checkpoint */
    dkf_diffkf_msg_t *msgs;       /* l: the running step's messages */
    unsigned char *present, *contrib; /* l */
    record_t rec;
    int64_t steady_steps;         /* computed steps that reused the settled gain */
};

/* ---- one step of the core fusion centre (the runtime's operations) ----------------- */

/* Loads every sensor's share of step k (dynamics at k, model at kmeas). */
static int load_sensors(dkf_net_fusion_t *fu, size_t k, size_t kmeas)
{
    size_t i;
    for (i = 0; i < fu->b.l; ++i) {
        if (dkf_sensor_model_dyn(&fu->md[i], fu->b.s, i, k) != 0 ||
            dkf_sensor_model_meas(&fu->md[i], fu->b.s, i, kmeas) != 0)
            return -1;
        fu->sens[i].B = &fu->md[i].B;
        fu->sens[i].Rd = &fu->md[i].Rd;
        fu->sens[i].meas = fu->md[i].meas;
    }
    return 0;
}

static void note_fault(dkf_net_fusion_t *fu, long k, const char *call, dkf_status_t st,
                       const dkf_diffkf_fc_fault_t *fault)
{
    if (fault->node == DKF_DIFFKF_FC_NO_NODE)
        dkf_fcr_notef(fu->b.rt, "fusion: step k=%ld: %s failed: %s (%s)", k, call,
                      dkf_status_str(st), dkf_diffkf_fc_cond_str(fault->which));
    else
        dkf_fcr_notef(fu->b.rt, "fusion: step k=%ld: %s failed: %s (%s, node %zu)", k, call,
                      dkf_status_str(st), dkf_diffkf_fc_cond_str(fault->which), fault->node);
}

/* Mirrors the (re)start of node i's local filter at step k (dkf_fcr_ops_t
 * restart): its replica restarts from its prior with the model at k. */
static int op_restart(void *user, size_t i, long k)
{
    dkf_net_fusion_t *fu = user;
    const size_t n = fu->b.n;
    dkf_diffkf_sensor_t sk;
    dkf_mat_t P0 = DKF_MAT(n, n, fu->P0_local + i * n * n);
    dkf_diffkf_fc_fault_t fault = {DKF_DIFFKF_FC_NO_FAULT, 0};
    dkf_status_t st;
    if (dkf_sensor_model_meas(&fu->md[i], fu->b.s, i, (size_t)k) != 0) return -1;
    sk.B = NULL;
    sk.Rd = NULL;
    sk.meas = fu->md[i].meas;
    st = dkf_diffkf_fc_restart_node(&fu->fc, i, (size_t)k, &P0, &sk, &fault);
    if (st != DKF_OK) {
        /* the replica cannot follow this epoch: the node stays masked */
        note_fault(fu, k, "dkf_diffkf_fc_restart_node", st, &fault);
        return -1;
    }
    return 0;
}

static int op_save(void *user, void *ckpt)
{
    dkf_net_fusion_t *fu = user;
    return dkf_diffkf_fc_save(&fu->fc, ckpt, fu->ck_len) == DKF_OK ? 0 : -1;
}

static int op_restore(void *user, const void *ckpt)
{
    dkf_net_fusion_t *fu = user;
    return dkf_diffkf_fc_restore(&fu->fc, ckpt, fu->ck_len) == DKF_OK ? 0 : -1;
}

/* Step k = fc.k + 1 from the payloads present (dkf_fcr_ops_t step); records
 * it. A node the core refuses (rank, model) is masked and the step retried,
 * so a step always completes unless the central filter itself fails; the
 * refusals are returned (the runtime counts them). */
static int op_step(void *user, long k, const void *const *pay, unsigned char *contrib)
{
    dkf_net_fusion_t *fu = user;
    const size_t n = fu->b.n, l = fu->b.l, j = (size_t)(k - 1);
    dkf_diffkf_fc_fault_t fault = {DKF_DIFFKF_FC_NO_FAULT, 0};
    dkf_status_t st = DKF_OK;
    size_t i, tries;
    int refused = 0;
    if (load_sensors(fu, (size_t)k, (size_t)k + 1) != 0) {
        dkf_fcr_notef(fu->b.rt, "fusion: the scenario has no model for step k=%ld", k);
        return -1;
    }
    for (i = 0; i < l; ++i) {
        fu->present[i] = pay[i] != NULL;
        if (pay[i] != NULL) {
            dkf_net_copy_node_msg(&fu->msgs[i], pay[i]);
        } else {
            memset(&fu->msgs[i], 0, sizeof fu->msgs[i]);
            fu->msgs[i].node = (uint16_t)i;
            fu->msgs[i].k = (uint32_t)k;
            fu->msgs[i].n = (uint16_t)n;
        }
    }
    /* the prior x_{k|k-1}, P_{k|k-1} is the central filter's xp before the step */
    dkf_net_centre_to_double(fu->rec.xp + j * n, fu->fc.central.xn.data, n);
    dkf_net_centre_to_double(fu->rec.Pp + j * n * n, fu->fc.central.Pn.data, n * n);
    for (tries = 0; tries <= l; ++tries) {
        st = dkf_diffkf_fc_step_partial(&fu->fc, &fu->md[0].F, &fu->md[0].Q, fu->sens, fu->msgs,
                                        fu->present, fu->contrib, &fault);
        if (st == DKF_OK) break;
        note_fault(fu, k, "dkf_diffkf_fc_step_partial", st, &fault);
        ++refused;
        if (fault.node != DKF_DIFFKF_FC_NO_NODE && fault.node < l && fu->present[fault.node])
            fu->present[fault.node] = 0;
        else if (memchr(fu->present, 1, l) != NULL)
            memset(fu->present, 0, l); /* the prediction alone */
        else
            break;
    }
    if (st != DKF_OK) return -1;
    fu->steady_steps += fu->fc.central.steady ? 1 : 0;
    dkf_net_centre_to_double(fu->rec.xf + j * n, fu->fc.central.xf.data, n);
    dkf_net_centre_to_double(fu->rec.Pf + j * n * n, fu->fc.central.Pf.data, n * n);
    memcpy(contrib, fu->contrib, l);
    return refused;
}

/* ---- outputs (the runtime's operations) --------------------------------------------- */

/* Publishes step st->k (revision st->revision) on <prefix>_FUSED. */
static int op_publish(void *user, const dkf_fcr_step_t *st, int64_t *utime)
{
    dkf_net_fusion_t *fu = user;
    return dkf_net_centre_publish(&fu->b, st, fu->rec.xf, fu->rec.Pf, fu->rec.xp, fu->rec.Pp,
                                  utime);
}

/* Appends step st->k as it stands now (first computation or a replay) to
 * the journal, one JSON line (centre_common.h). */
static void op_record(void *user, const dkf_fcr_step_t *st, int published)
{
    dkf_net_fusion_t *fu = user;
    const size_t n = fu->b.n, j = (size_t)(st->k - 1);
    json_t *o = dkf_net_centre_journal_line(&fu->b, st, published);
    if (o == NULL) return;
    dkf_fcr_json_set_block(o, "xf", fu->rec.xf + j * n, n, 0);
    dkf_fcr_json_set_block(o, "xp", fu->rec.xp + j * n, n, 0);
    dkf_fcr_json_set_block(o, "Pf", fu->rec.Pf + j * n * n, n, n);
    dkf_fcr_json_set_block(o, "Pp", fu->rec.Pp + j * n * n, n, n);
    dkf_net_centre_journal_write(&fu->b, st, o);
}

/* The runtime is DONE or FAILED: say so on <prefix>_STATUS. */
static void op_state(void *user, int state)
{
    dkf_net_fusion_t *fu = user;
    (void)state;
    dkf_net_centre_report(&fu->b);
}

static const dkf_fcr_ops_t dkf_fc_ops = {op_step,    op_restart, op_save,  op_restore,
                                         op_publish, op_record,  op_state,
                                         dkf_net_copy_node_payload};

void dkf_net_fusion_tick(dkf_net_fusion_t *fu, int64_t mono_us, int64_t heartbeat_us)
{
    if (fu->wf != NULL)
        dkf_net_wfusion_tick(fu->wf, mono_us, heartbeat_us);
    else
        dkf_net_centre_tick(&fu->b, mono_us, heartbeat_us);
}

/* ---- set-up --------------------------------------------------------------------- */

static int fu_alloc(dkf_net_fusion_t *fu)
{
    const size_t l = fu->b.l, n = fu->b.n, N = (size_t)fu->b.N;
    size_t j;
    fu->md = calloc(l, sizeof *fu->md);
    fu->sens = calloc(l, sizeof *fu->sens);
    fu->fcn = calloc(l, sizeof *fu->fcn);
    fu->P0_local = calloc(l * n * n, sizeof *fu->P0_local);
    fu->msgs = calloc(l, sizeof *fu->msgs);
    fu->present = calloc(l, 1);
    fu->contrib = calloc(l, 1);
    fu->rec.xf = calloc(N * n, sizeof(double));
    fu->rec.xp = calloc(N * n, sizeof(double));
    fu->rec.Pf = calloc(N * n * n, sizeof(double));
    fu->rec.Pp = calloc(N * n * n, sizeof(double));
    if (!fu->md || !fu->sens || !fu->fcn || !fu->P0_local || !fu->msgs || !fu->present ||
        !fu->contrib || !fu->rec.xf || !fu->rec.xp || !fu->rec.Pf || !fu->rec.Pp)
        return -1;
    for (j = 0; j < l; ++j) {
        if (dkf_sensor_model_init(&fu->md[j], fu->b.s, j) != 0) return -1;
        dkf_scn_to_real(fu->P0_local + j * n * n, dkf_scn_P00_local(fu->b.s, j), n * n);
    }
    return 0;
}

/* fc init + start; -1 with err naming the call and the fault. */
static int fc_setup(dkf_net_fusion_t *fu, char *err, size_t errlen)
{
    const dkf_scenario_t *s = fu->b.s;
    const size_t l = fu->b.l, n = fu->b.n;
    size_t m[DKF_NET_MAX_NODES], p[DKF_NET_MAX_NODES], i, len;
    dkf_real_t *P = calloc((l + 1) * n * n + n, sizeof *P), *F0 = NULL;
    dkf_mat_t x0, P0, Pl[DKF_NET_MAX_NODES], F0m, Q0m;
    const dkf_mat_t *Plp[DKF_NET_MAX_NODES];
    dkf_diffkf_fc_fault_t fault = {DKF_DIFFKF_FC_NO_FAULT, 0};
    dkf_status_t st;
    const char *call = "dkf_diffkf_fc_init";
    if (P == NULL) return -1;
    for (i = 0; i < l; ++i) {
        m[i] = fu->md[i].m;
        p[i] = fu->md[i].p;
    }
    len = dkf_diffkf_fc_storage_len(n, l, m, p);
    fu->fc_store = len ? calloc(len, sizeof *fu->fc_store) : NULL;
    F0 = calloc(2 * n * n, sizeof *F0);
    if (fu->fc_store == NULL || F0 == NULL) {
        snprintf(err, errlen, "%s: fusion: no storage for the fusion centre", s->file);
        free(P);
        free(F0);
        return -1;
    }
    dkf_scn_to_real(P, dkf_scn_at(dkf_scn_init(s, "x00"), 0), n);
    dkf_scn_to_real(P + n, dkf_scn_P00_central(s), n * n);
    x0 = (dkf_mat_t)DKF_MAT(n, 1, P);
    P0 = (dkf_mat_t)DKF_MAT(n, n, P + n);
    for (i = 0; i < l; ++i) {
        dkf_scn_to_real(P + n + (i + 1) * n * n, dkf_scn_P00_local(s, i), n * n);
        Pl[i] = (dkf_mat_t)DKF_MAT(n, n, P + n + (i + 1) * n * n);
        Plp[i] = &Pl[i];
    }
    st = dkf_diffkf_fc_init(&fu->fc, fu->fcn, l, n, m, p, fu->fc_store, len, &x0, &P0, Plp,
                            &fault);
    if (st == DKF_OK) {
        /* start: F_0, Q_0 and the models at 1 (B of step 1 for the FC's check) */
        call = "dkf_diffkf_fc_start";
        F0m = (dkf_mat_t)DKF_MAT(n, n, F0);
        Q0m = (dkf_mat_t)DKF_MAT(n, n, F0 + n * n);
        if (dkf_sensor_model_dyn(&fu->md[0], s, 0, 0) != 0 || load_sensors(fu, 1, 1) != 0) {
            st = DKF_ERR_ARG;
        } else {
            dkf_scn_to_real(F0, dkf_scn_at(dkf_scn_model(s, "F"), 0), n * n);
            dkf_scn_to_real(F0 + n * n, dkf_scn_at(dkf_scn_model(s, "Q"), 0), n * n);
            st = dkf_diffkf_fc_start(&fu->fc, &F0m, &Q0m, fu->sens, &fault);
        }
    }
    free(P);
    free(F0);
    if (st != DKF_OK) {
        if (fault.node == DKF_DIFFKF_FC_NO_NODE)
            snprintf(err, errlen, "%s: fusion: %s failed: %s (%s)", s->file, call,
                     dkf_status_str(st), dkf_diffkf_fc_cond_str(fault.which));
        else
            snprintf(err, errlen, "%s: fusion: %s failed: %s (%s, node %zu)", s->file, call,
                     dkf_status_str(st), dkf_diffkf_fc_cond_str(fault.which), fault.node);
        return -1;
    }
    return 0;
}

/* The runtime over the core centre just started (the state after the start,
 * before step 1, is saved now) and the node subscription. -1 with err. */
static int rt_setup(dkf_net_fusion_t *fu, char *err, size_t errlen)
{
    fu->ck_len = dkf_diffkf_fc_checkpoint_len(&fu->fc);
    return dkf_net_centre_start(&fu->b, &dkf_fc_ops, fu, fu->ck_len * sizeof(dkf_real_t), err,
                                errlen);
}

dkf_net_fusion_t *dkf_net_fusion_create(dkf_net_t *net, const dkf_scenario_t *s,
                                        const char *prefix, int64_t deadline_us, char *err,
                                        size_t errlen)
{
    dkf_net_fusion_t *fu = calloc(1, sizeof *fu);
    if (fu == NULL) {
        snprintf(err, errlen, "fusion: out of memory");
        return NULL;
    }
    if (s->layout == DKF_SCN_LAYOUT_WFCASES) {
        fu->wf = dkf_net_wfusion_create(net, s, prefix, deadline_us, err, errlen);
        if (fu->wf == NULL) {
            free(fu);
            return NULL;
        }
        return fu;
    }
    dkf_net_centre_init(&fu->b, "fusion", net, s, prefix, deadline_us);
    if (fu_alloc(fu) != 0) {
        snprintf(err, errlen, "fusion: out of memory");
        dkf_net_fusion_free(fu);
        return NULL;
    }
    if (fc_setup(fu, err, errlen) != 0 || rt_setup(fu, err, errlen) != 0) {
        dkf_net_fusion_free(fu);
        return NULL;
    }
    return fu;
}

void dkf_net_fusion_free(dkf_net_fusion_t *fu)
{
    size_t j;
    if (fu == NULL) return;
    dkf_net_wfusion_free(fu->wf);
    dkf_fcr_free(fu->b.rt);
    for (j = 0; fu->md != NULL && j < fu->b.l; ++j) dkf_sensor_model_free(&fu->md[j]);
    free(fu->md);
    free(fu->sens);
    free(fu->fcn);
    free(fu->fc_store);
    free(fu->P0_local);
    free(fu->msgs);
    free(fu->present);
    free(fu->contrib);
    free(fu->rec.xf);
    free(fu->rec.xp);
    free(fu->rec.Pf);
    free(fu->rec.Pp);
    free(fu);
}

int dkf_net_fusion_state(const dkf_net_fusion_t *fu)
{
    return fu->wf != NULL ? dkf_net_wfusion_state(fu->wf) : dkf_net_centre_state(&fu->b);
}

void dkf_net_fusion_report(dkf_net_fusion_t *fu)
{
    if (fu->wf != NULL)
        dkf_net_wfusion_report(fu->wf);
    else
        dkf_net_centre_report(&fu->b);
}

void dkf_net_fusion_journal(dkf_net_fusion_t *fu, FILE *f)
{
    if (fu->wf != NULL)
        dkf_net_wfusion_journal(fu->wf, f);
    else
        dkf_net_centre_journal(&fu->b, f);
}

long dkf_net_fusion_k(const dkf_net_fusion_t *fu)
{
    return fu->wf != NULL ? dkf_net_wfusion_k(fu->wf) : dkf_fcr_done_k(fu->b.rt);
}
const dkf_net_counts_t *dkf_net_fusion_counts(const dkf_net_fusion_t *fu)
{
    return fu->wf != NULL ? dkf_net_wfusion_counts(fu->wf) : &fu->b.c;
}

int dkf_net_fusion_steady(dkf_net_fusion_t *fu, double tol)
{
    return fu->wf == NULL && dkf_diffkf_fc_set_steady(&fu->fc, (dkf_real_t)tol) == DKF_OK ? 0 : -1;
}

/* The result document (fusion_result.h) with outputs.fused.{xf,xp,Pf,Pp}. */
json_t *dkf_net_fusion_result(const dkf_net_fusion_t *fu)
{
    const size_t n = fu->b.n, K = fu->wf != NULL ? 0 : (size_t)dkf_fcr_done_k(fu->b.rt);
    json_t *outputs, *fused, *doc;
    if (fu->wf != NULL) return dkf_net_wfusion_result(fu->wf);
    outputs = json_object();
    fused = json_object();
    dkf_fcr_json_set_rows(fused, "xf", fu->rec.xf, K, n, 0);
    dkf_fcr_json_set_rows(fused, "xp", fu->rec.xp, K, n, 0);
    dkf_fcr_json_set_rows(fused, "Pf", fu->rec.Pf, K, n, n);
    dkf_fcr_json_set_rows(fused, "Pp", fu->rec.Pp, K, n, n);
    json_object_set_new(outputs, "fused", fused);
    doc = dkf_net_centre_result(&fu->b, outputs);
    json_object_set_new(json_object_get(doc, "counters"), "steady_gain_steps",
                        json_integer((json_int_t)fu->steady_steps));
    return doc;
}
