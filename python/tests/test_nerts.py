"""dkf.NERTS and dkf.NLModel (dkf/nerts.h, dkf/nl_model.h): seed 001's
vectors tests/test_nerts_vectors.c checks (nertsif.json with NERTSIF and
NERTSF, dnertsif_single.json's radar, one and 12 stacked, with DNERTSIF and
DNERTSF), the same models as expressions (dkf.expr_model, the scenarios'
strings), filter() against its loop bit for bit, a Python exception in a
callback as the step's failure, and failures that leave the filter as it
was."""

import json

import numpy as np
import pytest

import dkf
from conftest import ROOT, assert_refused_untouched, load_vector, poker, rel_err, same_bits
from nl_models import lxs_model, radar_model

# tests/test_nerts_vectors.c's tolerances: double 1e-8, float 1e-3
TOL = {np.float64: 1e-8, np.float32: 1e-3}
# the files' names of the filter's views (the paper's A, G, H)
VIEW = {"A": "Fx", "G": "Fd", "H": "Hd"}
INFO_ONLY = {"Y_pred", "y_pred", "Rbar_inv", "i", "I", "Y", "y"}


def arr(v):
    return np.array(v, dtype=np.float64)


def prior(c):
    i = c["init"]
    return dict(x0=arr(i["x0"]), P0=arr(i["Px0"]), d0=arr(i["d0"]), Pd0=arr(i["Pd0"]),
                Pxd0=arr(i["Pxd0"]))


def run_case(m, dt, kind, c, model, Q, R, phases=True):
    pr = prior(c)
    f = m.NERTS(model, pr.pop("x0"), pr.pop("P0"), kind=kind, **pr)
    info = kind.endswith("IF")
    for s in c["steps"]:
        if phases:
            f.predict(Q=Q)
            f.local(arr(s["z"]), R=R)
            f.update()
        else:
            f.step(arr(s["z"]), Q=Q, R=R)
        assert f.k == s["k"]
        for key, val in s["expected"].items():
            if key in INFO_ONLY and not info:
                continue
            got = getattr(f, VIEW.get(key, key))
            assert got.dtype == dt
            want = arr(val).reshape(got.shape)
            assert rel_err(got, want) <= TOL[dt], (c["name"], kind, s["k"], key, rel_err(got, want))
    return f


@pytest.mark.parametrize("kind", ["NERTSIF", "NERTSF"])
def test_nertsif_vectors(mod, kind):
    m, dt = mod
    v = load_vector("infofusion/nertsif.json")
    for c in v["cases"]:
        md = c["model"]
        run_case(m, dt, kind, c, lxs_model(m, md), arr(md["Q"]), arr(md["R"]))


@pytest.mark.parametrize("kind", ["DNERTSIF", "DNERTSF"])
def test_radar_vectors(mod, kind):
    m, dt = mod
    v = load_vector("infofusion/dnertsif_single.json")
    one = next(c for c in v["cases"] if c["name"] == "s1_single_node_sensor2")
    md = one["model"]
    Q, R = arr(md["Q"]), arr(md["R"])
    run_case(m, dt, kind, one, radar_model(m, md["sensor_xy"]), Q, R, phases=False)
    # the 12 radars stacked (CF-DNERTSF): one model, R = blkdiag of the single R
    st = next(c for c in v["cases"] if c["name"] == "s1_centralised_12_sensors")
    xy = st["model"]["sensor_xy"]
    run_case(m, dt, kind, st, radar_model(m, xy), Q, np.kron(np.eye(len(xy)), R))


def scenario_model(m, name):
    """The expression model of scenarios/NAME.json through dkf.expr_model."""
    case = json.loads((ROOT / "scenarios" / f"{name}.json").read_text())["cases"][0]
    e = dict(case["model"]["expr"])
    p = len(case["init"]["d0"]) if "init" in case else 1
    return m.expr_model(e.pop("f"), e.pop("g"), p=p, **e), case["model"]


@pytest.mark.parametrize("kind", ["NERTSIF", "NERTSF", "DNERTSIF", "DNERTSF"])
def test_expression_models_match_the_vectors(mod, kind):
    """The scenarios' expressions, unchanged: lin_x_sin_d with its
    Jacobians gives nertsif.json's numbers (the EKF kinds), the radar (no
    Jacobians: dg/dd by forward differences) dnertsif_single.json's (the
    cubature kinds)."""
    m, dt = mod
    if not kind.startswith("D"):
        md, spec = scenario_model(m, "nl_lin_x_sin_d_expr")
        assert md.f_jac is not None and (md.n, md.m, md.p) == (3, 3, 1)
        c = load_vector("infofusion/nertsif.json")["cases"][0]
    else:
        md, spec = scenario_model(m, "nl_radar_expr")
        assert md.angles == [1] and md.h_jac is None
        v = load_vector("infofusion/dnertsif_single.json")
        c = next(c for c in v["cases"] if c["name"] == "s1_single_node_sensor2")
    run_case(m, dt, kind, c, md, arr(spec["Q"]), arr(spec["R"]))


