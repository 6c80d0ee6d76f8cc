"""dkf.run_scenario: dkf-run's per-step output of a scenario, from Python.

The scenario (docs/reference/scenario-format.md) is read with Python's json
(its float parsing is correctly rounded, as the C reader's strtod), the
filters are the bindings' (the C core), and the glue here makes the calls of
the C runner (ports/linux/runner/estimator.c, ports/linux/families/est_*.c)
in the same order with the same matrices, so the dict equals the document
`dkf-run --filter NAME --output OUT.json SCENARIO` writes, number for number
(docs/decisions.md item 70). This module reads the canonical and the linear
cases layouts and runs the estimator families; _steps.py runs the seed-004
steps layout, _network.py the seed-003 network layout, _wfcases.py seed
002's weighted-fusion cases.
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _dkf_double as _core

# --filter name -> the label of its single-sensor output (dkf-run's registry).
_LABELS = {"kf": "KF", "info": "IF", "dkf": "DKF", "askf": "ASKF", "otskf": "OTSKF"}
_FUSED = ("info", "dkf")  # the kinds with a fused estimator (several sensors)
_NEEDS_UI = ("dkf", "askf", "otskf")
_INPUT_PRIOR = ("askf", "otskf")

_UIF = ("rtsf", "nrtsf_df", "nrtsf")  # the seed-004 steps layout (_steps.py)
_TW = ("tw1", "tw2", "tw3")  # the seed-003 network layout (_network.py)
# seed 002's weighted-fusion cases (_wfcases.py)
_WF = ("local_kf", "fusion_scalar", "fusion_matrix", "fusion_steady", "fusion_selftune",
       "central_kf")
# seed 001's nonlinear cases (_nlcases.py)
_NL = ("nertsf", "nertsif", "dnertsf", "dnertsif", "cf_dnertsf", "df_dnertsif", "df_ckf",
       "df_dnertsif_joint")

TW_MAX_ETA = 1000000  # DKF_TW_MAX_ETA (dkf/tw.h): the largest eta of tw3

SUPPORTED_FILTERS: Tuple[str, ...] = tuple(_LABELS) + _UIF + _TW + _WF + _NL
"""The --filter names run_scenario runs: kf, info, dkf, askf, otskf over the
canonical layout (kf and info the linear and weighted-fusion cases too);
rtsf, nrtsf_df, nrtsf over the seed-004 steps layout; tw1, tw2, tw3 over the
seed-003 network layout; local_kf, fusion_scalar, fusion_matrix,
fusion_steady, fusion_selftune, central_kf over seed 002's weighted-fusion
cases; nertsf, nertsif, dnertsf, dnertsif, cf_dnertsf, df_dnertsif, df_ckf,
df_dnertsif_joint over seed 001's nonlinear cases."""

# The keys of the canonical layout (scn_canonical.c); the vector files' own
# top-level keys are accepted and ignored, strings are comments.
_TOP_KEYS = {"model", "init", "y", "runs", "truth", "k", "N"}
_TOP_IGNORED = {"outputs", "tolerance", "dims", "seed", "time_varying", "expect_error_case"}
_MODEL_KEYS = {"F", "Q", "H", "R", "D", "B", "Rd", "sensors"}
_SENSOR_KEYS = {"H", "R", "D", "B", "Rd"}
_INIT_KEYS = {"x00", "P00", "P00_local", "P00_central", "d00", "Pd00"}


def _fail(file: str, path: str, what: str) -> ValueError:
    return ValueError("%s: %s: %s" % (file, path, what) if path else "%s: %s" % (file, what))


def _comment(v: Any) -> bool:
    """A string, or a list of strings: a comment, which the reader skips."""
    return isinstance(v, str) or (isinstance(v, list) and all(isinstance(x, str) for x in v))


class _Mat:
    """A model matrix: one (const) or one per k from 0 (per_k)."""

    def __init__(self, file: str, path: str, value: Any) -> None:
        self.file, self.path = file, path
        self.const: Optional[np.ndarray] = None
        self.per_k: Optional[List[np.ndarray]] = None
        if isinstance(value, list):
            self.const = _matrix(file, path, value)
        elif isinstance(value, dict):
            extra = set(value) - {"const", "per_k"}
            if extra or len(value) != 1:
                raise _fail(file, path, 'expected exactly one of "const" and "per_k"')
            if "const" in value:
                self.const = _matrix(file, path + ".const", value["const"])
            else:
                lst = value["per_k"]
                if not isinstance(lst, list) or not lst:
                    raise _fail(file, path + ".per_k", "expected a non-empty list of matrices")
                self.per_k = [_matrix(file, "%s.per_k[%d]" % (path, i), M)
                              for i, M in enumerate(lst)]
                if any(M.shape != self.per_k[0].shape for M in self.per_k):
                    raise _fail(file, path + ".per_k", "entries of different shapes")
        else:
            raise _fail(file, path, 'expected {"const": M}, {"per_k": [...]} or a matrix')

    @property
    def shape(self) -> Tuple[int, ...]:
        M = self.const if self.const is not None else self.per_k[0]  # type: ignore[index]
        return M.shape

    def at(self, k: int) -> np.ndarray:
        if self.const is not None:
            return self.const
        assert self.per_k is not None
        if not 0 <= k < len(self.per_k):
            raise _fail(self.file, self.path + ".per_k",
                        "has %d entries (k = 0..%d): no entry for k = %d"
                        % (len(self.per_k), len(self.per_k) - 1, k))
        return self.per_k[k]


