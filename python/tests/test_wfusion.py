"""dkf.WeightedFusion (dkf/wfusion.h): seed 002's example against
tests/vectors/infofusion/s2_weighted_fusion.json (every step's local gains,
covariances and estimates, the cross covariances, both fusions; the steady
state), as tests/test_wfusion.c checks it; filter() against its loop bit
for bit, a missing sensor, and failures that leave the fusion as it was."""

import numpy as np
import pytest

import dkf
from conftest import assert_refused_untouched, load_vector, poker, rel_err, same_bits

# tests/test_wfusion.c's tolerances: double, the file's rtol 1e-8 (per
# array, of max(1, max|expected|)); float, 1e-3 as the other float golden
# vectors (measured worst 7.6e-5).
TOL = {np.float64: 1e-8, np.float32: 1e-3}
NX, NL = 4, 5


def case():
    c = load_vector("infofusion/s2_weighted_fusion.json")["cases"][0]
    assert c["name"] == "seed002_5_sensors"
    G, Qe = np.array(c["Gamma"]), np.array(c["Qe"])
    model = dict(F=np.array(c["Phi"]), Q=G @ Qe @ G.T,
                 H=[np.array(h, dtype=np.float64) for h in c["H"]],
                 R=[np.array(r, dtype=np.float64) for r in c["R"]])
    Y = [np.array([s["y"][i] for s in c["steps"]], dtype=np.float64) for i in range(NL)]
    return c, model, Y


def make(m, c, sensors=NL):
    return m.WeightedFusion(np.array(c["x_hat0"]), np.array(c["P0"]), np.array(c["H_signal"][0]),
                            m=[1] * sensors)


def joint(Pj):
    """(n l, n l) as the vector's P_ij[i][j] (l, l, n, n)."""
    return Pj.reshape(NL, NX, NL, NX).transpose(0, 2, 1, 3)


def weights(A):
    """[A_1 ... A_l] (n, n l) as the vector's matrix_weights[i] (l, n, n)."""
    return A.reshape(NX, NL, NX).transpose(1, 0, 2)


def close(got, want, tol, what):
    want = np.asarray(want, dtype=np.float64)
    got = np.asarray(got, dtype=np.float64).reshape(want.shape)
    assert rel_err(got, want) <= tol, (what, rel_err(got, want))


def compare(f, exp, tol, t):
    close(np.stack([k.ravel() for k in f.K]), np.array(exp["K"])[..., 0], tol, ("K", t))
    close(f.Sigma_pred, exp["Sigma_pred"], tol, ("Sigma_pred", t))
    close(joint(f.Pj), exp["P_ij"], tol, ("P_ij", t))
    close(f.PS, exp["P_S"], tol, ("P_S", t))
    close(f.w, exp["w"], tol, ("w", t))
    close(f.PS0, exp["P_S0"], tol, ("P_S0", t))
    close(f.Pf, exp["P0_matrix"], tol, ("P0_matrix", t))


def test_matches_seed002_vector(mod):
    m, dt = mod
    c, md, Y = case()
    f = make(m, c)
    tol, nonunique = TOL[dt], 0
    for j, st in enumerate(c["steps"]):
        exp, t = st["expected"], st["t"]
        assert t == j + 1
        f.step(md["F"], md["Q"], md["H"], md["R"], y=[Y[i][j] for i in range(NL)])
        s0, PS0 = f.fuse_scalar()
        xf, Pf = f.fuse_matrix()
        assert xf.dtype == dt and f.Pj.dtype == dt
        compare(f, exp, tol, t)
        close(f.x_local, exp["x_local"], tol, ("x_local", t))
        close(f.x_local @ np.array(c["H_signal"][0]), exp["s_local"], tol, ("s_local", t))
        close(s0, exp["s_fused"], tol, ("s_fused", t))
        close(xf, exp["x_fused_matrix"], tol, ("x_fused_matrix", t))
        assert same_bits(xf, f.xf) and same_bits(Pf, f.Pf) and PS0 == f.PS0
        assert f.w_unique and f.A_unique == exp["matrix_weights_unique"]
        if f.A_unique:
            close(weights(f.A), exp["matrix_weights"], tol, ("matrix_weights", t))
        nonunique += not f.A_unique
        assert f.used == NL and f.t == t
    assert nonunique == 3  # t = 1, 2, 3: the joint covariance has rank 8, 12, 16 < 20


def test_matches_the_steady_state(mod):
    m, dt = mod
    c, md, _ = case()
    f = make(m, c)
    f.steady(md["F"], md["Q"], md["H"], md["R"])
    f.fuse_scalar()
    f.fuse_matrix()
    ss = c["steady_state"]
    compare(f, ss, TOL[dt], "steady")
    close(weights(f.A), ss["matrix_weights"], TOL[dt], "steady matrix_weights")
    assert f.A_unique and f.steady_state
    # dkf.dare gives each local filter's steady predictor covariance
    for i in range(NL):
        X = m.dare(md["F"], md["H"][i], md["Q"], md["R"][i])
        close(X, ss["Sigma_pred"][i], TOL[dt], ("dare", i))


