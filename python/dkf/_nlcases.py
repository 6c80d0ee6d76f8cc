"""run_scenario's nonlinear cases (seed 001): the single-node filters nertsf,
nertsif, dnertsf, dnertsif, the centralised cf_dnertsf, and the consensus
network df_dnertsif, df_ckf, df_dnertsif_joint.

The C side is ports/linux/scenario/scn_nlcases.c (the reader),
ports/linux/nlm/ (the models) and ports/linux/families/nerts_run.c,
dfnerts_run.c (the runners: one dkf_nerts_step, or one
dkf_dfnerts_net_step, per step with the model's Q and R and z_k; every step
recorded under the vector files' `expected` names). A built-in family runs
dkf-run's own C model (dkf.builtin_model), so those cases give dkf-run's
document bit for bit; an expression model (`"expr"`, muparser in dkf-run)
runs through dkf.expr_model (sympy and numpy), which agrees with dkf-run to
a tolerance, not bit for bit (docs/decisions.md item 75).
"""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ._expr import build as _expr_build
from ._nlm import build as _builtin_build
from ._scenario import _case_index, _fail, real_name

NL_LABELS = {"nertsf": "NERTSF", "nertsif": "NERTSIF", "dnertsf": "DNERTSF",
             "dnertsif": "DNERTSIF", "cf_dnertsf": "CF_DNERTSF"}
DF_LABELS = {"df_dnertsif": "DF_DNERTSIF", "df_ckf": "DF_CKF",
             "df_dnertsif_joint": "DF_DNERTSIF_JOINT"}
_KINDS = {"nertsf": "NERTSF", "nertsif": "NERTSIF", "dnertsf": "DNERTSF",
          "dnertsif": "DNERTSIF", "cf_dnertsf": "DNERTSF"}

_CASE_KEYS = {"name", "model", "node_models", "init", "init_per_node", "W", "W_sparse", "edges",
              "Tp", "scale", "steps", "truth", "x_true", "d_true", "held_out",
              "node_sensor_index_in_paper"}
_INIT_KEYS = ("x0", "Px0", "d0", "Pd0", "Pxd0")
_MODEL_KEYS = {"family", "expr", "angles", "Q", "R", "A", "b", "C", "H", "T", "omega_fixed",
               "phi_gain", "sensor_xy", "sensor", "sensors"}
_FAMILY_KEYS = ("A", "b", "C", "H", "T", "omega_fixed", "phi_gain", "sensor_xy")
_EXPR_KEYS = {"f", "g", "A", "G", "C", "H", "angles"}
_DFNERTS_MAX_TP = 1000000  # dkf/dfnerts.h
_SCN_MAX_TP = 100000  # the reader's bound (scenario.h)

# nerts_run.c's dkf_host_nerts_record: (key, NERTS property, a vector), in order;
# the EKF kinds first A, G, the information kinds the second block.
_EKF_KEYS = (("A", "Fx", False), ("G", "Fd", False))
_KEYS = (("x_pred", "x_pred", True), ("P_pred", "P_pred", False), ("z_hat", "z_hat", True),
         ("nu", "nu", True), ("R_tilde", "R_tilde", False), ("Pzz", "Pzz", False),
         ("Pxz", "Pxz", False), ("H", "Hd", False), ("M", "M", False), ("C", "C", False),
         ("Rbar", "Rbar", False))
_INFO_KEYS = (("Y_pred", "Y_pred", False), ("y_pred", "y_pred", True),
              ("Rbar_inv", "Rbar_inv", False), ("i", "i", True), ("I", "I", False),
              ("Y", "Y", False), ("y", "y", True))
_END_KEYS = (("x", "x", True), ("Px", "Px", False), ("d", "d", True), ("Pd", "Pd", False),
             ("Pxd", "Pxd", False))


def _record_keys(kind: str) -> Tuple[Tuple[str, str, bool], ...]:
    ekf = kind in ("NERTSF", "NERTSIF")
    info = kind in ("NERTSIF", "DNERTSIF")
    return (_EKF_KEYS if ekf else ()) + _KEYS + (_INFO_KEYS if info else ()) + _END_KEYS


