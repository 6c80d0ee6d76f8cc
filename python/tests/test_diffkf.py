"""dkf.DifferenceKF (dkf/diffkf.h): seed 000 Example 1's DKF outputs (the
vector tests/test_diffkf.c checks), filter() against its step loop bit for
bit, and failures that leave the filter as it was."""

import numpy as np
import pytest

import dkf
from conftest import assert_refused_untouched, load_vector, model_at, poker, rel_err, same_bits

# tests/test_diffkf.c's tolerances: double, the vectors' 1e-9; float, L_k
# is a sum of four covariances with differences of nearly equal terms,
# cond(L) ~ 30 and x reaches 300, a step costs ~cond * p * eps: 1e-4.
TOL = {np.float64: 1e-9, np.float32: 1e-4}
KEYS = ("F", "Q", "B", "Rd", "H", "D", "R")


def ex1():
    v = load_vector("diffkf/ex1_single.json")
    N = len(v["k"])
    assert N == 50
    # the model at every time 0..N+1 (constant here: checks the stacks too)
    model = {key: np.stack([model_at(v["model"], key, k) for k in range(N + 2)]) for key in KEYS}
    Y = np.stack([np.array(y, dtype=np.float64).reshape(-1) for y in v["y"]["values"]])
    x0 = np.array(v["init"]["x00"], dtype=np.float64).reshape(-1)
    P0 = np.atleast_2d(np.array(v["init"]["P00"], dtype=np.float64))
    return model, Y, x0, P0, v["outputs"]["DKF"]


def at(model, k):
    return {key: model[key][k] for key in KEYS}


def test_steps_match_ex1_vector(mod):
    m, dt = mod
    model, Y, x0, P0, out = ex1()
    mm, p = model["D"].shape[1], model["D"].shape[2]
    f = m.DifferenceKF(x0, P0, m=mm, p=p)
    f.start(Y[0], model["H"][1], model["D"][1], model["R"][1], F0=model["F"][0], Q0=model["Q"][0])
    tol = TOL[dt]
    for j in range(50):
        k = j + 1
        for key, got in (("xp", f.xn), ("Pp", f.Pn)):
            assert got.dtype == dt
            assert rel_err(got, np.array(out[key][j]).reshape(got.shape)) <= tol, (key, k)
        a, b = at(model, k), at(model, k + 1)
        f.step(Y[k], F=a["F"], Q=a["Q"], B=a["B"], Rd=a["Rd"], H=b["H"], D=b["D"], R=b["R"])
        assert f.k == k
        for key, got in (("z", f.z), ("dz", f.dz), ("J", f.J), ("L", f.L), ("K", f.K),
                         ("xf", f.xf), ("Pf", f.Pf), ("xp", f.xp)):
            assert rel_err(got, np.array(out[key][j]).reshape(got.shape)) <= tol, (key, k)


def test_filter_equals_steps_and_vector(mod):
    m, dt = mod
    model, Y, x0, P0, out = ex1()
    mm, p = model["D"].shape[1], model["D"].shape[2]
    a = m.DifferenceKF(x0, P0, m=mm, p=p)
    XF, PF, XN, PN = a.filter(Y, **model)
    assert XF.shape == (50, x0.size) and PN.shape == (50, x0.size, x0.size) and XF.dtype == dt
    b = m.DifferenceKF(x0, P0, m=mm, p=p)
    b.start(Y[0], model["H"][1], model["D"][1], model["R"][1], F0=model["F"][0], Q0=model["Q"][0])
    for j in range(50):
        k = j + 1
        s, n1 = at(model, k), at(model, k + 1)
        b.step(Y[k], F=s["F"], Q=s["Q"], B=s["B"], Rd=s["Rd"], H=n1["H"], D=n1["D"], R=n1["R"])
        assert same_bits(XF[j], b.xf) and same_bits(PF[j], b.Pf), k
        assert same_bits(XN[j], b.xn) and same_bits(PN[j], b.Pn), k
        assert rel_err(XF[j], np.array(out["xf"][j])) <= TOL[dt], k
    # constant matrices give the same bits as their stacks
    c = m.DifferenceKF(x0, P0, m=mm, p=p)
    XF2 = c.filter(Y, **{key: model[key][0] for key in KEYS})[0]
    assert same_bits(XF, XF2)
    assert a.k == b.k == c.k == 50


