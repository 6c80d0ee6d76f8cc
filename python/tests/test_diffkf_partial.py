"""dkf.DiffKFFusionCentre's degraded steps (dkf_diffkf_fc_step_partial,
restart_node), checkpoints and steady gain, and DifferenceKF's set_time,
set_steady, save and restore: tests/test_diffkf_fusion.c's expectations
through Python, an independent central filter, and failures that leave the
objects as they were."""

import numpy as np
import pytest

import dkf
from conftest import (assert_refused_untouched, load_vector, model_at, poker, rand_spd, rel_err,
                      same_bits)
from test_diffkf_fusion import TOL, World

FIELDS = ("xf", "Pf", "xn", "Pn", "xp", "z", "dz", "J", "L", "K")


def blkdiag(mats):
    mats = [np.atleast_2d(a) for a in mats]
    out = np.zeros((sum(a.shape[0] for a in mats), sum(a.shape[1] for a in mats)))
    r = c = 0
    for a in mats:
        out[r:r + a.shape[0], c:c + a.shape[1]] = a
        r, c = r + a.shape[0], c + a.shape[1]
    return out


def fc_state(fc):
    """Everything a caller sees of a centre, and its checkpoint (all of it)."""
    rec = tuple(a.tobytes() for i in range(fc.l) for a in fc.recovered(i))
    return (tuple(getattr(fc, a).tobytes() for a in FIELDS) + rec +
            (fc.k, tuple(fc.synced), fc.steady, fc.save().tobytes()))


def test_partial_with_every_message_is_step_bit_for_bit(mod):
    m, _ = mod
    a, b = World(m, "tv3_multi.json"), World(m, "tv3_multi.json")
    a.start()
    b.start()
    for k in range(1, a.N + 1):
        a.fc.step(*a.nodes_step(k))
        assert b.fc.step_partial(*b.nodes_step(k)) == [True] * b.l
        assert fc_state(a.fc) == fc_state(b.fc), k


@pytest.mark.parametrize("name, j", [("ex3_multi.json", 1), ("tv4_multi.json", 2)])
def test_a_missing_node_is_the_central_filter_on_the_other_sensors(mod, name, j):
    """Node j's messages never arrive: the centre's masked gain gives the
    centralized Difference KF on the other sensors' stacked model, run here
    directly on their measurements (no recovery involved)."""
    m, dt = mod
    w = World(m, name)
    w.start()
    keep = [i for i in range(w.l) if i != j]
    x0 = np.array(w.v["init"]["x00"], dtype=np.float64).reshape(-1)
    P0 = np.array(w.v["init"]["P00_central"], dtype=np.float64)
    ref = m.DifferenceKF(x0, P0, m=sum(w.m[i] for i in keep), p=sum(w.p[i] for i in keep))

    def stacked(k, kmeas):
        s = [w.sensor(i, k, kmeas) for i in keep]
        y = np.concatenate([w.y(i, kmeas) for i in keep])
        return y, dict(B=blkdiag([x["B"] for x in s]), Rd=blkdiag([x["Rd"] for x in s]),
                       H=np.vstack([x["H"] for x in s]), D=blkdiag([x["D"] for x in s]),
                       R=blkdiag([x["R"] for x in s]))

    F0, Q0 = w.dyn(0)
    y, s = stacked(1, 1)
    ref.start(y, s["H"], s["D"], s["R"], F0=F0, Q0=Q0)
    for k in range(1, w.N + 1):
        F, Q, sensors, msgs = w.nodes_step(k)
        msgs[j] = None
        assert w.fc.step_partial(F, Q, sensors, msgs) == [i != j for i in range(w.l)]
        y, s = stacked(k, k + 1)
        ref.step(y, F=F, Q=Q, **s)
        assert w.fc.z.shape == ref.z.shape == (sum(w.p[i] for i in keep),)
        for key in ("xf", "Pf", "xn", "Pn", "z"):
            assert rel_err(getattr(w.fc, key), getattr(ref, key)) <= TOL[dt], (name, k, key)
        assert w.fc.synced == [i != j for i in range(w.l)]


