/*
 * m4_node.c - the node role of the emulated Cortex-M4F image (m4_node.h):
 * QEMU as a child process, the two named pipes, the frames of
 * ports/cortex-m4/live_main.c.
 */
#define _XOPEN_SOURCE 700 /* realpath; POSIX 2008: mkdtemp, O_CLOEXEC, nanosleep */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "dkf/status.h"
#include "live_frames.h" /* ports/cortex-m4 */
#include "m4_node.h"
#include "registry.h"
#include "sensor_model.h"


struct dkf_node_filter {
    const dkf_scenario_t *s;
    const dkf_m4_conf_t *conf;
    size_t id, n, m, p;
    dkf_sensor_model_t md;
    dkf_real_t *frame;       /* one start or step frame's reals */
    size_t frame_len;
    dkf_node_estimate_t est; /* the last message */
    pid_t qemu;              /* 0: not running */
    int in_fd, out_fd;
    char dir[64];            /* QEMU's working directory, the pipes' */
    char image[PATH_MAX];    /* conf->image, absolute */
    json_t *k, *xf, *xp;     /* every message */
    long stack_bytes;        /* -1 until the goodbye */
};

static void fail_msg(char *err, size_t errlen, const dkf_node_filter_t *nf, const char *fmt, ...)
{
    va_list ap;
    int len = snprintf(err, errlen, "node %zu (m4 image): ", nf->id);
    va_start(ap, fmt);
    if (len >= 0 && (size_t)len < errlen) vsnprintf(err + len, errlen - (size_t)len, fmt, ap);
    va_end(ap);
}

static int64_t mono_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (int64_t)t.tv_sec * 1000 + t.tv_nsec / 1000000;
}

static void sleep_ms(long ms)
{
    struct timespec t;
    t.tv_sec = ms / 1000;
    t.tv_nsec = (ms % 1000) * 1000000L;
    (void)nanosleep(&t, NULL);
}

static void path_of(char *out, size_t len, const dkf_node_filter_t *nf, const char *name)
{
    snprintf(out, len, "%s/%s", nf->dir, name);
}

/* "exited with status N" / "killed by signal N" of QEMU, once it has ended
 * (waits up to 2 s, then kills it); "" if it had not been started. */
static const char *qemu_end(dkf_node_filter_t *nf, char *buf, size_t len)
{
    int status = 0;
    int64_t t0 = mono_ms();
    buf[0] = '\0';
    if (nf->qemu <= 0) return buf;
    while (waitpid(nf->qemu, &status, WNOHANG) == 0) {
        if (mono_ms() - t0 > 2000) {
            kill(nf->qemu, SIGKILL);
            waitpid(nf->qemu, &status, 0);
            break;
        }
        sleep_ms(5);
    }
    nf->qemu = 0;
    if (WIFEXITED(status))
        snprintf(buf, len, "qemu-system-arm exited with status %d", WEXITSTATUS(status));
    else
        snprintf(buf, len, "qemu-system-arm killed by signal %d", WTERMSIG(status));
    return buf;
}

static void m4_destroy(dkf_node_filter_t *nf)
{
    char path[96], why[80];
    if (nf == NULL) return;
    if (nf->in_fd >= 0) close(nf->in_fd);
    if (nf->out_fd >= 0) close(nf->out_fd);
    if (nf->qemu > 0) {
        kill(nf->qemu, SIGTERM);
        (void)qemu_end(nf, why, sizeof why);
    }
    if (nf->dir[0] != '\0') {
        path_of(path, sizeof path, nf, LV_PIPE_IN);
        unlink(path);
        path_of(path, sizeof path, nf, LV_PIPE_OUT);
        unlink(path);
        rmdir(nf->dir);
    }
    json_decref(nf->k);
    json_decref(nf->xf);
    json_decref(nf->xp);
    dkf_sensor_model_free(&nf->md);
    free(nf->frame);
    free(nf);
}

static int write_all(dkf_node_filter_t *nf, const void *buf, size_t len, char *err, size_t errlen)
{
    const unsigned char *b = buf;
    char why[80];
    while (len > 0) {
        ssize_t w = write(nf->in_fd, b, len);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) {
            fail_msg(err, errlen, nf, "cannot write to the image (%s; %s)", strerror(errno),
                     qemu_end(nf, why, sizeof why));
            return -1;
        }
        b += w;
        len -= (size_t)w;
    }
    return 0;
}

