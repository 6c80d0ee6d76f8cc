"""dkf.UIF (dkf/uif.h): the seed-004 vectors of RTSF, NRTSF-DF and NRTSF
(the files tests/test_uif_vectors.c checks), filter() against its loop of
step() bit for bit, the RTSF's refusal of a rank-deficient D, and failures
that leave the filter as it was."""

import numpy as np
import pytest

import dkf
from conftest import assert_refused_untouched, load_vector, poker, rel_err, same_bits

# tests/test_uif_vectors.c's tolerances (the vectors' README): double
# 1e-9; float 1e-3 (a step costs a few Cholesky solves with cond ~1e2, and
# rounding the inputs to float32 alone moves the outputs by 5.6e-6).
TOL = {np.float64: 1e-9, np.float32: 1e-3}
FIELDS = ("x_pred", "P_pred", "Rtilde", "d", "Pd", "x", "Px", "K", "L")
# the vector files and the kinds that run them (NRTSF_DF reproduces the
# RTSF on the RTSF's full-rank system)
RUNS = [("s004_rtsf", "RTSF"), ("s004_rtsf", "NRTSF_DF"), ("s004_nrtsf_df", "NRTSF_DF"),
        ("s004_nrtsf", "NRTSF")]


def arr(v):
    return np.atleast_2d(np.array(v, dtype=np.float64))


def load(name):
    """The vector: (x0, P0), the model (one matrix each: the files are time
    invariant), Y indexed by the time (NRTSF: row 0 unused), the steps."""
    v = load_vector(f"uif/{name}.json")
    assert v["time_varying"] is False
    model = {key: arr(val) for key, val in v["model"].items()}
    steps = v["steps"]
    first = steps[0]["k"]
    assert [s["k"] for s in steps] == list(range(first, first + len(steps)))
    Y = np.full((first + len(steps), model["H"].shape[0]), np.nan)
    for s in steps:
        Y[s["k"]] = np.array(s["inputs"]["y"], dtype=np.float64)
    x0 = np.array(v["init"]["x0"], dtype=np.float64).reshape(-1)
    return x0, arr(v["init"]["P0"]), model, Y, steps, v


def make(m, kind, x0, P0, model):
    return m.UIF(x0, P0, m=model["H"].shape[0], p=model["G"].shape[1], kind=kind)


def step_args(kind, model, k):
    a = {"H": model["H"], "R": model["R"]}
    if kind != "NRTSF":
        a["D"] = model["D"]
    if k > 0:
        a.update(F=model["F"], G=model["G"], Q=model["Q"])
    return a


@pytest.mark.parametrize("name,kind", RUNS)
def test_matches_seed004_vector(mod, name, kind):
    m, dt = mod
    x0, P0, model, Y, steps, v = load(name)
    f = make(m, kind, x0, P0, model)
    p = f.p
    for s in steps:
        k = s["k"]
        f.step(Y[k], **step_args(kind, model, k))
        exp = s["expected"]
        for key in FIELDS + ("Pxd_extra" if kind == "NRTSF" else "Pxd",):
            got = getattr(f, "Pxd" if key == "Pxd_extra" else key)
            assert got.dtype == dt
            want = np.array(exp[key], dtype=np.float64).reshape(got.shape)
            assert rel_err(got, want) <= TOL[dt], (key, k, rel_err(got, want))
        if v["filter"] == "rtsf":  # full-rank D: proj = I
            assert rel_err(f.M, np.array(exp["M"]).reshape(f.M.shape)) <= TOL[dt]
            assert f.rank == p and rel_err(f.proj, np.eye(p)) <= TOL[dt]
            assert f.estimable == [2] * p
        else:
            assert f.rank == exp["rank"]
            assert rel_err(f.proj, np.array(exp["proj"]).reshape(p, p)) <= TOL[dt]
        assert f.k == k + (1 if kind != "NRTSF" else 0)
    assert f.kind == kind and f.bias_steps >= 0


@pytest.mark.parametrize("name,kind", RUNS)
def test_filter_equals_its_steps(mod, name, kind):
    m, dt = mod
    x0, P0, model, Y, steps, _ = load(name)
    a = make(m, kind, x0, P0, model)
    T = Y.shape[0]
    # stacks indexed by the time 0..T-1 give the bits of one matrix each
    stacked = {key: np.stack([val] * T) for key, val in model.items()}
    X, Px, D, Pd = a.filter(Y, **stacked)
    first = 1 if kind == "NRTSF" else 0
    S, n, p = T - first, a.n, a.p
    assert X.shape == (S, n) and Px.shape == (S, n, n) and D.shape == (S, p)
    assert Pd.shape == (S, p, p) and X.dtype == dt
    b = make(m, kind, x0, P0, model)
    for k in range(first, T):
        b.step(Y[k], **step_args(kind, model, k))
        j = k - first
        assert same_bits(X[j], b.x) and same_bits(Px[j], b.Px), k
        assert same_bits(D[j], b.d) and same_bits(Pd[j], b.Pd), k
    assert a.k == b.k
    for key in ("x", "Px", "d", "Pd", "Pxd", "K", "L", "M", "proj"):
        assert same_bits(getattr(a, key), getattr(b, key)), key
    want = np.array(steps[-1]["expected"]["x"])
    assert rel_err(X[-1], want) <= TOL[dt]