def _plain(a: Any, vector: bool) -> Any:
    """A field as dkf-run writes it: a vector flat, a matrix as rows."""
    a = np.asarray(a)
    return a.reshape(-1).tolist() if vector else a.tolist()


def is_nlcase(doc: Dict[str, Any], file: str, case: Union[int, str, None]) -> bool:
    """Whether the selected case of a cases-layout document is a nonlinear one."""
    cases = doc.get("cases")
    if not isinstance(cases, list) or not cases:
        return False
    cj = cases[_case_index(doc, file, case)]
    return isinstance(cj, dict) and ("model" in cj or "node_models" in cj)


def _numbers(file: str, path: str, v: Any, ndim: int) -> np.ndarray:
    try:
        a = np.array(v, dtype=np.float64)
    except (TypeError, ValueError):
        a = None
    if a is None or a.ndim != ndim or not np.all(np.isfinite(a)):
        raise _fail(file, path, "expected %s of finite numbers" % ("a list", "a matrix")[ndim - 1])
    return a


def _check_keys(file: str, obj: Dict[str, Any], path: str, known: Any) -> None:
    """dkf_scn_check_keys: every key known, or a comment (a string, null)."""
    for key, v in obj.items():
        if key not in known and not (v is None or isinstance(v, str)):
            raise _fail(file, "%s.%s" % (path, key), "unknown key")


def _empty(v: Any) -> bool:
    return isinstance(v, list) and all(isinstance(x, list) and not x for x in v)


def _square(file: str, path: str, v: Any, r: int, what: str) -> np.ndarray:
    M = _numbers(file, path, v, 2)
    if M.shape != (r, r):
        raise _fail(file, path, "expected %d x %d, got %d x %d" % ((r, r) + M.shape))
    if not np.array_equal(M, M.T):
        raise _fail(file, path, "not symmetric")
    ev = np.linalg.eigvalsh(M) if r else np.zeros(0)
    if (what == "R" and np.any(ev <= 0)) or np.any(ev < -1e-12 * max(1.0, float(np.max(
            np.abs(ev), initial=0.0)))):
        raise _fail(file, path, "the measurement noise covariance R must be SPD" if what == "R"
                    else "must be symmetric PSD")
    return M


