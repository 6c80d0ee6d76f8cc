"""dkf.DFNERTSNode (dkf/dfnerts.h's node API): N nodes exchanging their
packets by hand are DFNERTS.step's network bit for bit (as
tests/test_dfnerts_vectors.c's solo nodes are), a restart from a node's own
posterior and a rejoin from a neighbour's packet (tests/test_dfnerts_props.c),
and failures that leave the node as it was."""

import numpy as np
import pytest

import dkf
from conftest import assert_refused_untouched, poker, same_bits
from test_dfnerts import PER_M, armed_case, case, load

# the views compared bit for bit (the m-dependent ones included)
VIEWS = ("x", "Px", "d", "Pd", "Pxd", "x_pred", "P_pred", "Y_pred", "y_pred", "i", "I", "Y",
         "y", "z_hat", "nu", "R_tilde", "M", "Rbar_inv")


class Net:
    """Case c's network twice: DFNERTS, and N DFNERTSNode that a test
    steps by hand."""

    def __init__(self, m, name, variant):
        c = case(name)
        models, pri, A, run, Z = load(m, c)
        self.run, self.Z, self.N = run, Z, len(models)
        self.pri = pri
        self.net = m.DFNERTS(models, pri["x0"], pri["P0"], adjacency=A, variant=variant,
                             **{k: v for k, v in pri.items() if k not in ("x0", "P0")})
        self.nodes = [m.DFNERTSNode(models[l], variant=variant,
                                    **{k: v[l] for k, v in pri.items()}) for l in range(self.N)]
        # node l's neighbourhood, itself included, in the graph's order
        self.nbr = [[j for j in range(self.N) if j == l or A[l, j]] for l in range(self.N)]

    def hand_step(self, t, skip=()):
        r, W = self.run, self.run["W"]
        out = [nd.local(self.Z[l][t], Q=r["Q"][l], R=r["R"][l], scale=r["scale"])
               for l, nd in enumerate(self.nodes)]
        for l, nd in enumerate(self.nodes):
            assert same_bits(out[l], nd.pkt) and nd.pending and nd.tau == 0
        for _ in range(r["Tp"]):
            sent = list(out)
            out = [nd.mix([sent[j] for j in self.nbr[l]], W[l, self.nbr[l]])
                   for l, nd in enumerate(self.nodes)]
        for nd in self.nodes:
            assert nd.tau == r["Tp"]
            nd.commit()
            assert not nd.pending

    def net_step(self, t):
        self.net.step([z[t] for z in self.Z], **self.run)

    def assert_same(self, t):
        for key in VIEWS:
            got = getattr(self.net, key)
            for l, nd in enumerate(self.nodes):
                assert same_bits(getattr(nd, key), got[l]), (t, l, key)
        assert all(nd.k == self.net.k for nd in self.nodes)


@pytest.mark.parametrize("name, variant", [("s1_4node_Tp3_scale4", "paper"),
                                           ("s1_4node_Tp3_scale1", "joint"),
                                           ("s1_4node_DF_CKF_Tp3_scale1", "paper")])
def test_nodes_by_hand_are_the_network_bit_for_bit(mod, name, variant):
    m, dt = mod
    w = Net(m, name, variant)
    nd = w.nodes[0]
    q = nd.n + (nd.p if variant == "joint" else 0)
    assert (nd.q, nd.pkt_len, nd.variant, nd.kind) == (q, q + q * (q + 1) // 2, variant,
                                                        "DNERTSIF")
    assert nd.pkt.dtype == dt and nd.pkt.shape == (nd.pkt_len,)
    for t in range(1, len(w.Z[0])):
        w.net_step(t)
        w.hand_step(t)
        w.assert_same(t)
    assert set(PER_M) <= set(VIEWS)


