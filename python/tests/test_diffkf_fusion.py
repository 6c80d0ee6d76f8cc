"""dkf.DiffKFFusionCentre (dkf/diffkf_fusion.h) fed by dkf.DifferenceKF
nodes: the fused estimates of the multi-sensor golden vectors
(tests/test_diffkf_fusion.c's), the recovered data, and failures that leave
the centre as it was."""

import numpy as np
import pytest

import dkf
from conftest import load_vector, model_at, rel_err

# tests/test_diffkf_fusion.c's tolerances: double, the vectors' 1e-9 (they
# equal a batch LMMSE to <= 6e-14, 1.6e-11 for ex3); float, the local
# filters' 1e-4 plus the recovery's |dz error| ~ eps |x| / sigma_min(K^i)
# (<= 1.2e-7 * 300 / 0.16 ~ 2e-4 on z^i), which the central gain carries
# to x: 1e-3, stable over the 50 steps.
TOL = {np.float64: 1e-9, np.float32: 1e-3}
FILES = ["ex3_multi.json", "tv3_multi.json", "tv4_multi.json", "cond6_multi.json"]


class World:
    """A vector's nodes (DifferenceKF each), their centre and the model."""

    def __init__(self, mod, name):
        self.v = v = load_vector("diffkf/" + name)
        self.n = v["dims"]["m"]
        self.m, self.p = list(v["dims"]["n_i"]), list(v["dims"]["p_i"])
        self.l, self.N = len(self.p), len(v["k"])
        self.model, self.sens = v["model"], v["model"]["sensors"]
        init = v["init"]
        x0 = np.array(init["x00"], dtype=np.float64).reshape(-1)
        P0c = np.array(init["P00_central"], dtype=np.float64)
        P0l = [np.array(P, dtype=np.float64) for P in init["P00_local"]]
        self.nodes = [mod.DifferenceKF(x0, P0l[i], m=self.m[i], p=self.p[i]) for i in range(self.l)]
        self.fc = mod.DiffKFFusionCentre(x0, P0c, m=self.m, p=self.p, P0_local=P0l)

    def dyn(self, k):
        return model_at(self.model, "F", k), model_at(self.model, "Q", k)

    def sensor(self, i, k, kmeas):
        s = self.sens[i]
        return dict(B=model_at(s, "B", k), Rd=model_at(s, "Rd", k), H=model_at(s, "H", kmeas),
                    D=model_at(s, "D", kmeas), R=model_at(s, "R", kmeas))

    def y(self, i, k):
        return np.array(self.v["y"][i]["values"][k - 1], dtype=np.float64).reshape(-1)

    def start(self):
        F0, Q0 = self.dyn(0)
        for i, node in enumerate(self.nodes):
            s = self.sensor(i, 1, 1)
            node.start(self.y(i, 1), s["H"], s["D"], s["R"], F0=F0, Q0=Q0)
        self.fc.start(F0, Q0, [self.sensor(i, 1, 1) for i in range(self.l)])

    def nodes_step(self, k):
        """The nodes' step k (y_{k+1}); returns the centre's arguments."""
        F, Q = self.dyn(k)
        sensors = [self.sensor(i, k, k + 1) for i in range(self.l)]
        for i, node in enumerate(self.nodes):
            s = sensors[i]
            node.step(self.y(i, k + 1), F=F, Q=Q, B=s["B"], Rd=s["Rd"], H=s["H"], D=s["D"],
                      R=s["R"])
        return F, Q, sensors, [node.message() for node in self.nodes]


@pytest.mark.parametrize("name", FILES)
def test_fused_estimates_match_vectors(mod, name):
    m, dt = mod
    w = World(m, name)
    w.start()
    fused = w.v["outputs"]["fused"]
    tol = TOL[dt]
    for j in range(w.N):
        k = j + 1
        assert rel_err(w.fc.xn, fused["xp"][j]) <= tol and rel_err(w.fc.Pn, fused["Pp"][j]) <= tol
        F, Q, sensors, msgs = w.nodes_step(k)
        assert all(msg[0] == k for msg in msgs)
        w.fc.step(F, Q, sensors, msgs)
        assert w.fc.k == k and w.fc.xf.dtype == dt
        assert rel_err(w.fc.xf, fused["xf"][j]) <= tol, (name, k)
        assert rel_err(w.fc.Pf, fused["Pf"][j]) <= tol, (name, k)
        for i, node in enumerate(w.nodes):
            z, dz = w.fc.recovered(i)
            assert rel_err(z, node.z) <= tol and rel_err(dz, node.dz) <= tol, (name, k, i)