class _Node:
    """One node's model (NLModel, Q, R in double) and initial estimate."""

    def __init__(self, core: Any, file: str, mj: Any, mpath: str, init: Any, ipath: str,
                 n: Optional[int], p: Optional[int]) -> None:
        if not isinstance(init, dict):
            raise _fail(file, ipath, "expected {x0, Px0, d0, Pd0, Pxd0}")
        _check_keys(file, init, ipath, _INIT_KEYS)
        for key in _INIT_KEYS:
            if key not in init:
                raise _fail(file, "%s.%s" % (ipath, key), "missing key")
        self.x0 = _numbers(file, ipath + ".x0", init["x0"], 1)
        d0 = init["d0"]
        if not isinstance(d0, list):
            raise _fail(file, ipath + ".d0", "expected a list ([] for no unknown input)")
        self.n, self.p = len(self.x0), len(d0)
        if n is not None and (self.n, self.p) != (n, p):
            raise _fail(file, ipath, "x0 of %d and d0 of %d values; node 0 has %d and %d (n and "
                        "p are common to every node; m, g and R may differ)"
                        % (self.n, self.p, n, p))
        n, p = self.n, self.p
        self.P0 = _square(file, ipath + ".Px0", init["Px0"], n, "P")
        if p:
            self.d0: Optional[np.ndarray] = _numbers(file, ipath + ".d0", d0, 1)
            self.Pd0: Optional[np.ndarray] = _square(file, ipath + ".Pd0", init["Pd0"], p, "P")
            self.Pxd0: Optional[np.ndarray] = _numbers(file, ipath + ".Pxd0", init["Pxd0"], 2)
            if self.Pxd0.shape != (n, p):
                raise _fail(file, ipath + ".Pxd0", "expected %d x %d" % (n, p))
        else:
            for key in ("Pd0", "Pxd0"):
                if not _empty(init[key]):
                    raise _fail(file, "%s.%s" % (ipath, key),
                                "expected an empty list (d0 = [], no unknown input)")
            self.d0 = self.Pd0 = self.Pxd0 = None
        self.model, self.owner, self.Q, self.R = self._model(core, file, mj, mpath)
        self.m = self.model.m
        self.expr = self.owner is None

    def _model(self, core: Any, file: str, mj: Any, path: str) -> Tuple[Any, Any, Any, Any]:
        """nlm.c's dkf_nlm_load: (NLModel, its _NlmFamily or None, Q, R)."""
        if not isinstance(mj, dict):
            raise _fail(file, path, "expected a model object")
        _check_keys(file, mj, path, _MODEL_KEYS)
        expr, family = mj.get("expr"), mj.get("family")
        angles = mj.get("angles")
        if expr is not None and isinstance(expr, dict) and "angles" in expr:
            if angles is not None:
                raise _fail(file, path + ".angles", "given twice (also in expr.angles): keep one")
            angles = expr["angles"]
        if angles is not None and (not isinstance(angles, list) or not all(
                isinstance(a, int) and not isinstance(a, bool) and a >= 0 for a in angles)):
            raise _fail(file, path + ".angles", "expected a list of measurement indices")
        owner = None
        if expr is not None:
            model = self._expr(core, file, expr, path + ".expr", angles)
        elif isinstance(family, str):
            params = {key: mj[key] for key in _FAMILY_KEYS if key in mj}
            try:
                model, owner = _builtin_build(core, family, n=self.n, p=self.p, angles=angles,
                                              path="%s: %s" % (file, path), **params)
            except ValueError as e:
                raise ValueError(str(e)) from None
        else:
            raise _fail(file, path + (".family" if family is not None else ".expr"),
                        "missing key (give \"expr\" or a built-in \"family\")")
        if "Q" not in mj:
            raise _fail(file, path + ".Q", "missing key (the %d x %d state noise covariance)"
                        % (self.n, self.n))
        Q = _square(file, path + ".Q", mj["Q"], self.n, "Q")
        if "R" in mj:
            R = _square(file, path + ".R", mj["R"], model.m, "R")
        elif family == "s1_radar_stacked" and expr is None:
            R = np.array(owner.R_default, dtype=np.float64).reshape(model.m, model.m)
        else:
            raise _fail(file, path + ".R", "missing key (the %d x %d measurement noise "
                        "covariance)" % (model.m, model.m))
        return model, owner, Q, R

    def _expr(self, core: Any, file: str, ej: Any, path: str, angles: Any) -> Any:
        if not isinstance(ej, dict):
            raise _fail(file, path, "expected {\"f\": [...], \"g\": [...]}")
        _check_keys(file, ej, path, _EXPR_KEYS)

        def strings(key: str, v: Any) -> Any:
            if isinstance(v, list):
                return [strings(key, x) for x in v]
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                return repr(float(v))
            if not isinstance(v, str):
                raise _fail(file, "%s.%s" % (path, key), "expected expression strings")
            return v

        f, g = ej.get("f"), ej.get("g")
        if not isinstance(f, list) or len(f) != self.n or not isinstance(g, list) or not g:
            raise _fail(file, path, "expected f (%d strings, one per state) and g" % self.n)
        jac = {key: strings(key, ej[key]) for key in ("A", "G", "C", "H") if key in ej}
        if not self.p:
            jac.pop("G", None)
            jac.pop("H", None)
        try:
            return _expr_build(core.NLModel, strings("f", f), strings("g", g), p=self.p,
                               angles=angles or (), **jac)
        except ValueError as e:
            raise _fail(file, path, str(e)) from None


