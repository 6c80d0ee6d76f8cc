/*
 * live_main.c - the live dkf node image: one sensor's local Difference KF
 * on an emulated Cortex-M4F (QEMU -M mps2-an386), fed one time step at a
 * time by a host program (dkf-m4-bridge, docs/guide/network.md, "A
 * firmware node in the network"), answering each step at once with the
 * node message's payload.
 *
 * The bridge makes two named pipes in QEMU's working directory and the
 * image opens them by semihosting (SYS_OPEN, target=native): it reads
 * m4_live.in and writes m4_live.out (docs/decisions.md, decision 68; the
 * words of the frames: live_frames.h).
 * Every integer is a 32-bit word, every real the image's dkf_real_t, both
 * in the target's byte order (little-endian, as the host's).
 *
 *   in:   header  "DKL1", bytes per real, n, m, p, x00[n], P00_local[n*n]
 *         frame   kind, k, bytes, then `bytes` bytes:
 *                 kind 1 (start at k0 = k): the dynamics at 0, sensor model
 *                 at k0 and y_{k0}; kind 2 (step k): the dynamics at k,
 *                 sensor model at k+1 and y_{k+1}; both laid out
 *                 F[n*n] Q[n*n] B[p*p] Rd[p*p] H[m*n] R[m*m] D[m*p] y[m];
 *                 kind 3 (the end): no bytes.
 *   out:  frame   "DKM1", kind, k, value, then for kind 2 xf[n] xp[n]:
 *                 kind 0 ready (value n), 1 started (value n), 2 the
 *                 message of step k (value n: x_{k|k}, x_{k|k-1}), 3 a
 *                 refusal (value: the dkf_status_t of a failed call, or 0
 *                 for a frame refused), 4 bye (value: the stack's
 *                 high-water mark in bytes).
 *
 * The start and the step are est_diffkf_node.c's (the host's node role):
 * dkf_diffkf_init from (x00, P00_local) at every start; at k0 = 1
 * dkf_diffkf_start with F_0, Q_0, else with no dynamics and
 * dkf_diffkf_set_time(k0 - 1); dkf_diffkf_step; dkf_diffkf_msg_fill. Every
 * word from the bridge is checked before it sizes a read or indexes a
 * buffer: the header's dimensions against the capacity below, a frame's
 * kind, its k (1..10^9, a step's after the start's) and its byte count
 * against the one its kind must have. A refusal is answered with kind 3,
 * said on the console, and ends the image with status 2 (refused input) or
 * 3 (a filter call failed); the end frame with status 0.
 *
 * Everything lives in static storage: no heap.
 */
#include <stdint.h>
#include <string.h>

#include "dkf/diffkf.h"
#include "dkf/diffkf_fusion.h"
#include "live_frames.h"
#include "semihost.h"
#include "stack.h"

/* Capacity: one sensor of the golden vectors' size (qemu_main.c's). */
#define LV_MAX_N 8
#define LV_MAX_M 4
#define LV_MAX_P 2
#define LV_MAX_K 1000000000u


#define LV_EXIT_INPUT 2
#define LV_EXIT_RUN 3

/* One frame's data (the layout of the file comment). */
static struct {
    dkf_real_t F[LV_MAX_N * LV_MAX_N], Q[LV_MAX_N * LV_MAX_N];
    dkf_real_t B[LV_MAX_P * LV_MAX_P], Rd[LV_MAX_P * LV_MAX_P];
    dkf_real_t H[LV_MAX_M * LV_MAX_N], R[LV_MAX_M * LV_MAX_M], D[LV_MAX_M * LV_MAX_P];
    dkf_real_t y[LV_MAX_M];
} rec;

static uint32_t n, m, p;
static dkf_real_t x00[LV_MAX_N], P00[LV_MAX_N * LV_MAX_N];
DKF_DIFFKF_DECLARE(static, node, LV_MAX_N, LV_MAX_M, LV_MAX_P);
static dkf_diffkf_msg_t msg;
static int in_fd = -1, out_fd = -1;

/* ---- the pipes ----------------------------------------------------------- */

/* Sends a frame head, then `len` bytes of body (may be 0). */
static void send(uint32_t kind, uint32_t k, uint32_t value, const void *body, size_t len)
{
    uint32_t head[4];
    head[0] = LV_MAGIC_OUT;
    head[1] = kind;
    head[2] = k;
    head[3] = value;
    /* a broken pipe leaves nobody to tell: the bridge sees the image end */
    if (sh_write(out_fd, head, sizeof head) != 0) sh_exit(LV_EXIT_RUN);
    if (len > 0 && sh_write(out_fd, body, len) != 0) sh_exit(LV_EXIT_RUN);
}