def test_expression_refusals():
    for f, g, pattern in [
        (["x1 + d2"], ["x1"], r"f\[0\]: 'x1 \+ d2': unknown variable or function 'd2' "
                              r"\(variables: d1, x1\)"),
        (["x1"], ["x1 > 0 ? 1 : 0"], r"g\[0\]: .*'>' is not supported"),
        (["x1 + (0.1*x2"], ["x1"], r"f\[0\]: 'x1 \+ \(0.1\*x2'"),
        (["__import__('os')"], ["x1"], r"\"'\" is not supported"),
        (["x1.real"], ["x1"], r"unknown variable or function 'real'"),
    ]:
        with pytest.raises(ValueError, match=pattern):
            dkf.expr_model(f, g, p=1)
    with pytest.raises(ValueError, match="give A and G together"):
        dkf.expr_model(["x1"], ["x1 + d1"], p=1, A=[["1"]])
    md = dkf.float32.expr_model(["hypot(x1, 2)^2 + rint(0.4) + log2(8) + avg(1, 3)"],
                                ["x1 + d1"], p=1)
    assert isinstance(md, dkf.float32.NLModel)
    assert np.isclose(md.f(np.array([1.0]), np.zeros(1), None)[0], 5 + 0 + 3 + 2)


@pytest.mark.parametrize("kind", ["NERTSF", "DNERTSIF"])
def test_filter_equals_its_steps(mod, kind):
    m, dt = mod
    v = load_vector("infofusion/nertsif.json")
    c = v["cases"][0]
    md, Q, R = lxs_model(m, c["model"], jacobians=False), arr(c["model"]["Q"]), arr(c["model"]["R"])
    Z = np.array([np.full(3, np.nan)] + [s["z"] for s in c["steps"]])
    T = Z.shape[0]
    pr = prior(c)
    a = m.NERTS(md, pr["x0"], pr["P0"], kind=kind, d0=pr["d0"], Pd0=pr["Pd0"])
    X, Px, D, Pd = a.filter(Z, Q=np.stack([Q] * T), R=R)
    assert X.shape == (T - 1, 3) and Px.shape == (T - 1, 3, 3) and D.shape == (T - 1, 1)
    assert Pd.shape == (T - 1, 1, 1) and X.dtype == dt
    b = m.NERTS(md, pr["x0"], pr["P0"], kind=kind, d0=pr["d0"], Pd0=pr["Pd0"])
    for t in range(1, T):
        b.step(Z[t], Q=Q, R=R)
        assert same_bits(X[t - 1], b.x) and same_bits(Px[t - 1], b.Px), t
        assert same_bits(D[t - 1], b.d) and same_bits(Pd[t - 1], b.Pd), t
    for key in ("x", "Px", "d", "Pd", "Pxd", "x_pred", "P_pred", "nu", "R_tilde", "M"):
        assert same_bits(getattr(a, key), getattr(b, key)), key
    assert a.k == b.k == T - 1


class Flaky:
    """A model whose f raises, or returns a wrong shape, when told to."""

    def __init__(self, m, c):
        self.inner = lxs_model(m, c["model"])
        self.mode = None
        self.model = m.NLModel(self.f, self.inner.h, n=3, m=3, p=1)

    def f(self, x, d, u):
        if self.mode == "raise":
            raise ZeroDivisionError("boom")
        if self.mode == "shape":
            return np.zeros(2)
        if self.mode == "nan":
            return np.full(3, np.nan)
        return self.inner.f(x, d, u)