def restart(w, j, k):
    """Node j restarts at time k: a new DifferenceKF from its P00_local
    prior and any x, started at k without F0, Q0, set to absolute time;
    the centre restarts its replica likewise."""
    P = np.array(w.v["init"]["P00_local"][j], dtype=np.float64)
    s = w.sensor(j, k, k)
    node = type(w.nodes[j])(17.0 * np.arange(w.n) - 3.0, P, m=w.m[j], p=w.p[j])
    node.start(w.y(j, k), s["H"], s["D"], s["R"])
    node.set_time(k - 1)
    assert node.k == k - 1 and node.started
    w.nodes[j] = node
    w.fc.restart_node(j, k, P, {key: s[key] for key in ("H", "D", "R")})
    assert w.fc.synced[j]


@pytest.mark.parametrize("name, seed, rj, ra, rb", [
    ("ex3_multi.json", 31, 0, 0, 0),
    ("tv4_multi.json", 33, 0, 0, 0),
    ("ex3_multi.json", 41, 1, 7, 12),  # node 1 absent for steps 7..12, restarted at 13
    ("tv3_multi.json", 43, 0, 1, 6),  # node 0 starts late, at 7
])
def test_random_losses_and_restarts_follow_the_sync_rule(mod, name, seed, rj, ra, rb):
    """tests/test_diffkf_fusion.c's degraded runs: messages lost at random
    (step 5 all, step 6 none), a node out for a while and restarted. A node
    contributes iff its message is present and its last one was (or it
    restarted); every contributing node's recovered z is its own z."""
    m, dt = mod
    rng = np.random.default_rng(seed)
    w = World(m, name)
    w.start()
    prev = [True] * w.l
    lost = masked = 0
    for k in range(1, w.N + 1):
        if rb and k == rb + 1:
            restart(w, rj, k)
        F, Q, sensors, msgs = w.nodes_step(k)
        present = [k == 6 or (k != 5 and rng.uniform() >= 0.3) for _ in range(w.l)]
        if rb and ra <= k <= rb:
            present[rj] = False
        if rb and k == rb + 1:
            present[rj] = True
        got = w.fc.step_partial(F, Q, sensors, [x if p else None for x, p in zip(msgs, present)])
        assert w.fc.k == k and w.fc.synced == present
        for i in range(w.l):
            restarted = bool(rb) and i == rj and k == rb + 1
            assert got[i] == (present[i] and (prev[i] or restarted)), (k, i)
            if got[i]:
                z, dz = w.fc.recovered(i)
                assert rel_err(z, w.nodes[i].z) <= TOL[dt] and rel_err(dz, w.nodes[i].dz) <= TOL[dt]
            elif not present[i]:  # (a present node's dz is recovered: in sync again)
                assert not np.any(w.fc.recovered(i)[0]) and not np.any(w.fc.recovered(i)[1])
        assert w.fc.z.shape == (sum(p for p, c in zip(w.p, got) if c),)
        lost += present.count(False)
        masked += got.count(False)
        prev = present
    assert masked > lost  # the sync rule masked more than the losses