def test_rtsf_refuses_a_rank_deficient_D(mod):
    """The RTSF file's expect_error_case: the paper's D (rank 2 < p = 3) is
    a dkf.RankError for the RTSF, which NRTSF_DF takes."""
    m, _ = mod
    x0, P0, model, Y, _, v = load("s004_rtsf")
    D = arr(v["expect_error_case"]["H"])
    f = make(m, "RTSF", x0, P0, model)
    args = {**step_args("RTSF", model, 0), "D": D}
    with pytest.raises(dkf.RankError, match=r"^UIF.step: .*D lacks full column rank") as info:
        f.step(Y[0], **args)
    assert info.value.matrix == "D" and f.k == 0
    g = make(m, "NRTSF_DF", x0, P0, model)
    g.step(Y[0], **args)
    assert g.rank == 2 and g.k == 1


@pytest.mark.parametrize("kind", ["RTSF", "NRTSF_DF", "NRTSF"])
@pytest.mark.parametrize("seed", range(3))
def test_failures_leave_the_filter_bit_identical(mod, kind, seed):
    m, dt = mod
    rng = np.random.default_rng(900 + seed)
    poke = poker(rng)
    name = {"RTSF": "s004_rtsf", "NRTSF_DF": "s004_nrtsf_df", "NRTSF": "s004_nrtsf"}[kind]
    x0, P0, model, Y, _, _ = load(name)
    f, twin = make(m, kind, x0, P0, model), make(m, kind, x0, P0, model)
    k0 = 1 if kind == "NRTSF" else 0
    for g in (f, twin):
        g.step(Y[k0], **step_args(kind, model, k0))
    fields = ("x", "Px", "d", "Pd", "Pxd", "x_pred", "P_pred", "Rtilde", "K", "L", "M", "proj")
    state = lambda: (tuple(getattr(f, a).tobytes() for a in fields),  # noqa: E731
                     f.k, f.rank, f.estimable, f.bias_steps, f.bias_risk)
    want = state()
    k = k0 + 1
    s = step_args(kind, model, k)
    mm = model["H"].shape[0]
    bad = [
        (lambda: f.step(poke(Y[k], np.nan), **s), dkf.NonFiniteError, "y"),
        (lambda: f.step(Y[k], **{**s, "G": poke(s["G"], np.inf)}), dkf.NonFiniteError, "G"),
        (lambda: f.step(Y[k], **{**s, "R": -np.eye(mm)}), dkf.NotSPDError, None),
        (lambda: f.step(Y[k], **{**s, "F": None, "G": None, "Q": None}), dkf.StateError, None),
        (lambda: f.step(Y[k], **{**s, "Q": None}), ValueError, None),
        (lambda: f.step(Y[k][:-1], **s), ValueError, None),
        (lambda: f.step(Y[k], **{**s, "H": s["H"].astype(complex)}), TypeError, None),
        (lambda: f.filter(Y, **model), dkf.StateError, None),
    ]
    if kind == "NRTSF":
        bad.append((lambda: f.step(Y[k], **s, D=np.zeros((mm, f.p))), ValueError, None))
    else:
        bad.append((lambda: f.step(Y[k], **{**s, "D": None}), ValueError, None))
    if kind == "RTSF":
        bad.append((lambda: f.step(Y[k], **{**s, "D": np.zeros_like(s["D"])}), dkf.RankError,
                    "D"))
    assert_refused_untouched(bad, rng, state, want, "UIF")
    for g in (f, twin):
        g.step(Y[k], **s)
    assert state() == (tuple(getattr(twin, a).tobytes() for a in fields), twin.k, twin.rank,
                       twin.estimable, twin.bias_steps, twin.bias_risk)


def test_filter_failure_names_the_step_and_undoes_it(mod):
    m, _ = mod
    x0, P0, model, Y, _, _ = load("s004_nrtsf_df")
    f = make(m, "NRTSF_DF", x0, P0, model)
    before = (f.x.tobytes(), f.Px.tobytes(), f.k)
    Yb = Y.copy()
    Yb[6, 2] = np.inf
    refused = [
        (Yb, model, dkf.NonFiniteError, r"^UIF.filter, step 6: .*y not finite"),
        (Y, {**model, "F": np.stack([model["F"]] * 3)}, ValueError,
         "a stack has one matrix per time 0..T-1"),
    ]
    for Yr, md, exc, pattern in refused:
        with pytest.raises(exc, match=pattern) as info:
            f.filter(Yr, **md)
        assert (f.x.tobytes(), f.Px.tobytes(), f.k) == before
    with pytest.raises(dkf.NonFiniteError) as info:
        f.filter(Yb, **model)
    assert (info.value.step, info.value.matrix) == (6, "y")
    with pytest.raises(ValueError, match="kind must be"):
        m.UIF(x0, P0, m=5, p=3, kind="rtsf")
    with pytest.raises(dkf.RankError):
        m.UIF(x0, P0, m=2, p=3, kind="RTSF")
    f.filter(Y, **model)
    assert f.k == Y.shape[0]