/* Exactly len bytes of the image's answer within the timeout. */
static int read_all(dkf_node_filter_t *nf, void *buf, size_t len, char *err, size_t errlen)
{
    unsigned char *b = buf;
    const int64_t end = mono_ms() + (int64_t)(nf->conf->timeout_s * 1000.0);
    char why[80];
    while (len > 0) {
        struct pollfd pf;
        const int64_t left = end - mono_ms();
        ssize_t r;
        int rc;
        pf.fd = nf->out_fd;
        pf.events = POLLIN;
        rc = left > 0 ? poll(&pf, 1, (int)left) : 0;
        if (rc < 0 && errno == EINTR) continue;
        if (rc == 0) {
            fail_msg(err, errlen, nf, "no answer within %g s", nf->conf->timeout_s);
            return -1;
        }
        r = read(nf->out_fd, b, len);
        if (r < 0 && (errno == EINTR || errno == EAGAIN)) continue;
        if (r <= 0) {
            fail_msg(err, errlen, nf, "the image ended (%s; its console line is above)",
                     qemu_end(nf, why, sizeof why));
            return -1;
        }
        b += r;
        len -= (size_t)r;
    }
    return 0;
}

/* The head of the image's next answer, which must be of `kind` for step k
 * with value `value` (kind 4: any value, into *got). */
static int expect(dkf_node_filter_t *nf, uint32_t kind, uint32_t k, uint32_t value,
                  uint32_t *got, char *err, size_t errlen)
{
    uint32_t h[4];
    if (read_all(nf, h, sizeof h, err, errlen) != 0) return -1;
    if (h[0] != LV_MAGIC_OUT) {
        fail_msg(err, errlen, nf, "an answer without the magic DKM1");
        return -1;
    }
    if (h[1] == LV_OUT_REFUSED) {
        if (h[3] != 0u)
            fail_msg(err, errlen, nf, "step k=%u: a filter call failed: %s (%u)", h[2],
                     dkf_status_str((dkf_status_t)h[3]), h[3]);
        else
            fail_msg(err, errlen, nf, "the image refused a frame (its console line is above)");
        return -1;
    }
    if (h[1] != kind || h[2] != k || (kind != LV_OUT_BYE && h[3] != value)) {
        fail_msg(err, errlen, nf, "answer kind %u, k=%u, value %u; expected kind %u, k=%u", h[1],
                 h[2], h[3], kind, k);
        return -1;
    }
    if (got != NULL) *got = h[3];
    return 0;
}

/* QEMU in nf->dir on the image, its console on our stderr. */
static int spawn(dkf_node_filter_t *nf, char *err, size_t errlen)
{
    const char *argv[] = {nf->conf->qemu, "-M", "mps2-an386", "-display", "none", "-monitor",
                          "none", "-serial", "none", "-semihosting-config",
                          "enable=on,target=native", "-kernel", nf->image, NULL};
    pid_t pid = fork();
    if (pid < 0) {
        fail_msg(err, errlen, nf, "fork: %s", strerror(errno));
        return -1;
    }
    if (pid == 0) {
        if (chdir(nf->dir) != 0 || dup2(2, 1) < 0) _exit(127);
        execvp(argv[0], (char *const *)argv);
        fprintf(stderr, "dkf-m4-bridge: %s: %s\n", argv[0], strerror(errno));
        _exit(127);
    }
    nf->qemu = pid;
    return 0;
}

/* The pipes, both ends open: the image opens m4_live.in, then m4_live.out. */
static int connect_pipes(dkf_node_filter_t *nf, char *err, size_t errlen)
{
    char in[96], out[96], why[80];
    const int64_t end = mono_ms() + (int64_t)(nf->conf->timeout_s * 1000.0);
    int status;
    path_of(in, sizeof in, nf, LV_PIPE_IN);
    path_of(out, sizeof out, nf, LV_PIPE_OUT);
    /* non-blocking: fails (ENXIO) until the image has the reading end */
    while ((nf->in_fd = open(in, O_WRONLY | O_NONBLOCK | O_CLOEXEC)) < 0) {
        if (errno != ENXIO) {
            fail_msg(err, errlen, nf, "%s: %s", in, strerror(errno));
            return -1;
        }
        if (waitpid(nf->qemu, &status, WNOHANG) == nf->qemu) {
            nf->qemu = 0;
            fail_msg(err, errlen, nf, "qemu-system-arm ended before opening its input (status "
                     "%d; is %s a dkf_m4_live image?)", WIFEXITED(status) ? WEXITSTATUS(status) : -1,
                     nf->image);
            return -1;
        }
        if (mono_ms() > end) {
            fail_msg(err, errlen, nf, "the image did not open its input within %g s (%s)",
                     nf->conf->timeout_s, qemu_end(nf, why, sizeof why));
            return -1;
        }
        sleep_ms(2);
    }
    if (fcntl(nf->in_fd, F_SETFL, 0) != 0 ||
        (nf->out_fd = open(out, O_RDONLY | O_NONBLOCK | O_CLOEXEC)) < 0) {
        fail_msg(err, errlen, nf, "%s: %s", out, strerror(errno));
        return -1;
    }
    return 0;
}