def _matrix(file: str, path: str, value: Any) -> np.ndarray:
    if (not isinstance(value, list) or not value
            or not all(isinstance(r, list) for r in value)):
        raise _fail(file, path, "expected a matrix (non-empty list of rows)")
    try:
        M = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise _fail(file, path, "expected a matrix of numbers with rows of one length") from None
    if M.ndim != 2 or M.shape[1] == 0:
        raise _fail(file, path, "expected a matrix of numbers with rows of one length")
    return M


def _numbers(file: str, path: str, value: Any, depth: int) -> np.ndarray:
    try:
        A = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        A = None
    if A is None or A.ndim != depth or A.size == 0:
        raise _fail(file, path, "expected %s of numbers"
                    % ("a vector", "a matrix", "a list of matrices")[depth - 1])
    return A


def _series(file: str, path: str, value: Any, vkey: str,
            dim: Optional[int]) -> Dict[int, np.ndarray]:
    if not isinstance(value, dict) or vkey not in value:
        raise _fail(file, path, 'expected {"k": [...], "%s": [...]}' % vkey)
    vals = value[vkey]
    ks = value.get("k", list(range(len(vals))))
    if not isinstance(vals, list) or not isinstance(ks, list) or len(ks) != len(vals):
        raise _fail(file, path, "k and %s must be lists of one length" % vkey)
    out: Dict[int, np.ndarray] = {}
    last = -1
    for i, (k, v) in enumerate(zip(ks, vals)):
        if isinstance(k, bool) or not isinstance(k, (int, float)) or k != int(k) or k <= last:
            raise _fail(file, "%s.k[%d]" % (path, i), "times must be strictly increasing integers")
        last = int(k)
        a = _numbers(file, "%s.%s[%d]" % (path, vkey, i), v, 1)
        if dim is not None and a.shape[0] != dim:
            raise _fail(file, "%s.%s[%d]" % (path, vkey, i),
                        "expected %d values, got %d" % (dim, a.shape[0]))
        out[last] = a
    return out


def _letters(file: str, obj: Dict[str, Any], path: str) -> Dict[str, Any]:
    """The canonical layout's old letter A (the feedthrough) read as D."""
    if "A" not in obj:
        return obj
    if "D" in obj:
        raise _fail(file, path, "A and D: the old and the library's letter for one matrix; "
                    "give one (docs/reference/scenario-format.md, \"Letters\")")
    return {("D" if key == "A" else key): v for key, v in obj.items()}


