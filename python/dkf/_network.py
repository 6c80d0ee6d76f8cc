"""run_scenario's seed-003 network layout: tw1, tw2, tw3 (dkf/tw.h).

The C side is ports/linux/scenario/scn_steps.c and scn_network.c (the
reader: graph.edges, the weights dense or as triplets, eta; the per-node H
and R in model or per step) and ports/linux/families/tw_run.c (the runner):
every step runs Algorithm 1 (the reference), and Algorithm 2 or 3 over the
whole graph beside it; it records the algorithm's fields under the
vectors' names and, from the truth, the metrics, summed in double in
tw_run.c's order. Steps start at n = 1 with (x0, P0) = x_{0|0}; step n takes
the dynamics F, G, Q of n - 1 and every node's H, R, y of n.
"""

from __future__ import annotations

import math
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ._scenario import TW_MAX_ETA, _comment, _fail, _numbers, real_name
from ._steps import _Steps

TW_LABELS = {"tw1": "alg1", "tw2": "alg2", "tw3": "alg3"}

# (the JSON key, the bindings' property): the paper's names (z = d, G = Gpost,
# Q / Ups = I, vphi = i), tw_run.c's fields1..3
_FIELDS = {
    1: (("x", "x"), ("P", "P"), ("z", "d"), ("phi", "phi"), ("Phi", "Phi"),
        ("phi_post", "phi_post"), ("Phi_post", "Phi_post"), ("S", "S"), ("G", "Gpost")),
    2: (("x", "x"), ("P", "P"), ("z", "d"), ("psi", "psi"), ("Q", "I"), ("phi_post", "phi_post"),
        ("Phi_post", "Phi_post"), ("S", "S"), ("G", "Gpost")),
    3: (("x", "x"), ("P", "P"), ("z", "d"), ("Ups", "I"), ("vphi", "i"), ("psi", "psi"),
        ("Ploc", "Ploc"), ("phi_post", "phi_post"), ("Phi_post", "Phi_post"), ("S", "S"),
        ("G", "Gpost")),
}
_TOP_KEYS = {"init", "model", "steps", "graph", "W_consensus", "W_consensus_sparse",
             "alpha_diffusion", "alpha_diffusion_sparse", "eta", "outputs", "tolerance", "dims",
             "seed", "time_varying", "expect_error_case", "conventions"}


