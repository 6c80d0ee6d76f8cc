/*
 * The stacked sensor model of the centralised filter CF-DNERTSF
 * (dkf/nerts.h, dkf_nerts_stack): z = [z_1; ...; z_l] of l sensor models
 * of one system, the measurement whose DNERTSF is seed 001's centralised
 * fusion filter (section 4.2, eq 3).
 */
#include "dkf/nerts.h"

#include "internal.h"

static const dkf_nl_model_t *first(const void *ctx)
{
    return ((const dkf_nerts_stack_t *)ctx)->sensors;
}

static int stack_f(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                   const dkf_real_t *u, dkf_real_t *x_next)
{
    const dkf_nl_model_t *s = first(ctx);
    return s->f(s->ctx, k, x, d, u, x_next);
}

static int stack_f_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                       const dkf_real_t *u, dkf_real_t *Fx, dkf_real_t *Fd)
{
    const dkf_nl_model_t *s = first(ctx);
    return s->f_jac(s->ctx, k, x, d, u, Fx, Fd);
}

/* Sensor j writes rows off .. off + m_j - 1 of y, Hx (n columns) and Hd
 * (p columns): row-major blocks one under the other. */
static int stack_h(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                   const dkf_real_t *u, dkf_real_t *y)
{
    const dkf_nerts_stack_t *st = ctx;
    size_t j, off = 0;
    for (j = 0; j < st->count; ++j) {
        const dkf_nl_model_t *s = &st->sensors[j];
        if (s->h(s->ctx, k, x, d, u, y + off) != 0) return 1;
        off += s->m;
    }
    return 0;
}

static int stack_h_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                       const dkf_real_t *u, dkf_real_t *Hx, dkf_real_t *Hd)
{
    const dkf_nerts_stack_t *st = ctx;
    size_t j, off = 0;
    for (j = 0; j < st->count; ++j) {
        const dkf_nl_model_t *s = &st->sensors[j];
        if (s->h_jac(s->ctx, k, x, d, u, Hx + off * s->n, Hd + off * s->p) != 0) return 1;
        off += s->m;
    }
    return 0;
}

static void stack_y_diff(void *ctx, const dkf_real_t *a, const dkf_real_t *b, dkf_real_t *out)
{
    const dkf_nerts_stack_t *st = ctx;
    size_t j, off = 0;
    for (j = 0; j < st->count; ++j) {
        dkf_nl_y_diff(&st->sensors[j], a + off, b + off, out + off);
        off += st->sensors[j].m;
    }
}

dkf_status_t dkf_nerts_stack(dkf_nl_model_t *out, dkf_nerts_stack_t *st,
                             const dkf_nl_model_t *sensors, size_t count)
{
    dkf_nl_model_t g;
    size_t j, m = 0;
    int all_jac = 1, any_diff = 0;
    DKF_CHECK_NULL(out);
    DKF_CHECK_NULL(st);
    DKF_CHECK_NULL(sensors);
    if (count == 0 || count > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    for (j = 0; j < count; ++j) {
        const dkf_nl_model_t *s = &sensors[j];
        DKF_TRY(dkf_nl_model_check(s));
        if (s->n != sensors[0].n || s->p != sensors[0].p || s->q != sensors[0].q)
            return DKF_ERR_DIM;
        m += s->m;
        if (m > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
        all_jac = all_jac && s->h_jac != NULL;
        any_diff = any_diff || s->y_diff != NULL;
    }
    st->sensors = sensors;
    st->count = count;
    g.ctx = st;
    g.n = sensors[0].n;
    g.m = m;
    g.p = sensors[0].p;
    g.q = sensors[0].q;
    g.f = stack_f;
    g.h = stack_h;
    g.f_jac = sensors[0].f_jac != NULL ? stack_f_jac : NULL;
    g.h_jac = all_jac ? stack_h_jac : NULL;
    g.y_diff = any_diff ? stack_y_diff : NULL;
    *out = g;
    return DKF_OK;
}