class _Scenario:
    """A canonical-layout scenario, one run selected."""

    def __init__(self, doc: Dict[str, Any], file: str, run: int) -> None:
        if not isinstance(doc, dict):
            raise _fail(file, "", "expected a JSON object")
        self.file = file
        if "cases" in doc or "steps" in doc:
            raise _fail(file, "cases" if "cases" in doc else "steps",
                        "run_scenario reads the canonical and the linear cases layouts; run "
                        "this file with dkf-run")
        for key, v in doc.items():
            if key not in _TOP_KEYS | _TOP_IGNORED and not _comment(v):
                raise _fail(file, key, "unknown key")
        for key in ("model", "init"):
            if not isinstance(doc.get(key), dict):
                raise _fail(file, key, "missing key" if key not in doc else "expected an object")
        model = _letters(file, doc["model"], "model")
        init = doc["init"]
        for key, v in model.items():
            if key not in _MODEL_KEYS and not isinstance(v, str):
                raise _fail(file, "model." + key, "unknown key")
        for key, v in init.items():
            if key not in _INIT_KEYS and not isinstance(v, str):
                raise _fail(file, "init." + key, "unknown key")
        self.model = {key: _Mat(file, "model." + key, v) for key, v in model.items()
                      if key != "sensors" and v is not None and not isinstance(v, str)}
        self.multi = "sensors" in model
        if self.multi:
            sl = model["sensors"]
            if not isinstance(sl, list) or not sl:
                raise _fail(file, "model.sensors", "expected a non-empty list of sensor objects")
            self.sensors = []
            for i, so in enumerate(sl):
                p = "model.sensors[%d]" % i
                if not isinstance(so, dict):
                    raise _fail(file, p, "expected an object")
                so = _letters(file, so, p)
                for key, v in so.items():
                    if key not in _SENSOR_KEYS and not isinstance(v, str):
                        raise _fail(file, "%s.%s" % (p, key), "unknown key")
                self.sensors.append({key: _Mat(file, "%s.%s" % (p, key), v)
                                     for key, v in so.items()
                                     if v is not None and not isinstance(v, str)})
        else:
            self.sensors = [{}]
        self.init: Dict[str, np.ndarray] = {}
        for key, v in init.items():
            if v is None or isinstance(v, str):
                continue
            depth = 1
            probe = v
            while isinstance(probe, list) and probe and isinstance(probe[0], list):
                depth, probe = depth + 1, probe[0]
            self.init[key] = _numbers(file, "init." + key, v, depth)
        if "F" not in self.model:
            raise _fail(file, "model.F", "missing key")
        self.n = self.model["F"].shape[0]
        if "x00" not in self.init:
            raise _fail(file, "init.x00", "missing key")
        if "P00" not in self.init and not ("P00_central" in self.init and (
                not self.multi or "P00_local" in self.init)):
            raise _fail(file, "init.P00", "missing key (needed unless init.P00_central%s are "
                        "given)" % (" and init.P00_local" if self.multi else ""))
        # the run's measurements
        runs = doc.get("runs")
        if runs is not None:
            if "y" in doc or "truth" in doc:
                raise _fail(file, "y" if "y" in doc else "truth", "not allowed together with runs")
            if not isinstance(runs, list) or not runs:
                raise _fail(file, "runs", "expected a non-empty list of runs")
            if not 0 <= run < len(runs):
                raise _fail(file, "--run %d" % run, "the file has %d run%s (0..%d)" % (
                    len(runs), "" if len(runs) == 1 else "s", len(runs) - 1))
            yj, ypath = runs[run].get("y"), "runs[%d].y" % run
        else:
            if run != 0:
                raise _fail(file, "--run %d" % run, "the file has 1 run (0..0)")
            yj, ypath = doc.get("y"), "y"
        if yj is None:
            raise _fail(file, ypath, "missing key")
        if self.multi:
            if not isinstance(yj, list) or len(yj) != len(self.sensors):
                raise _fail(file, ypath, "expected a list of %d measurement series (one per "
                            "model.sensors entry)" % len(self.sensors))
            self.y = [_series(file, "%s[%d]" % (ypath, i), yi, "values",
                              self.sensor("H", i).shape[0]) for i, yi in enumerate(yj)]
        else:
            self.y = [_series(file, ypath, yj, "values", self.sensor("H", 0).shape[0])]
        self.steps = self._steps(doc)

    def _steps(self, doc: Dict[str, Any]) -> int:
        N = doc.get("N")
        ks = doc.get("k")
        if N is not None and (isinstance(N, bool) or not isinstance(N, (int, float))
                              or N != int(N) or N < 1):
            raise _fail(self.file, "N", "expected an integer >= 1")
        if ks is not None:
            if not isinstance(ks, list) or ks != list(range(1, len(ks) + 1)):
                raise _fail(self.file, "k", "expected the list [1, 2, ..., N]")
            if N is not None and int(N) != len(ks):
                raise _fail(self.file, "k", "has %d entries but N = %d" % (len(ks), N))
            return len(ks)
        if N is not None:
            return int(N)
        last = min(max(y) for y in self.y)
        if last < 1:
            raise _fail(self.file, "y", "no measurement at k >= 1")
        return last

    def sensor(self, name: str, i: int) -> _Mat:
        """Sensor i's matrix `name`, else the model's."""
        m = self.sensors[i].get(name, self.model.get(name))
        if m is None:
            where = "model.sensors[%d]" % i if self.multi else "model"
            raise _fail(self.file, "%s.%s" % (where, name), "missing key")
        return m

    def mat(self, name: str) -> _Mat:
        if name not in self.model:
            raise _fail(self.file, "model." + name, "missing key")
        return self.model[name]

    def yk(self, i: int, k: int) -> np.ndarray:
        v = self.y[i].get(k)
        if v is None:
            raise _fail(self.file, "y[%d]" % i if self.multi else "y",
                        "no measurement at k = %d" % k)
        return v

    def P00_local(self, i: int) -> np.ndarray:
        Pl = self.init.get("P00_local")
        return Pl[i] if Pl is not None else self.init["P00"]

    def P00_central(self) -> np.ndarray:
        return self.init.get("P00_central", self.init.get("P00"))  # type: ignore[return-value]


