/*
 * est_internal.h - what the estimator kinds share (private to estimator.c
 * and est_*.c): the estimator object, its sensor groups and the helpers
 * that load the model of a step and record matrices. A kind file
 * (est_kf.c, ...) defines its dkf_est_kind_t and its registry family.
 */
#ifndef DKF_HOST_EST_INTERNAL_H
#define DKF_HOST_EST_INTERNAL_H

#include <stddef.h>

#include "dkf/askf.h"
#include "dkf/diffkf.h"
#include "dkf/diffkf_fusion.h"
#include "dkf/info.h"
#include "dkf/kf.h"
#include "dkf/otskf.h"
#include "estimator.h"
#include "registry.h"

/* Series key names of the layout (see estimator.h). */
typedef struct {
    const char *xp, *Pp, *xf, *Pf, *yp, *Yp, *yf, *Yf, *i, *I;
} dkf_est_names_t;

/* The measurement a filter takes per step: its sensors stacked, with the
 * unknown-input model (A, B, Rd block-diagonal) when the kind needs it. */
typedef struct {
    size_t nsens;
    size_t *idx;
    size_t m, p;     /* stacked dimensions (p = 0: no unknown-input model) */
    dkf_real_t *buf; /* H, R, y, D, B, Rd, i, I, contribution work */
    dkf_mat_t H, R, y, D, B, Rd;
    dkf_mat_t i, I;  /* information contribution (info kinds) */
    dkf_real_t *work;
    dkf_ui_meas_t meas; /* views of H, D, R */
} dkf_est_group_t;

struct dkf_est {
    const dkf_est_kind_t *kind;
    dkf_est_mode_t mode;
    const dkf_scenario_t *s;
    const dkf_est_names_t *names;
    dkf_est_opts_t opts;
    size_t n;
    size_t ngroups;
    dkf_est_group_t *groups;
    dkf_mat_t *ivec, *Imat;  /* views of every group's i, I for dkf_info_fuse */
    dkf_real_t *storage;     /* the core filter's storage */
    dkf_real_t *FQ;          /* F, Q of the current step, x0, P0, x_{k|k-1}, P_x */
    dkf_mat_t F, Q;
    dkf_mat_t xpk;           /* x_{k|k-1} of the current step (copy) */
    dkf_mat_t Pbuf;          /* ASKF: P_x block, copied out of P^a */
    dkf_mat_t xview;         /* ASKF: the x block of X */
    dkf_kf_t kf;
    dkf_info_t info;
    dkf_diffkf_t dkf;
    dkf_askf_t askf;
    dkf_otskf_t otskf;
    dkf_diffkf_t *locals;    /* fused DKF: node filters, one per group */
    dkf_real_t **local_storage;
    dkf_diffkf_fc_t fc;
    dkf_diffkf_fc_node_t *nodes;
    dkf_real_t *fc_storage;
    dkf_diffkf_msg_t *msgs;
    dkf_diffkf_sensor_t *fcs;
    const dkf_mat_t *x, *P;  /* current x_{k|k}, P_{k|k} */
    json_t *series;
    double *sq;              /* per-component sum of squared errors against truth */
    size_t nsq;
    double *err_f, *err_p;   /* per-step squared errors of x_{k|k}, x_{k|k-1} */
    char what[128];          /* the failing operation, for messages */
};

/* A into the series under key (nothing with no_record). */
void dkf_est_record_mat(dkf_est_t *e, const char *key, const dkf_mat_t *A, int as_vector);
/* F_k, Q_k into e->F, e->Q. */
void dkf_est_load_FQ(dkf_est_t *e, long k);
/* H_k stacked; R_k, A_k block-diagonal; y_k stacked over the group's sensors. */
void dkf_est_group_meas(dkf_est_group_t *g, const dkf_scenario_t *s, long k);
/* B_k, Rd_k block-diagonal over the group's sensors. */
void dkf_est_group_load_dyn(dkf_est_group_t *g, const dkf_scenario_t *s, long k);
/* The dynamics (F, Q of e; B, Rd of g) as the unknown-input filters take them. */
dkf_ui_dyn_t dkf_est_group_dyn(dkf_est_t *e, dkf_est_group_t *g);
/* d_{0|0}, P_{d0|0} (p, p x p) from init or the options (ASKF, OTSKF). */
void dkf_est_input_prior(const dkf_est_t *e, size_t p, dkf_real_t *d0, dkf_real_t *Pd0);

/* ---- the registry operations of every estimator family (est_run.c) ---- */
int dkf_est_run_check(const dkf_filter_t *f, const dkf_run_opts_t *o, const dkf_scenario_t *s,
                      char *err, size_t errlen);
dkf_runner_t *dkf_est_run_create(const dkf_filter_t *f, const dkf_run_opts_t *o,
                                 const dkf_scenario_t *s, char *err, size_t errlen, int *rc);
int dkf_est_run_step(dkf_runner_t *r, long k, char *err, size_t errlen);
void dkf_est_run_record(dkf_runner_t *r, dkf_out_t *out);
int dkf_est_run_errors(const dkf_runner_t *r, size_t i, const char **name, const double **sq_f,
                       const double **sq_p);
void dkf_est_run_summary(const dkf_runner_t *r, FILE *out);
void dkf_est_run_destroy(dkf_runner_t *r);

/* The dkf family's sensor-node role (est_diffkf_node.c). */
extern const dkf_node_ops_t dkf_diffkf_node_ops;
/* The wfusion family's sensor-node role (est_wfusion_node.c): seed 002's
 * local Kalman filter. */
extern const dkf_node_ops_t dkf_wfusion_node_ops;

/* Defines the registry family dkf_family_<fam> of the kind dkf_est_<fam>:
 * one filter (--filter <fam>, outputs.<label>, the --help text and the
 * DKF_RUN_OPT_* options it takes), the canonical and cases layouts, the
 * operations above. */
#define DKF_EST_FAMILY(fam, label, options, node, help)                                     \
    extern const dkf_family_t dkf_family_##fam;                                             \
    static const dkf_filter_t fam##_filters[] = {                                           \
        {#fam, label, help, options, &dkf_family_##fam, &dkf_est_##fam}};                   \
    const dkf_family_t dkf_family_##fam = {                                                 \
        #fam, fam##_filters, 1,                                                             \
        (1u << DKF_SCN_LAYOUT_CANONICAL) | (1u << DKF_SCN_LAYOUT_CASES), dkf_est_run_check, \
        dkf_est_run_create, dkf_est_run_step, dkf_est_run_record, NULL, dkf_est_run_errors, \
        dkf_est_run_summary, dkf_est_run_destroy, node}

#endif /* DKF_HOST_EST_INTERNAL_H */
