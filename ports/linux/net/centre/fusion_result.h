/*
 * fusion_result.h - the result file and the journal of a fusion centre run
 * by fc_runtime.h (host side; docs/guide/network.md, "dkf-fusion's result file").
 *
 * The runtime's record (status, contributors, revisions, epochs, latency,
 * counters) is written here for any centre; the centre adds its own
 * estimates: the result document's "outputs" object, and its fields of each
 * journal line (dkf_fcr_json_set_rows / dkf_fcr_json_set_block). Also the
 * LCM side every centre shares: a node message into the runtime.
 */
#ifndef DKF_NET_FUSION_RESULT_H
#define DKF_NET_FUSION_RESULT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <jansson.h>

#include "codec.h" /* dkf_net_rejects_t, dkf_net_expect_t */
#include "fc_runtime.h"
#include "report.h" /* dkf_net_counts_t */

/* What the result and the journal say of the run besides the runtime's record. */
typedef struct {
    const char *scenario;          /* the scenario file */
    int64_t model_id;
    int64_t deadline_us;
    int64_t rejected;              /* messages refused by validation (codec.h) */
    const dkf_net_rejects_t *why;  /* and why */
} dkf_fcr_doc_info_t;

/* The result document of the run so far (new reference): scenario, real,
 * model_id, N, deadline_us, checkpoints, joined_at, k, outputs (the
 * caller's, reference stolen), status, contributors, revisions,
 * first_status, first_contributors, epochs, latency_us, counters,
 * last_note. */
json_t *dkf_fcr_result_doc(const dkf_fcr_t *rt, const dkf_fcr_doc_info_t *info, json_t *outputs);

/* o[key] = the published steps' blocks: steps rows x cols doubles each
 * (cols == 0: a vector of rows), from v (steps x rows x cols). */
void dkf_fcr_json_set_rows(json_t *o, const char *key, const double *v, size_t steps,
                           size_t rows, size_t cols);
/* o[key] = one rows x cols block (cols == 0: a vector). */
void dkf_fcr_json_set_block(json_t *o, const char *key, const double *v, size_t rows,
                            size_t cols);

/* The journal's header line (one per run of the centre: a restarted one
 * appends its own), written at utime. 0, or -1 (not written). */
int dkf_fcr_journal_header(FILE *f, const dkf_fcr_t *rt, const dkf_fcr_doc_info_t *info,
                           int64_t utime);
/* A journal line of step st as computed now (new reference): k, revision,
 * status, contributors, published; the centre adds its estimates. */
json_t *dkf_fcr_journal_line(const dkf_fcr_step_t *st, int published);
/* Appends line (with utime last), flushed, and releases it. 0 or -1. */
int dkf_fcr_journal_write(FILE *f, json_t *line, int64_t utime);

/* ---- the node messages (both centres' LCM handler) ------------------------------------ */

/* One node message received on `channel` (<prefix>_NODE_<i>) from `from`
 * into rt, while rt is RUNNING: decoded against ex (ex->node is set to the
 * sender's node, dkf_net_from_node), a refusal counted in c->rejected and c->why and noted
 * as "<who>: message on <channel> rejected: <why>"; in and in_prev are the
 * decoder's buffers (the runtime copies the payload). c's runtime counters
 * are synced afterwards. */
void dkf_fcr_node_message(dkf_fcr_t *rt, dkf_net_expect_t *ex, const char *who,
                          const char *channel, const dkf_net_from_t *from, const void *data,
                          size_t len, int64_t recv_utime,
                          dkf_diffkf_msg_t *in, dkf_diffkf_msg_t *in_prev, dkf_net_counts_t *c);
/* Step st as a fused_t on channel chan: the step's status and
 * contributors from st, its estimate xf, Pf and prior xp, Pp (n and n x n
 * doubles) from the centre; *seq is the centre's sequence counter (then
 * incremented), *utime the publication time. 0, or -1 (noted as
 * "<who>: step k=..: cannot publish"). */
int dkf_fcr_publish_fused(dkf_net_t *net, const char *chan, dkf_fcr_t *rt, const char *who,
                          const dkf_fcr_step_t *st, size_t nnodes, size_t n, const double *xf,
                          const double *Pf, const double *xp, const double *Pp,
                          int64_t model_id, int64_t *seq, int64_t *utime);
/* c->sent, received, stale, missed from rt's counters. */
void dkf_fcr_sync_counts(const dkf_fcr_t *rt, dkf_net_counts_t *c);

#endif /* DKF_NET_FUSION_RESULT_H */