class _Case:
    """A nonlinear case (scn_nlcases.c): one node (`model`) or a network."""

    def __init__(self, core: Any, doc: Dict[str, Any], file: str,
                 case: Union[int, str, None]) -> None:
        idx = _case_index(doc, file, case)
        cpath = "cases[%d]" % idx
        cj = doc["cases"][idx]
        self.file, self.cpath = file, cpath
        name = cj.get("name")
        self.name = name if isinstance(name, str) else ""
        _check_keys(file, cj, cpath, _CASE_KEYS)
        self.network = "node_models" in cj
        if self.network and "model" in cj:
            raise _fail(file, cpath, "both model and node_models: a case has one of them")
        mkey, ikey = ("node_models", "init_per_node") if self.network else ("model", "init")
        if ikey not in cj:
            raise _fail(file, "%s.%s" % (cpath, ikey), "missing key")
        if self.network:
            models, inits = cj[mkey], cj[ikey]
            if not isinstance(models, list) or not models:
                raise _fail(file, "%s.%s" % (cpath, mkey), "expected a list of node models")
            if not isinstance(inits, list) or len(inits) != len(models):
                raise _fail(file, "%s.%s" % (cpath, ikey), "expected a list of %d initial "
                            "estimates (one per node)" % len(models))
            pairs = [(mj, "%s.%s[%d]" % (cpath, mkey, i), ij, "%s.%s[%d]" % (cpath, ikey, i))
                     for i, (mj, ij) in enumerate(zip(models, inits))]
        else:
            pairs = [(cj[mkey], "%s.%s" % (cpath, mkey), cj[ikey], "%s.%s" % (cpath, ikey))]
        self.nodes: List[_Node] = []
        for mj, mp, ij, ip in pairs:
            n0 = self.nodes[0] if self.nodes else None
            self.nodes.append(_Node(core, file, mj, mp, ij, ip, n0.n if n0 else None,
                                    n0.p if n0 else None))
        self.n, self.p = self.nodes[0].n, self.nodes[0].p
        self.z = self._steps(cj.get("steps"))
        if self.network:
            self._consensus(cj)

    def _steps(self, steps: Any) -> List[List[np.ndarray]]:
        file, spath = self.file, self.cpath + ".steps"
        if not isinstance(steps, list) or not steps:
            raise _fail(file, spath, "expected a non-empty list of steps")
        out = []
        for j, t in enumerate(steps):
            p = "%s[%d]" % (spath, j)
            if not isinstance(t, dict) or t.get("k") != j + 1 or isinstance(t.get("k"), bool):
                raise _fail(file, p + ".k", "expected %d (the steps are k = 1..N in order)"
                            % (j + 1))
            z = t.get("z")
            zs = z if self.network else [z]
            if not isinstance(zs, list) or len(zs) != len(self.nodes):
                raise _fail(file, p + ".z", "expected a list of %d measurements (one per node, "
                            "as node_models)" % len(self.nodes))
            row = []
            for i, (zi, node) in enumerate(zip(zs, self.nodes)):
                zp = "%s.z[%d]" % (p, i) if self.network else p + ".z"
                v = _numbers(file, zp, zi, 1)
                if len(v) != node.m:
                    raise _fail(file, zp, "expected %d values (the model's g), got %d"
                                % (node.m, len(v)))
                row.append(v)
            out.append(row)
        return out

    def _consensus(self, cj: Dict[str, Any]) -> None:
        """scn_nlcases.c's consensus(): W's entries as triplets (a dense W's
        nonzero ones), the graph `edges` or W's links i < j, Tp, scale."""
        file, cpath, N = self.file, self.cpath, len(self.nodes)
        trip: List[Tuple[int, int, float]] = []
        if "W" in cj and "W_sparse" in cj:
            raise _fail(file, cpath + ".W", "W and W_sparse: give one")
        if "W" in cj:
            Wd = _numbers(file, cpath + ".W", cj["W"], 2)
            if Wd.shape != (N, N):
                raise _fail(file, cpath + ".W", "expected %d x %d" % (N, N))
            trip = [(i, j, float(Wd[i, j])) for i in range(N) for j in range(N) if Wd[i, j] != 0]
        elif "W_sparse" in cj:
            sp = cj["W_sparse"]
            for t, e in enumerate(sp if isinstance(sp, list) and sp else [None]):
                if not (isinstance(e, list) and len(e) == 3 and all(
                        isinstance(x, (int, float)) and not isinstance(x, bool) for x in e)
                        and e[0] == int(e[0]) and e[1] == int(e[1])
                        and 0 <= e[0] < N and 0 <= e[1] < N):
                    raise _fail(file, "%s.W_sparse[%d]" % (cpath, t), "expected [i, j, w] with "
                                "node indices 0..%d" % (N - 1))
                trip.append((int(e[0]), int(e[1]), float(e[2])))
        else:
            raise _fail(file, cpath + ".W", "missing key (the %d x %d consensus weights)"
                        % (N, N))
        if "edges" in cj:
            edges = cj["edges"]
            if not isinstance(edges, list) or not all(
                    isinstance(e, list) and len(e) == 2 and all(
                        isinstance(x, int) and not isinstance(x, bool) and 0 <= x < N for x in e)
                    for e in edges):
                raise _fail(file, cpath + ".edges", "expected a list of [i, j] node pairs")
            pairs = [(e[0], e[1]) for e in edges]
        else:
            pairs = [(i, j) for i, j, _ in trip if i < j]
        adj = np.zeros((N, N))
        for a, b in pairs:
            if a == b or adj[a, b]:
                raise _fail(file, cpath + ".edges", "not a simple undirected graph (a self loop "
                            "or a repeated edge)")
            adj[a, b] = adj[b, a] = 1
        W = np.zeros((N, N))
        for i, j, v in trip:
            if i != j and not adj[i, j]:
                raise _fail(file, cpath + (".W" if "W" in cj else ".W_sparse"), "entry (%d, %d) "
                            "is not a link of the graph" % (i, j))
            if W[i, j] != 0 or not np.isfinite(v):
                raise _fail(file, cpath + ".W_sparse", "entry (%d, %d) given twice or not "
                            "finite" % (i, j))
            W[i, j] = v
        self.adjacency, self.W, self.E = adj, W, len(pairs)
        tp = cj.get("Tp")
        if tp is None:
            raise _fail(file, cpath + ".Tp", "missing key (consensus iterations per step)")
        if isinstance(tp, bool) or not isinstance(tp, (int, float)) or tp != int(tp) or not (
                1 <= tp <= _SCN_MAX_TP):
            raise _fail(file, cpath + ".Tp", "expected an integer in [1, %d]" % _SCN_MAX_TP)
        self.Tp = int(tp)
        sc = cj.get("scale", 1.0)
        if isinstance(sc, bool) or not isinstance(sc, (int, float)) or not (
                np.isfinite(sc) and sc > 0):
            raise _fail(file, cpath + ".scale", "expected a finite number > 0 (1: the paper's "
                        "Algorithm 3, N: the N-scaled variant)")
        self.scale = float(sc)


