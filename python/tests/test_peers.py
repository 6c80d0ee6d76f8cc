"""dkf against other libraries that compute the same filters, on random
models with fixed seeds: FilterPy's KalmanFilter, InformationFilter and
CubatureKalmanFilter, and Stone Soup's Kalman predictor and updater. Each
comparison is skipped, with the reason, where its library is not
installed (FilterPy is in the test command's venv; Stone Soup is optional).

Where they agree they differ by rounding only (the tolerances of
test_kf_oracle.py: 1e-10 relative to max(1, max|reference|) for these
well-conditioned models). Where they differ:

* FilterPy's CubatureKalmanFilter evaluates h at the points it propagated
  through f (`sigmas_f`), whose spread is the prediction's before Q is
  added, so its Pxz and Pzz miss Q; dkf's cubature filters (dkf/nerts.h,
  eqs 43-47) draw the 2n points afresh from N(x_pred, P_pred), P_pred
  including Q. A numpy oracle of each variant shows which is which: dkf
  equals the re-drawn one, FilterPy the propagated one, and the two differ
  by an amount that grows with Q.
* A missing measurement: FilterPy's update(None) and dkf's all-NaN y are
  the same skipped update; a partly missing y has no FilterPy form (dkf
  updates with the measured components).
* FilterPy's InformationFilter needs F invertible (it predicts through
  F^-1); dkf's does not. On invertible F they agree. Its likelihood must
  be switched off: it evaluates the innovation (m) under the n x n
  posterior information and fails for m != n.
"""

import numpy as np
import pytest

import dkf
from conftest import rand_model, rand_spd, rel_err

TOL = 1e-10


def filterpy():
    return pytest.importorskip("filterpy.kalman", reason="filterpy is not installed (pip "
                               "install filterpy): the FilterPy comparisons are skipped")


# ---- the Kalman filter -------------------------------------------------------


@pytest.mark.parametrize("n,m", [(3, 2), (6, 4)])
def test_kalman_filter_with_control_and_gaps_matches_filterpy(n, m):
    """A time-invariant model with a known input B u and every fifth
    measurement missing (FilterPy: update(None); dkf: an all-NaN y)."""
    fp = filterpy()
    rng = np.random.default_rng(40 + n)
    md = rand_model(rng, n, m, 1)
    F, Q, H, R = md["F"][0], md["Q"][0], md["H"][0], md["R"][0]
    B = rng.normal(size=(n, 2))
    ref = fp.KalmanFilter(dim_x=n, dim_z=m, dim_u=2)
    ref.x, ref.P = md["x0"].reshape(n, 1).copy(), md["P0"].copy()
    ref.F, ref.Q, ref.H, ref.R, ref.B = F, Q, H, R, B
    kf = dkf.KalmanFilter(F=F, Q=Q, H=H, R=R, x0=md["x0"], P0=md["P0"])
    for t in range(60):
        u, y = rng.normal(size=2), rng.normal(size=m)
        ref.predict(u=u.reshape(2, 1))
        kf.predict(u=B @ u)
        if t % 5 == 4:
            ref.update(None)
            kf.update(np.full(m, np.nan))
        else:
            ref.update(y.reshape(m, 1))
            kf.update(y)
        assert rel_err(kf.x, ref.x.reshape(-1)) <= TOL, t
        assert rel_err(kf.P, ref.P) <= TOL, t


def test_information_filter_matches_filterpy():
    fp = filterpy()
    rng = np.random.default_rng(41)
    n, m, T = 4, 3, 50
    md = rand_model(rng, n, m, 1)
    F, Q, H, R = md["F"][0], md["Q"][0], md["H"][0], md["R"][0]
    ref = fp.InformationFilter(dim_x=n, dim_z=m)
    ref.x = md["x0"].reshape(n, 1).copy()
    ref.P_inv = np.linalg.inv(md["P0"])
    ref.F, ref.Q, ref.H, ref.R_inv = F, Q, H, np.linalg.inv(R)
    # its likelihood takes the n x n information for the m x m innovation
    # covariance and fails for m != n
    ref.compute_log_likelihood = False
    f = dkf.InformationFilter(F=F, Q=Q, x0=md["x0"], P0=md["P0"])
    for t in range(T):
        z = rng.normal(size=m)
        ref.predict()
        ref.update(z.reshape(m, 1))
        f.predict()
        f.update(z, H=H, R=R)
        assert rel_err(f.x, ref.x.reshape(-1)) <= TOL, t
        assert rel_err(f.Y, ref.P_inv) <= TOL, t


# ---- the cubature filter -------------------------------------------------------

N_X, N_Z = 4, 2


