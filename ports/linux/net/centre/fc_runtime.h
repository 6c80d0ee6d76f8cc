/*
 * fc_runtime.h - the transport-free runtime of a fusion centre (host side;
 * docs/design/network.md, "The fusion-centre runtime").
 *
 * A fusion centre gets, from every node i, a payload per step k (what node
 * i's local filter contributes to step k), fuses step k from the payloads
 * it has, and publishes every step by its deadline. What is the same for
 * every such centre lives here, whatever the payload and the fusion are:
 *   - the payload ring: DKF_FCR_CKPT revisable steps, the present one and
 *     DKF_FCR_WINDOW ahead, per node; duplicates, copies (the previous
 *     step's payload riding along in a message) and reordering;
 *   - epochs: a node's local filter (re)started at k_start (epoch, k_start
 *     increase together); a restart is mirrored before its first step;
 *   - deadlines and the "given up" rules: step k is fused once every node
 *     whose epoch owns k has its payload there, has moved on (its payload
 *     of step k+2 arrived) or has been silent for a deadline of the others'
 *     arrivals; a step still incomplete a deadline after it opened is
 *     published degraded; the window follows the arrivals (a payload of
 *     step k pushes steps before k - DKF_FCR_WINDOW out);
 *   - checkpoints and rollback/replay: a payload of a published step that
 *     arrives late (within DKF_FCR_CKPT steps), or an epoch that starts
 *     there, restores the checkpoint taken before that step and recomputes
 *     every step since, each published again with revision + 1; at most
 *     two rollbacks between first publications (or one per deadline after
 *     step N): a revision beyond that waits, merged with the others, and
 *     runs before the next step is published;
 *   - the join (a centre started mid-run fuses from the first step it has
 *     a payload of) and the linger (after step N it waits until every node
 *     heard has its revisable payloads or is silent for linger_us);
 *   - the per-step record (status, contributors, revisions, latency) and
 *     the counters of the result file.
 *
 * No transport and no clock inside: the owner decodes and validates a
 * message (codec.h) and hands its payloads in with their metadata and
 * arrival times (dkf_fcr_receive), calls dkf_fcr_tick with the monotonic
 * time, and is called back through a dkf_fcr_ops_t table for the fusion
 * itself (step, restart, save, restore) and the outputs (publish, record,
 * state). The seed-000 Difference-KF centre (fusion.c) is one user; a
 * test drives it with synthetic payloads and a fake clock
 * (net/tests/test_fc_runtime.c).
 *
 * Contract of the callbacks (each gets the user pointer of dkf_fcr_create;
 * a callback must not call back into the runtime, but dkf_fcr_notef):
 *   step     computes step k (always the step after the one the user's
 *            state is at: 1, 2, ... and again from j after a restore of
 *            the checkpoint of step j-1) from pay[i], node i's payload of
 *            step k or NULL (missing, masked). Sets contrib[i] = 1 for every
 *            node whose payload it used (0 else). Returns how many times
 *            the fusion refused a payload (or the whole data) and went on
 *            without it (>= 0, counted as core_refusals), or -1: step k
 *            cannot be computed at all (the centre fails).
 *   restart  (may be NULL) before step k > 1: node i's local filter
 *            restarted at k (a new epoch); mirror it. 0, or -1: the node's
 *            epoch cannot be followed (its payloads stay masked).
 *   save     writes the state after the step just computed to ckpt
 *            (ckpt_size bytes). 0, or -1 (no checkpoint of that step).
 *   restore  sets the state back to what save wrote there. 0 or -1.
 *   publish  step k has been computed (revision 0: the first time, r > 0:
 *            the r-th recomputation); publish it and set *utime to the
 *            publication's wall-clock time stamp (us; also when it fails,
 *            0 if none). 0, or -1 (not sent; the runtime goes on). Not
 *            called for steps before the join.
 *   record   (may be NULL) after publish (or instead of it, published = 0,
 *            before the join): the step as computed now, e.g. a journal line.
 *   state    (may be NULL) the runtime has become DKF_FCR_DONE or
 *            DKF_FCR_FAILED.
 *   copy     (may be NULL: all payload_size bytes are copied) copies a
 *            payload into its slot (payload_size bytes, zero at first, then
 *            as the last copy left them): the bytes step will read.
 */
#ifndef DKF_NET_FC_RUNTIME_H
#define DKF_NET_FC_RUNTIME_H

#include <stddef.h>
#include <stdint.h>

#define DKF_FCR_WINDOW 32      /* steps buffered ahead of the last published one */
#define DKF_FCR_CKPT 8         /* published steps a late payload can still revise */
#define DKF_FCR_MAX_NODES 256  /* nodes of one centre (DKF_NET_MAX_NODES) */
#define DKF_FCR_MAX_STEPS 100000000L /* steps of one run */
#define DKF_FCR_NOTE_LEN 160

enum { DKF_FCR_RUNNING = 1, DKF_FCR_DONE = 2, DKF_FCR_FAILED = 3 };

typedef struct dkf_fcr dkf_fcr_t;

/* A step as computed now (publish, record). */
typedef struct {
    long k;
    int revision;                     /* 0 first computation, r > 0 r-th recomputation */
    int degraded;                     /* some node's payload was not used */
    size_t nodes;
    const unsigned char *contributed; /* nodes flags: its payload was used */
    int64_t meas_utime_first;         /* earliest / latest meas_utime of the contributors' */
    int64_t meas_utime_last;          /*   own messages (0: none known) */
    int64_t recv_utime_last;          /* latest arrival of a contributor's payload (0: none) */
} dkf_fcr_step_t;