def test_restart_from_its_own_posterior_rejoins_bit_for_bit(mod):
    """tests/test_dfnerts_props.c: node 2 restarted at step 5 from its own
    posterior; the network goes on as the one that ran undisturbed. A prior
    that is not positive definite is refused, the node untouched."""
    m, _ = mod
    w = Net(m, "s1_4node_Tp3_scale4", "joint")
    for t in range(1, len(w.Z[0])):
        w.net_step(t)
        w.hand_step(t)
        if t == 5:
            nd = w.nodes[2]
            prior = {key: getattr(nd, key) for key in ("x", "Px", "d", "Pd", "Pxd")}
            before = [getattr(nd, key).tobytes() for key in VIEWS] + [nd.k]
            bad = prior["Px"].copy()
            bad[0, 0] = -1
            with pytest.raises(dkf.NotSPDError) as info:
                nd.restart(5, prior["x"], bad, d0=prior["d"], Pd0=prior["Pd"], Pxd0=prior["Pxd"])
            assert info.value.call == "DFNERTSNode.restart" and info.value.matrix == "P0"
            assert [getattr(nd, key).tobytes() for key in VIEWS] + [nd.k] == before
            nd.restart(5, prior["x"], prior["Px"], d0=prior["d"], Pd0=prior["Pd"],
                       Pxd0=prior["Pxd"])
            assert nd.k == 5 and not nd.pending
        if t > 5:
            w.assert_same(t)


def test_rejoin_from_a_neighbours_packet(mod):
    """tests/test_dfnerts_props.c: after a step (joint), node 1's packet is
    the consensus pair it committed from, so node 2 rejoined from it holds
    node 1's posterior bit for bit; a packet whose Y is not positive
    definite, or that is not finite, is refused and changes nothing."""
    m, _ = mod
    w = Net(m, "s1_4node_Tp3_scale4", "joint")
    for t in range(1, 5):
        w.hand_step(t)
    a, b = w.nodes[1], w.nodes[2]
    state = lambda: ([getattr(b, key).tobytes() for key in VIEWS], b.k)  # noqa: E731
    want = state()
    zero = np.zeros(a.pkt_len)
    nan = a.pkt
    nan[0] = np.nan
    bad = [
        (lambda: b.rejoin(4, zero), dkf.NotSPDError, "pkt"),
        (lambda: b.rejoin(4, nan), dkf.NonFiniteError, "pkt"),
        (lambda: b.rejoin(4, a.pkt[:-1]), ValueError, None),
        (lambda: b.rejoin(4, a.pkt, d0=np.zeros(1), Pd0=np.eye(1)), ValueError, None),
    ]
    assert_refused_untouched(bad, np.random.default_rng(80), state, want, "DFNERTSNode")
    b.rejoin(4, a.pkt)
    assert b.k == 4
    for key in ("x", "Px", "d", "Pd", "Pxd"):
        assert same_bits(getattr(b, key), getattr(a, key)), key
    w.hand_step(5)
    assert all(nd.k == 5 for nd in w.nodes)
    # the paper variant agrees on x alone: the input's prior is the caller's
    p = Net(m, "s1_4node_Tp3_scale4", "paper")
    p.hand_step(1)
    c = p.nodes[2]
    with pytest.raises(ValueError, match="d0 and Pd0 are required"):
        c.rejoin(1, p.nodes[1].pkt)
    c.rejoin(1, p.nodes[1].pkt, d0=np.array([0.25]), Pd0=np.eye(1))
    assert c.d[0] == c.d.dtype.type(0.25) and not np.any(c.Pxd)


