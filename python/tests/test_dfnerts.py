"""dkf.DFNERTS (dkf/dfnerts.h): seed 001's consensus network, DF-DNERTSIF
and DF-CKF (p = 0), against the vector tests/test_dfnerts_vectors.c checks
(every case, step, node and field), filter() against its loop bit for bit,
a node's callback exception as the step's failure, and failures that leave
the network as it was."""

import numpy as np
import pytest

import dkf
from conftest import assert_refused_untouched, load_vector, poker, rel_err, same_bits
from nl_models import radar_model

# tests/test_dfnerts_vectors.c's tolerances: double 1e-8, float 5e-4
TOL = {np.float64: 1e-8, np.float32: 5e-4}
# the fields that depend on a node's m: a list, one array per node
PER_M = {"z_hat", "R_tilde", "nu", "M", "Rbar_inv"}


def arr(v):
    return np.array(v, dtype=np.float64)


def load(m, c):
    """The network of case c: models, priors, adjacency, W, the per-node
    Q, R, and Z per node indexed by the time (row 0 unused)."""
    N = len(c["node_models"])
    models = []
    for mo in c["node_models"]:
        fixed = mo.get("omega_fixed") if mo["family"] == "s1_ckf" else None
        models.append(radar_model(m, mo["sensor_xy"], omega_fixed=fixed))
    p = models[0].p
    init = c["init_per_node"]
    pri = dict(x0=[arr(i["x0"]) for i in init], P0=[arr(i["Px0"]) for i in init])
    if p:
        pri.update(d0=[arr(i["d0"]) for i in init], Pd0=[arr(i["Pd0"]) for i in init],
                   Pxd0=[arr(i["Pxd0"]) for i in init])
    A = np.zeros((N, N))
    for i, j in c["edges"]:
        A[i, j] = A[j, i] = 1
    Q = [arr(mo["Q"]) for mo in c["node_models"]]
    R = [arr(mo["R"]) for mo in c["node_models"]]
    T = len(c["steps"]) + 1
    Z = [np.full((T, md.m), np.nan) for md in models]
    for s in c["steps"]:
        for l in range(N):
            Z[l][s["k"]] = s["z"][l]
    run = dict(Q=Q, R=R, W=arr(c["W"]), Tp=c["Tp"], scale=c["scale"])
    return models, pri, A, run, Z


def make(m, c):
    models, pri, A, run, Z = load(m, c)
    x0, P0 = pri.pop("x0"), pri.pop("P0")
    return m.DFNERTS(models, x0, P0, adjacency=A, kind="DNERTSIF", variant="paper", **pri), run, Z


CASES = [c["name"] for c in load_vector("infofusion/df_dnertsif.json")["cases"]]


def case(name):
    return next(c for c in load_vector("infofusion/df_dnertsif.json")["cases"] if c["name"] == name)


@pytest.mark.parametrize("name", CASES)
def test_matches_the_df_dnertsif_vector(mod, name):
    m, dt = mod
    c = case(name)
    net, run, Z = make(m, c)
    for s in c["steps"]:
        net.step([z[s["k"]] for z in Z], **run)
        assert net.k == s["k"]
        for key in s["expected_per_node"][0]:
            got = getattr(net, key)
            for l, exp in enumerate(s["expected_per_node"]):
                g = got[l]
                want = arr(exp[key])
                if want.size == 0:  # p = 0: d, Pd, Pxd are empty
                    assert g.size == 0
                    continue
                assert g.dtype == dt and (key in PER_M) == isinstance(got, list)
                assert rel_err(g, want.reshape(g.shape)) <= TOL[dt], (name, s["k"], l, key)
    N = net.N
    assert net.broadcasts == len(c["steps"]) * N * c["Tp"]
    assert net.reals_sent == net.broadcasts * (4 + 10)  # PAPER: packets of y and packed Y


def test_filter_equals_its_steps(mod):
    m, dt = mod
    c = case("s1_4node_Tp3_scale4")
    a, run, Z = make(m, c)
    T, N = Z[0].shape[0], a.N
    X, Px, D, Pd = a.filter(Z, **{**run, "Q": np.stack([run["Q"][0]] * T)})
    assert X.shape == (T - 1, N, 4) and Px.shape == (T - 1, N, 4, 4) and D.shape == (T - 1, N, 1)
    assert Pd.shape == (T - 1, N, 1, 1) and X.dtype == dt
    b, _, _ = make(m, c)
    for t in range(1, T):
        b.step([z[t] for z in Z], **run)
        assert same_bits(X[t - 1], b.x) and same_bits(Px[t - 1], b.Px), t
        assert same_bits(D[t - 1], b.d) and same_bits(Pd[t - 1], b.Pd), t
    for key in ("Y", "y", "Pxd", "i", "I"):
        assert same_bits(getattr(a, key), getattr(b, key)), key
    assert a.k == b.k == T - 1 and a.reals_sent == b.reals_sent
    assert rel_err(X[-1][0], arr(c["steps"][-1]["expected_per_node"][0]["x"])) <= TOL[dt]


