"""dkf.KalmanFilter against an independent numpy Kalman filter (conftest's
oracle_step) and against FilterPy's KalmanFilter, on random time-varying
models with fixed seeds.

Tolerance, relative to max(1, max|reference|): the filters compute the same
quantities in different orders (dkf: Joseph form with A = I - K H formed, a
Cholesky solve; the oracle: the short form and an LU solve; FilterPy: the
Joseph form and an inverse), so they differ by rounding only, O(n^2 eps
cond) per step with cond(S) < 1e2 (F = 0.95 * orthogonal, Q and R of
condition 5 and 3), and the differences do not accumulate (a stable
filter): 1e-10 in float64 (n <= 12: n^2 cond eps ~ 3e-12), 2e-5 in float32
(cond * n * eps / 4 at n = 12). These are tests/test_kf.c's bounds for the
same kind of models. The float32 oracle runs on the inputs rounded to
float32, the numbers the float core receives.
"""

import numpy as np
import pytest

from conftest import oracle_step, rand_model, rel_err

TOL = {np.float64: 1e-10, np.float32: 2e-5}
SIZES = [(1, 1), (2, 1), (4, 2), (6, 3), (8, 4), (12, 6), (5, 7)]


@pytest.mark.parametrize("n,m", SIZES)
def test_matches_numpy_oracle(mod, n, m):
    dkfm, dt = mod
    rng = np.random.default_rng(1000 + 31 * n + m)
    T = 40
    md = rand_model(rng, n, m, T)
    # the numbers the module computes with
    md = {k: v.astype(dt).astype(np.float64) for k, v in md.items()}
    kf = dkfm.KalmanFilter(F=md["F"][0], Q=md["Q"][0], H=md["H"][0], R=md["R"][0],
                           x0=md["x0"], P0=md["P0"])
    x, P = md["x0"], md["P0"]
    worst = 0.0
    for t in range(T):
        x, P = oracle_step(x, P, md["F"][t], md["Q"][t], md["H"][t], md["R"][t], md["Y"][t])
        kf.predict(F=md["F"][t], Q=md["Q"][t])
        kf.update(md["Y"][t], H=md["H"][t], R=md["R"][t])
        ex, eP = rel_err(kf.x, x), rel_err(kf.P, P)
        assert ex <= TOL[dt] and eP <= TOL[dt], (t, ex, eP)
        worst = max(worst, ex, eP)
    print(f"n={n} m={m} worst relative error {worst:.3e}")


def test_filter_matches_numpy_oracle_stacked(mod):
    dkfm, dt = mod
    rng = np.random.default_rng(77)
    n, m, T = 6, 3, 60
    md = {k: v.astype(dt).astype(np.float64) for k, v in rand_model(rng, n, m, T).items()}
    kf = dkfm.KalmanFilter(F=md["F"], Q=md["Q"], H=md["H"], R=md["R"], x0=md["x0"], P0=md["P0"])
    X, Ps = kf.filter(md["Y"])
    x, P = md["x0"], md["P0"]
    for t in range(T):
        x, P = oracle_step(x, P, md["F"][t], md["Q"][t], md["H"][t], md["R"][t], md["Y"][t])
        assert rel_err(X[t], x) <= TOL[dt], t
        assert rel_err(Ps[t], P) <= TOL[dt], t


@pytest.mark.parametrize("n,m", [(2, 1), (4, 2), (6, 3)])
def test_matches_filterpy(n, m):
    fp = pytest.importorskip("filterpy.kalman", reason="filterpy is not installed "
                             "(pip install filterpy): the FilterPy comparison is skipped")
    import dkf

    rng = np.random.default_rng(500 + n)
    T = 50
    md = rand_model(rng, n, m, T)
    ref = fp.KalmanFilter(dim_x=n, dim_z=m)
    ref.x = md["x0"].reshape(n, 1).copy()
    ref.P = md["P0"].copy()
    kf = dkf.KalmanFilter(F=md["F"][0], Q=md["Q"][0], H=md["H"][0], R=md["R"][0],
                          x0=md["x0"], P0=md["P0"])
    for t in range(T):
        ref.predict(F=md["F"][t], Q=md["Q"][t])
        ref.update(md["Y"][t].reshape(m, 1), R=md["R"][t], H=md["H"][t])
        kf.predict(F=md["F"][t], Q=md["Q"][t])
        kf.update(md["Y"][t], H=md["H"][t], R=md["R"][t])
        assert rel_err(kf.x, ref.x.reshape(-1)) <= TOL[np.float64], t
        assert rel_err(kf.P, ref.P) <= TOL[np.float64], t