/* The header: "DKL1", bytes per real, n, m, p, x00, P00_local[id]. */
static int send_header(dkf_node_filter_t *nf, char *err, size_t errlen)
{
    const size_t n = nf->n;
    uint32_t h[5];
    dkf_real_t *v = calloc(n + n * n, sizeof *v);
    int rc;
    if (v == NULL) {
        fail_msg(err, errlen, nf, "out of memory");
        return -1;
    }
    h[0] = LV_MAGIC_IN;
    h[1] = (uint32_t)sizeof(dkf_real_t);
    h[2] = (uint32_t)n;
    h[3] = (uint32_t)nf->m;
    h[4] = (uint32_t)nf->p;
    dkf_scn_to_real(v, dkf_scn_at(dkf_scn_init(nf->s, "x00"), 0), n);
    dkf_scn_to_real(v + n, dkf_scn_P00_local(nf->s, nf->id), n * n);
    rc = write_all(nf, h, sizeof h, err, errlen) ||
         write_all(nf, v, (n + n * n) * sizeof *v, err, errlen) ||
         expect(nf, LV_OUT_READY, 0u, h[2], NULL, err, errlen);
    free(v);
    return rc ? -1 : 0;
}

static dkf_node_filter_t *m4_create(const dkf_filter_t *f, const dkf_scenario_t *s, size_t id,
                                    char *err, size_t errlen)
{
    dkf_node_filter_t *nf = calloc(1, sizeof *nf);
    char in[96], out[96];
    if (nf == NULL) {
        snprintf(err, errlen, "node %zu: out of memory", id);
        return NULL;
    }
    nf->in_fd = nf->out_fd = -1;
    nf->s = s;
    nf->conf = f->impl;
    nf->id = id;
    nf->stack_bytes = -1;
    nf->k = json_array();
    nf->xf = json_array();
    nf->xp = json_array();
    if (dkf_sensor_model_init(&nf->md, s, id) != 0 || nf->k == NULL || nf->xf == NULL ||
        nf->xp == NULL) {
        fail_msg(err, errlen, nf, "out of memory");
        m4_destroy(nf);
        return NULL;
    }
    nf->n = s->n;
    nf->m = nf->md.m;
    nf->p = nf->md.p;
    nf->frame_len = 2 * nf->n * nf->n + 2 * nf->p * nf->p + nf->m * nf->n + nf->m * nf->m +
                    nf->m * nf->p + nf->m;
    nf->frame = calloc(nf->frame_len, sizeof *nf->frame);
    if (realpath(nf->conf->image, nf->image) == NULL) {
        fail_msg(err, errlen, nf, "%s: %s", nf->conf->image, strerror(errno));
        m4_destroy(nf);
        return NULL;
    }
    snprintf(nf->dir, sizeof nf->dir, "/tmp/dkf-m4-XXXXXX");
    if (nf->frame == NULL || mkdtemp(nf->dir) == NULL) {
        fail_msg(err, errlen, nf, "%s", nf->frame == NULL ? "out of memory" : strerror(errno));
        nf->dir[0] = '\0';
        m4_destroy(nf);
        return NULL;
    }
    path_of(in, sizeof in, nf, LV_PIPE_IN);
    path_of(out, sizeof out, nf, LV_PIPE_OUT);
    /* a dead image must be an error of write(), not the end of the bridge */
    signal(SIGPIPE, SIG_IGN);
    if (mkfifo(in, 0600) != 0 || mkfifo(out, 0600) != 0) {
        fail_msg(err, errlen, nf, "mkfifo in %s: %s", nf->dir, strerror(errno));
        m4_destroy(nf);
        return NULL;
    }
    if (spawn(nf, err, errlen) != 0 || connect_pipes(nf, err, errlen) != 0 ||
        send_header(nf, err, errlen) != 0) {
        m4_destroy(nf);
        return NULL;
    }
    ((dkf_m4_conf_t *)nf->conf)->live = nf;
    return nf;
}

static void put(dkf_real_t **at, const dkf_mat_t *A)
{
    memcpy(*at, A->data, A->rows * A->cols * sizeof **at);
    *at += A->rows * A->cols;
}

