/*
 * The nonlinear model's shared services (dkf/nl_model.h): the table check,
 * Jacobians by callback or forward differences, and measurement
 * differences. Every result is formed in the caller's scratch and copied
 * out only once it is complete and finite.
 */
#include "dkf/nl_model.h"

#include <math.h>
#include <string.h>

#include "internal.h"
#include "kernels.h"

dkf_status_t dkf_nl_model_check(const dkf_nl_model_t *model)
{
    if (model == NULL || model->f == NULL || model->h == NULL) return DKF_ERR_NULL;
    if (model->n == 0 || model->m == 0 || model->n > DKF_MAX_DIM || model->m > DKF_MAX_DIM ||
        model->p > DKF_MAX_DIM || model->q > DKF_MAX_DIM)
        return DKF_ERR_CAPACITY;
    return DKF_OK;
}

void dkf_nl_y_diff(const dkf_nl_model_t *model, const dkf_real_t *a, const dkf_real_t *b,
                   dkf_real_t *out)
{
    size_t i;
    if (model->y_diff != NULL) {
        model->y_diff(model->ctx, a, b, out);
        return;
    }
    for (i = 0; i < model->m; ++i) out[i] = a[i] - b[i];
}

/* Which function a Jacobian is of: f (r = n outputs, plain differences) or
 * h (r = m outputs, differences through y_diff). */
typedef int (*nl_fun_t)(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                        const dkf_real_t *u, dkf_real_t *out);

/* The step for component v: DKF_NL_FD_STEP max(1, |v|), as the difference
 * of two representable numbers (so the quotient divides by the step
 * actually taken). */
static dkf_real_t fd_step(dkf_real_t v)
{
    const dkf_real_t a = v < 0 ? -v : v;
    const dkf_real_t moved = v + (dkf_real_t)DKF_NL_FD_STEP * (a > 1 ? a : (dkf_real_t)1);
    return moved - v;
}

/* Column j of J (r x c, row-major) = (fun(moved) - base) / step. */
static void fd_column(const dkf_nl_model_t *model, int is_h, dkf_real_t *J, size_t c, size_t j,
                      const dkf_real_t *moved_val, const dkf_real_t *base, dkf_real_t step,
                      dkf_real_t *tmp, size_t r)
{
    size_t i;
    if (is_h) dkf_nl_y_diff(model, moved_val, base, tmp);
    else
        for (i = 0; i < r; ++i) tmp[i] = moved_val[i] - base[i];
    for (i = 0; i < r; ++i) J[i * c + j] = tmp[i] / step;
}

/* Forward differences of fun at (x, d, u) into J = [Jx Jd] (r x (n + p)),
 * in work (2 r + n + p reals past J). */
static dkf_status_t fd_jacobian(const dkf_nl_model_t *model, nl_fun_t fun, int is_h, size_t k,
                                const dkf_real_t *x, const dkf_real_t *d, const dkf_real_t *u,
                                dkf_real_t *J, size_t r, dkf_real_t *work)
{
    const size_t n = model->n, p = model->p, c = n + p;
    dkf_real_t *base = work, *val = base + r, *xm = val + r, *dm = xm + n;
    size_t j;
    if (fun(model->ctx, k, x, d, u, base) != 0) return DKF_ERR_MODEL;
    if (!dkf__all_finite(base, r)) return DKF_ERR_NONFINITE;
    dkf__copy(xm, x, n);
    if (p > 0) dkf__copy(dm, d, p);
    for (j = 0; j < c; ++j) {
        dkf_real_t *v = j < n ? &xm[j] : &dm[j - n];
        const dkf_real_t v0 = *v, step = fd_step(v0);
        if (!(step > 0)) return DKF_ERR_NONFINITE; /* |v| near the largest real */
        *v = v0 + step;
        if (fun(model->ctx, k, xm, p > 0 ? dm : d, u, val) != 0) return DKF_ERR_MODEL;
        *v = v0;
        if (!dkf__all_finite(val, r)) return DKF_ERR_NONFINITE;
        /* val is free once the column is formed: it is the difference's scratch */
        fd_column(model, is_h, J, c, j, val, base, step, val, r);
    }
    return DKF_OK;
}

/* Splits J = [Jx Jd] (r x (n + p)) into Jx (r x n) and Jd (r x p). */
static void split_columns(const dkf_real_t *J, size_t r, size_t n, size_t p, dkf_real_t *Jx,
                          dkf_real_t *Jd)
{
    size_t i;
    for (i = 0; i < r; ++i) {
        dkf__copy(Jx + i * n, J + i * (n + p), n);
        if (p > 0) dkf__copy(Jd + i * p, J + i * (n + p) + n, p);
    }
}

/* The Jacobian of f (is_h = 0) or h (is_h = 1), by callback or forward
 * differences, formed in work and copied out when finite. */
static dkf_status_t jacobian(const dkf_nl_model_t *model, int is_h, size_t k, const dkf_real_t *x,
                             const dkf_real_t *d, const dkf_real_t *u, dkf_real_t *Jx,
                             dkf_real_t *Jd, dkf_real_t *work)
{
    size_t n, p, r;
    dkf_real_t *J;
    DKF_TRY(dkf_nl_model_check(model));
    if (x == NULL || Jx == NULL || work == NULL) return DKF_ERR_NULL;
    if (model->p > 0 && (d == NULL || Jd == NULL)) return DKF_ERR_NULL;
    if (model->q > 0 && u == NULL) return DKF_ERR_NULL;
    n = model->n;
    p = model->p;
    r = is_h ? model->m : n;
    J = work;
    if (!dkf__all_finite(x, n) || (p > 0 && !dkf__all_finite(d, p)) ||
        (model->q > 0 && !dkf__all_finite(u, model->q)))
        return DKF_ERR_NONFINITE;
    if ((is_h ? model->h_jac : model->f_jac) != NULL) {
        /* the callback writes Jx | Jd into the scratch, side by side */
        dkf_real_t *Jdx = J + r * n;
        const int rc = is_h ? model->h_jac(model->ctx, k, x, d, u, J, Jdx)
                            : model->f_jac(model->ctx, k, x, d, u, J, Jdx);
        if (rc != 0) return DKF_ERR_MODEL;
        if (!dkf__all_finite(J, r * (n + p))) return DKF_ERR_NONFINITE;
        dkf__copy(Jx, J, r * n);
        if (p > 0) dkf__copy(Jd, Jdx, r * p);
        return DKF_OK;
    }
    DKF_TRY(fd_jacobian(model, is_h ? model->h : model->f, is_h, k, x, d, u, J, r,
                        J + DKF_NL_R_(n, model->m) * (n + p)));
    split_columns(J, r, n, p, Jx, Jd);
    return DKF_OK;
}

dkf_status_t dkf_nl_f_jacobian(const dkf_nl_model_t *model, size_t k, const dkf_real_t *x,
                               const dkf_real_t *d, const dkf_real_t *u, dkf_real_t *Fx,
                               dkf_real_t *Fd, dkf_real_t *work)
{
    return jacobian(model, 0, k, x, d, u, Fx, Fd, work);
}

dkf_status_t dkf_nl_h_jacobian(const dkf_nl_model_t *model, size_t k, const dkf_real_t *x,
                               const dkf_real_t *d, const dkf_real_t *u, dkf_real_t *Hx,
                               dkf_real_t *Hd, dkf_real_t *work)
{
    return jacobian(model, 1, k, x, d, u, Hx, Hd, work);
}
