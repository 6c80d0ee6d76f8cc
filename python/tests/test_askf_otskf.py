"""dkf.ASKF and dkf.OTSKF (dkf/askf.h, dkf/otskf.h): seed 000 Example 1's
outputs (the vectors tests/test_askf_otskf.c checks), filter() against its
loop of predict() and update() bit for bit, missing measurements, and
failures that leave the filter as it was."""

import numpy as np
import pytest

import dkf
from conftest import assert_refused_untouched, load_vector, model_at, poker, rel_err, same_bits

# tests/test_askf_otskf.c's tolerances: double, the vectors' 1e-9; float,
# one step loses ~(n + p) cond(S) eps with cond(S) <= 10 and the stable
# loop forgets old errors: 1e-5 (~84 eps).
TOL = {np.float64: 1e-9, np.float32: 1e-5}
DYN = ("F", "Q", "B", "Rd")
MEAS = ("H", "D", "R")
CLASSES = ("ASKF", "OTSKF")


def ex1(name):
    v = load_vector("diffkf/ex1_single.json")
    N = len(v["k"])
    assert N == 50
    # the model at every time 0..N (constant here: checks the stacks too)
    model = {key: np.stack([model_at(v["model"], key, k) for k in range(N + 1)])
             for key in DYN + MEAS}
    Y = np.stack([np.array(y, dtype=np.float64).reshape(-1) for y in v["y"]["values"][:N]])
    init = v["init"]
    prior = [np.array(init[key], dtype=np.float64) for key in ("x00", "P00", "d00", "Pd00")]
    prior = [prior[0].reshape(-1), np.atleast_2d(prior[1]), prior[2].reshape(-1),
             np.atleast_2d(prior[3])]
    return model, Y, prior, v["outputs"][name]


def make(m, name, prior, mm):
    return getattr(m, name)(*prior, m=mm)


def dyn(model, k):
    return {key: model[key][k] for key in DYN}


def meas(model, k):
    return {key: model[key][k] for key in MEAS}


# The vectors' outputs after each predict and each update, by property.
AFTER = {
    "ASKF": ((("Xp", "X"), ("PXp", "PX"), ("xp", "x"), ("Pp", "P")),
             (("Xf", "X"), ("PXf", "PX"), ("xf", "x"), ("Pf", "P"))),
    "OTSKF": ((("xtp", "xt"), ("Pxp", "Px"), ("dp", "d"), ("Pdp", "Pd"), ("U", "U"),
               ("xp", "x"), ("Pp", "P")),
              (("xtf", "xt"), ("Pxf", "Px"), ("df", "d"), ("Pdf", "Pd"), ("V", "V"),
               ("xf", "x"), ("Pf", "P"))),
}


@pytest.mark.parametrize("name", CLASSES)
def test_matches_ex1_vector(mod, name):
    """Every output of the vector after every predict and update (the
    OTSKF's with each intermediate of docs/design/derivation-seed000.md §5)."""
    m, dt = mod
    model, Y, prior, out = ex1(name)
    f = make(m, name, prior, Y.shape[1])
    for j in range(50):
        for half, after in enumerate(AFTER[name]):
            if half == 0:
                f.predict(**dyn(model, j))
            else:
                f.update(Y[j], **meas(model, j + 1))
            for key, prop in after:
                got = getattr(f, prop)
                assert got.dtype == dt
                want = np.array(out[key][j], dtype=np.float64).reshape(got.shape)
                assert rel_err(got, want) <= TOL[dt], (key, j, rel_err(got, want))
    if name == "ASKF":
        n = prior[0].size
        assert same_bits(f.d, f.X[n:]) and same_bits(f.Pd, f.PX[n:, n:])


@pytest.mark.parametrize("name", CLASSES)
def test_filter_equals_its_loop(mod, name):
    """filter() is the loop of predict() and update(), bit for bit, with an
    all-NaN row (a missing measurement) a predict only."""
    m, dt = mod
    model, Y, prior, out = ex1(name)
    Y = Y.copy()
    Y[[4, 17]] = np.nan
    a = make(m, name, prior, Y.shape[1])
    X, P, D, Pd = a.filter(Y, **model)
    T, n, p = Y.shape[0], prior[0].size, prior[2].size
    assert X.shape == (T, n) and P.shape == (T, n, n) and D.shape == (T, p)
    assert Pd.shape == (T, p, p) and X.dtype == dt
    b = make(m, name, prior, Y.shape[1])
    for t in range(T):
        b.predict(**dyn(model, t))
        b.update(Y[t], **meas(model, t + 1))
        assert same_bits(X[t], b.x) and same_bits(P[t], b.P), t
        assert same_bits(D[t], b.d) and same_bits(Pd[t], b.Pd), t
    # the step of the missing row is the prediction alone
    c = make(m, name, prior, Y.shape[1])
    c.filter(Y[:4], **{key: model[key][:5] for key in model})
    c.predict(**dyn(model, 4))
    assert same_bits(c.x, X[4]) and same_bits(c.P, P[4])
    # constant matrices give the bits of their stacks
    e = make(m, name, prior, Y.shape[1])
    assert same_bits(e.filter(Y, **{key: model[key][0] for key in model})[0], X)
    # and the rows without a gap follow the vector
    assert rel_err(X[3], np.array(out["xf"][3])) <= TOL[dt]