@pytest.mark.parametrize("seed", range(2))
def test_failures_leave_the_network_bit_identical(mod, seed):
    m, _ = mod
    rng = np.random.default_rng(700 + seed)
    poke = poker(rng)
    c = case("s1_4node_Tp3_scale1")
    net, run, Z = make(m, c)
    net.step([z[1] for z in Z], **run)
    fields = ("x", "Px", "d", "Pd", "Pxd", "x_pred", "P_pred", "Y", "y", "i", "I")
    state = lambda: (tuple(getattr(net, a).tobytes() for a in fields), net.k,  # noqa: E731
                     net.reals_sent, net.broadcasts)
    want = state()
    z = [zz[2] for zz in Z]
    zb = list(z)
    zb[2] = poke(z[2], np.inf)
    W = run["W"]
    i, j = np.argwhere(np.eye(4) + (W > 0) == 0)[0]  # two nodes without a link
    Woff = W.copy()
    Woff[i, j] = Woff[j, i] = 0.1
    Zb = [zz.copy() for zz in Z]
    Zb[1][3, 0] = np.inf
    bad = [
        (lambda: net.step(zb, **run), dkf.NonFiniteError, "z"),
        (lambda: net.step(z, **{**run, "W": W * 1.5}), dkf.WeightsError, "W"),
        (lambda: net.step(z, **{**run, "W": Woff}), dkf.GraphError, "W"),
        (lambda: net.step(z, **{**run, "Tp": 0}), dkf.ArgError, None),
        (lambda: net.step(z, **{**run, "R": [-r for r in run["R"]]}), dkf.NotSPDError, None),
        (lambda: net.step(z[:3], **run), ValueError, None),
        (lambda: net.filter(Z, **run), dkf.StateError, None),
    ]
    assert_refused_untouched(bad, rng, state, want, "DFNERTS")
    with pytest.raises(dkf.NonFiniteError) as info:
        net.step(zb, **run)
    assert info.value.node == 2 and "node 2" in str(info.value)
    fresh, _, _ = make(m, c)
    with pytest.raises(dkf.NonFiniteError) as info:
        fresh.filter(Zb, **run)
    assert (info.value.step, info.value.node, info.value.matrix) == (3, 1, "z") and fresh.k == 0


def armed_case(m):
    """Case s1_4node_Tp3_scale1 whose node 3's h raises OverflowError once
    `armed` (returned last) is not empty."""
    models, pri, A, run, Z = load(m, case("s1_4node_Tp3_scale1"))
    inner = models[3]
    armed = []

    def h(x, d, u):
        if armed:
            raise OverflowError("node 3's sensor")
        return inner.h(x, d, u)

    models[3] = m.NLModel(inner.f, h, n=4, m=3, p=1, angles=[1])
    return models, pri, A, run, Z, armed


def test_a_nodes_callback_exception_fails_the_step(mod):
    m, _ = mod
    models, pri, A, run, Z, armed = armed_case(m)
    x0, P0 = pri.pop("x0"), pri.pop("P0")
    net = m.DFNERTS(models, x0, P0, adjacency=A, **pri)
    assert (net.kind, net.variant, net.m) == ("DNERTSIF", "paper", [3, 3, 3, 3])
    net.step([z[1] for z in Z], **run)
    before = (net.x.tobytes(), net.Px.tobytes(), net.k)
    armed.append(1)
    with pytest.raises(dkf.ModelError, match=r"^DFNERTS.step: .*node 3: model.h raised "
                                             "OverflowError") as info:
        net.step([z[2] for z in Z], **run)
    assert info.value.node == 3 and isinstance(info.value.__cause__, OverflowError)
    assert (net.x.tobytes(), net.Px.tobytes(), net.k) == before
    with pytest.raises(dkf.StateError):
        net.filter(Z, **run)
    fresh = m.DFNERTS(models, x0, P0, adjacency=A, **pri)
    with pytest.raises(dkf.ModelError) as info:
        fresh.filter(Z, **run)
    assert info.value.step == 1 and info.value.node == 3 and fresh.k == 0
    with pytest.raises(ValueError, match="variant must be"):
        m.DFNERTS(models, x0, P0, adjacency=A, variant="consistent", **pri)
    with pytest.raises(ValueError, match="kind must be"):
        m.DFNERTS(models, x0, P0, adjacency=A, kind="DNERTSF", **pri)
