"""dkf.InformationFilter and dkf.info_contribution (dkf/info.h): the seed-001
linear golden vector (tests/test_info.c's), equality with the Kalman filter
on the stacked measurement, filter() against its loop bit for bit, and
failures that leave the filter as it was."""

import numpy as np
import pytest

import dkf
from conftest import load_vector, rand_model, rand_spd, rel_err, same_bits

# The C test's tolerances on the vector (tests/test_info.c): the file's rule
# rtol 1e-8 in double; float: cond(Y) ~ 30 and n = 4, an inversion costs
# ~cond * n * eps ~ 1.4e-5 relative and the filter forgets: 2e-5.
VEC_TOL = {np.float64: 1e-8, np.float32: 2e-5}
# Information fusion against the stacked-measurement KF (test_info.c): the
# same algebra, rounding in two different inversions, cond(P) < 1e2:
# 1e-9 in double, 1e-4 ~ cond * n * eps in float.
KF_TOL = {np.float64: 1e-9, np.float32: 1e-4}


def lif():
    c = load_vector("infofusion/lif_central_fusion.json")["cases"][0]
    assert len(c["steps"]) == 30
    return c


def arr(v):
    return np.array(v, dtype=np.float64)


def test_step_by_step_matches_lif_vector(mod):
    m, dt = mod
    c = lif()
    H, R = [arr(h) for h in c["H"]], [arr(r) for r in c["R"]]
    f = m.InformationFilter(F=arr(c["steps"][0]["F"]), Q=arr(c["Q"]), x0=arr(c["x0"]),
                            P0=arr(c["P0"]))
    tol = VEC_TOL[dt]
    for t, st in enumerate(c["steps"]):
        e = st["expected"]
        f.predict(F=arr(st["F"]))
        for name, got in (("x_pred", f.x), ("P_pred", f.P), ("Y_pred", f.Y), ("y_pred", f.y)):
            assert got.dtype == dt
            assert rel_err(got, arr(e[name]).reshape(got.shape)) <= tol, (t, name)
        contribs = [m.info_contribution(arr(z).reshape(-1), H[j], R[j])
                    for j, z in enumerate(st["z"])]
        for j, (i, I) in enumerate(contribs):
            assert rel_err(i, arr(e["i"][j]).reshape(-1)) <= tol, (t, j)
            assert rel_err(I, arr(e["I"][j])) <= tol, (t, j)
        f.fuse(np.stack([i for i, _ in contribs]), np.stack([I for _, I in contribs]))
        for name, got in (("x", f.x), ("P", f.P), ("Y", f.Y), ("y", f.y)):
            assert rel_err(got, arr(e[name]).reshape(got.shape)) <= tol, (t, name)


def test_filter_matches_lif_vector(mod):
    m, dt = mod
    c = lif()
    steps = c["steps"]
    H, R = [arr(h) for h in c["H"]], [arr(r) for r in c["R"]]
    Z = [np.stack([arr(st["z"][j]).reshape(-1) for st in steps]) for j in range(len(H))]
    F = np.stack([arr(st["F"]) for st in steps])
    f = m.InformationFilter(F=F, Q=arr(c["Q"]), x0=arr(c["x0"]), P0=arr(c["P0"]))
    X, P = f.filter(Z, H, R)
    assert X.shape == (30, 4) and P.shape == (30, 4, 4) and X.dtype == dt
    for t, st in enumerate(steps):
        assert rel_err(X[t], arr(st["expected"]["x"]).reshape(-1)) <= VEC_TOL[dt], t
        assert rel_err(P[t], arr(st["expected"]["P"])) <= VEC_TOL[dt], t


def sensors(rng, n, dims, T):
    """Per sensor: H (T, m, n), R (T, m, m) correlated within the sensor, Z (T, m)."""
    H = [rng.normal(size=(T, m, n)) for m in dims]
    R = [np.stack([rand_spd(rng, m, 3.0, 0.5) for _ in range(T)]) for m in dims]
    Z = [rng.normal(size=(T, m)) for m in dims]
    return H, R, Z


