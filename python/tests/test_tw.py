"""dkf.TWCentral and dkf.TWNetwork (dkf/tw.h, seed 003's Algorithms 1-3):
the golden vectors tests/test_tw_vectors.c checks (every field, every
node), filter() against its loop of steps bit for bit, the NaN rule, and
failures that leave the filter as it was."""

import numpy as np
import pytest

import dkf
from conftest import assert_refused_untouched, load_vector, poker, rel_err, same_bits

# tests/test_tw_vectors.c's tolerances: double 1e-9, float 1e-3.
TOL = {np.float64: 1e-9, np.float32: 1e-3}
# the vectors keep the paper's names (z = d, G = Gpost, Q and Ups = I, vphi = i)
FIELD = {"z": "d", "G": "Gpost", "Q": "I", "Ups": "I", "vphi": "i"}


def weights(v, name, N):
    """A weight matrix of the file as a dense (N, N) array."""
    if name in v:
        return np.array(v[name], dtype=np.float64)
    w = np.zeros((N, N))
    for i, j, val in v[name + "_sparse"]:
        w[i, j] = val
    return w


def load(name):
    """The case: x0, P0, the model (F, G, Q; H, R per node), the adjacency,
    alpha, W, eta, Y per node indexed by the time (row 0, y_0, unused), and
    the steps."""
    v = load_vector(f"uif/{name}.json")
    assert v["time_varying"] is False
    N, T = v["dims"]["N"], len(v["steps"]) + 1
    md = v["model"]
    model = {k: np.array(md[k], dtype=np.float64) for k in ("F", "G", "Q")}
    model["H"] = [np.array(h, dtype=np.float64) for h in md["H"]]
    model["R"] = [np.array(r, dtype=np.float64) for r in md["R"]]
    A = np.zeros((N, N))
    for i, j in v["graph"]["edges"]:
        A[i, j] = A[j, i] = 1
    Y = [np.full((T, h.shape[0]), np.nan) for h in model["H"]]
    for s in v["steps"]:
        for l in range(N):
            Y[l][s["n"]] = s["inputs"]["y"][l]
    x0 = np.array(v["init"]["x0"], dtype=np.float64).reshape(-1)
    P0 = np.array(v["init"]["P0"], dtype=np.float64)
    w = {}
    if "W_consensus" in v or "W_consensus_sparse" in v:
        w = dict(alpha=weights(v, "alpha_diffusion", N), W=weights(v, "W_consensus", N),
                 eta=v["eta"])
    return x0, P0, model, A, w, Y, v["steps"]


def at(Y, t):
    return [y[t] for y in Y]


def compare(f, exp, dt, what, nodes):
    for key, val in exp.items():
        got = getattr(f, FIELD.get(key, key))
        want = np.array(val, dtype=np.float64).reshape(got.shape)
        assert got.dtype == dt
        assert got.shape[0] == nodes or nodes == 1
        assert rel_err(got, want) <= TOL[dt], (what, key, rel_err(got, want))


@pytest.mark.parametrize("name", ["s003_6node", "s003_200node_alg1"])
def test_central_matches_seed003_vector(mod, name):
    m, dt = mod
    x0, P0, model, _, _, Y, steps = load(name)
    f = m.TWCentral(x0, P0, m_max=2, p=2)
    for s in steps:
        f.step(at(Y, s["n"]), **model)
        compare(f, s["expected"]["alg1"], dt, s["n"], 1)
        assert f.k == s["n"]


@pytest.mark.parametrize("name", ["s003_6node", "s003_200node_alg23"])
def test_network_matches_seed003_vector(mod, name):
    m, dt = mod
    x0, P0, model, A, w, Y, steps = load(name)
    N = A.shape[0]
    for alg in ("alg2", "alg3"):
        f = m.TWNetwork(x0, P0, adjacency=A, m_max=2, p=2)
        for s in steps:
            if alg == "alg2":
                f.diffusion_step(at(Y, s["n"]), alpha=w["alpha"], **model)
            else:
                f.consensus_step(at(Y, s["n"]), W=w["W"], eta=w["eta"], **model)
            compare(f, s["expected"][alg], dt, (alg, s["n"]), N)
        assert f.k == len(steps) and f.N == N
        assert same_bits(f.adjacency, A.astype(dt))
    # the consensus counts its broadcasts: 2 eta per node and step
    assert f.broadcasts == 2 * w["eta"] * N * len(steps)


