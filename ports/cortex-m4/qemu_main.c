/*
 * qemu_main.c - the dkf node image that QEMU runs on an emulated Cortex-M4F
 * (machine mps2-an386; docs/results/footprint.md, "The image on an
 * emulated Cortex-M4F").
 *
 * tools/m4_run.py packs a scenario into m4_in.bin (the host's working
 * directory, read by semihosting); the image runs the Kalman filter or the
 * Difference KF on it exactly as dkf-run's estimators do
 * (ports/linux/runner/estimator.c: local filters, the stacked central one
 * and, for the Difference KF, the fusion centre fed with the local
 * filters' messages), writes every recorded estimate to m4_out.bin, then
 * the SysTick count of every filter step and the stack high-water mark,
 * and exits through SYS_EXIT_EXTENDED: 0, 2 (input refused: bad header,
 * a dimension above the capacity, a short file), 3 (a filter call
 * failed) or 4 (an output write failed). The layout of both files is
 * m4_run.py's (its docstring); every count and length is checked against
 * the capacity below before anything is read into a buffer.
 *
 * Everything lives in static storage: no heap.
 */
#include <stdint.h>
#include <string.h>

#include "dkf/diffkf.h"
#include "dkf/diffkf_fusion.h"
#include "dkf/kf.h"
#include "semihost.h"
#include "stack.h"

/* Capacity (the golden vectors need n <= 6, up to 4 sensors of m_i <= 4,
 * p_i <= 2). */
#define QM_MAX_N 8
#define QM_MAX_L 4
#define QM_MAX_M 4
#define QM_MAX_P 2
#define QM_MAX_MS (QM_MAX_L * QM_MAX_M)
#define QM_MAX_PS (QM_MAX_L * QM_MAX_P)
#define QM_MAX_STEPS 1000000u
#define QM_SLOTS (QM_MAX_L + 2) /* local[0..L-1] or the single filter, central, fused */

#define QM_MAGIC_IN 0x314E4B44u    /* "DKN1" */
#define QM_MAGIC_OUT 0x314F4B44u   /* "DKO1" */
#define QM_MAGIC_STATS 0x31534B44u /* "DKS1" */
#define QM_FILTER_KF 1u
#define QM_FILTER_DKF 2u

#define QM_EXIT_INPUT 2
#define QM_EXIT_RUN 3
#define QM_EXIT_IO 4

#define QM_MAX(a, b) ((a) > (b) ? (a) : (b))
#define QM_STORE_LEN \
    QM_MAX(DKF_DIFFKF_STORAGE_LEN(QM_MAX_N, QM_MAX_MS, QM_MAX_PS), \
           DKF_KF_STORAGE_LEN(QM_MAX_N, QM_MAX_MS))

/* One time k of the input: the dynamics and every sensor's model and y. */
typedef struct {
    dkf_real_t F[QM_MAX_N * QM_MAX_N], Q[QM_MAX_N * QM_MAX_N];
    struct {
        dkf_real_t H[QM_MAX_M * QM_MAX_N], R[QM_MAX_M * QM_MAX_M], y[QM_MAX_M];
        dkf_real_t D[QM_MAX_M * QM_MAX_P], B[QM_MAX_P * QM_MAX_P], Rd[QM_MAX_P * QM_MAX_P];
    } s[QM_MAX_L];
} qm_rec_t;

/* A filter's sensors: H stacked, R, D, B, Rd block-diagonal (estimator.c). */
typedef struct {
    size_t first, count, m, p;
    dkf_real_t H[QM_MAX_MS * QM_MAX_N], R[QM_MAX_MS * QM_MAX_MS], y[QM_MAX_MS];
    dkf_real_t D[QM_MAX_MS * QM_MAX_PS], B[QM_MAX_PS * QM_MAX_PS], Rd[QM_MAX_PS * QM_MAX_PS];
    dkf_mat_t Hm, Rm, ym, Dm, Bm, Rdm;
    dkf_ui_meas_t meas;
} qm_group_t;

typedef struct {
    uint32_t steps, max, min;
    uint64_t sum;
} qm_ticks_t;

