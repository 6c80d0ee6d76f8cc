/*
 * est_kind.h - what an estimator kind (dkf_est_kind_t, estimator.h) is
 * given: the estimator object, its sensor groups and the helpers that load
 * the model of a step and record matrices. The object holds what every
 * kind shares; a kind's own filter objects live in its state (e->state,
 * kind->state_size bytes, zeroed), declared in the kind's file
 * (families/est_kf.c, ...), never here.
 */
#ifndef DKF_HOST_EST_KIND_H
#define DKF_HOST_EST_KIND_H

#include <stddef.h>

#include <jansson.h>

#include "dkf/ui_model.h"
#include "estimator.h"

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
    dkf_real_t *buf; /* H, R, y, D, B, Rd */
    dkf_mat_t H, R, y, D, B, Rd;
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
    void *state;             /* the kind's own (kind->state_size bytes) */
    dkf_real_t *storage;     /* the core filter's storage */
    dkf_real_t *FQ;          /* F, Q of the current step, P0, x0, x_{k|k-1} */
    dkf_mat_t F, Q;
    dkf_mat_t xpk;           /* x_{k|k-1} of the current step (copy) */
    const dkf_mat_t *x, *P;  /* current x_{k|k}, P_{k|k} (the kind points them) */
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

#endif /* DKF_HOST_EST_KIND_H */