@pytest.mark.parametrize("name, k0, node", [("ex3_multi.json", 10, 1), ("tv4_multi.json", 7, 2)])
def test_rollback_and_replay_give_the_full_data_centre(mod, name, k0, node):
    """tests/test_diffkf_fusion.c's rollback: node's message of step k0 is
    late; a checkpoint taken before step k0, restored and replayed with it,
    is the centre that never missed it bit for bit (and the vector's fused
    estimate); a save-restore round trip changes no bit."""
    m, dt = mod
    w, full = World(m, name), World(m, name)
    w.start()
    full.start()
    fused = w.v["outputs"]["fused"]
    saved = {}
    for k in range(1, w.N + 1):
        full.fc.step(*full.nodes_step(k))
        F, Q, sensors, msgs = saved[k] = w.nodes_step(k)
        if k == k0:
            ck = w.fc.save()
            assert ck.dtype == dt and ck.ndim == 1
        w.fc.step_partial(F, Q, sensors, [None if (k == k0 and i == node) else x
                                          for i, x in enumerate(msgs)])
        if k == k0 + 3:
            assert rel_err(w.fc.Pf, full.fc.Pf) > 1e-6  # degraded so far
            now = fc_state(w.fc)
            w.fc.restore(w.fc.save())
            assert fc_state(w.fc) == now
            w.fc.restore(ck)
            assert w.fc.k == k0 - 1
            for i in range(k0, k + 1):
                assert w.fc.step_partial(*saved[i]) == [True] * w.l
        if k >= k0 + 3:
            assert same_bits(w.fc.xf, full.fc.xf) and same_bits(w.fc.Pn, full.fc.Pn), k
            assert rel_err(w.fc.xf, fused["xf"][k - 1]) <= TOL[dt]