_CASE_KEYS = {"name", "x0", "P0", "Q", "H", "R", "steps", "truth", "held_out"}
_STEP_KEYS = {"k", "F", "Q", "z", "expected"}
# the cases layout's output names (estimator.c's cases_names)
_CASE_NAMES = {"xp": "x_pred", "Pp": "P_pred", "xf": "x", "Pf": "P", "yp": "y_pred",
               "Yp": "Y_pred", "yf": "y", "Yf": "Y"}


def _case_index(doc: Dict[str, Any], file: str, case: Union[int, str, None]) -> int:
    """The index of the case `case` (a name, an index, None: 0) of a cases-layout document."""
    cases = doc["cases"]
    if not isinstance(cases, list) or not cases:
        raise _fail(file, "cases", "expected a non-empty list of cases")
    if case is None:
        idx = 0
    else:
        names = [c.get("name") if isinstance(c, dict) else None for c in cases]
        if case in names:
            idx = names.index(case)
        elif isinstance(case, int) or (isinstance(case, str) and case.isdigit()):
            idx = int(case)
            if idx >= len(cases):
                raise _fail(file, "cases", "case index %d out of range (file has %d)"
                            % (idx, len(cases)))
        else:
            raise _fail(file, "cases", "no case named '%s' (use a name or an index 0..%d)"
                        % (case, len(cases) - 1))
    return idx


def _from_case(doc: Dict[str, Any], file: str,
               case: Union[int, str, None]) -> Tuple[Dict[str, Any], str, bool]:
    """The selected case of a cases-layout document as a canonical one (scn_cases.c,
    scn_wfcases.c), its name, and whether it is a weighted-fusion case."""
    idx = _case_index(doc, file, case)
    cpath = "cases[%d]" % idx
    cj = doc["cases"][idx]
    if not isinstance(cj, dict):
        raise _fail(file, cpath, "expected an object")
    cname = cj.get("name")
    cname = cname if isinstance(cname, str) else ""
    from ._wfcases import canonical, is_wfcase  # (it imports this module's reader)

    if is_wfcase(cj):
        return canonical(cj, file, cpath), cname, True
    if "C" in cj:
        if "H" in cj:
            raise _fail(file, cpath, "C and H: the old and the library's letter for one "
                        "matrix; give one")
        cj = {("H" if key == "C" else key): v for key, v in cj.items()}
    for key, v in cj.items():
        if key not in _CASE_KEYS and not isinstance(v, str):
            raise _fail(file, "%s.%s" % (cpath, key), "unknown key")
    steps = cj.get("steps")
    if not isinstance(steps, list) or not steps or not all(isinstance(t, dict) for t in steps):
        raise _fail(file, cpath + ".steps", "expected a list of step objects")
    for j, t in enumerate(steps):
        for key, v in t.items():
            if key not in _STEP_KEYS and not isinstance(v, str):
                raise _fail(file, "%s.steps[%d].%s" % (cpath, j, key), "unknown key")
        if t.get("k") != j + 1:
            raise _fail(file, "%s.steps[%d].k" % (cpath, j),
                        "expected %d (steps list k = 1..N)" % (j + 1))
    model: Dict[str, Any] = {}
    for name in ("F", "Q"):  # from every step (step k's propagates k-1 -> k) or the case
        if name in steps[0]:
            if any(name not in t for t in steps):
                raise _fail(file, "%s.steps[].%s" % (cpath, name),
                            "missing key (step 0 has it, so every step needs it)")
            model[name] = {"per_k": [t[name] for t in steps]}
        elif name in cj:
            model[name] = cj[name]
        else:
            raise _fail(file, "%s.%s" % (cpath, name),
                        "missing key (give it in the case or in every step)")
    for key in ("H", "R", "x0", "P0"):
        if key not in cj:
            raise _fail(file, "%s.%s" % (cpath, key), "missing key")
    H, R = cj["H"], cj["R"]
    if not isinstance(H, list) or not H or not isinstance(R, list) or len(R) != len(H):
        raise _fail(file, cpath + ".R", "expected a list of matrices, one per H")
    model["sensors"] = [{"H": h, "R": r} for h, r in zip(H, R)]
    ks = list(range(1, len(steps) + 1))
    y = []
    for i in range(len(H)):
        vals = []
        for j, t in enumerate(steps):
            z = t.get("z")
            if not isinstance(z, list) or len(z) != len(H):
                raise _fail(file, "%s.steps[%d].z" % (cpath, j),
                            "expected a list of %d measurements (one per sensor, as H)" % len(H))
            vals.append(z[i])
        y.append({"k": ks, "values": vals})
    return ({"model": model, "init": {"x00": cj["x0"], "P00": cj["P0"]}, "y": y,
             "N": len(steps)}, cname, False)