def ckf_model(seed, linear=False):
    """f(x) = F x + 0.1 sin(x), h(x) = (x_0 x_1 / 4 + x_2, sin(x_3) + x_0),
    or with linear, f(x) = F x, h(x) = H x; F = 0.95 orthogonal, H random."""
    rng = np.random.default_rng(seed)
    F = 0.95 * np.linalg.qr(rng.normal(size=(N_X, N_X)))[0]
    H = rng.normal(size=(N_Z, N_X))
    if linear:
        return (lambda x: F @ x), (lambda x: H @ x), F, H, rng

    def f(x):
        return F @ x + 0.1 * np.sin(x)

    def h(x):
        return np.array([x[0] * x[1] / 4 + x[2], np.sin(x[3]) + x[0]])

    return f, h, F, H, rng


def points(x, P):
    """The 2n cubature points of N(x, P): x +- sqrt(n) times the columns of
    P's lower Cholesky factor."""
    L = np.linalg.cholesky(P) * np.sqrt(len(x))
    return np.concatenate([x + L.T, x - L.T])


def ckf_oracle_step(x, P, z, f, h, Q, R, redraw):
    """One cubature step in numpy; redraw: h at points drawn afresh from
    (x_pred, P_pred) (dkf, eqs 43-47), else at the propagated points
    (FilterPy)."""
    Xf = np.array([f(p) for p in points(x, P)])
    x_pred = Xf.mean(axis=0)
    P_pred = (Xf - x_pred).T @ (Xf - x_pred) / len(Xf) + Q
    Xh = points(x_pred, P_pred) if redraw else Xf
    Zh = np.array([h(p) for p in Xh])
    z_hat = Zh.mean(axis=0)
    Pzz = (Zh - z_hat).T @ (Zh - z_hat) / len(Zh) + R
    Pxz = (Xh - Xh.mean(axis=0)).T @ (Zh - z_hat) / len(Zh)
    K = Pxz @ np.linalg.inv(Pzz)
    return x_pred + K @ (z - z_hat), P_pred - K @ Pzz @ K.T


def ckf_run(q_scale, seed, linear, T=30):
    """dkf's plain cubature filter (DNERTSF with p = 0), FilterPy's CKF,
    both numpy oracles and (linear) dkf's Kalman filter on one measurement
    series. The worst relative differences (x and P) of dkf to the re-drawn
    oracle, of FilterPy to the propagated oracle, of FilterPy to dkf, and
    (linear) of dkf's CKF to its Kalman filter."""
    fp = filterpy()
    f, h, F, H, rng = ckf_model(seed, linear)
    x0, P0, R = rng.normal(size=N_X), rand_spd(rng, N_X, 5.0, 0.5), rand_spd(rng, N_Z, 3.0, 0.1)
    Q = q_scale * rand_spd(rng, N_X, 4.0, 1.0)
    model = dkf.NLModel(lambda x, d, u: f(x), lambda x, d, u: h(x), n=N_X, m=N_Z, p=0)
    ckf = dkf.NERTS(model, x0, P0, kind="DNERTSF")
    kf = dkf.KalmanFilter(F=F, Q=Q, H=H, R=R, x0=x0, P0=P0)
    ref = fp.CubatureKalmanFilter(dim_x=N_X, dim_z=N_Z, dt=1.0, hx=h, fx=lambda x, dt: f(x))
    ref.x, ref.P, ref.Q, ref.R = x0.copy(), P0.copy(), Q, R
    xr, Pr, xp, Pp = x0, P0, x0, P0
    worst = np.zeros(4)
    for t in range(T):
        z = h(xr) + rng.normal(size=N_Z) * 0.3
        ckf.step(z, Q=Q, R=R)
        ref.predict()
        ref.update(z.reshape(N_Z, 1))  # FilterPy's x is a column after predict()
        kf.predict()
        kf.update(z)
        xr, Pr = ckf_oracle_step(xr, Pr, z, f, h, Q, R, redraw=True)
        xp, Pp = ckf_oracle_step(xp, Pp, z, f, h, Q, R, redraw=False)
        fx = ref.x.reshape(-1)
        worst = np.maximum(worst, [
            max(rel_err(ckf.x, xr), rel_err(ckf.Px, Pr)),
            max(rel_err(fx, xp), rel_err(ref.P, Pp)),
            max(rel_err(fx, ckf.x), rel_err(ref.P, ckf.Px)),
            max(rel_err(ckf.x, kf.x), rel_err(ckf.Px, kf.P)) if linear else 0.0,
        ])
    return worst


@pytest.mark.parametrize("q", [1e-4, 1e-2, 1.0])
def test_cubature_filter_redraws_its_points_filterpy_does_not(q):
    """A nonlinear model: dkf equals the re-drawn oracle, FilterPy the
    propagated one, to rounding; the two filters differ."""
    dkf_vs_redrawn, fp_vs_propagated, fp_vs_dkf, _ = ckf_run(q, 60, linear=False)
    assert dkf_vs_redrawn <= 1e-12 and fp_vs_propagated <= 1e-12, q
    assert fp_vs_dkf > 1e-3