typedef struct {
    int (*step)(void *user, long k, const void *const *pay, unsigned char *contrib);
    int (*restart)(void *user, size_t node, long k);
    int (*save)(void *user, void *ckpt);
    int (*restore)(void *user, const void *ckpt);
    int (*publish)(void *user, const dkf_fcr_step_t *st, int64_t *utime);
    void (*record)(void *user, const dkf_fcr_step_t *st, int published);
    void (*state)(void *user, int state);
    void (*copy)(void *user, void *dst, const void *src);
} dkf_fcr_ops_t;

typedef struct {
    size_t nodes;         /* l: node ids 0..l-1 (1..DKF_FCR_MAX_NODES) */
    long steps;           /* N: steps 1..N (1..DKF_FCR_MAX_STEPS) */
    size_t payload_size;  /* bytes of one payload (> 0), copied in as it comes (ops copy) */
    size_t ckpt_size;     /* bytes of one checkpoint (> 0) */
    int64_t deadline_us;  /* > 0 */
    int64_t linger_us;    /* > 0 */
} dkf_fcr_config_t;

/* One message of a node, decoded and validated by the owner: the payload of
 * step k and, if the message carries it, the copy of the payload of k-1. */
typedef struct {
    size_t node;
    long k;               /* 1..N */
    long epoch, k_start;  /* the node's local filter run: epoch >= 0, 1 <= k_start <= k */
    int64_t seq;          /* the message's number within the run (0, 1, ...; any value
                             is taken: it only counts the messages made) */
    int64_t meas_utime;   /* time stamp of the measurement that completed step k (0: unknown) */
    int64_t recv_utime;   /* arrival, wall clock (compared only with other arrivals) */
    const void *pay;      /* payload of step k (payload_size bytes) */
    const void *prev;     /* payload of step k-1 (k-1 >= k_start), or NULL */
} dkf_fcr_msg_t;

/* Fault and traffic counters (the result file's "counters"). */
typedef struct {
    int64_t received;   /* distinct messages taken (their own step's payload) */
    int64_t stale;      /* duplicate, too late, too far ahead, old epoch, conflicting */
    int64_t missed;     /* steps degraded at their first publication */
    int64_t sent;       /* publications that succeeded */
    int64_t duplicates, redundant, late, too_late, ahead, old_epoch, conflicts;
    int64_t rollbacks, replayed, revised_sent, restarts, core_masked, lost_epochs, pushed;
    int64_t deferred;   /* late data whose rollback waited for the budget (merged) */
} dkf_fcr_counts_t;

/* What is recorded of steps 1..N (index k-1). */
typedef struct {
    const int *degraded, *first_degraded;   /* N: latest / first publication */
    const int *revisions;                   /* N: recomputations after the first */
    const unsigned char *contributed;       /* N x l: latest */
    const unsigned char *first_contributed; /* N x l: at the first publication */
    const int64_t *lat_first, *lat_last;    /* N: publication - meas_utime_first/last (-1) */
    /* N: lat_last in parts, at the first publication (-1: unknown): the last
     * contributing measurement to its message's arrival, the arrival to the
     * computation, the computation (ops->step), its end to the publication */
    const int64_t *t_arrive, *t_wait, *t_compute, *t_publish;
} dkf_fcr_steps_t;

/* An epoch a node's message announced. */
typedef struct {
    long epoch, k_start;
    int usable; /* 0: it started before every checkpoint, or could not be followed */
} dkf_fcr_epoch_t;

/* The runtime, and the checkpoint of the user's state before step 1 (save
 * is called once). NULL if cfg is out of range, ops lacks step, save,
 * restore or publish, or memory is short. */
dkf_fcr_t *dkf_fcr_create(const dkf_fcr_config_t *cfg, const dkf_fcr_ops_t *ops, void *user);
void dkf_fcr_free(dkf_fcr_t *rt);

/* Takes a node's message at monotonic time mono_us: stores its payloads,
 * rolls back and replays if they revise a published step (now, or later if
 * the rollback budget is spent), then publishes every step that has all it
 * can get. 0, or -1 if it was not looked at
 * (not RUNNING, node, k, k_start or epoch out of range). */
int dkf_fcr_receive(dkf_fcr_t *rt, const dkf_fcr_msg_t *m, int64_t mono_us);
/* Publishes the steps whose deadline has passed at mono_us; ends the run
 * once step N is out and settled. */
void dkf_fcr_tick(dkf_fcr_t *rt, int64_t mono_us);

/* The configuration it was created with. */
const dkf_fcr_config_t *dkf_fcr_config(const dkf_fcr_t *rt);
/* DKF_FCR_RUNNING, DONE, FAILED. */
int dkf_fcr_state(const dkf_fcr_t *rt);
/* Last published step (0: none); first step fused from data. */
long dkf_fcr_done_k(const dkf_fcr_t *rt);
long dkf_fcr_join_k(const dkf_fcr_t *rt);
const dkf_fcr_counts_t *dkf_fcr_counts(const dkf_fcr_t *rt);
const dkf_fcr_steps_t *dkf_fcr_steps(const dkf_fcr_t *rt);
/* Node i's messages taken, and made (from the sequence numbers of its runs). */
void dkf_fcr_node_traffic(const dkf_fcr_t *rt, size_t i, int64_t *got, int64_t *made);
/* The epochs node i's messages announced, oldest first (at most cap);
 * returns how many there are. */
size_t dkf_fcr_epochs(const dkf_fcr_t *rt, size_t i, dkf_fcr_epoch_t *out, size_t cap);
/* The last note (why a message was stale, a step degraded, ...; "" none). */
const char *dkf_fcr_note(const dkf_fcr_t *rt);
void dkf_fcr_notef(dkf_fcr_t *rt, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

#endif /* DKF_NET_FC_RUNTIME_H */
