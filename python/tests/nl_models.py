"""The seed-001 test models of the Python tests, written from the vector
files' `equations` texts as numpy callables: lin_x_sin_d (nertsif.json)
and the constant-turn radar (dnertsif_single.json, df_dnertsif.json),
each with analytic Jacobians."""

import numpy as np


def lxs_model(mod, model, jacobians=True):
    """f(x, d) = A x + b sin(d), g(x, d) = C x + H d."""
    A, b = np.array(model["A"], float), np.array(model["b"], float)
    C, H = np.array(model["C"], float), np.array(model["H"], float)
    n, m, p = A.shape[0], C.shape[0], H.shape[1]
    B = b.reshape(n, p)
    f = lambda x, d, u: A @ x + B @ np.sin(d)  # noqa: E731
    h = lambda x, d, u: C @ x + H @ d  # noqa: E731
    fj = (lambda x, d, u: (A, B * np.cos(d))) if jacobians else None
    hj = (lambda x, d, u: (C, H)) if jacobians else None
    return mod.NLModel(f, h, n=n, m=m, p=p, f_jac=fj, h_jac=hj)


def ct(w, x):
    """F_CT(w) x, T = 1 (eq 62)."""
    s, c = np.sin(w), np.cos(w)
    a, b = (s / w, (1 - c) / w) if abs(w) > 1e-12 else (1.0, 0.0)
    return np.array([x[0] + a * x[1] - b * x[3], c * x[1] - s * x[3],
                     x[2] + b * x[1] + a * x[3], s * x[1] + c * x[3]])


def radar_h(xy, x, d):
    """Range, bearing (and 10 omega with d) of the sensors at xy (k, 2)."""
    out = []
    for sx, sy in xy:
        dx, dy = x[0] - sx, x[2] - sy
        out += [np.hypot(dx, dy), np.arctan2(dy, dx)] + ([10.0 * d[0]] if len(d) else [])
    return np.array(out)


def radar_model(mod, xy, omega_fixed=None):
    """The radar at the points xy (one (2,) or several (k, 2): stacked),
    d = [omega] (p = 1), or p = 0 with the turn rate fixed (DF-CKF)."""
    xy = np.atleast_2d(np.array(xy, float))
    p = 0 if omega_fixed is not None else 1
    f = (lambda x, d, u: ct(omega_fixed, x)) if p == 0 else (lambda x, d, u: ct(d[0], x))  # noqa
    per = 3 if p else 2
    return mod.NLModel(f, lambda x, d, u: radar_h(xy, x, d), n=4, m=per * len(xy), p=p,
                       angles=[per * j + 1 for j in range(len(xy))])
