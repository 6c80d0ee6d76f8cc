/*
 * src/nerts_internal.h - what dkf/dfnerts.h's nodes take from the
 * single-node filter beyond its public calls (nerts.c): init's checks
 * alone, and a time update and local statistics formed aside, in the
 * filter's stage, so that a node (a network) can check everything before
 * anything is written. Not installed.
 */
#ifndef DKF_NERTS_INTERNAL_H
#define DKF_NERTS_INTERNAL_H

#include "dkf/nerts.h"

/* Every check dkf_nerts_init(f, kind, ...) makes, without initialising
 * anything: only the scratch part of storage is written. */
dkf_status_t dkf__nerts_check_init(dkf_nerts_kind_t kind, size_t n, size_t m, size_t p,
                                   dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                                   const dkf_mat_t *P0, const dkf_mat_t *d0, const dkf_mat_t *Pd0,
                                   const dkf_mat_t *Pxd0);

/* The staged results a node's packets are made of (dkf/nerts.h's views
 * of the same names), valid until the filter's next call. */
typedef struct {
    const dkf_real_t *x_pred, *y_pred, *Y_pred, *nu, *C, *Hd, *Rbar, *i, *I;
} dkf__nerts_staged_t;

/* dkf_nerts_predict (u_prev, Q) then dkf_nerts_local (u, R, z) from the
 * state at `from` (DKF_NERTS_STATE_LEN(n, m, p) reals laid out as f's
 * state, e.g. a snapshot of it; NULL: f's own state), with f's k, kind
 * and dimensions, into f's stage (its scratch); *out points at the
 * results there. The statuses of the two phases; neither *f nor its
 * state is written. */
dkf_status_t dkf__nerts_stage_local(const dkf_nerts_t *f, const dkf_real_t *from,
                                    const dkf_nl_model_t *model, const dkf_real_t *u_prev,
                                    const dkf_mat_t *Q, const dkf_real_t *u, const dkf_mat_t *R,
                                    const dkf_mat_t *z, dkf__nerts_staged_t *out);

/* Copies the stage of the last successful dkf__nerts_stage_local over f's
 * state: f is then as after dkf_nerts_local (phase DKF_NERTS_LOCAL). */
void dkf__nerts_commit_stage(dkf_nerts_t *f);

#endif /* DKF_NERTS_INTERNAL_H */