def test_refused_degraded_calls_leave_the_centre_bit_identical(mod):
    m, dt = mod
    rng = np.random.default_rng(71)
    poke = poker(rng)
    w, twin = World(m, "tv3_multi.json"), World(m, "tv3_multi.json")
    for x in (w, twin):
        x.start()
        x.fc.step(*x.nodes_step(1))
    F, Q, sensors, msgs = w.nodes_step(2)
    want = fc_state(twin.fc)
    part = [msgs[0], None, (msgs[2][0], msgs[2][1], poke(msgs[2][2], np.inf))]
    P = np.array(w.v["init"]["P00_local"][1], dtype=np.float64)
    s1 = {key: w.sensor(1, 2, 2)[key] for key in ("H", "D", "R")}
    s0 = {key: w.sensor(0, 2, 2)[key] for key in ("H", "D", "R")}
    s0_rank = dict(s0, D=np.repeat(s0["D"][:, :1], s0["D"].shape[1], axis=1))
    ck = w.fc.save()
    other = World(m, "ex3_multi.json").fc.save()

    def bad_ck(i, v):
        b = ck.copy()
        b[i] = v
        return b

    bad = [
        (lambda: w.fc.step_partial(F, Q, sensors, part), dkf.NonFiniteError, "messages"),
        (lambda: w.fc.step_partial(F, Q, sensors, part[:2]), ValueError, None),
        (lambda: w.fc.step_partial(F, Q, sensors, [msgs[0], None, (1, 2)]), ValueError, None),
        (lambda: w.fc.restart_node(1, w.fc.k + 2, P, s1), dkf.StateError, None),
        (lambda: w.fc.restart_node(5, w.fc.k + 1, P, s1), dkf.ArgError, None),
        (lambda: w.fc.restart_node(1, w.fc.k + 1, -P, s1), dkf.NotSPDError, "P_prior"),
        (lambda: w.fc.restart_node(0, w.fc.k + 1, P, s0_rank), dkf.RankError, "D"),
        (lambda: w.fc.restart_node(1, w.fc.k + 1, P, {"H": s1["H"]}), ValueError, None),
        (lambda: w.fc.restore(ck[:-1]), dkf.CapacityError, "buf"),
        (lambda: w.fc.restore(bad_ck(0, 1)), dkf.ArgError, "buf"),
        (lambda: w.fc.restore(bad_ck(1, ck[1] + 1)), dkf.DimError, "buf"),
        (lambda: w.fc.restore(other), dkf.CapacityError, "buf"),
        (lambda: w.fc.restore(bad_ck(len(ck) - 3, np.nan)), dkf.NonFiniteError, "buf"),
        (lambda: w.fc.restore(bad_ck(len(ck) // 2, np.nan)), dkf.NonFiniteError, "buf"),
        (lambda: w.fc.restore(ck.astype(np.float16)), TypeError, None),
        (lambda: w.fc.restore(list(ck)), TypeError, None),
        (lambda: w.fc.restore(ck.reshape(1, -1)), ValueError, None),
        (lambda: w.fc.set_steady(1.0), dkf.ArgError, None),
        (lambda: w.fc.set_steady(float("nan")), dkf.ArgError, None),
    ]
    assert_refused_untouched(bad, rng, lambda: fc_state(w.fc), want, "DiffKFFusionCentre")
    for call, node, text in [(bad[0][0], 2, "node 2: "), (bad[3][0], 1, "k_start must be"),
                             (bad[5][0], 1, "node 1: "), (bad[6][0], 0, "node 0: D rank")]:
        with pytest.raises(dkf.Error) as info:
            call()
        assert info.value.node == node and text in str(info.value), str(info.value)
    # the failures changed nothing: both centres step on identically
    part[2] = msgs[2]
    tF, tQ, tsensors, tmsgs = twin.nodes_step(2)
    assert w.fc.step_partial(F, Q, sensors, part) == [True, False, True]
    assert twin.fc.step_partial(tF, tQ, tsensors, [tmsgs[0], None, tmsgs[2]]) == [True, False, True]
    assert fc_state(w.fc) == fc_state(twin.fc)


# tests/test_diffkf_fusion.c's steady settings: the tolerance and the bound
# of the distance to the recomputed filter
STEADY = {np.float64: (1e-12, 1e-10), np.float32: (1e-5, 5e-4)}


class ConstantWorld(World):
    """A time-invariant stable model (F 0.9 times a rotation) of sensors of
    dimensions (m_i, p_i), its matrices and measurements drawn with a fixed
    seed (the steady gain does not depend on the data)."""

    def __init__(self, mod, seed, m, p, n=4, T=202):
        rng = np.random.default_rng(seed)
        self.n, self.m, self.p, self.l = n, list(m), list(p), len(m)
        c = lambda a: {"const": a}  # noqa: E731
        self.model = {"F": c(0.9 * np.linalg.qr(rng.normal(size=(n, n)))[0]),
                      "Q": c(rand_spd(rng, n, 5.0, 0.1))}
        self.sens = [{"H": c(rng.normal(size=(mi, n))), "D": c(rng.normal(size=(mi, pi))),
                      "R": c(rand_spd(rng, mi, 3.0, 0.5)), "B": c(0.5 * np.eye(pi)),
                      "Rd": c(rand_spd(rng, pi, 2.0, 0.2))} for mi, pi in zip(m, p)]
        Y = rng.normal(size=(self.l, T, max(m)))
        self.y = lambda i, k: Y[i, k, :self.m[i]]
        self.nodes = [mod.DifferenceKF(np.zeros(n), np.eye(n), m=mi, p=pi) for mi, pi in zip(m, p)]
        self.fc = mod.DiffKFFusionCentre(np.zeros(n), np.eye(n), m=self.m, p=self.p)


def test_steady_centre_settles_near_the_recomputed_one(mod):
    """A time-invariant model over 200 steps: the centre with the steady
    gain settles and stays within the C test's bound of the one that
    recomputes every gain."""
    m, dt = mod
    tol, reg = STEADY[dt]
    a, b = ConstantWorld(m, 75, [3, 2, 3], [2, 1, 2]), ConstantWorld(m, 75, [3, 2, 3], [2, 1, 2])
    a.fc.set_steady(tol)
    for x in (a, b):
        x.start()
    settled = 0
    for k in range(1, 201):
        a.fc.step(*a.nodes_step(k))
        b.fc.step(*b.nodes_step(k))
        assert not b.fc.steady
        settled = settled or (k if a.fc.steady else 0)
        for key in ("xf", "Pf", "xn", "Pn"):
            assert rel_err(getattr(a.fc, key), getattr(b.fc, key)) <= reg, (k, key)
    assert 0 < settled < 150 and a.fc.steady


def ex1():
    v = load_vector("diffkf/ex1_single.json")
    md = v["model"]
    at = lambda key, k: model_at(md, key, k)  # noqa: E731
    Y = [np.array(y, dtype=np.float64).reshape(-1) for y in v["y"]["values"]]
    x0 = np.array(v["init"]["x00"], dtype=np.float64).reshape(-1)
    P0 = np.atleast_2d(np.array(v["init"]["P00"], dtype=np.float64))
    return at, Y, x0, P0


def ex1_filter(m):
    at, Y, x0, P0 = ex1()
    f = m.DifferenceKF(x0, P0, m=at("D", 1).shape[0], p=at("D", 1).shape[1])
    f.start(Y[0], at("H", 1), at("D", 1), at("R", 1), F0=at("F", 0), Q0=at("Q", 0))

    def step(k):
        f.step(Y[k], F=at("F", k), Q=at("Q", k), B=at("B", k), Rd=at("Rd", k), H=at("H", k + 1),
               D=at("D", k + 1), R=at("R", k + 1))

    return f, step


def dkf_state(f):
    return tuple(getattr(f, a).tobytes() for a in FIELDS) + (f.k, f.steady, f.save().tobytes())


def test_difference_kf_checkpoint_round_trip_and_refusals(mod):
    m, dt = mod
    rng = np.random.default_rng(72)
    f, step = ex1_filter(m)
    for k in range(1, 21):
        step(k)
    ck = f.save()
    assert ck.dtype == dt and f.k == 20
    want = dkf_state(f)
    after = []
    for k in range(21, 31):
        step(k)
        after.append(dkf_state(f))
    f.restore(ck)
    assert dkf_state(f) == want
    for k in range(21, 31):
        step(k)
        assert dkf_state(f) == after[k - 21], k
    f.restore(ck)
    other = m.DifferenceKF(np.zeros(f.n), np.eye(f.n), m=f.m + 1, p=f.p).save()
    b = ck.copy()
    b[-1] = np.inf
    bad = [
        (lambda: f.restore(ck[:-1]), dkf.CapacityError, "buf"),
        (lambda: f.restore(np.concatenate([[0.0], ck[1:]]).astype(dt)), dkf.ArgError, "buf"),
        (lambda: f.restore(other), dkf.DimError, "buf"),
        (lambda: f.restore(b), dkf.NonFiniteError, "buf"),
        (lambda: f.restore(ck.astype(np.float32 if dt == np.float64 else np.float64)), TypeError,
         None),
        (lambda: f.set_steady(-1e-3), dkf.ArgError, None),
    ]
    assert_refused_untouched(bad, rng, lambda: dkf_state(f), want, "DifferenceKF")


def test_difference_kf_set_time_and_steady(mod):
    """ex1's time-invariant model over 200 steps of drawn measurements: the
    filter with the steady gain settles (at step 115 in double, 45 in float)
    and stays within the C test's bound of the one that recomputes it."""
    m, dt = mod
    tol, reg = STEADY[dt]
    at, Y, x0, P0 = ex1()
    mm, p = at("D", 1).shape
    a, b = m.DifferenceKF(x0, P0, m=mm, p=p), m.DifferenceKF(x0, P0, m=mm, p=p)
    for f in (a, b):
        f.start(Y[0], at("H", 1), at("D", 1), at("R", 1), F0=at("F", 0), Q0=at("Q", 0))
    a.set_steady(tol)
    model = dict(F=at("F", 1), Q=at("Q", 1), B=at("B", 1), Rd=at("Rd", 1), H=at("H", 2),
                 D=at("D", 2), R=at("R", 2))
    rng = np.random.default_rng(74)
    settled = 0
    for k in range(1, 201):
        y = 10 * rng.normal(size=mm)
        a.step(y, **model)
        b.step(y, **model)
        settled = settled or (k if a.steady else 0)
        assert not b.steady
        for key in ("xf", "Pf", "xn", "Pn"):
            assert rel_err(getattr(a, key), getattr(b, key)) <= reg, (k, key)
    assert 0 < settled < 150 and a.steady
    a.set_time(1000)
    assert a.k == 1000 and a.message()[0] == 1000