class _Group:
    """The sensors a filter takes stacked: H stacked; R, D, B, Rd block-diagonal."""

    def __init__(self, s: _Scenario, idx: Sequence[int], ui: bool) -> None:
        self.s, self.idx, self.ui = s, list(idx), ui
        self.ms = [s.sensor("H", i).shape[0] for i in idx]
        self.ps = [s.sensor("D", i).shape[1] for i in idx] if ui else [0] * len(idx)
        self.m, self.p = sum(self.ms), sum(self.ps)

    def meas(self, k: int) -> Dict[str, np.ndarray]:
        s, n = self.s, self.s.n
        H = np.zeros((self.m, n))
        R = np.zeros((self.m, self.m))
        D = np.zeros((self.m, self.p))
        y = np.zeros(self.m)
        r0 = c0 = 0
        for i, m, p in zip(self.idx, self.ms, self.ps):
            H[r0:r0 + m] = s.sensor("H", i).at(k)
            R[r0:r0 + m, r0:r0 + m] = s.sensor("R", i).at(k)
            y[r0:r0 + m] = s.yk(i, k)
            if self.ui:
                D[r0:r0 + m, c0:c0 + p] = s.sensor("D", i).at(k)
            r0, c0 = r0 + m, c0 + p
        out = {"H": H, "R": R, "y": y}
        if self.ui:
            out["D"] = D
        return out

    def dyn(self, k: int) -> Dict[str, np.ndarray]:
        B = np.zeros((self.p, self.p))
        Rd = np.zeros((self.p, self.p))
        c0 = 0
        for i, p in zip(self.idx, self.ps):
            B[c0:c0 + p, c0:c0 + p] = self.s.sensor("B", i).at(k)
            Rd[c0:c0 + p, c0:c0 + p] = self.s.sensor("Rd", i).at(k)
            c0 += p
        return {"B": B, "Rd": Rd}


def _rec(series: Dict[str, list], key: str, A: Any, rows: Optional[int] = None) -> None:
    """A vector (rows None) or a matrix of `rows` rows into the series (the
    bindings give a matrix of one column as a vector: its shape back)."""
    A = np.asarray(A)
    series.setdefault(key, []).append((A.reshape(-1) if rows is None else A.reshape(rows, -1))
                                      .tolist())