def _blkdiag(Ms: Sequence[np.ndarray]) -> np.ndarray:
    """blkdiag(M_1, ...) (nerts_run.c's load_R)."""
    ends = np.cumsum([len(M) for M in Ms])
    out = np.zeros((int(ends[-1]), int(ends[-1])))
    for M, e in zip(Ms, ends):
        out[e - len(M):e, e - len(M):e] = M
    return out


def _same_dynamics(core: Any, c: _Case, i: int) -> bool:
    """nerts_run.c's same_dynamics: node i's f gives node 0's values, in the
    core's reals, at node 0's initial estimate and a point beside it."""
    a, b = c.nodes[0], c.nodes[i]
    x0 = a.x0.tolist()
    d0 = a.d0.tolist() if a.d0 is not None else []
    dt = np.dtype(core.dtype)
    for t in range(2):
        x = np.array([x0[j] + 0.1 * float(t * (j + 1)) for j in range(c.n)]).astype(dt)
        d = np.array([d0[j] + 0.1 * float(t) for j in range(c.p)]).astype(dt)
        try:
            fa, fb = (np.asarray(node.model.f(x, d, np.zeros(0, dt)), dtype=dt)
                      if node.owner is None else node.owner.eval_f(x.tolist(), d.tolist())
                      for node in (a, b))
        except Exception:  # noqa: BLE001 (a failing f is a difference, as in the C check)
            return False
        if np.asarray(fa, dtype=dt).tobytes() != np.asarray(fb, dtype=dt).tobytes():
            return False
    return True