static void say_num(uint32_t v)
{
    char tmp[11], out[12];
    size_t i = 0, j = 0;
    do {
        tmp[i++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0u);
    while (i > 0) out[j++] = tmp[--i];
    out[j] = '\0';
    sh_puts(out);
}

/* Refuses: "m4 live: what: got V" on the console, kind 3 to the bridge
 * (status: the failed call's, 0 for a refused frame), then exit code. */
static void refuse(int code, const char *what, uint32_t v, uint32_t k, uint32_t status)
{
    sh_puts("m4 live: ");
    sh_puts(what);
    sh_puts(": got ");
    say_num(v);
    sh_puts("\n");
    if (out_fd >= 0) send(LV_OUT_REFUSED, k, status, NULL, 0);
    sh_exit(code);
}

/* Exactly len bytes from the pipe (several reads when the pipe hands them
 * over in parts); the end of the pipe before them is a refusal. */
static void get(void *buf, size_t len, const char *what)
{
    unsigned char *b = buf;
    while (len > 0) {
        long got = sh_read_part(in_fd, b, len);
        if (got <= 0) refuse(LV_EXIT_INPUT, what, (uint32_t)len, 0u, 0u);
        b += got;
        len -= (size_t)got;
    }
}

/* A word in lo..hi, else a refusal naming it. */
static uint32_t get_dim(const char *what, uint32_t lo, uint32_t hi)
{
    uint32_t v;
    get(&v, sizeof v, what);
    if (v < lo || v > hi) refuse(LV_EXIT_INPUT, what, v, 0u, 0u);
    return v;
}

static void read_header(void)
{
    uint32_t hi;
    (void)get_dim("header: magic", LV_MAGIC_IN, LV_MAGIC_IN);
    (void)get_dim("header: bytes per real (this image's)", (uint32_t)sizeof(dkf_real_t),
                  (uint32_t)sizeof(dkf_real_t));
    n = get_dim("n outside 1..8 (the image's capacity)", 1u, LV_MAX_N);
    m = get_dim("m outside 1..4 (the image's capacity)", 1u, LV_MAX_M);
    hi = m < n ? m : n;
    if (hi > LV_MAX_P) hi = LV_MAX_P;
    p = get_dim("p outside 1..min(m, n, 2)", 1u, hi);
    get(x00, n * sizeof x00[0], "header: x00");
    get(P00, n * n * sizeof P00[0], "header: P00_local");
}

/* The bytes of a start or step frame at this header's dimensions. */
static uint32_t rec_bytes(void)
{
    return (uint32_t)((2u * n * n + 2u * p * p + m * n + m * m + m * p + m) * sizeof(dkf_real_t));
}

static void read_rec(void)
{
    get(rec.F, n * n * sizeof rec.F[0], "frame: F");
    get(rec.Q, n * n * sizeof rec.Q[0], "frame: Q");
    get(rec.B, p * p * sizeof rec.B[0], "frame: B");
    get(rec.Rd, p * p * sizeof rec.Rd[0], "frame: Rd");
    get(rec.H, m * n * sizeof rec.H[0], "frame: H");
    get(rec.R, m * m * sizeof rec.R[0], "frame: R");
    get(rec.D, m * p * sizeof rec.D[0], "frame: D");
    get(rec.y, m * sizeof rec.y[0], "frame: y");
}

/* ---- the node role ---------------------------------------------------------- */

static void check(dkf_status_t st, const char *what, uint32_t k)
{
    if (st != DKF_OK) refuse(LV_EXIT_RUN, what, (uint32_t)st, k, (uint32_t)st);
}

/* (Re)start at k0 from (x00, P00_local). */
static void start(uint32_t k0)
{
    dkf_mat_t x0 = DKF_MAT(n, 1, x00), P0 = DKF_MAT(n, n, P00);
    dkf_mat_t F = DKF_MAT(n, n, rec.F), Q = DKF_MAT(n, n, rec.Q);
    dkf_mat_t H = DKF_MAT(m, n, rec.H), R = DKF_MAT(m, m, rec.R), D = DKF_MAT(m, p, rec.D);
    dkf_mat_t y = DKF_MAT(m, 1, rec.y);
    const dkf_ui_meas_t meas = {&H, &D, &R};
    check(dkf_diffkf_init(&node, n, m, p, node_storage,
                          sizeof node_storage / sizeof node_storage[0], &x0, &P0),
          "dkf_diffkf_init failed: status", k0);
    if (k0 == 1u) {
        check(dkf_diffkf_start(&node, &F, &Q, &meas, &y), "dkf_diffkf_start failed: status", k0);
    } else {
        check(dkf_diffkf_start(&node, NULL, NULL, &meas, &y), "dkf_diffkf_start failed: status",
              k0);
        check(dkf_diffkf_set_time(&node, (size_t)k0 - 1u), "dkf_diffkf_set_time failed: status",
              k0);
    }
    send(LV_OUT_STARTED, k0, n, NULL, 0);
}

/* Step k, then its message. */
static void step(uint32_t k)
{
    dkf_mat_t F = DKF_MAT(n, n, rec.F), Q = DKF_MAT(n, n, rec.Q);
    dkf_mat_t B = DKF_MAT(p, p, rec.B), Rd = DKF_MAT(p, p, rec.Rd);
    dkf_mat_t H = DKF_MAT(m, n, rec.H), R = DKF_MAT(m, m, rec.R), D = DKF_MAT(m, p, rec.D);
    dkf_mat_t y = DKF_MAT(m, 1, rec.y);
    const dkf_ui_dyn_t dyn = {&F, &Q, &B, &Rd};
    const dkf_ui_meas_t meas = {&H, &D, &R};
    dkf_real_t body[2 * LV_MAX_N];
    check(dkf_diffkf_step(&node, &dyn, &meas, &y), "dkf_diffkf_step failed: status", k);
    check(dkf_diffkf_msg_fill(&msg, 0u, &node), "dkf_diffkf_msg_fill failed: status", k);
    if (msg.k != k) refuse(LV_EXIT_RUN, "the filter's step is not the frame's: filter k", msg.k, k, 0u);
    memcpy(body, msg.xf, n * sizeof body[0]);
    memcpy(body + n, msg.xp, n * sizeof body[0]);
    send(LV_OUT_MSG, k, n, body, 2u * n * sizeof body[0]);
}

int main(void)
{
    uint32_t started = 0u, last = 0u; /* last: the filter's time (start k0 - 1, then each step) */

    m4_stack_paint();
    if ((in_fd = sh_open(LV_PIPE_IN, 0)) < 0) refuse(LV_EXIT_INPUT, "cannot open " LV_PIPE_IN, 0u, 0u, 0u);
    if ((out_fd = sh_open(LV_PIPE_OUT, 1)) < 0) {
        out_fd = -1;
        refuse(LV_EXIT_INPUT, "cannot open " LV_PIPE_OUT, 0u, 0u, 0u);
    }
    read_header();
    send(LV_OUT_READY, 0u, n, NULL, 0);
    for (;;) {
        const uint32_t kind = get_dim("frame: kind (1 start, 2 step, 3 end)", LV_IN_START, LV_IN_END);
        const uint32_t k = get_dim("frame: k outside 0..10^9", 0u, LV_MAX_K);
        const uint32_t bytes = get_dim("frame: bytes above its dimensions'", 0u, rec_bytes());
        if (kind == LV_IN_END) {
            if (bytes != 0u) refuse(LV_EXIT_INPUT, "end frame: bytes (0)", bytes, k, 0u);
            break;
        }
        if (bytes != rec_bytes()) refuse(LV_EXIT_INPUT, "frame: bytes (its dimensions')", bytes, k, 0u);
        if (k < 1u) refuse(LV_EXIT_INPUT, "frame: k of a start or step (1..10^9)", k, k, 0u);
        if (kind == LV_IN_STEP && (!started || k != last + 1u))
            refuse(LV_EXIT_INPUT, "step frame: k (not the step after the filter's)", k, k, 0u);
        read_rec();
        if (kind == LV_IN_START) {
            start(k);
            started = 1u;
            last = k - 1u;
        } else {
            step(k);
            last = k;
        }
    }
    send(LV_OUT_BYE, last, m4_stack_used(), NULL, 0);
    (void)sh_close(out_fd);
    (void)sh_close(in_fd);
    sh_exit(0);
    return 0;
}