class _Est:
    """One estimator (estimator.c's dkf_est_t): a kind's filter over a group."""

    def __init__(self, kind: str, s: _Scenario, idx: Sequence[int], P0: np.ndarray,
                 fused: bool, opts: Dict[str, Any]) -> None:
        self.kind, self.s, self.fused = kind, s, fused
        self.core = core = opts["core"]
        self.series: Dict[str, list] = {}
        ui = kind in _NEEDS_UI
        self.groups = [_Group(s, [i], ui) for i in idx] if fused else [_Group(s, idx, ui)]
        x0 = s.init["x00"].reshape(-1)
        F0, Q0 = s.mat("F").at(0), s.mat("Q").at(0)
        g = self.groups[0]
        if kind == "kf":
            m0 = g.meas(1)
            self.f = core.KalmanFilter(F=F0, Q=Q0, H=m0["H"], R=m0["R"], x0=x0, P0=P0)
        elif kind == "info":
            self.f = core.InformationFilter(F=F0, Q=Q0, x0=x0, P0=P0)
        elif kind in _INPUT_PRIOR:
            d00 = opts.get("d00")
            d0 = (np.asarray(d00, dtype=np.float64) if d00 is not None
                  else s.init["d00"].reshape(-1))
            scale = opts.get("Pd00_scale") or 1.0
            Pd0 = np.asarray(scale * s.init["Pd00"], dtype=np.float64)
            cls = core.ASKF if kind == "askf" else core.OTSKF
            self.f = cls(x0, P0, d0, Pd0, m=g.m)
        elif not fused:  # dkf, stacked: start with F_0, Q_0 and y_1
            self.f = core.DifferenceKF(x0, P0, m=g.m, p=g.p)
            m1 = g.meas(1)
            self.f.start(m1["y"], m1["H"], m1["D"], m1["R"], F0=F0, Q0=Q0)
        else:  # dkf, fused: a node filter per sensor and the fusion centre
            self.nodes = []
            for gi, i in zip(self.groups, idx):
                self.nodes.append(core.DifferenceKF(x0, s.P00_local(i), m=gi.m, p=gi.p))
            self.f = core.DiffKFFusionCentre(
                x0, P0, m=[gi.m for gi in self.groups], p=[gi.p for gi in self.groups],
                P0_local=[s.P00_local(i) for i in idx])
            sensors = []
            for node, gi in zip(self.nodes, self.groups):
                m1 = gi.meas(1)
                node.start(m1["y"], m1["H"], m1["D"], m1["R"], F0=F0, Q0=Q0)
                sensors.append({"B": gi.dyn(1)["B"], "H": m1["H"], "D": m1["D"], "R": m1["R"]})
            self.f.start(F0, Q0, sensors)

    def _x(self) -> Tuple[np.ndarray, np.ndarray]:
        if self.kind == "dkf":
            return self.f.xf, self.f.Pf
        return self.f.x, self.f.P

    def step(self, k: int) -> None:
        s, ser, f = self.s, self.series, self.f
        n, p = s.n, self.groups[0].p
        if self.kind == "dkf":
            self._dkf_step(k)
        else:
            F, Q = s.mat("F").at(k - 1), s.mat("Q").at(k - 1)
            if self.kind == "kf":
                f.predict(F=F, Q=Q)
            elif self.kind == "info":
                f.predict(F=F, Q=Q)
                _rec(ser, "yp", f.y)
                _rec(ser, "Yp", f.Y, n)
            else:
                f.predict(F, Q, **self.groups[0].dyn(k - 1))
                if self.kind == "askf":
                    _rec(ser, "Xp", f.X)
                    _rec(ser, "PXp", f.PX, n + p)
                else:
                    for key, v, rows in (("xtp", f.xt, None), ("Pxp", f.Px, n),
                                         ("dp", f.d, None), ("Pdp", f.Pd, p), ("U", f.U, n)):
                        _rec(ser, key, v, rows)
            _rec(ser, "xp", f.x)
            _rec(ser, "Pp", f.P, n)
            self._update(k)
        x, P = self._x()
        _rec(ser, "xf", x)
        _rec(ser, "Pf", P, n)

    def _update(self, k: int) -> None:
        ser, f = self.series, self.f
        n, p = self.s.n, self.groups[0].p
        meas = [g.meas(k) for g in self.groups]
        if self.kind == "kf":
            f.update(meas[0]["y"], H=meas[0]["H"], R=meas[0]["R"])
        elif self.kind == "info":
            contrib = [self.core.info_contribution(mi["y"], mi["H"], mi["R"]) for mi in meas]
            if self.fused:
                ser.setdefault("i", []).append([np.reshape(c[0], -1).tolist() for c in contrib])
                ser.setdefault("I", []).append([np.reshape(c[1], (n, n)).tolist()
                                                for c in contrib])
            f.fuse(np.stack([c[0] for c in contrib]), np.stack([c[1] for c in contrib]))
            _rec(ser, "yf", f.y)
            _rec(ser, "Yf", f.Y, n)
        else:
            mi = meas[0]
            f.update(mi["y"], mi["H"], mi["D"], mi["R"])
            if self.kind == "askf":
                _rec(ser, "Xf", f.X)
                _rec(ser, "PXf", f.PX, n + p)
            else:
                n, p = self.s.n, self.groups[0].p
                for key, v, rows in (("xtf", f.xt, None), ("Pxf", f.Px, n), ("df", f.d, None),
                                     ("Pdf", f.Pd, p), ("V", f.V, n)):
                    _rec(ser, key, v, rows)

    def _dkf_step(self, k: int) -> None:
        """Step k takes y_{k+1}: the dynamics at k, the model at k + 1 (est_diffkf.c)."""
        s, ser, f = self.s, self.series, self.f
        n = s.n
        _rec(ser, "xp", f.xn)
        _rec(ser, "Pp", f.Pn, n)
        F, Q = s.mat("F").at(k), s.mat("Q").at(k)
        if not self.fused:
            g = self.groups[0]
            mk = g.meas(k + 1)
            f.step(mk["y"], F=F, Q=Q, H=mk["H"], D=mk["D"], R=mk["R"], **g.dyn(k))
        else:
            sensors, messages = [], []
            for node, g in zip(self.nodes, self.groups):
                mk, dk = g.meas(k + 1), g.dyn(k)
                node.step(mk["y"], F=F, Q=Q, H=mk["H"], D=mk["D"], R=mk["R"], **dk)
                messages.append(node.message())
                sensors.append({"B": dk["B"], "Rd": dk["Rd"], "H": mk["H"], "D": mk["D"],
                                "R": mk["R"]})
            f.step(F, Q, sensors, messages)
        pk = np.size(f.dz)  # J, K: n x pk; L: pk x pk (diffkf.h)
        for key, rows in (("z", None), ("dz", None), ("J", n), ("L", pk), ("K", n)):
            _rec(ser, key, getattr(f, key), rows)
        if self.fused:
            _rec(ser, "messages", [{"xf": m[1], "xp": m[2]} for m in messages])
            rec = []
            for i in range(len(self.nodes)):
                z, dz = f.recovered(i)
                rec.append({"dz": dz.tolist(), "z": z.tolist(),
                            "K": self.nodes[i].K.reshape(self.s.n, -1).tolist()})
            ser.setdefault("fc_recovered", []).append(rec)