def _stacked(core: Any, c: _Case) -> Any:
    """nerts_run.c's bind_model for cf_dnertsf on a network case: dkf_nerts_stack
    over the nodes' models (built-in ones: the C stack of their C models)."""
    nodes = c.nodes
    angles: List[int] = []
    off = 0
    for node in nodes:
        angles += [off + a for a in node.model.angles]
        off += node.m
    if all(node.owner is not None for node in nodes):
        from ._nlm import _Fn

        st = core._NlmStack([node.owner for node in nodes])
        return core.NLModel.native(
            _Fn(st.f, st), _Fn(st.h, st), n=c.n, m=off, p=c.p,
            f_jac=_Fn(st.f_jac, st) if st.f_jac else None,
            h_jac=_Fn(st.h_jac, st) if st.h_jac else None, angles=angles, ctx=st.ctx)
    models = [node.model for node in nodes]
    p = c.p
    f0 = models[0]

    def h(x: Any, d: Any, u: Any) -> Any:
        return np.concatenate([np.asarray(md.h(x, d, u)).reshape(-1) for md in models])

    h_jac = None
    if all(md.h_jac is not None for md in models):
        def h_jac(x: Any, d: Any, u: Any) -> Any:
            parts = [md.h_jac(x, d, u) for md in models]
            Hx = np.vstack([np.asarray(P[0]).reshape(md.m, c.n) for P, md in zip(parts, models)])
            Hd = (np.vstack([np.asarray(P[1]).reshape(md.m, p) for P, md in zip(parts, models)])
                  if p else np.zeros((off, 0)))
            return Hx, Hd
    return core.NLModel(f0.f, h, n=c.n, m=off, p=p, f_jac=f0.f_jac, h_jac=h_jac, angles=angles)


def _check_central(core: Any, c: _Case, filter: str) -> None:
    file = c.file
    for i in range(1, len(c.nodes)):
        if not np.array_equal(c.nodes[i].Q, c.nodes[0].Q):
            raise _fail(file, "%s.node_models[%d].Q" % (c.cpath, i), "differs from node 0's "
                        "(the centralised filter has one dynamics: node 0's f and Q)")
    for i in range(1, len(c.nodes)):
        if not _same_dynamics(core, c, i):
            raise _fail(file, "%s.node_models[%d].%s" % (
                c.cpath, i, "expr.f" if c.nodes[i].expr else "family"), "its f differs from "
                "node 0's (the centralised filter has one dynamics: node 0's f and Q)")
    m = sum(node.m for node in c.nodes)
    if m > core.MAX_DIM:
        raise _fail(file, c.cpath + ".node_models", "the stacked measurement has %d components, "
                    "more than the core's %d" % (m, core.MAX_DIM))


def _run_single(core: Any, c: _Case, filter: str) -> Dict[str, Any]:
    """nerts_run.c: one NERTS over node 0's model, or every node's stacked."""
    kind = _KINDS[filter]
    node = c.nodes[0]
    if c.network:
        _check_central(core, c, filter)
        model = _stacked(core, c)
        R = _blkdiag([nd.R for nd in c.nodes])
    else:
        model, R = node.model, node.R
    f = core.NERTS(model, node.x0, node.P0, kind=kind, d0=node.d0, Pd0=node.Pd0, Pxd0=node.Pxd0)
    keys = _record_keys(kind)
    series: Dict[str, list] = {key: [] for key, _, _ in keys}
    for zs in c.z:
        f.step(np.concatenate(zs), Q=node.Q, R=R)
        for key, prop, vec in keys:
            series[key].append(_plain(getattr(f, prop), vec))
    return {NL_LABELS[filter]: series}