class _Net(_Steps):
    """A seed-003 network file: the steps layout with per-node H, R, y and a graph."""

    OLD = (("A", "F"), ("B", "G"), ("Sv", "Q"), ("Sw", "R"))  # A, B, Sv, Sw = F, G, Q, R
    OLD_ONLY, NEW_ONLY = ("A", "B", "Sv", "Sw"), ("F", "G", "Q", "R")
    NODE_KEYS = ("H", "R")

    def __init__(self, doc: Dict[str, Any], file: str) -> None:
        for key, v in doc.items():
            if key not in _TOP_KEYS and not _comment(v) and v is not None:
                raise _fail(file, key, "unknown key")
        super().__init__(doc, file)
        H = self.node_model.get("H", self.inputs[0].get("H"))
        if not isinstance(H, list) or not H:
            raise _fail(file, "model.H", "missing key (seed-003 files give one H per node, in "
                        "model or in every step's inputs)")
        self.N = len(H)
        self.n = self.prev("F", 0).shape[0]
        self.p = self.prev("G", 0).shape[1]
        self.m = [self.node("H", l, 0).shape[0] for l in range(self.N)]
        self.adjacency, self.E = self._graph(doc)
        self.alpha = self._weights(doc, "alpha_diffusion")
        self.W = self._weights(doc, "W_consensus")
        eta = doc.get("eta")
        if eta is not None and (isinstance(eta, bool) or not isinstance(eta, (int, float))
                                or eta != int(eta) or not 0 <= eta <= TW_MAX_ETA):
            raise _fail(file, "eta", "expected an integer in 0..%d" % TW_MAX_ETA)
        self.eta = None if eta is None else int(eta)
        truth = [t.get("truth") or {} for t in doc["steps"]]
        self.truth_x = self._truth(truth, ("x",), self.n)
        ukey = next((key for key in ("d", "d_prev", "z_prev") if key in truth[0]), None)
        self.truth_u = self._truth(truth, (ukey,), self.p) if ukey else None

    def node(self, name: str, l: int, j: int) -> np.ndarray:
        """Node l's H or R at step j's time (the step's inputs, else the model's)."""
        if name in self.inputs[j]:
            where, lst = "steps[%d].inputs.%s" % (j, name), self.inputs[j][name]
        elif name in self.node_model:
            where, lst = "model." + name, self.node_model[name]
        else:
            raise _fail(self.file, "model." + name, "missing key (one %s per node, in model or "
                        "in every step's inputs)" % name)
        if not isinstance(lst, list) or len(lst) != self.N:
            raise _fail(self.file, where, "expected a list of %d matrices (one per node)" % self.N)
        return _numbers(self.file, "%s[%d]" % (where, l), lst[l], 2)

    def ys(self, j: int) -> List[np.ndarray]:
        y = self.inputs[j].get("y")
        where = "steps[%d].inputs.y" % j
        if not isinstance(y, list) or len(y) != self.N:
            raise _fail(self.file, where, "expected a list of %d measurement vectors (one per "
                        "node)" % self.N)
        out = [_numbers(self.file, "%s[%d]" % (where, l), v, 1) for l, v in enumerate(y)]
        for l, v in enumerate(out):
            if v.shape[0] != self.m[l]:
                raise _fail(self.file, "%s[%d]" % (where, l), "expected a vector of %d values "
                            "(the rows of H[%d]), got %d" % (self.m[l], l, l, v.shape[0]))
        return out

    def _graph(self, doc: Dict[str, Any]) -> Tuple[np.ndarray, int]:
        graph = doc["graph"]
        edges = graph.get("edges") if isinstance(graph, dict) else None
        if not isinstance(edges, list):
            raise _fail(self.file, "graph.edges", "missing key or not a list of [i, j] pairs")
        A = np.zeros((self.N, self.N))
        for e, pair in enumerate(edges):
            p = "graph.edges[%d]" % e
            if (not isinstance(pair, list) or len(pair) != 2
                    or not all(isinstance(v, int) and not isinstance(v, bool) for v in pair)):
                raise _fail(self.file, p, "expected a pair [i, j] of node indices")
            i, j = pair
            if not (0 <= i < self.N and 0 <= j < self.N):
                raise _fail(self.file, p, "node index out of range 0..%d (model.H has %d nodes)"
                            % (self.N - 1, self.N))
            if i == j or A[i, j]:
                raise _fail(self.file, "graph.edges", "not a simple undirected graph (a self "
                            "loop or a repeated edge)")
            A[i, j] = A[j, i] = 1.0
        return A, len(edges)

    def _weights(self, doc: Dict[str, Any], key: str) -> Optional[np.ndarray]:
        """The file's weights (dense, or [i, j, value] triplets) as an (N, N) array; None if
        absent (the runner takes the library's defaults)."""
        dense, sparse = doc.get(key), doc.get(key + "_sparse")
        if dense is not None and sparse is not None:
            raise _fail(self.file, key + "_sparse", "not allowed together with " + key)
        if dense is None and sparse is None:
            return None
        N = self.N
        if dense is not None:
            w = _numbers(self.file, key, dense, 2)
            if w.shape != (N, N):
                raise _fail(self.file, key, "expected a %dx%d matrix, got %dx%d"
                            % (N, N, w.shape[0], w.shape[1]))
            triplets = [(i, j, w[i, j]) for i in range(N) for j in range(N) if w[i, j] != 0.0]
            where = key
        else:
            where = key + "_sparse"
            if not isinstance(sparse, list) or not sparse:
                raise _fail(self.file, where, "expected a non-empty list of [i, j, value] "
                            "triplets")
            triplets = []
            for t, tr in enumerate(sparse):
                ok = (isinstance(tr, list) and len(tr) == 3
                      and all(isinstance(v, int) and not isinstance(v, bool) for v in tr[:2])
                      and isinstance(tr[2], (int, float)) and not isinstance(tr[2], bool))
                if not ok or not (0 <= tr[0] < N and 0 <= tr[1] < N):
                    raise _fail(self.file, "%s[%d]" % (where, t), "expected a triplet [i, j, "
                                "value] with node indices in 0..%d" % (N - 1))
                triplets.append((tr[0], tr[1], float(tr[2])))
        out = np.zeros((N, N))
        seen = set()
        for i, j, v in triplets:
            if i != j and not self.adjacency[i, j]:
                raise _fail(self.file, where, "entry (%d, %d) is not a link of graph.edges"
                            % (i, j))
            if (i, j) in seen:
                raise _fail(self.file, where, "entry (%d, %d) given twice" % (i, j))
            seen.add((i, j))
            out[i, j] = v
        return out

    def check_weights(self, core: Any) -> None:
        """The file's weights row-stochastic (alpha) or doubly stochastic (W) and
        non-negative, in the core's real type and order (dkf_graph_check_row_stochastic,
        dkf_graph_check_doubly_stochastic: sums within 4 k eps of 1): dkf-run checks both
        before any filter runs."""
        real = np.dtype(core.dtype).type
        eps = real(np.finfo(core.dtype).eps)
        nbrs = [[j for j in range(self.N) if j == i or self.adjacency[i, j]]
                for i in range(self.N)]
        for key, w, doubly in (("alpha_diffusion", self.alpha, False),
                               ("W_consensus", self.W, True)):
            if w is None:
                continue
            wr = w.astype(core.dtype)
            sums = []
            for i, row in enumerate(nbrs):
                if any(wr[i, j] < 0 for j in row):
                    sums.append(real(-1))
                    continue
                sums.append(sum((wr[i, j] for j in row), real(0)))
                if doubly:
                    sums.append(sum((wr[j, i] for j in row), real(0)))
            tol = [real(4.0) * real(len(row)) * eps for row in nbrs for _ in range(1 + doubly)]
            if any(not abs(sm - real(1)) <= t for sm, t in zip(sums, tol)):
                raise _fail(self.file, key, "not %s and non-negative" % (
                    "doubly stochastic" if doubly else "row-stochastic"))

    def _truth(self, truth: List[Dict[str, Any]], keys: Sequence[str],
               dim: int) -> Optional[List[List[float]]]:
        key = keys[0]
        if key not in truth[0]:
            return None
        out = []
        for j, t in enumerate(truth):
            p = "steps[%d].truth.%s" % (j, key)
            if key not in t:
                raise _fail(self.file, p, "missing key (steps[0] has it, so every step needs it)")
            v = _numbers(self.file, p, t[key], 1)
            if v.shape[0] != dim:
                raise _fail(self.file, p, "expected %d values, got %d" % (dim, v.shape[0]))
            out.append(v.tolist())
        return out