def real_name(core: Any) -> str:
    """dkf-run's "real" of a core module: "double" or "float"."""
    return "float" if core.dtype == "float32" else "double"


def _plain(v: Any) -> Any:
    """Arrays inside dicts and lists as lists of floats."""
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, dict):
        return {key: _plain(x) for key, x in v.items()}
    if isinstance(v, list):
        return [_plain(x) for x in v]
    return v


def run_scenario(scenario: Union[str, "os.PathLike[str]", Dict[str, Any]], filter: str,
                 run: int = 0, *, d00: Optional[Sequence[float]] = None,
                 Pd00_scale: Optional[float] = None, case: Union[int, str, None] = None,
                 name: Optional[str] = None, eta: Optional[int] = None,
                 metrics_only: bool = False) -> Dict[str, Any]:
    """Run filter `filter` over a scenario; the dict `dkf-run --output` writes.

    scenario: a path to a scenario JSON file, or the scenario as a dict
    (docs/reference/scenario-format.md: the canonical layout, the linear
    cases layout with kf and info, the seed-004 steps layout, the seed-003
    network layout, seed 002's weighted-fusion cases). filter: one of
    SUPPORTED_FILTERS. run: the Monte-Carlo run (dkf-run --run). d00,
    Pd00_scale: dkf-run's --d00 and --Pd00-scale (askf, otskf). case: a
    cases-layout file's case, a name or an index (dkf-run --case; default
    0). name: the document's "scenario" (default: the path as given,
    "<dict>" for a dict). eta, metrics_only: dkf-run's --eta (tw3) and
    --metrics-only (tw1, tw2, tw3).

    Returns {"scenario", ("case",) "filter", "real", "k", "outputs"} (tw1-3
    also "communication", tw3 "eta"), every number the one dkf-run writes. A
    file this runner cannot read (another layout, a filter it does not run)
    raises ValueError naming it; a failed filter call raises the dkf.Error
    of the call.
    """
    return run_with(_core, scenario, filter, run, d00=d00, Pd00_scale=Pd00_scale, case=case,
                    name=name, eta=eta, metrics_only=metrics_only)