def test_filter_equals_its_steps(mod):
    m, dt = mod
    x0, P0, model, A, w, Y, steps = load("s003_6node")
    T, N = Y[0].shape[0], A.shape[0]
    # stacks indexed by the time give the bits of one matrix each
    stk = {k: np.stack([model[k]] * T) for k in ("F", "G", "Q")}
    stk["H"] = [np.stack([h] * T) for h in model["H"]]
    stk["R"] = model["R"]
    c = m.TWCentral(x0, P0, m_max=2, p=2)
    X, P, D = c.filter(Y, **stk)
    assert X.shape == (T - 1, 4) and P.shape == (T - 1, 4, 4) and D.shape == (T - 1, 2)
    b = m.TWCentral(x0, P0, m_max=2, p=2)
    for t in range(1, T):
        b.step(at(Y, t), **model)
        assert same_bits(X[t - 1], b.x) and same_bits(P[t - 1], b.P) and same_bits(D[t - 1], b.d)
    for key in ("x", "P", "d", "phi", "Phi", "I", "i", "S", "Gpost", "psi", "Ploc"):
        assert same_bits(getattr(c, key), getattr(b, key)), key
    assert rel_err(X[-1], np.array(steps[-1]["expected"]["alg1"]["x"])) <= TOL[dt]
    for kw, call in ((dict(alpha=w["alpha"]), "diffusion_step"),
                     (dict(W=w["W"], eta=w["eta"]), "consensus_step")):
        a = m.TWNetwork(x0, P0, adjacency=A, m_max=2, p=2)
        X, P, D = a.filter(Y, **stk, **kw)
        assert X.shape == (T - 1, N, 4) and P.shape == (T - 1, N, 4, 4) and D.shape == (T - 1, N, 2)
        b = m.TWNetwork(x0, P0, adjacency=A, m_max=2, p=2)
        for t in range(1, T):
            getattr(b, call)(at(Y, t), **kw, **model)
            assert same_bits(X[t - 1], b.x) and same_bits(P[t - 1], b.P), (call, t)
            assert same_bits(D[t - 1], b.d)
        assert a.k == b.k == a.steps == b.steps == T - 1 and a.reals_sent == b.reals_sent


def test_nan_is_a_missing_component(mod):
    """A NaN in y leaves that component out (the rows of H, the rows and
    columns of R): the same bits as the smaller sensor; an all-NaN sensor
    adds nothing to the centralised sum, and a network node refuses it."""
    m, _ = mod
    x0, P0, model, A, w, Y, _ = load("s003_6node")
    y = at(Y, 1)
    y[2] = np.array([np.nan, y[2][1]])
    y[4] = np.full(2, np.nan)
    f = m.TWCentral(x0, P0, m_max=2, p=2)
    f.step(y, **model)
    keep = [l for l in range(6) if l != 4]
    H = [model["H"][l] if l != 2 else model["H"][l][1:] for l in keep]
    R = [model["R"][l] if l != 2 else model["R"][l][1:, 1:] for l in keep]
    g = m.TWCentral(x0, P0, m_max=2, p=2)
    g.step([y[l] if l != 2 else y[l][1:] for l in keep], F=model["F"], G=model["G"],
           Q=model["Q"], H=H, R=R)
    assert same_bits(f.x, g.x) and same_bits(f.P, g.P) and same_bits(f.d, g.d)
    net = m.TWNetwork(x0, P0, adjacency=A, m_max=2, p=2)
    with pytest.raises(dkf.NonFiniteError, match="node 4: y all missing") as info:
        net.diffusion_step(y, alpha=w["alpha"], **model)
    assert info.value.matrix == "y" and net.k == 0
    y[4] = at(Y, 1)[4]
    net.diffusion_step(y, alpha=w["alpha"], **model)
    assert net.k == 1