def test_prior_start(mod):
    """prior=True: x0, P0 are the prior of time 1 (start without F0, Q0)."""
    m, _ = mod
    model, Y, x0, P0, _ = ex1()
    mm, p = model["D"].shape[1], model["D"].shape[2]
    a = m.DifferenceKF(x0, P0, m=mm, p=p)
    XF = a.filter(Y[:6], prior=True, **{key: model[key][:7] for key in KEYS})[0]
    b = m.DifferenceKF(x0, P0, m=mm, p=p)
    b.start(Y[0], model["H"][1], model["D"][1], model["R"][1])
    assert same_bits(b.xn, x0.astype(b.xn.dtype))
    s, n1 = at(model, 1), at(model, 2)
    b.step(Y[1], F=s["F"], Q=s["Q"], B=s["B"], Rd=s["Rd"], H=n1["H"], D=n1["D"], R=n1["R"])
    assert same_bits(XF[0], b.xf)


@pytest.mark.parametrize("seed", range(6))
def test_failures_leave_the_filter_bit_identical(mod, seed):
    m, dt = mod
    rng = np.random.default_rng(700 + seed)
    model, Y, x0, P0, _ = ex1()
    mm, p = model["D"].shape[1], model["D"].shape[2]
    f, twin = m.DifferenceKF(x0, P0, m=mm, p=p), m.DifferenceKF(x0, P0, m=mm, p=p)
    with pytest.raises(dkf.StateError, match="DifferenceKF.step: .*start"):
        f.step(Y[1], **at(model, 1))
    for g in (f, twin):
        g.start(Y[0], model["H"][1], model["D"][1], model["R"][1], F0=model["F"][0],
                Q0=model["Q"][0])
        g.step(Y[1], **at(model, 1))
    fields = ("xf", "Pf", "xn", "Pn", "xp", "z", "dz", "J", "L", "K", "k")
    state = lambda g: tuple(np.asarray(getattr(g, a)).tobytes() for a in fields)  # noqa: E731
    want = state(twin)
    s = at(model, 2)

    def with_(**kw):
        return {**s, **kw}

    poke = poker(rng)

    n = x0.size
    bad = [
        (lambda: f.step(poke(Y[2], np.nan), **s), dkf.NonFiniteError, "y"),
        (lambda: f.step(Y[2], **with_(F=poke(s["F"], np.inf))), dkf.NonFiniteError, "F"),
        (lambda: f.step(Y[2], **with_(B=np.zeros((p, p)))), dkf.SingularError, "B"),
        (lambda: f.step(Y[2], **with_(D=np.zeros((mm, p)))), dkf.RankError, "D"),
        (lambda: f.step(Y[2], **with_(R=-1e3 * np.eye(mm))), dkf.NotSPDError, None),
        (lambda: f.step(Y[2], **with_(Q=np.eye(n + 1))), ValueError, None),
        (lambda: f.step(Y[2][:-1], **s), ValueError, None),
        (lambda: f.step(Y[2], **with_(H=s["H"].astype(complex))), TypeError, None),
        (lambda: f.start(Y[0], model["H"][1], model["D"][1], model["R"][1], F0=model["F"][0]),
         ValueError, None),
        (lambda: f.filter(Y, **model), dkf.StateError, None),
    ]
    assert_refused_untouched(bad, rng, lambda: state(f), want, "DifferenceKF")
    for g in (f, twin):
        g.step(Y[2], **s)
    assert state(f) == state(twin)


def test_filter_failure_names_the_step_and_undoes_it(mod):
    m, _ = mod
    model, Y, x0, P0, _ = ex1()
    mm, p = model["D"].shape[1], model["D"].shape[2]
    f = m.DifferenceKF(x0, P0, m=mm, p=p)
    before = (f.xf.tobytes(), f.Pf.tobytes(), f.k, f.started)
    B = model["B"].copy()
    B[7] = 0.0
    with pytest.raises(dkf.SingularError, match=r"^DifferenceKF.filter, step 7: .*B is singular"):
        f.filter(Y, **{**model, "B": B})
    Yb = Y.copy()
    Yb[0, 1] = np.inf
    with pytest.raises(dkf.NonFiniteError, match=r"step 0: .*start: y not finite") as info:
        f.filter(Yb, **model)
    assert info.value.step == 0 and info.value.matrix == "y"
    with pytest.raises(ValueError, match="a stack has one matrix per time 0..T"):
        f.filter(Y[:10], **model)
    assert (f.xf.tobytes(), f.Pf.tobytes(), f.k, f.started) == before
    f.filter(Y, **model)
    assert f.k == 50