def test_filter_equals_its_loop(mod):
    m, dt = mod
    c, md, Y = case()
    a = make(m, c)
    # F as a stack of one per step: the same bits as the one matrix
    XF, PF, S0, PS0 = a.filter(Y, **{**md, "F": np.stack([md["F"]] * len(Y[0]))})
    T = Y[0].shape[0]
    assert XF.shape == (T, NX) and PF.shape == (T, NX, NX) and S0.shape == (T,)
    assert XF.dtype == dt and PS0.dtype == dt
    b = make(m, c)
    for t in range(T):
        b.step(**md, y=[y[t] for y in Y])
        s0, ps0 = b.fuse_scalar()
        xf, Pf = b.fuse_matrix()
        assert same_bits(XF[t], xf) and same_bits(PF[t], Pf), t
        assert S0[t] == s0 and PS0[t] == ps0, t
    for key in ("Pj", "x_local", "P_local", "Sigma_pred", "w", "A", "xf", "Pf"):
        assert same_bits(getattr(a, key), getattr(b, key)), key
    assert a.t == b.t == T


def test_missing_sensor_is_the_fusion_of_the_others(mod):
    """x[2] = None fuses the other four: the bits of a four-sensor fusion."""
    m, _ = mod
    c, md, Y = case()
    keep = [0, 1, 3, 4]
    f, g = make(m, c), make(m, c, sensors=4)
    for t in range(8):
        f.step(**md, y=[y[t] for y in Y])
        g.step(md["F"], md["Q"], [md["H"][i] for i in keep], [md["R"][i] for i in keep],
               y=[Y[i][t] for i in keep])
        xs = [f.x_local[i] if i in keep else None for i in range(NL)]
        assert f.fuse_scalar(xs) == g.fuse_scalar()
        xf, Pf = f.fuse_matrix(xs)
        xg, Pg = g.fuse_matrix()
        assert same_bits(xf, xg) and same_bits(Pf, Pg), t
        assert f.used == 4 and f.w[2] == 0 and same_bits(f.w[keep], g.w)


@pytest.mark.parametrize("seed", range(3))
def test_failures_leave_the_fusion_bit_identical(mod, seed):
    m, dt = mod
    rng = np.random.default_rng(1000 + seed)
    poke = poker(rng)
    c, md, Y = case()
    f = make(m, c)
    f.step(**md, y=[y[0] for y in Y])
    f.fuse_scalar()
    f.fuse_matrix()
    fields = ("Pj", "x_local", "P_local", "Sigma_pred", "Psi", "J", "PS", "w", "A", "xf", "Pf")
    state = lambda: (tuple(getattr(f, a).tobytes() for a in fields),  # noqa: E731
                     f.s0, f.PS0, f.t, f.used, f.steady_state)
    want = state()
    y1 = [y[1] for y in Y]
    R_bad = list(md["R"])
    R_bad[3] = -np.ones((1, 1))
    H_nan = list(md["H"])
    H_nan[1] = poke(H_nan[1], np.nan)
    bad = [
        (lambda: f.step(**md, y=[poke(v, np.inf) if i == 2 else v for i, v in enumerate(y1)]),
         dkf.NonFiniteError, "y"),
        (lambda: f.step(md["F"], md["Q"], H_nan, md["R"], y=y1), dkf.NonFiniteError, "H"),
        (lambda: f.step(md["F"], md["Q"], md["H"], R_bad, y=y1), dkf.NotSPDError, None),
        (lambda: f.steady(2.0 * np.eye(NX), np.zeros((NX, NX)), md["H"], md["R"]),
         dkf.UnstableError, None),
        (lambda: f.fuse_scalar([None] * NL), dkf.ArgError, "x"),
        (lambda: f.fuse_matrix([poke(np.zeros(NX), np.nan)] + [None] * 4), dkf.NonFiniteError,
         "x"),
        (lambda: f.step(**md, y=y1[:4]), ValueError, None),
        (lambda: f.step(np.eye(NX + 1), md["Q"], md["H"], md["R"], y=y1), ValueError, None),
        (lambda: f.step(**{**md, "H": np.stack([md["H"]] * 2)}, y=y1), ValueError, None),
        (lambda: f.filter([y[:5] for y in Y[:4]], **md), ValueError, None),
    ]
    assert_refused_untouched(bad, rng, state, want, "WeightedFusion")
    with pytest.raises(dkf.NonFiniteError) as info:
        f.step(**md, y=[poke(v, np.inf) if i == 2 else v for i, v in enumerate(y1)])
    assert info.value.node == 2


def test_filter_failure_names_the_step_and_undoes_it(mod):
    m, _ = mod
    c, md, Y = case()
    f = make(m, c)
    f.step(**md, y=[y[0] for y in Y])
    before = (f.Pj.tobytes(), f.x_local.tobytes(), f.t)
    Yb = [y.copy() for y in Y]
    Yb[3][6, 0] = np.nan
    with pytest.raises(dkf.NonFiniteError, match=r"^WeightedFusion.filter, step 6: .*sensor 3: "
                       r"y not finite") as info:
        f.filter(Yb, **md)
    assert info.value.step == 6 and info.value.node == 3 and info.value.matrix == "y"
    assert (f.Pj.tobytes(), f.x_local.tobytes(), f.t) == before