@pytest.mark.parametrize("seed", range(2))
def test_refused_calls_leave_the_node_bit_identical(mod, seed):
    """Between steps and with a step pending, every refused call leaves
    the node (its views, counters and pending step) as it was; cancel
    gives back the node as before local()."""
    m, dt = mod
    rng = np.random.default_rng(810 + seed)
    poke = poker(rng)
    w, twin = Net(m, "s1_4node_Tp3_scale1", "paper"), Net(m, "s1_4node_Tp3_scale1", "paper")
    w.hand_step(1)
    twin.hand_step(1)
    nd, r = w.nodes[0], w.run
    z, Q, R = w.Z[0][2], r["Q"][0], r["R"][0]
    pri = {k: v[0] for k, v in w.pri.items()}

    def state():
        return ([getattr(nd, key).tobytes() for key in VIEWS] +
                [nd.k, nd.tau, nd.pending, nd.scale, nd.pkt.tobytes()])

    want = state()
    P_bad = pri["P0"].copy()
    P_bad[1, 1] = -1
    idle = [
        (lambda: nd.mix([nd.pkt], [1.0]), dkf.StateError, None),
        (lambda: nd.commit(), dkf.StateError, None),
        (lambda: nd.cancel(), dkf.StateError, None),
        (lambda: nd.local(poke(z, np.inf), Q=Q, R=R), dkf.NonFiniteError, "z"),
        (lambda: nd.local(z, Q=poke(Q, np.nan), R=R), dkf.NonFiniteError, "Q"),
        (lambda: nd.local(z, Q=Q, R=-R), dkf.NotSPDError, None),
        (lambda: nd.local(z, Q=Q, R=R, scale=0.0), dkf.ArgError, None),
        (lambda: nd.local(z[:2], Q=Q, R=R), ValueError, None),
        (lambda: nd.restart(3, pri["x0"], P_bad, d0=pri["d0"], Pd0=pri["Pd0"]), dkf.NotSPDError,
         "P0"),
        (lambda: nd.restart(3, pri["x0"], pri["P0"]), ValueError, None),
        (lambda: nd.rejoin(1, np.zeros(nd.pkt_len), d0=pri["d0"], Pd0=pri["Pd0"]),
         dkf.NotSPDError, None),
    ]
    assert_refused_untouched(idle, rng, state, want, "DFNERTSNode")
    sent = nd.local(z, Q=Q, R=R, scale=r["scale"])
    pending = state()
    assert pending != want and nd.pending
    nbr = [sent, sent, sent]
    busy = [
        (lambda: nd.commit(), dkf.StateError, None),
        (lambda: nd.mix([sent, poke(sent, np.nan), sent], [0.5, 0.25, 0.25]), dkf.NonFiniteError,
         "pkts"),
        (lambda: nd.mix(nbr, [0.5, np.inf, 0.25]), dkf.NonFiniteError, "w"),
        (lambda: nd.mix(nbr, [0.5, 0.5]), ValueError, None),
        (lambda: nd.mix([sent[:-1]] * 3, [0.5, 0.25, 0.25]), ValueError, None),
        (lambda: nd.local(poke(z, np.inf), Q=Q, R=R), dkf.NonFiniteError, "z"),
    ]
    assert_refused_untouched(busy, rng, state, pending, "DFNERTSNode")
    nd.cancel()
    assert state()[:-1] == want[:-1]  # (pkt: the dropped step's, as in C)
    assert not nd.pending and nd.tau == 0
    w.hand_step(2)
    twin.hand_step(2)
    for a, b in zip(w.nodes, twin.nodes):
        assert [getattr(a, k).tobytes() for k in VIEWS] == [getattr(b, k).tobytes() for k in VIEWS]


def test_a_callback_exception_fails_local(mod):
    m, _ = mod
    models, pri, A, run, Z, armed = armed_case(m)
    model = models[3]
    nd = m.DFNERTSNode(model, **{k: v[3] for k, v in pri.items()})
    assert nd.model is model and "DFNERTSNode DNERTSIF paper" in repr(nd)
    nd.local(Z[3][1], Q=run["Q"][3], R=run["R"][3])
    nd.cancel()
    before = (nd.x.tobytes(), nd.Px.tobytes(), nd.k, nd.pending)
    armed.append(1)
    with pytest.raises(dkf.ModelError, match=r"^DFNERTSNode.local: .*model.h raised "
                                             "OverflowError") as info:
        nd.local(Z[3][1], Q=run["Q"][3], R=run["R"][3])
    assert isinstance(info.value.__cause__, OverflowError)
    assert (nd.x.tobytes(), nd.Px.tobytes(), nd.k, nd.pending) == before
    with pytest.raises(ValueError, match="variant must be"):
        m.DFNERTSNode(model, variant="consistent", **{k: v[3] for k, v in pri.items()})
    with pytest.raises(ValueError, match="kind must be"):
        m.DFNERTSNode(model, kind="DNERTSF", **{k: v[3] for k, v in pri.items()})