def _run_network(core: Any, c: _Case, filter: str) -> Tuple[Dict[str, Any], Dict[str, int]]:
    """dfnerts_run.c: the whole graph in process, every node recorded per step."""
    file = c.file
    ckf = filter == "df_ckf"
    if ckf and c.p:
        raise _fail(file, c.cpath + ".init_per_node[0].d0", "filter df_ckf has no unknown input "
                    "(d0 = []), the case has p = %d: use df_dnertsif" % c.p)
    if not ckf and not c.p:
        raise _fail(file, c.cpath + ".init_per_node[0].d0", "filter %s estimates an unknown "
                    "input, the case has none (d0 = []): use df_ckf" % filter)
    if c.Tp > _DFNERTS_MAX_TP:
        raise _fail(file, c.cpath + ".Tp", "at most %d" % _DFNERTS_MAX_TP)
    nodes = c.nodes
    net = core.DFNERTS([nd.model for nd in nodes], [nd.x0 for nd in nodes],
                       [nd.P0 for nd in nodes], adjacency=c.adjacency, kind="DNERTSIF",
                       variant="joint" if filter == "df_dnertsif_joint" else "paper",
                       d0=[nd.d0 for nd in nodes] if c.p else None,
                       Pd0=[nd.Pd0 for nd in nodes] if c.p else None,
                       Pxd0=[nd.Pxd0 for nd in nodes] if c.p else None)
    keys = _record_keys("DNERTSIF")
    series: Dict[str, list] = {key: [] for key, _, _ in keys}
    Q = [nd.Q for nd in nodes]
    R = [nd.R for nd in nodes]
    for zs in c.z:
        net.step(zs, Q=Q, R=R, W=c.W, Tp=c.Tp, scale=c.scale)
        for key, prop, vec in keys:
            v = getattr(net, prop)
            series[key].append([_plain(v[i], vec) for i in range(len(nodes))])
    comm = {"reals_sent": int(net.reals_sent), "broadcasts": int(net.broadcasts),
            "N": len(nodes), "edges": c.E}
    return {DF_LABELS[filter]: series}, comm


def run_nl(core: Any, doc: Dict[str, Any], file: str, case: Union[int, str, None],
           filter: str) -> Dict[str, Any]:
    """The document dkf-run --filter <filter> writes for a nonlinear case."""
    if filter not in NL_LABELS and filter not in DF_LABELS:
        raise _fail(file, "cases", "filter %s reads the canonical or a linear cases layout, not "
                    "a nonlinear case (run it with %s)"
                    % (filter, ", ".join(list(NL_LABELS) + list(DF_LABELS))))
    c = _Case(core, doc, file, case)
    if filter in DF_LABELS and not c.network:
        raise _fail(file, "cases", "filter %s needs a network case of a nonlinear model "
                    "(node_models, init_per_node, W, Tp)" % filter)
    if filter in NL_LABELS and c.network and filter != "cf_dnertsf":
        raise _fail(file, c.cpath + ".node_models", "filter %s runs one node (`model`); this "
                    "network case runs with cf_dnertsf or a network filter" % filter)
    comm: Optional[Dict[str, int]] = None
    if filter in DF_LABELS:
        outputs, comm = _run_network(core, c, filter)
    else:
        outputs = _run_single(core, c, filter)
    out: Dict[str, Any] = {"scenario": file, "case": c.name, "filter": filter,
                           "real": real_name(core), "k": list(range(1, len(c.z) + 1)),
                           "outputs": outputs}
    if comm is not None:
        out["communication"] = comm
    return out