static struct {
    uint32_t filter, n, l, steps, m[QM_MAX_L], p[QM_MAX_L];
} hdr;

static qm_rec_t rec[2];
static dkf_real_t x00[QM_MAX_N], P00[QM_MAX_N * QM_MAX_N];
static dkf_real_t P00_local[QM_MAX_L][QM_MAX_N * QM_MAX_N];
static qm_group_t group[QM_SLOTS];
static size_t nslots, central, fused; /* fused: 0 if none */
static dkf_kf_t kf[QM_SLOTS];
static dkf_diffkf_t dk[QM_SLOTS];
static dkf_real_t store[QM_SLOTS - 1][QM_STORE_LEN];
DKF_DIFFKF_FC_DECLARE(static, fc, QM_MAX_N, QM_MAX_L, QM_MAX_M, QM_MAX_P);
static dkf_diffkf_msg_t msgs[QM_MAX_L];
static dkf_diffkf_sensor_t fcs[QM_MAX_L];
static qm_ticks_t ticks[QM_SLOTS];
static int in_fd = -1, out_fd = -1, out_failed;
static unsigned char out_buf[4096];
static size_t out_len;

/* ---- console, exit ------------------------------------------------------- */

static void put_u32(char *p, uint32_t v)
{
    char tmp[11];
    size_t n = 0;
    do {
        tmp[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0u);
    while (n > 0) *p++ = tmp[--n];
    *p = '\0';
}

/* "m4: what: got V" on the console, then exit with code. */
static void fail(int code, const char *what, uint32_t v)
{
    char num[12];
    put_u32(num, v);
    sh_puts("m4: ");
    sh_puts(what);
    sh_puts(": got ");
    sh_puts(num);
    sh_puts("\n");
    sh_exit(code);
}

/* ---- SysTick (the processor clock; one tick per 40 instructions under
 * QEMU -icount shift=0 on mps2-an386: tools/m4_run.py calibrates it) ---- */

#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)

static void systick_start(void)
{
    SYST_RVR = 0xFFFFFFu;
    SYST_CVR = 0u;
    SYST_CSR = 5u; /* enable, processor clock, no interrupt */
}

/* The counter counts down and wraps at 24 bits. */
static uint32_t ticks_since(uint32_t t0)
{
    return (t0 - SYST_CVR) & 0xFFFFFFu;
}

static void ticks_add(qm_ticks_t *t, uint32_t d)
{
    if (t->steps == 0u || d < t->min) t->min = d;
    if (d > t->max) t->max = d;
    t->sum += d;
    t->steps++;
}

/* 2 n instructions (subs, bne), the calibration of the tick. */
static void spin(uint32_t n)
{
    __asm__ volatile("1: subs %0, %0, #1\n\tbne 1b" : "+r"(n) : : "cc");
}

/* ---- input --------------------------------------------------------------- */

static void read_bytes(void *buf, size_t len, const char *what)
{
    if (sh_read(in_fd, buf, len) != 0) fail(QM_EXIT_INPUT, what, (uint32_t)len);
}

static void read_reals(dkf_real_t *v, size_t count, const char *what)
{
    read_bytes(v, count * sizeof *v, what);
}

static uint32_t read_u32(const char *what)
{
    uint32_t v;
    read_bytes(&v, sizeof v, what);
    return v;
}

static uint32_t read_dim(const char *what, uint32_t lo, uint32_t hi)
{
    uint32_t v = read_u32(what);
    if (v < lo || v > hi) fail(QM_EXIT_INPUT, what, v);
    return v;
}

static void read_header(void)
{
    uint32_t i;
    if (read_u32("header: magic") != QM_MAGIC_IN) fail(QM_EXIT_INPUT, "header: magic", 0u);
    (void)read_dim("header: bytes per real (this image's)", (uint32_t)sizeof(dkf_real_t),
                   (uint32_t)sizeof(dkf_real_t));
    hdr.filter = read_dim("header: filter (1 kf, 2 dkf)", QM_FILTER_KF, QM_FILTER_DKF);
    hdr.n = read_dim("n outside 1..8 (the image's capacity)", 1u, QM_MAX_N);
    hdr.l = read_dim("sensors outside 1..4 (the image's capacity)", 1u, QM_MAX_L);
    hdr.steps = read_dim("steps outside 1..1000000", 1u, QM_MAX_STEPS);
    for (i = 0; i < hdr.l; ++i) {
        hdr.m[i] = read_dim("m_i outside 1..4 (the image's capacity)", 1u, QM_MAX_M);
        if (hdr.filter == QM_FILTER_DKF) {
            uint32_t hi = hdr.m[i] < hdr.n ? hdr.m[i] : hdr.n;
            if (hi > QM_MAX_P) hi = QM_MAX_P;
            hdr.p[i] = read_dim("p_i outside 1..min(m_i, n, 2)", 1u, hi);
        }
        else
            hdr.p[i] = read_dim("p_i of a kf input (0)", 0u, 0u);
    }
}

/* Time k's record (the layout of m4_run.py). */
static void read_rec(qm_rec_t *r)
{
    size_t n = hdr.n, i;
    read_reals(r->F, n * n, "record: F");
    read_reals(r->Q, n * n, "record: Q");
    for (i = 0; i < hdr.l; ++i) {
        size_t m = hdr.m[i], p = hdr.p[i];
        read_reals(r->s[i].H, m * n, "record: H");
        read_reals(r->s[i].R, m * m, "record: R");
        read_reals(r->s[i].y, m, "record: y");
        if (hdr.filter != QM_FILTER_DKF) continue;
        read_reals(r->s[i].D, m * p, "record: D");
        read_reals(r->s[i].B, p * p, "record: B");
        read_reals(r->s[i].Rd, p * p, "record: Rd");
    }
}

/* ---- output -------------------------------------------------------------- */

static void out_flush(void)
{
    if (out_len > 0 && sh_write(out_fd, out_buf, out_len) != 0) out_failed = 1;
    out_len = 0;
}

static void put_bytes(const void *v, size_t len)
{
    const unsigned char *b = v;
    while (len > 0) {
        size_t k = sizeof out_buf - out_len;
        if (k > len) k = len;
        memcpy(out_buf + out_len, b, k);
        out_len += k;
        b += k;
        len -= k;
        if (out_len == sizeof out_buf) out_flush();
    }
}

static void put_mat(const dkf_mat_t *A)
{
    put_bytes(A->data, A->rows * A->cols * sizeof *A->data);
}

static void put_word(uint32_t v)
{
    put_bytes(&v, sizeof v);
}

/* ---- groups -------------------------------------------------------------- */

static void group_init(qm_group_t *g, size_t first, size_t count)
{
    size_t j, n = hdr.n;
    g->first = first;
    g->count = count;
    g->m = g->p = 0;
    for (j = first; j < first + count; ++j) {
        g->m += hdr.m[j];
        g->p += hdr.p[j];
    }
    g->Hm = (dkf_mat_t)DKF_MAT(g->m, n, g->H);
    g->Rm = (dkf_mat_t)DKF_MAT(g->m, g->m, g->R);
    g->ym = (dkf_mat_t)DKF_MAT(g->m, 1, g->y);
    g->Dm = (dkf_mat_t)DKF_MAT(g->m, g->p, g->D);
    g->Bm = (dkf_mat_t)DKF_MAT(g->p, g->p, g->B);
    g->Rdm = (dkf_mat_t)DKF_MAT(g->p, g->p, g->Rd);
    g->meas.H = &g->Hm;
    g->meas.D = &g->Dm;
    g->meas.R = &g->Rm;
}

/* Entries (r0 + r, c0 + c) of dst (ld columns) = src (rows x cols). */
static void put_block(dkf_real_t *dst, size_t ld, size_t r0, size_t c0, const dkf_real_t *src,
                      size_t rows, size_t cols)
{
    size_t r;
    for (r = 0; r < rows; ++r) memcpy(dst + (r0 + r) * ld + c0, src + r * cols, cols * sizeof *src);
}

/* H, R, D, y at the record's time. */
static void group_meas(qm_group_t *g, const qm_rec_t *t)
{
    size_t j, r0 = 0, c0 = 0, n = hdr.n;
    memset(g->R, 0, g->m * g->m * sizeof g->R[0]);
    memset(g->D, 0, g->m * g->p * sizeof g->D[0]);
    for (j = g->first; j < g->first + g->count; ++j) {
        size_t m = hdr.m[j], p = hdr.p[j];
        put_block(g->H, n, r0, 0, t->s[j].H, m, n);
        put_block(g->R, g->m, r0, r0, t->s[j].R, m, m);
        memcpy(g->y + r0, t->s[j].y, m * sizeof g->y[0]);
        if (p > 0) put_block(g->D, g->p, r0, c0, t->s[j].D, m, p);
        r0 += m;
        c0 += p;
    }
}

/* B, Rd at the record's time. */
static void group_dyn(qm_group_t *g, const qm_rec_t *t)
{
    size_t j, c0 = 0;
    memset(g->B, 0, g->p * g->p * sizeof g->B[0]);
    memset(g->Rd, 0, g->p * g->p * sizeof g->Rd[0]);
    for (j = g->first; j < g->first + g->count; ++j) {
        size_t p = hdr.p[j];
        put_block(g->B, g->p, c0, c0, t->s[j].B, p, p);
        put_block(g->Rd, g->p, c0, c0, t->s[j].Rd, p, p);
        c0 += p;
    }
}

/* ---- the filters ----------------------------------------------------------- */

static void check(dkf_status_t st, const char *what, size_t slot)
{
    if (st != DKF_OK) fail(QM_EXIT_RUN, what, (uint32_t)slot);
}

/* Slots: one filter, or local[0..l-1], central (and fused for the DKF). */
static void slots_init(void)
{
    size_t j, l = hdr.l;
    if (l == 1) {
        nslots = 1;
        central = 0;
        fused = 0;
        group_init(&group[0], 0, 1);
        return;
    }
    for (j = 0; j < l; ++j) group_init(&group[j], j, 1);
    central = l;
    group_init(&group[central], 0, l);
    nslots = l + 1;
    fused = 0;
    if (hdr.filter == QM_FILTER_DKF) fused = nslots++;
}

static dkf_mat_t prior_of(size_t j)
{
    return (dkf_mat_t)DKF_MAT(hdr.n, hdr.n, hdr.l > 1 && j != central ? P00_local[j] : P00);
}

static void kf_start(void)
{
    dkf_mat_t x0 = DKF_MAT(hdr.n, 1, x00);
    size_t j;
    for (j = 0; j < nslots; ++j) {
        dkf_mat_t P0 = prior_of(j);
        check(dkf_kf_init(&kf[j], hdr.n, group[j].m, store[j], QM_STORE_LEN, &x0, &P0),
              "dkf_kf_init failed; filter", j);
    }
}

/* Step k: predict with the record of k-1, update with that of k. */
static void kf_step(const qm_rec_t *prev, const qm_rec_t *now)
{
    dkf_mat_t F = DKF_MAT(hdr.n, hdr.n, (dkf_real_t *)prev->F);
    dkf_mat_t Q = DKF_MAT(hdr.n, hdr.n, (dkf_real_t *)prev->Q);
    const dkf_kf_dyn_t dyn = {&F, &Q};
    size_t j;
    for (j = 0; j < nslots; ++j) {
        qm_group_t *g = &group[j];
        const dkf_kf_meas_t meas = {&g->Hm, &g->Rm};
        uint32_t t0, d;
        dkf_status_t st;
        group_meas(g, now);
        t0 = SYST_CVR;
        st = dkf_kf_predict(&kf[j], &dyn, NULL);
        d = ticks_since(t0);
        check(st, "dkf_kf_predict failed; filter", j);
        put_mat(&kf[j].x);
        put_mat(&kf[j].P);
        t0 = SYST_CVR;
        st = dkf_kf_update(&kf[j], &meas, &g->ym);
        d += ticks_since(t0);
        check(st, "dkf_kf_update failed; filter", j);
        ticks_add(&ticks[j], d);
        put_mat(&kf[j].x);
        put_mat(&kf[j].P);
    }
}

/* Every filter from (x00, P00), predicted to k = 1 with y_1. */
static void dkf_start(const qm_rec_t *r0, const qm_rec_t *r1)
{
    dkf_mat_t x0 = DKF_MAT(hdr.n, 1, x00);
    dkf_mat_t F = DKF_MAT(hdr.n, hdr.n, (dkf_real_t *)r0->F);
    dkf_mat_t Q = DKF_MAT(hdr.n, hdr.n, (dkf_real_t *)r0->Q);
    dkf_mat_t Pl[QM_MAX_L];
    const dkf_mat_t *Pv[QM_MAX_L];
    size_t m[QM_MAX_L], p[QM_MAX_L];
    dkf_diffkf_fc_fault_t fault;
    size_t j, end = fused != 0 ? fused : nslots;
    for (j = 0; j < end; ++j) {
        qm_group_t *g = &group[j];
        dkf_mat_t P0 = prior_of(j);
        check(dkf_diffkf_init(&dk[j], hdr.n, g->m, g->p, store[j], QM_STORE_LEN, &x0, &P0),
              "dkf_diffkf_init failed; filter", j);
        group_meas(g, r1);
        group_dyn(g, r1); /* the fusion centre's start checks B of step 1 */
        check(dkf_diffkf_start(&dk[j], &F, &Q, &g->meas, &g->ym), "dkf_diffkf_start failed; filter",
              j);
    }
    if (fused == 0) return;
    for (j = 0; j < hdr.l; ++j) {
        m[j] = hdr.m[j];
        p[j] = hdr.p[j];
        Pl[j] = prior_of(j);
        Pv[j] = &Pl[j];
        fcs[j].B = &group[j].Bm;
        fcs[j].Rd = NULL;
        fcs[j].meas = group[j].meas;
    }
    {
        dkf_mat_t P0 = prior_of(central);
        check(dkf_diffkf_fc_init(&fc, fc_nodes, hdr.l, hdr.n, m, p, fc_storage,
                                 sizeof fc_storage / sizeof fc_storage[0], &x0, &P0,
                                 (const dkf_mat_t *const *)Pv, &fault),
              "dkf_diffkf_fc_init failed; fault", (uint32_t)fault.which);
    }
    check(dkf_diffkf_fc_start(&fc, &F, &Q, fcs, &fault), "dkf_diffkf_fc_start failed; fault",
          (uint32_t)fault.which);
}

static void put_dkf_step(const dkf_diffkf_t *f, size_t p, size_t slot)
{
    if (f->pk != p) fail(QM_EXIT_RUN, "a step kept fewer rows of z than p; filter", (uint32_t)slot);
    put_mat(&f->z);
    put_mat(&f->dz);
    put_mat(&f->J);
    put_mat(&f->L);
    put_mat(&f->K);
    put_mat(&f->xf);
    put_mat(&f->Pf);
}

/* Step k: the dynamics of record k, the model and y of record k+1. */
static void dkf_step(const qm_rec_t *now, const qm_rec_t *next)
{
    dkf_mat_t F = DKF_MAT(hdr.n, hdr.n, (dkf_real_t *)now->F);
    dkf_mat_t Q = DKF_MAT(hdr.n, hdr.n, (dkf_real_t *)now->Q);
    dkf_diffkf_fc_fault_t fault;
    size_t j, end = fused != 0 ? fused : nslots;
    uint32_t t0, d;
    dkf_status_t st;
    for (j = 0; j < end; ++j) {
        qm_group_t *g = &group[j];
        const dkf_ui_dyn_t dyn = {&F, &Q, &g->Bm, &g->Rdm};
        put_mat(&dk[j].xn);
        put_mat(&dk[j].Pn);
        group_dyn(g, now);
        group_meas(g, next);
        t0 = SYST_CVR;
        st = dkf_diffkf_step(&dk[j], &dyn, &g->meas, &g->ym);
        /* a node (one sensor) also fills its message to the fusion centre */
        if (st == DKF_OK && g->count == 1)
            st = dkf_diffkf_msg_fill(&msgs[j], (uint16_t)j, &dk[j]);
        d = ticks_since(t0);
        check(st, "dkf_diffkf_step failed; filter", j);
        ticks_add(&ticks[j], d);
        put_dkf_step(&dk[j], g->p, j);
    }
    if (fused == 0) return;
    put_mat(&fc.central.xn);
    put_mat(&fc.central.Pn);
    for (j = 0; j < hdr.l; ++j) {
        fcs[j].B = &group[j].Bm;
        fcs[j].Rd = &group[j].Rdm;
        fcs[j].meas = group[j].meas;
    }
    t0 = SYST_CVR;
    st = dkf_diffkf_fc_step(&fc, &F, &Q, fcs, msgs, &fault);
    d = ticks_since(t0);
    check(st, "dkf_diffkf_fc_step failed; fault", (uint32_t)fault.which);
    ticks_add(&ticks[fused], d);
    put_dkf_step(&fc.central, group[central].p, fused);
    for (j = 0; j < hdr.l; ++j) {
        put_bytes(msgs[j].xf, hdr.n * sizeof msgs[j].xf[0]);
        put_bytes(msgs[j].xp, hdr.n * sizeof msgs[j].xp[0]);
    }
    for (j = 0; j < hdr.l; ++j) {
        put_mat(&fc_nodes[j].dz);
        put_mat(&fc_nodes[j].z);
        put_mat(&fc_nodes[j].rep.K);
    }
}

/* ---- main ---------------------------------------------------------------- */

#define QM_CALIB_LOOPS 100000u

int main(void)
{
    uint32_t k, t0, calib, used;
    size_t j;

    m4_stack_paint();
    systick_start();
    t0 = SYST_CVR;
    spin(QM_CALIB_LOOPS);
    calib = ticks_since(t0);

    if ((in_fd = sh_open("m4_in.bin", 0)) < 0) fail(QM_EXIT_INPUT, "cannot open m4_in.bin", 0u);
    if ((out_fd = sh_open("m4_out.bin", 1)) < 0) fail(QM_EXIT_IO, "cannot open m4_out.bin", 0u);
    read_header();
    read_reals(x00, hdr.n, "init: x00");
    read_reals(P00, (size_t)hdr.n * hdr.n, "init: P00");
    for (j = 0; hdr.l > 1 && j < hdr.l; ++j)
        read_reals(P00_local[j], (size_t)hdr.n * hdr.n, "init: P00_local");
    slots_init();
    put_word(QM_MAGIC_OUT);
    put_word((uint32_t)sizeof(dkf_real_t));
    put_word(hdr.steps);

    read_rec(&rec[0]);
    if (hdr.filter == QM_FILTER_KF) {
        kf_start();
        for (k = 1; k <= hdr.steps; ++k) {
            read_rec(&rec[k & 1u]);
            kf_step(&rec[(k - 1u) & 1u], &rec[k & 1u]);
        }
    } else {
        read_rec(&rec[1]);
        dkf_start(&rec[0], &rec[1]);
        for (k = 1; k <= hdr.steps; ++k) {
            read_rec(&rec[(k + 1u) & 1u]);
            dkf_step(&rec[k & 1u], &rec[(k + 1u) & 1u]);
        }
    }

    used = m4_stack_used();
    put_word(QM_MAGIC_STATS);
    put_word(calib);
    put_word(2u * QM_CALIB_LOOPS);
    put_word(used);
    put_word(m4_stack_size());
    put_word((uint32_t)nslots);
    for (j = 0; j < nslots; ++j) {
        put_word(ticks[j].steps);
        put_word((uint32_t)ticks[j].sum);
        put_word((uint32_t)(ticks[j].sum >> 32));
        put_word(ticks[j].min);
        put_word(ticks[j].max);
    }
    out_flush();
    if (sh_close(out_fd) != 0 || out_failed) fail(QM_EXIT_IO, "cannot write m4_out.bin", 0u);
    (void)sh_close(in_fd);
    if (used >= m4_stack_size())
        fail(QM_EXIT_RUN, "stack overflow: bytes used", used);
    sh_exit(0);
    return 0;
}