def multi_sensor(seed, n, dims, T):
    """A random model of T steps (conftest.rand_model) and its sensors."""
    rng = np.random.default_rng(seed)
    md = rand_model(rng, n, 1, T)
    return (md,) + sensors(rng, n, dims, T)


def block_diag(blocks):
    size = sum(b.shape[0] for b in blocks)
    out = np.zeros((size, size))
    k = 0
    for b in blocks:
        out[k:k + b.shape[0], k:k + b.shape[0]] = b
        k += b.shape[0]
    return out


def test_fusion_equals_stacked_kalman_filter(mod):
    m, dt = mod
    T = 30
    md, H, R, Z = multi_sensor(40, 6, (1, 2, 3), T)
    rnd = lambda a: a.astype(dt).astype(np.float64)  # noqa: E731 (the inputs both see)
    md = {k: rnd(v) for k, v in md.items()}
    H, R, Z = [rnd(h) for h in H], [rnd(r) for r in R], [rnd(z) for z in Z]
    f = m.InformationFilter(F=md["F"], Q=md["Q"], x0=md["x0"], P0=md["P0"])
    X, P = f.filter(Z, H, R)
    Hs = np.concatenate(H, axis=1)
    Rs = np.stack([block_diag([r[t] for r in R]) for t in range(T)])
    kf = m.KalmanFilter(F=md["F"], Q=md["Q"], H=Hs, R=Rs, x0=md["x0"], P0=md["P0"])
    Xk, Pk = kf.filter(np.concatenate(Z, axis=1))
    assert rel_err(X, Xk) <= KF_TOL[dt] and rel_err(P, Pk) <= KF_TOL[dt]


def test_filter_equals_loop_bit_for_bit(mod):
    m, dt = mod
    T = 25
    md, H, R, Z = multi_sensor(41, 4, (2, 1, 3), T)
    Z[0][3] = np.nan                         # sensor 0 silent at step 3
    Z[0][7] = np.nan
    Z[1][7] = np.nan
    Z[2][7] = np.nan                         # nobody at step 7
    Z[2][9, 1] = np.nan                      # sensor 2 partly at step 9
    a = m.InformationFilter(F=md["F"], Q=md["Q"], x0=md["x0"], P0=md["P0"])
    b = m.InformationFilter(F=md["F"][0], Q=md["Q"][0], x0=md["x0"], P0=md["P0"])
    X, P = a.filter(Z, H, R)
    for t in range(T):
        b.predict(F=md["F"][t], Q=md["Q"][t])
        cs = [m.info_contribution(Z[j][t], H[j][t], R[j][t]) for j in range(3)
              if not np.all(np.isnan(Z[j][t]))]
        if cs:
            b.fuse(np.stack([i for i, _ in cs]), np.stack([I for _, I in cs]))
        assert same_bits(X[t], b.x) and same_bits(P[t], b.P), t
    assert same_bits(a.Y, b.Y) and same_bits(a.y, b.y)


def test_update_is_one_contribution_fused(mod):
    m, _ = mod
    rng = np.random.default_rng(42)
    md = rand_model(rng, 3, 2, 1)
    a = m.InformationFilter(F=md["F"][0], Q=md["Q"][0], x0=md["x0"], P0=md["P0"])
    b = m.InformationFilter(F=md["F"][0], Q=md["Q"][0], x0=md["x0"], P0=md["P0"])
    z = np.array([0.3, np.nan])
    a.update(z, md["H"][0], md["R"][0])
    i, I = m.info_contribution(z, md["H"][0], md["R"][0])
    i1, I1 = m.info_contribution(z[:1], md["H"][0][:1], md["R"][0][:1, :1])
    assert same_bits(i, i1) and same_bits(I, I1)
    b.fuse(i, I)
    assert same_bits(a.x, b.x) and same_bits(a.P, b.P) and same_bits(a.Y, b.Y)
    before = a.P.tobytes()
    a.update([np.nan, np.nan], md["H"][0], md["R"][0])   # no measurement: no update
    assert a.P.tobytes() == before
    i0, I0 = m.info_contribution([np.nan, np.nan], md["H"][0], md["R"][0])
    assert not np.any(i0) and not np.any(I0)