def test_askf_equals_otskf(mod):
    """The two filters are one estimator (the C tests' 1e-9 in double)."""
    m, dt = mod
    model, Y, prior, _ = ex1("ASKF")
    A = make(m, "ASKF", prior, Y.shape[1]).filter(Y, **model)
    O = make(m, "OTSKF", prior, Y.shape[1]).filter(Y, **model)
    for a, o in zip(A, O):
        assert rel_err(o, a) <= (1e-9 if dt == np.float64 else 1e-4)


@pytest.mark.parametrize("name", CLASSES)
@pytest.mark.parametrize("seed", range(4))
def test_failures_leave_the_filter_bit_identical(mod, name, seed):
    m, dt = mod
    rng = np.random.default_rng(800 + seed)
    model, Y, prior, _ = ex1(name)
    mm, n, p = Y.shape[1], prior[0].size, prior[2].size
    f, twin = make(m, name, prior, mm), make(m, name, prior, mm)
    for g in (f, twin):
        g.predict(**dyn(model, 0))
        g.update(Y[0], **meas(model, 1))
        g.predict(**dyn(model, 1))
    fields = ("x", "P", "d", "Pd") + (("X", "PX") if name == "ASKF" else ("xt", "Px", "U", "V"))
    state = lambda g: tuple(getattr(g, a).tobytes() for a in fields)  # noqa: E731
    want = state(twin)
    s, d = meas(model, 2), dyn(model, 2)

    poke = poker(rng)

    y_part = Y[1].copy()
    y_part[0] = np.nan
    bad = [
        (lambda: f.update(y_part, **s), dkf.NonFiniteError, "y"),
        (lambda: f.update(poke(Y[1], np.inf), **s), dkf.NonFiniteError, "y"),
        (lambda: f.update(Y[1], **{**s, "H": poke(s["H"], np.nan)}), dkf.NonFiniteError, "H"),
        (lambda: f.update(Y[1], **{**s, "R": -1e3 * np.eye(mm)}), dkf.NotSPDError, None),
        (lambda: f.predict(**{**d, "Q": poke(d["Q"], np.inf)}), dkf.NonFiniteError, "Q"),
        (lambda: f.predict(**{**d, "Rd": -1e3 * np.eye(p)}), dkf.NotSPDError, None),
        (lambda: f.predict(**{**d, "F": np.eye(n + 1)}), ValueError, None),
        (lambda: f.update(Y[1][:-1], **s), ValueError, None),
        (lambda: f.update(Y[1], **{**s, "D": s["D"].astype(complex)}), TypeError, None),
        (lambda: f.filter(Y[:5], **model), ValueError, None),
    ]
    if name == "OTSKF":
        bad += [
            (lambda: f.predict(**{**d, "B": np.zeros((p, p))}), dkf.SingularError, "B"),
            (lambda: f.update(Y[1], **{**s, "D": np.zeros((mm, p))}), dkf.RankError, "D"),
        ]
    assert_refused_untouched(bad, rng, lambda: state(f), want, name)
    for g in (f, twin):
        g.update(Y[1], **s)
    assert state(f) == state(twin)


@pytest.mark.parametrize("name", CLASSES)
def test_filter_failure_names_the_step_and_undoes_it(mod, name):
    m, _ = mod
    model, Y, prior, _ = ex1(name)
    f = make(m, name, prior, Y.shape[1])
    f.predict(**dyn(model, 0))
    before = (f.x.tobytes(), f.P.tobytes(), f.d.tobytes(), f.Pd.tobytes())
    R = model["R"].copy()
    R[8] = -1e3 * np.eye(R.shape[1])
    with pytest.raises(dkf.NotSPDError, match=rf"^{name}.filter, step 7: .*update: ") as info:
        f.filter(Y, **{**model, "R": R})
    assert info.value.step == 7
    Yb = Y.copy()
    Yb[3, 1] = np.nan
    with pytest.raises(dkf.NonFiniteError, match=r"step 3: .*update: y not finite .*partly missing"):
        f.filter(Yb, **model)
    assert (f.x.tobytes(), f.P.tobytes(), f.d.tobytes(), f.Pd.tobytes()) == before


def test_askf_cross_prior():
    """Pxd0 enters P^a; the OTSKF starts with x and d uncorrelated."""
    _, Y, prior, _ = ex1("ASKF")
    n, p = prior[0].size, prior[2].size
    Pxd0 = np.full((n, p), 0.1)
    f = dkf.ASKF(*prior, m=Y.shape[1], Pxd0=Pxd0)
    assert same_bits(f.PX[:n, n:], Pxd0) and same_bits(f.PX[n:, :n], Pxd0.T)
    with pytest.raises(dkf.NotSPDError) as info:
        dkf.ASKF(*prior, m=Y.shape[1], Pxd0=np.full((n, p), 1e3))
    assert info.value.matrix == "P0"
    with pytest.raises(TypeError):
        dkf.OTSKF(*prior, m=Y.shape[1], Pxd0=Pxd0)