def run_with(core: Any, scenario: Union[str, "os.PathLike[str]", Dict[str, Any]], filter: str,
             run: int = 0, *, d00: Optional[Sequence[float]] = None,
             Pd00_scale: Optional[float] = None, case: Union[int, str, None] = None,
             name: Optional[str] = None, eta: Optional[int] = None,
             metrics_only: bool = False) -> Dict[str, Any]:
    """run_scenario over the filters of `core` (_dkf_double or _dkf_float)."""
    if filter not in SUPPORTED_FILTERS:
        raise ValueError("run_scenario: filter %r: not run from Python (this runner takes %s; "
                         "dkf-run runs the others)" % (filter, ", ".join(SUPPORTED_FILTERS)))
    if isinstance(scenario, dict):
        doc, file = scenario, name if name is not None else "<dict>"
    else:
        file = os.fspath(scenario)
        with open(file, encoding="utf-8") as fh:
            doc = json.load(fh)
        if name is not None:
            file = name
    if isinstance(run, bool) or not isinstance(run, int) or run < 0:
        raise ValueError("run_scenario: run %r: expected a run index >= 0" % (run,))
    if (d00 is not None or Pd00_scale is not None) and filter not in _INPUT_PRIOR:
        raise ValueError("run_scenario: d00 and Pd00_scale: only for askf and otskf")
    if Pd00_scale is not None and not (np.isfinite(Pd00_scale) and Pd00_scale > 0):
        raise ValueError("run_scenario: Pd00_scale %r: expected a finite number > 0"
                         % (Pd00_scale,))
    if eta is not None and (filter != "tw3" or isinstance(eta, bool) or not isinstance(eta, int)
                            or not 0 <= eta <= TW_MAX_ETA):
        raise ValueError("run_scenario: eta %r: only for tw3, an integer in 0..%d"
                         % (eta, TW_MAX_ETA))
    if metrics_only and filter not in _TW:
        raise ValueError("run_scenario: metrics_only: only for tw1, tw2, tw3")
    steps_layout = isinstance(doc, dict) and "steps" in doc and "y" not in doc and "runs" not in doc
    if steps_layout and filter not in _UIF + _TW:
        raise _fail(file, "steps", "filter %s reads the canonical or the cases layout, not this "
                    "file's steps layout (run it with %s)" % (filter, ", ".join(_UIF + _TW)))
    if filter in _UIF + _TW and not steps_layout:
        raise _fail(file, "steps", "missing key (filter %s reads the seed-00%d steps layout)"
                    % (filter, 3 if filter in _TW else 4))
    if steps_layout and filter in _TW:
        if run != 0 or case is not None or d00 is not None or Pd00_scale is not None:
            raise _fail(file, "steps", "run, case, d00 and Pd00_scale: not for the steps layout")
        from ._network import run_tw  # (it imports this module's reader)

        return run_tw(core, doc, file, filter, eta=eta, metrics_only=metrics_only)
    if steps_layout:
        if run != 0 or case is not None or d00 is not None or Pd00_scale is not None:
            raise _fail(file, "steps", "run, case, d00 and Pd00_scale: not for the steps layout")
        from ._steps import run_uif  # (it imports this module's reader)

        return run_uif(core, doc, file, filter)
    case_name, wf = None, False
    if isinstance(doc, dict) and "cases" in doc and "steps" not in doc:
        if run != 0:
            raise _fail(file, "--run %d" % run, "the file has 1 run (0..0)")
        from ._nlcases import is_nlcase, run_nl  # (it imports this module)

        if is_nlcase(doc, file, case):
            return run_nl(core, doc, file, case, filter)
        if filter in _NL:
            raise _fail(file, "cases", "filter %s reads a nonlinear case (model or "
                        "node_models)" % filter)
        doc, case_name, wf = _from_case(doc, file, case)
    elif case is not None:
        raise _fail(file, "cases", "case given but the file has no cases")
    if filter in _NL and case_name is None:
        raise _fail(file, "cases", "missing key (filter %s reads seed 001's nonlinear cases)"
                    % filter)
    if filter in _WF and not wf:
        raise _fail(file, "cases", "filter %s reads a weighted-fusion case (Phi, Gamma, Qe, "
                    "H_signal: seed 002)" % filter)
    if wf and filter not in _WF + ("kf", "info"):
        raise _fail(file, "cases", "filter %s reads the canonical or a linear cases layout, "
                    "not this weighted-fusion case (run it with %s, kf or info)"
                    % (filter, ", ".join(_WF)))
    if wf:
        from ._wfcases import run_wfusion

        if filter in _WF:
            return run_wfusion(core, doc, file, case_name or "", filter)
        doc = {key: v for key, v in doc.items() if not key.startswith("_")}
    s = _Scenario(doc, file, run)
    if filter in _INPUT_PRIOR:
        if s.multi:
            raise _fail(file, "model.sensors", "filter %s supports single-sensor scenarios only"
                        % filter)
        p = s.sensor("D", 0).shape[1]
        if d00 is not None and len(d00) != p:
            raise _fail(file, "d00", "expected %d values (the columns of D), got %d"
                        % (p, len(d00)))
        for key in (("Pd00",) if d00 is not None else ("d00", "Pd00")):
            if key not in s.init:
                raise _fail(file, "init." + key, "missing key (filter %s needs it)" % filter)
    opts = {"d00": d00, "Pd00_scale": Pd00_scale, "core": core}
    P0c = s.P00_central()
    L = len(s.sensors)
    if not s.multi:
        ests = [(_LABELS[filter], _Est(filter, s, [0], P0c, False, opts))]
    else:
        ests = [("local[%d]" % i, _Est(filter, s, [i], s.P00_local(i), False, opts))
                for i in range(L)]
        ests.append(("central", _Est(filter, s, list(range(L)), P0c, False, opts)))
        if filter in _FUSED:
            ests.append(("fused", _Est(filter, s, list(range(L)), P0c, True, opts)))
    for k in range(1, s.steps + 1):
        for _, e in ests:
            e.step(k)
    outputs: Dict[str, Any] = {}
    for label, e in ests:
        ser = dict(e.series)
        if case_name is not None and not wf:
            ser = {_CASE_NAMES.get(key, key): v for key, v in ser.items()}
        for key in ("messages", "fc_recovered"):
            if key in ser:
                outputs[key] = ser.pop(key)
        if label.startswith("local["):
            outputs.setdefault("local", []).append(ser)
        else:
            outputs[label] = ser
    head: Dict[str, Any] = {"scenario": file}
    if case_name is not None:
        head["case"] = case_name
    head.update({"filter": filter, "real": real_name(core), "k": list(range(1, s.steps + 1)),
                 "outputs": outputs})
    return _plain(head)