def test_filterpy_cubature_filter_misses_q():
    """A linear model, where a cubature filter that draws its points from
    the prediction is the Kalman filter: dkf's is (to rounding) at every Q;
    FilterPy's equals it with Q = 0 and departs from it as Q grows, by its
    missing Q in Pxz and Pzz."""
    rows = [(q, *ckf_run(q, 61, linear=True)) for q in (0.0, 1e-4, 1e-2, 1.0)]
    for q, redrawn, propagated, fp_vs_dkf, ckf_vs_kf in rows:
        print(f"Q scale {q:g}: dkf CKF vs dkf KF {ckf_vs_kf:.1e}, FilterPy CKF vs dkf CKF "
              f"{fp_vs_dkf:.1e} (oracles {redrawn:.1e}, {propagated:.1e})")
        assert ckf_vs_kf <= TOL and redrawn <= 1e-12 and propagated <= 1e-12, q
    gaps = [r[3] for r in rows]
    assert gaps[0] <= TOL, gaps
    assert all(a < b for a, b in zip(gaps, gaps[1:])) and gaps[-1] > 1e-2, gaps


def test_cubature_filter_forms_agree():
    """DNERTSIF and a one-node DF-CKF (DFNERTS with p = 0, W = [[1]])
    compute the same plain cubature filter as DNERTSF."""
    f, h, _, _, rng = ckf_model(62)
    x0, P0, R = rng.normal(size=N_X), rand_spd(rng, N_X, 5.0, 0.5), rand_spd(rng, N_Z, 3.0, 0.1)
    Q = 0.01 * np.eye(N_X)
    model = dkf.NLModel(lambda x, d, u: f(x), lambda x, d, u: h(x), n=N_X, m=N_Z, p=0)
    Z = np.array([h(x0) + rng.normal(size=N_Z) * 0.3 for _ in range(20)])
    X, P, D, _ = dkf.NERTS(model, x0, P0, kind="DNERTSF").filter(Z, Q=Q, R=R)
    Xi, Pi, _, _ = dkf.NERTS(model, x0, P0, kind="DNERTSIF").filter(Z, Q=Q, R=R)
    net = dkf.DFNERTS([model], x0, P0, adjacency=np.zeros((1, 1)))
    Xn, Pn, Dn, _ = net.filter([Z], Q=Q, R=[R], W=np.ones((1, 1)), Tp=1)
    assert D.shape == (19, 0) and Dn.shape == (19, 1, 0)
    assert rel_err(Xi, X) <= TOL and rel_err(Pi, P) <= TOL
    assert rel_err(Xn[:, 0], X) <= TOL and rel_err(Pn[:, 0], P) <= TOL


# ---- Stone Soup ----------------------------------------------------------------


def test_kalman_filter_matches_stone_soup():
    """Stone Soup's KalmanPredictor and KalmanUpdater on a linear-Gaussian
    model: a constant-velocity transition (its CombinedLinearGaussian of
    ConstantVelocity) and a position measurement (LinearGaussian)."""
    pytest.importorskip("stonesoup", reason="stonesoup is not installed (pip install "
                        "stonesoup): the Stone Soup comparison is skipped")
    from datetime import datetime, timedelta

    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import KalmanUpdater

    rng = np.random.default_rng(42)
    trans = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05), ConstantVelocity(0.1)])
    meas = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.diag([0.25, 0.5]))
    t0, dt = datetime(2026, 1, 1), timedelta(seconds=1)
    F, Q = trans.matrix(time_interval=dt), trans.covar(time_interval=dt)
    H, R = meas.matrix(), meas.covar()
    x0, P0 = rng.normal(size=4), np.diag([1.0, 0.1, 1.0, 0.1])
    state = GaussianState(x0.reshape(4, 1), P0, timestamp=t0)
    predictor, updater = KalmanPredictor(trans), KalmanUpdater(meas)
    kf = dkf.KalmanFilter(F=F, Q=Q, H=H, R=R, x0=x0, P0=P0)
    for k in range(1, 40):
        y = rng.normal(size=2) + [k, -k]
        pred = predictor.predict(state, timestamp=t0 + k * dt)
        det = Detection(y.reshape(2, 1), timestamp=pred.timestamp, measurement_model=meas)
        state = updater.update(SingleHypothesis(pred, det))
        kf.predict()
        kf.update(y)
        assert rel_err(kf.x, np.asarray(state.state_vector, float).reshape(-1)) <= TOL, k
        assert rel_err(kf.P, np.asarray(state.covar, float)) <= TOL, k