@pytest.mark.parametrize("seed", range(8))
def test_failures_leave_the_filter_bit_identical(mod, seed):
    m, dt = mod
    rng = np.random.default_rng(300 + seed)
    n = int(rng.integers(1, 6))
    dims = tuple(int(d) for d in rng.integers(1, 4, size=int(rng.integers(1, 4))))
    T = 6
    md = rand_model(rng, n, 1, T)
    H, R, Z = sensors(rng, n, dims, T)
    args = dict(F=md["F"][0], Q=md["Q"][0], x0=md["x0"], P0=md["P0"])
    f, twin = m.InformationFilter(**args), m.InformationFilter(**args)
    for g in (f, twin):
        g.predict()
        g.update(Z[0][0], H[0][0], R[0][0])
    state = lambda g: (g.x.tobytes(), g.P.tobytes(), g.y.tobytes(), g.Y.tobytes())  # noqa: E731
    want = state(twin)
    m0 = dims[0]

    def poke(a, v):
        a = a.copy()
        a.flat[int(rng.integers(a.size))] = v
        return a

    Zi = [z.copy() for z in Z]
    t_bad, j_bad = int(rng.integers(T)), int(rng.integers(len(dims)))
    Zi[j_bad][t_bad, int(rng.integers(dims[j_bad]))] = np.inf
    Rn = [r.copy() for r in R]
    Rn[j_bad][t_bad] = -100.0 * np.eye(dims[j_bad])
    bad = [
        (lambda: f.predict(F=poke(md["F"][1], np.nan)), dkf.NonFiniteError, "F", None),
        (lambda: f.predict(Q=-1e3 * np.eye(n)), dkf.NotSPDError, "Q", None),
        (lambda: f.update(Z[0][1], poke(H[0][1], np.nan), R[0][1]), dkf.NonFiniteError, "H", None),
        (lambda: f.update(poke(Z[0][1], np.inf), H[0][1], R[0][1]), dkf.NonFiniteError, "z", None),
        (lambda: f.update(Z[0][1], H[0][1], -np.eye(m0)), dkf.NotSPDError, "R", None),
        (lambda: f.fuse(np.zeros(n), -1e6 * np.eye(n)), dkf.NotSPDError, "I", None),
        (lambda: f.fuse(np.full(n, np.nan), np.eye(n)), dkf.NonFiniteError, "i", None),
        (lambda: f.filter(Zi, H, R, F=md["F"], Q=md["Q"]), dkf.NonFiniteError, "z", t_bad),
        (lambda: f.filter(Z, H, Rn, F=md["F"], Q=md["Q"]), dkf.NotSPDError, "R", t_bad),
        (lambda: f.fuse(np.zeros(n + 1), np.eye(n + 1)), ValueError, None, None),
        (lambda: f.update(Z[0][1], H[0][1], np.eye(m0 + 1)), ValueError, None, None),
        (lambda: f.filter(Z, H[:-1] if len(H) > 1 else [], R, F=md["F"]), ValueError, None, None),
        (lambda: f.filter([z[:3] for z in Z], H, R, F=md["F"]), ValueError, None, None),
        (lambda: f.filter(Z, "H", R), TypeError, None, None),
        (lambda: f.update(Z[0][1] * 1j, H[0][1], R[0][1]), TypeError, None, None),
    ]
    for k in rng.permutation(len(bad)):
        call, exc, matrix, step = bad[k]
        with pytest.raises(exc) as info:
            call()
        if issubclass(exc, dkf.Error):
            e = info.value
            assert (e.status, e.matrix, e.step) == (exc.status, matrix, step), str(e)
            assert e.call.startswith("InformationFilter.") and e.call in str(e)
            if step is not None:
                assert f"step {step}" in str(e) and (matrix == "z") <= (f"sensor {j_bad}" in str(e))
        assert state(f) == want, k
    X1, P1 = f.filter(Z, H, R, F=md["F"], Q=md["Q"])
    X2, P2 = twin.filter(Z, H, R, F=md["F"], Q=md["Q"])
    assert same_bits(X1, X2) and same_bits(P1, P2)