def test_failures_leave_the_centre_bit_identical(mod):
    m, dt = mod
    w, twin = World(m, "tv3_multi.json"), World(m, "tv3_multi.json")
    for x in (w, twin):
        x.start()
        x.fc.step(*x.nodes_step(1))
    F, Q, sensors, msgs = w.nodes_step(2)
    fields = ("xf", "Pf", "xn", "Pn", "xp", "z", "dz", "J", "L", "K", "k")

    def state(fc):
        rec = tuple(a.tobytes() for i in range(fc.l) for a in fc.recovered(i))
        return tuple(np.asarray(getattr(fc, a)).tobytes() for a in fields) + rec

    want = state(twin.fc)

    def msg(i, k=None, xf=None):
        out = list(msgs)
        kk, a, b = out[i]
        out[i] = (kk if k is None else k, a if xf is None else xf, b)
        return out

    def sens(i, **kw):
        out = [dict(s) for s in sensors]
        out[i].update(kw)
        return out

    p0 = w.p[0]
    nan_xf = msgs[1][1].copy()
    nan_xf[0] = np.nan
    missing = [dict(s) for s in sensors]
    del missing[2]["Rd"]
    bad = [
        (lambda: w.fc.step(F, Q, sensors, msg(1, k=5)), dkf.StateError, "messages", 1),
        (lambda: w.fc.step(F, Q, sensors, msg(1, xf=nan_xf)), dkf.NonFiniteError, "messages", 1),
        (lambda: w.fc.step(F, Q, sens(0, B=np.zeros((p0, p0))), msgs), dkf.SingularError, "B", 0),
        (lambda: w.fc.step(F, Q, sens(0, D=np.zeros_like(sensors[0]["D"])), msgs), dkf.RankError,
         "D", 0),
        (lambda: w.fc.step(F, Q, sensors, msgs[:-1]), ValueError, None, None),
        (lambda: w.fc.step(F, Q, missing, msgs), ValueError, None, None),
        (lambda: w.fc.step(F, Q, sens(1, H=np.eye(3)), msgs), ValueError, None, None),
        (lambda: w.fc.step(F, Q, [tuple(s.values()) for s in sensors], msgs), TypeError, None,
         None),
        (lambda: w.fc.start(F, Q, sensors), dkf.StateError, None, None),
    ]
    for call, exc, matrix, node in bad:
        with pytest.raises(exc) as info:
            call()
        if issubclass(exc, dkf.Error):
            e = info.value
            assert (e.matrix, e.node) == (matrix, node), str(e)
            assert e.call.startswith("DiffKFFusionCentre.")
            if node is not None:
                assert f"node {node}: " in str(e)
        assert state(w.fc) == want, str(info.value)
    w.fc.step(F, Q, sensors, msgs)
    twin.fc.step(*twin.nodes_step(2))
    assert state(w.fc) == state(twin.fc)


def test_message_before_the_first_step(mod):
    m, _ = mod
    w = World(m, "ex3_multi.json")
    with pytest.raises(dkf.StateError, match="DifferenceKF.message: .*no step yet"):
        w.nodes[0].message()


def test_refused_set_ups_name_the_condition(mod):
    m, _ = mod
    x0, P0 = np.zeros(2), np.eye(2)
    with pytest.raises(dkf.RankError, match=r"node 1: p_i > m_i") as info:
        m.DiffKFFusionCentre(x0, P0, m=[2, 1], p=[1, 2])
    assert info.value.node == 1
    with pytest.raises(dkf.CapacityError, match="stacked capacity"):
        m.DiffKFFusionCentre(x0, P0, m=[30, 30], p=[1, 1])
    with pytest.raises(dkf.NotSPDError) as info:
        m.DiffKFFusionCentre(x0, P0, m=[2, 2], p=[1, 1], P0_local=[None, -P0])
    assert (info.value.matrix, info.value.node) == ("P0_local", 1)
    with pytest.raises(ValueError, match="same number"):
        m.DiffKFFusionCentre(x0, P0, m=[2, 2], p=[1])