def _put(ser: Dict[str, list], key: str, A: Any) -> None:
    """A matrix into the per-step list; one of one column as a vector (tw_run.c's mat_json)."""
    A = np.asarray(A)
    if A.ndim == 2 and A.shape[1] == 1:
        A = A.reshape(-1)
    ser.setdefault(key, []).append(A.tolist())


def _nees(x: List[float], P: List[List[float]], xt: List[float]) -> float:
    """e^T P^-1 e by tw_run.c's double Cholesky (util.c's dkf_chol_double): NaN if P is not
    positive definite."""
    n = len(x)
    L = [[0.0] * n for _ in range(n)]
    for j in range(n):
        d = P[j][j]
        for k in range(j):
            d -= L[j][k] * L[j][k]
        if not (d > 0.0) or not math.isfinite(d):
            return math.nan
        L[j][j] = math.sqrt(d)
        for i in range(j + 1, n):
            e = P[i][j]
            for k in range(j):
                e -= L[i][k] * L[j][k]
            L[i][j] = e / L[j][j]
    v = [0.0] * n
    q = 0.0
    for i in range(n):
        sm = x[i] - xt[i]
        for k in range(i):
            sm -= L[i][k] * v[k]
        v[i] = sm / L[i][i]
        q += v[i] * v[i]
    return q


def _metrics(ser: Dict[str, list], xs: List[List[float]], Ps: List[Any], ds: List[List[float]],
             xt: Optional[List[float]], zt: Optional[List[float]], gap: bool,
             ref_x: List[float], ref_d: List[float]) -> None:
    """tw_run.c's metrics of one step over the nodes (x, P, d as doubles), in its order."""
    count, n, p = len(xs), len(xs[0]), len(ds[0])
    if xt is not None:
        mx, mean, ne = [0.0] * n, [0.0] * n, 0.0
        for l in range(count):
            for i in range(n):
                e = xs[l][i] - xt[i]
                mx[i] += e * e / count
                mean[i] += xs[l][i] / count
            ne += _nees(xs[l], Ps[l], xt) / (count * n)
        lo, hi, sp = list(xs[0]), list(xs[0]), [0.0] * n
        for l in range(count):
            for i in range(n):
                v = xs[l][i]
                d = v - mean[i]
                sp[i] += d * d / count
                if v < lo[i]:
                    lo[i] = v
                if v > hi[i]:
                    hi[i] = v
        ser.setdefault("mse_x", []).append(mx)
        ser.setdefault("nees", []).append(ne)
        ser.setdefault("spread_x", []).append([math.sqrt(v) for v in sp])
        ser.setdefault("range_x", []).append([h - o for h, o in zip(hi, lo)])
    if zt is not None:
        mz = [0.0] * p
        for l in range(count):
            for i in range(p):
                e = ds[l][i] - zt[i]
                mz[i] += e * e / count
        ser.setdefault("mse_z", []).append(mz)
    if not gap:
        return
    nref, xinf = 0.0, 1.0
    for v in ref_x:
        nref += v * v
        if abs(v) > xinf:
            xinf = abs(v)
    nref = math.sqrt(nref)
    gx = gz = grel = ginf = 0.0
    for l in range(count):
        dx = dz = 0.0
        for i in range(n):
            d = xs[l][i] - ref_x[i]
            dx += d * d
            if abs(d) / xinf > ginf:
                ginf = abs(d) / xinf
        for i in range(p):
            d = ds[l][i] - ref_d[i]
            dz += d * d
        gx += dx / count
        gz += dz / count
        if nref > 0 and math.sqrt(dx) / nref > grel:
            grel = math.sqrt(dx) / nref
    for key, v in (("gap_x", gx), ("gap_z", gz), ("gap_x_rel_max", grel),
                   ("gap_x_vec_rule", ginf)):
        ser.setdefault(key, []).append(v)