def test_a_callback_exception_is_the_steps_failure(mod):
    m, _ = mod
    c = load_vector("infofusion/nertsif.json")["cases"][0]
    Q, R = arr(c["model"]["Q"]), arr(c["model"]["R"])
    fl = Flaky(m, c)
    pr = prior(c)
    f = m.NERTS(fl.model, pr["x0"], pr["P0"], kind="DNERTSIF", d0=pr["d0"], Pd0=pr["Pd0"])
    z = arr(c["steps"][0]["z"])
    f.step(z, Q=Q, R=R)
    before = (f.x.tobytes(), f.Px.tobytes(), f.d.tobytes(), f.k, f.phase)
    fl.mode = "raise"
    with pytest.raises(dkf.ModelError, match=r"^NERTS.step: .*model.f raised ZeroDivisionError: "
                                             "boom") as info:
        f.step(z, Q=Q, R=R)
    assert isinstance(info.value.__cause__, ZeroDivisionError)
    fl.mode = "shape"
    with pytest.raises(dkf.ModelError, match=r"returned shape \(2,\), expected \(3,\)") as info:
        f.predict(Q=Q)
    assert isinstance(info.value.__cause__, ValueError)
    fl.mode = "nan"
    with pytest.raises(dkf.NonFiniteError, match="a model value not finite"):
        f.step(z, Q=Q, R=R)
    assert (f.x.tobytes(), f.Px.tobytes(), f.d.tobytes(), f.k, f.phase) == before
    # in filter(), without the GIL: the step named, the run undone
    Z = np.array([np.full(3, np.nan)] + [s["z"] for s in c["steps"][:6]])
    calls = []

    def f_fails_late(x, d, u):
        calls.append(1)
        if len(calls) > 4:
            raise KeyError("late")
        return fl.inner.f(x, d, u)

    g = m.NERTS(m.NLModel(f_fails_late, fl.inner.h, n=3, m=3, p=1, f_jac=fl.inner.f_jac,
                          h_jac=fl.inner.h_jac), pr["x0"], pr["P0"], kind="NERTSIF",
                d0=pr["d0"], Pd0=pr["Pd0"])
    with pytest.raises(dkf.ModelError) as info:
        g.filter(Z, Q=Q, R=R)
    assert info.value.step == 5 and isinstance(info.value.__cause__, KeyError)
    assert g.k == 0 and same_bits(g.x, pr["x0"].astype(g.x.dtype))
    with pytest.raises(ValueError, match="T >= 2"):
        g.filter(Z[:1], Q=Q, R=R)


@pytest.mark.parametrize("kind", ["NERTSF", "NERTSIF", "DNERTSF", "DNERTSIF"])
@pytest.mark.parametrize("seed", range(2))
def test_failures_leave_the_filter_bit_identical(mod, kind, seed):
    m, _ = mod
    rng = np.random.default_rng(500 + seed)
    poke = poker(rng)
    c = load_vector("infofusion/nertsif.json")["cases"][0]
    Q, R = arr(c["model"]["Q"]), arr(c["model"]["R"])
    md = lxs_model(m, c["model"])
    no_d = m.NLModel(md.f, lambda x, d, u: md.h(x, 0 * d, u), n=3, m=3, p=1)
    pr = prior(c)
    f = m.NERTS(md, pr["x0"], pr["P0"], kind=kind, d0=pr["d0"], Pd0=pr["Pd0"])
    z = arr(c["steps"][0]["z"])
    f.step(z, Q=Q, R=R)
    f.predict(Q=Q)
    fields = ("x", "Px", "d", "Pd", "Pxd", "x_pred", "P_pred", "Y_pred", "y_pred", "z_hat",
              "nu", "R_tilde", "Pxz", "Hd", "M", "Y", "y")
    state = lambda: (tuple(getattr(f, a).tobytes() for a in fields), f.k, f.phase)  # noqa: E731
    want = state()
    bad = [
        (lambda: f.local(poke(z, np.nan), R=R), dkf.NonFiniteError, "z"),
        (lambda: f.local(z, R=-R), dkf.NotSPDError, None),
        (lambda: f.step(z, Q=poke(Q, np.inf), R=R), dkf.NonFiniteError, "Q"),
        (lambda: f.update(), dkf.StateError, None),
        (lambda: f.commit_info(np.eye(3), np.zeros(3)), dkf.StateError, None),
        (lambda: f.local(z[:2], R=R), ValueError, None),
        (lambda: f.step(z, Q=Q, R=R, u=np.ones(1)), ValueError, None),
        (lambda: f.filter(np.stack([z, z]), Q=Q, R=R), dkf.StateError, None),
    ]
    g = m.NERTS(no_d, pr["x0"], pr["P0"], kind=kind, d0=pr["d0"], Pd0=pr["Pd0"])
    with pytest.raises(dkf.RankError) as info:
        g.step(z, Q=Q, R=R)
    assert info.value.matrix == "Hd" and g.k == 0
    assert_refused_untouched(bad, rng, state, want, "NERTS")
    with pytest.raises(ValueError, match="kind must be"):
        m.NERTS(md, pr["x0"], pr["P0"], kind="EKF", d0=pr["d0"], Pd0=pr["Pd0"])
    with pytest.raises(dkf.NotSPDError):
        m.NERTS(md, pr["x0"], -pr["P0"], kind=kind, d0=pr["d0"], Pd0=pr["Pd0"])