/* Sends a frame: the dynamics at kd, the sensor model at km, y. */
static int send_frame(dkf_node_filter_t *nf, uint32_t kind, long k, size_t kd, size_t km,
                      const double *y, char *err, size_t errlen)
{
    dkf_real_t *at = nf->frame;
    uint32_t h[3];
    if (dkf_sensor_model_dyn(&nf->md, nf->s, nf->id, kd) != 0 ||
        dkf_sensor_model_meas(&nf->md, nf->s, nf->id, km) != 0) {
        fail_msg(err, errlen, nf, "the scenario has no model for step k=%ld", k);
        return -1;
    }
    put(&at, &nf->md.F);
    put(&at, &nf->md.Q);
    put(&at, &nf->md.B);
    put(&at, &nf->md.Rd);
    put(&at, &nf->md.H);
    put(&at, &nf->md.R);
    put(&at, &nf->md.D);
    dkf_scn_to_real(at, y, nf->m);
    h[0] = kind;
    h[1] = (uint32_t)k;
    h[2] = (uint32_t)(nf->frame_len * sizeof *nf->frame);
    return write_all(nf, h, sizeof h, err, errlen) ||
                   write_all(nf, nf->frame, nf->frame_len * sizeof *nf->frame, err, errlen)
               ? -1
               : 0;
}

/* (Re)start at k0: the dynamics at 0, the model at k0, y_{k0} (as
 * est_diffkf_node.c's start). */
static int m4_start(dkf_node_filter_t *nf, long k0, const double *y, char *err, size_t errlen)
{
    if (send_frame(nf, LV_IN_START, k0, 0, (size_t)k0, y, err, errlen) != 0 ||
        expect(nf, LV_OUT_STARTED, (uint32_t)k0, (uint32_t)nf->n, NULL, err, errlen) != 0)
        return DKF_EXIT_RUN;
    return DKF_EXIT_OK;
}

static json_t *reals_json(const dkf_real_t *v, size_t n)
{
    json_t *a = json_array();
    size_t i;
    for (i = 0; a != NULL && i < n; ++i) json_array_append_new(a, json_real((double)v[i]));
    return a;
}

/* Step k: the dynamics at k, the model at k+1, y_{k+1}; the answer is the
 * message of step k. */
static int m4_step(dkf_node_filter_t *nf, long k, const double *y, char *err, size_t errlen)
{
    dkf_real_t v[2 * DKF_MAX_DIM];
    const size_t n = nf->n;
    if (send_frame(nf, LV_IN_STEP, k, (size_t)k, (size_t)k + 1, y, err, errlen) != 0 ||
        expect(nf, LV_OUT_MSG, (uint32_t)k, (uint32_t)n, NULL, err, errlen) != 0 ||
        read_all(nf, v, 2 * n * sizeof v[0], err, errlen) != 0)
        return DKF_EXIT_RUN;
    memset(&nf->est, 0, sizeof nf->est);
    nf->est.k = (uint32_t)k;
    nf->est.n = (uint16_t)n;
    memcpy(nf->est.xf, v, n * sizeof v[0]);
    memcpy(nf->est.xp, v + n, n * sizeof v[0]);
    json_array_append_new(nf->k, json_integer(k));
    json_array_append_new(nf->xf, reals_json(nf->est.xf, n));
    json_array_append_new(nf->xp, reals_json(nf->est.xp, n));
    return DKF_EXIT_OK;
}

static int m4_payload(const dkf_node_filter_t *nf, dkf_node_estimate_t *est)
{
    if (nf->est.k == 0) return -1;
    *est = nf->est;
    return 0;
}

int dkf_m4_node_finish(dkf_node_filter_t *nf, char *err, size_t errlen)
{
    const uint32_t h[3] = {LV_IN_END, nf->est.k, 0u};
    uint32_t stack = 0;
    char why[80];
    if (write_all(nf, h, sizeof h, err, errlen) != 0 ||
        expect(nf, LV_OUT_BYE, nf->est.k, 0u, &stack, err, errlen) != 0)
        return -1;
    nf->stack_bytes = (long)stack;
    if (strcmp(qemu_end(nf, why, sizeof why), "qemu-system-arm exited with status 0") != 0) {
        fail_msg(err, errlen, nf, "after the end frame: %s", why);
        return -1;
    }
    return 0;
}

json_t *dkf_m4_node_json(const dkf_node_filter_t *nf)
{
    return json_pack("{sOsOsOso}", "k", nf->k, "xf", nf->xf, "xp", nf->xp, "stack_bytes",
                     nf->stack_bytes >= 0 ? json_integer(nf->stack_bytes) : json_null());
}

static const dkf_node_ops_t m4_node_ops = {
    m4_create, m4_start, m4_step, m4_payload, m4_destroy, 0,
};

void dkf_m4_filter(dkf_m4_conf_t *conf, dkf_family_t *fam, dkf_filter_t *f)
{
    const dkf_filter_t *dkf = dkf_registry_find("dkf");
    *fam = *dkf->family;
    fam->node = &m4_node_ops;
    *f = *dkf;
    f->name = "m4";
    f->family = fam;
    f->impl = conf;
}