@pytest.mark.parametrize("seed", range(3))
def test_failures_leave_the_filters_bit_identical(mod, seed):
    m, _ = mod
    rng = np.random.default_rng(300 + seed)
    poke = poker(rng)
    x0, P0, model, A, w, Y, _ = load("s003_6node")
    fields = ("x", "P", "d", "phi", "Phi", "I", "i", "phi_post", "Phi_post", "S", "Gpost", "psi",
              "Ploc")
    c = m.TWCentral(x0, P0, m_max=2, p=2)
    c.step(at(Y, 1), **model)
    state = lambda: (tuple(getattr(c, a).tobytes() for a in fields), c.k)  # noqa: E731
    want = state()
    y = at(Y, 2)
    bad_y = list(y)
    bad_y[3] = poke(y[3], np.inf)
    bad = [
        (lambda: c.step(bad_y, **model), dkf.NonFiniteError, "y"),
        (lambda: c.step(y, **{**model, "G": poke(model["G"], np.nan)}), dkf.NonFiniteError, "G"),
        (lambda: c.step(y, **{**model, "R": [-np.eye(2)] * 6}), dkf.NotSPDError, None),
        (lambda: c.step(y[:1], **{**model, "H": [np.zeros((2, 4))], "R": [np.eye(2)]}),
         dkf.RankError, "G"),
        (lambda: c.step(y, **{**model, "H": model["H"][:5]}), ValueError, None),
        (lambda: c.step([np.ones(3)] * 6, **model), dkf.CapacityError, "y"),
        (lambda: c.filter(Y, **model), dkf.StateError, None),
    ]
    assert_refused_untouched(bad, rng, state, want, "TWCentral")

    net = m.TWNetwork(x0, P0, adjacency=A, m_max=2, p=2)
    net.consensus_step(at(Y, 1), W=w["W"], eta=3, **model)
    nstate = lambda: (tuple(getattr(net, a).tobytes() for a in fields), net.k,  # noqa: E731
                      net.reals_sent, net.broadcasts, net.steps)
    want = nstate()
    i, j = np.argwhere(A + np.eye(6) == 0)[0]  # two nodes without a link
    off = w["W"].copy()
    off[i, j] = off[j, i] = 0.1
    bad = [
        (lambda: net.consensus_step(bad_y, W=w["W"], eta=3, **model), dkf.NonFiniteError, "y"),
        (lambda: net.consensus_step(y, W=w["alpha"] * 1.5, eta=3, **model), dkf.WeightsError, "W"),
        (lambda: net.diffusion_step(y, alpha=w["alpha"] * 2, **model), dkf.WeightsError,
         "alpha"),
        (lambda: net.consensus_step(y, W=off, eta=3, **model), dkf.GraphError, "W"),
        (lambda: net.consensus_step(y, W=w["W"], eta=10**7, **model), dkf.ArgError, "eta"),
        (lambda: net.diffusion_step(y, alpha=w["alpha"], **{**model, "Q": -np.eye(4)}),
         dkf.NotSPDError, None),
        (lambda: net.filter(Y, W=w["W"], eta=3, **model), dkf.StateError, None),
        (lambda: net.diffusion_step(y[:5], alpha=w["alpha"], **model), ValueError, None),
    ]
    assert_refused_untouched(bad, rng, nstate, want, "TWNetwork")


def test_filter_refusals_name_the_step_and_undo_it(mod):
    m, _ = mod
    x0, P0, model, A, w, Y, _ = load("s003_6node")
    Yb = [y.copy() for y in Y]
    Yb[2][4, 0] = np.inf
    net = m.TWNetwork(x0, P0, adjacency=A, m_max=2, p=2)
    c = m.TWCentral(x0, P0, m_max=2, p=2)
    before = (net.x.tobytes(), net.P.tobytes(), net.k, c.x.tobytes(), c.k)
    for call, exc, pattern in [
        (lambda: net.filter(Yb, W=w["W"], eta=3, **model), dkf.NonFiniteError,
         r"^TWNetwork.filter, step 4: .*node 2: y not finite"),
        (lambda: c.filter(Yb, **model), dkf.NonFiniteError, r"^TWCentral.filter, step 4: "),
        (lambda: net.filter(Y, W=w["W"], alpha=w["alpha"], **model), ValueError, "not both"),
        (lambda: net.filter(Y, W=w["W"], **model), ValueError, "needs eta"),
        (lambda: c.filter(Y, **{**model, "F": np.stack([model["F"]] * 3)}), ValueError, "F is a"),
        (lambda: c.filter(Y[:1] + [Y[0][:, :1]] * 5, **model), ValueError, None),
    ]:
        with pytest.raises(exc, match=pattern):
            call()
        assert (net.x.tobytes(), net.P.tobytes(), net.k, c.x.tobytes(), c.k) == before


def test_graph_refusals(mod):
    m, _ = mod
    x0, P0, model, A, w, Y, _ = load("s003_6node")
    i, j = np.argwhere(A + np.eye(6) == 0)[0]
    Ab = A.copy()
    Ab[i, j] = 1  # one direction only
    with pytest.raises(dkf.GraphError) as info:
        m.TWNetwork(x0, P0, adjacency=Ab, m_max=2, p=2)
    assert info.value.matrix == "adjacency"
    with pytest.raises(ValueError, match="square"):
        m.TWNetwork(x0, P0, adjacency=A[:5], m_max=2, p=2)
    with pytest.raises(dkf.RankError):
        m.TWCentral(x0, P0, m_max=2, p=5)