def run_tw(core: Any, doc: Dict[str, Any], file: str, filter: str, eta: Optional[int] = None,
           metrics_only: bool = False) -> Dict[str, Any]:
    """The document dkf-run --filter tw1|tw2|tw3 [--eta N] [--metrics-only] writes for a
    seed-003 network file."""
    if "graph" not in doc:
        raise _fail(file, "graph", "missing key (filter %s needs a seed-003 network file)"
                    % filter)
    s = _Net(doc, file)
    s.check_weights(core)
    alg = int(filter[2])
    if s.times[0] != 1:
        raise _fail(file, "steps[0].n", "filter %s starts at n = 1 ((x0, P0) = x_{0|0}, y_0 "
                    "unused), got %d" % (filter, s.times[0]))
    if alg == 3:
        eta = eta if eta is not None else s.eta
        if eta is None:
            raise _fail(file, "eta", "missing key (filter tw3 needs eta or --eta N)")
    x0, P0, N, p, m_max = s.x0.reshape(-1), s.P0, s.N, s.p, max(s.m)
    central = core.TWCentral(x0, P0, m_max=m_max, p=p)
    net = None
    if alg != 1:
        net = core.TWNetwork(x0, P0, adjacency=s.adjacency, m_max=m_max, p=p)
        if alg == 2:
            w = s.alpha if s.alpha is not None else core.graph_weights_uniform(s.adjacency)
        else:
            w = s.W if s.W is not None else core.graph_weights_metropolis(s.adjacency)
    ser: Dict[str, list] = {}
    for j in range(len(s.times)):
        dyn = {"F": s.prev("F", j), "G": s.prev("G", j), "Q": s.prev("Q", j),
               "H": [s.node("H", l, j) for l in range(N)],
               "R": [s.node("R", l, j) for l in range(N)]}
        y = s.ys(j)
        central.step(y, **dyn)
        if alg == 2:
            net.diffusion_step(y, alpha=w, **dyn)  # type: ignore[union-attr]
        elif alg == 3:
            net.consensus_step(y, W=w, eta=eta, **dyn)  # type: ignore[union-attr]
        f = central if net is None else net
        if not metrics_only:
            for key, prop in _FIELDS[alg]:
                v = getattr(f, prop)
                if net is None:
                    _put(ser, key, v)
                else:
                    v = np.asarray(v)
                    if v.ndim == 3 and v.shape[2] == 1:
                        v = v.reshape(v.shape[0], -1)
                    ser.setdefault(key, []).append(v.tolist())
        xs = np.asarray(f.x, dtype=np.float64).reshape(-1, s.n).tolist()
        Ps = np.asarray(f.P, dtype=np.float64).reshape(-1, s.n, s.n).tolist()
        ds = np.asarray(f.d, dtype=np.float64).reshape(-1, p).tolist()
        _metrics(ser, xs, Ps, ds, s.truth_x[j] if s.truth_x else None,
                 s.truth_u[j] if s.truth_u else None, alg != 1,
                 np.asarray(central.x, dtype=np.float64).tolist(),
                 np.asarray(central.d, dtype=np.float64).tolist())
    out: Dict[str, Any] = {"scenario": file, "filter": filter, "real": real_name(core),
                           "k": list(s.times)}
    if ser:  # (tw1 --metrics-only without truth records nothing: dkf-run writes no outputs)
        out["outputs"] = {TW_LABELS[filter]: ser}
    if alg == 3:
        out["eta"] = eta
    if net is None:  # every node sends its info packet to the centre once per step
        reals, msgs = float(s.n + s.n * (s.n + 1) // 2), 1.0
    else:
        reals = net.reals_sent / (N * net.steps)
        msgs = net.broadcasts / (N * net.steps)
    out["communication"] = {"reals_per_node_step": reals, "messages_per_node_step": msgs,
                            "N": N, "edges": s.E}
    return out
