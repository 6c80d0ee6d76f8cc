"""run_scenario's seed-004 steps layout: rtsf, nrtsf_df, nrtsf (dkf/uif.h).

The C runner is ports/linux/families/uif_run.c over scn_steps.c's reader:
rtsf and nrtsf_df start at k = 0 with (x0, P0) the prior of x_0 and no time
update in step 0; nrtsf starts at k = 1 from x_{0|0} and has no D. Every
step records the vectors' `expected` names, a matrix of one column written
as a vector (put_mat), proj always as a matrix.
"""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from ._scenario import _Mat, _comment, _fail, _numbers, real_name

UIF_LABELS = {"rtsf": "RTSF", "nrtsf_df": "NRTSF_DF", "nrtsf": "NRTSF"}


def _has(obj: Dict[str, Any], letters) -> Optional[str]:
    for key in letters:
        for k in (key, key + "_prev"):
            if k in obj:
                return k
    return None


def _renamed(obj: Dict[str, Any], pairs) -> Dict[str, Any]:
    out = dict(obj)
    for old, new in pairs:
        for suffix in ("", "_prev"):
            if old + suffix in out:
                out[new + suffix] = out.pop(old + suffix)
    return out


class _Steps:
    """A seed-004 steps-layout file: model (constant), per-step inputs, init
    (scn_steps.c; the network form of seed 003 is _network.py's _Net)."""

    # seed 004's old letters: A, C, H = F, H, D (H renamed first); the letters
    # only the old and only the new convention have (scn_letters.c)
    OLD = (("H", "D"), ("C", "H"), ("A", "F"))
    OLD_ONLY, NEW_ONLY = ("A", "C"), ("F", "D")
    NODE_KEYS: Tuple[str, ...] = ()  # the network's per-node matrices (lists of N)

    def __init__(self, doc: Dict[str, Any], file: str) -> None:
        self.file = file
        steps = doc["steps"]
        if not isinstance(steps, list) or not steps or not all(isinstance(t, dict)
                                                                for t in steps):
            raise _fail(file, "steps", "expected a non-empty list of step objects")
        model = doc.get("model") or {}
        inputs = [t.get("inputs") or {} for t in steps]
        objs = [("model", model)] + [("steps[%d].inputs" % j, i) for j, i in enumerate(inputs)]
        old = next(("%s.%s" % (p, k) for p, o in objs for k in [_has(o, self.OLD_ONLY)] if k),
                   None)
        new = next(("%s.%s" % (p, k) for p, o in objs for k in [_has(o, self.NEW_ONLY)] if k),
                   None)
        if old and new:
            raise _fail(file, old, "old letters beside the library's (%s): give one" % new)
        if old:
            model = _renamed(model, self.OLD)
            inputs = [_renamed(i, self.OLD) for i in inputs]
        given = {key for key, v in model.items() if v is not None and not _comment(v)}
        for j, i in enumerate(inputs):  # a matrix in one place: the model or the steps
            for key, v in i.items():
                base = key[:-5] if key.endswith("_prev") else key
                if key == "y" or v is None or _comment(v):
                    continue
                if base in given or key != base and any(base in o for o in inputs):
                    raise _fail(file, "steps[%d].inputs.%s" % (j, key), "also given as model.%s "
                                "or as another step input (give one)" % base)
        self.model = {key: _Mat(file, "model." + key, v) for key, v in model.items()
                      if v is not None and not _comment(v) and key not in self.NODE_KEYS}
        self.node_model = {key: model[key] for key in self.NODE_KEYS if key in model}
        self.inputs = inputs
        init = doc.get("init")
        if not isinstance(init, dict) or "x0" not in init or "P0" not in init:
            raise _fail(file, "init", "expected {\"x0\": [...], \"P0\": [[...]]}")
        self.x0 = _numbers(file, "init.x0", init["x0"], 1)
        self.P0 = _numbers(file, "init.P0", init["P0"], 2)
        self.times: List[int] = []
        for j, t in enumerate(steps):
            k = t.get("k", t.get("n"))  # seed 004's k, seed 003's n
            if isinstance(k, bool) or not isinstance(k, int):
                raise _fail(file, "steps[%d].k" % j, "missing key (k, or n) or not an integer")
            if j == 0 and k not in (0, 1):
                raise _fail(file, "steps[0].k", "expected 0 or 1, got %d" % k)
            if j > 0 and k != self.times[-1] + 1:
                raise _fail(file, "steps[%d].k" % j, "expected %d (the steps follow one by one)"
                            % (self.times[-1] + 1))
            self.times.append(k)

    def has(self, name: str) -> bool:
        return name in self.model or any(name in i or name + "_prev" in i for i in self.inputs)

    def at(self, name: str, j: int) -> np.ndarray:
        """name at step j's time."""
        if name in self.inputs[j]:
            return _numbers(self.file, "steps[%d].inputs.%s" % (j, name), self.inputs[j][name], 2)
        if name not in self.model:
            raise _fail(self.file, "model.%s" % name, "missing key")
        return self.model[name].at(self.times[j])

    def prev(self, name: str, j: int) -> np.ndarray:
        """name at step j's time - 1 (the dynamics that lead to it)."""
        if name + "_prev" in self.inputs[j]:
            return _numbers(self.file, "steps[%d].inputs.%s_prev" % (j, name),
                            self.inputs[j][name + "_prev"], 2)
        if j > 0 and name in self.inputs[j - 1]:
            return self.at(name, j - 1)
        if name not in self.model:
            raise _fail(self.file, "steps[%d].inputs.%s_prev" % (j, name), "missing key")
        return self.model[name].at(self.times[j] - 1)

    def first(self, name: str) -> np.ndarray:
        """name wherever the file first gives it (its shape is the same everywhere)."""
        if name in self.model:
            return self.model[name].at(self.times[0]) if self.model[name].const is None else (
                self.model[name].const)
        for j, i in enumerate(self.inputs):
            if name in i:
                return self.at(name, j)
            if name + "_prev" in i:
                return self.prev(name, j)
        raise _fail(self.file, "model.%s" % name, "missing key")

    def y(self, j: int) -> np.ndarray:
        if "y" not in self.inputs[j]:
            raise _fail(self.file, "steps[%d].inputs.y" % j, "missing key")
        return _numbers(self.file, "steps[%d].inputs.y" % j, self.inputs[j]["y"], 1)


def _put(series: Dict[str, list], key: str, A: Any, as_matrix: bool = False) -> None:
    A = np.asarray(A)
    if A.ndim == 2 and A.shape[1] == 1 and not as_matrix:
        A = A.reshape(-1)  # put_mat: a matrix of one column is written as a vector
    series.setdefault(key, []).append(A.tolist())


def run_uif(core: Any, doc: Dict[str, Any], file: str, filter: str) -> Dict[str, Any]:
    """The document dkf-run --filter rtsf|nrtsf_df|nrtsf writes for a seed-004 file."""
    if "graph" in doc:
        raise _fail(file, "graph", "filter %s needs a seed-004 file (model F, G, Q, H, D, R), "
                    "not a seed-003 network (run it with tw1, tw2, tw3)" % filter)
    s = _Steps(doc, file)
    kind = UIF_LABELS[filter]
    if filter == "nrtsf":
        if s.has("D"):
            raise _fail(file, "model.D", "filter nrtsf has no direct feedthrough (D = 0): the "
                        "file must not give D")
        if s.times[0] != 1:
            raise _fail(file, "steps[0].k", "filter nrtsf starts at k = 1 ((x0, P0) = x_{0|0}, "
                        "y_0 unused), got %d" % s.times[0])
    else:
        if not s.has("D"):
            raise _fail(file, "model.D", "missing key (filter %s needs the feedthrough D)"
                        % filter)
        if s.times[0] != 0:
            raise _fail(file, "steps[0].k", "filter %s starts at k = 0 ((x0, P0) is the prior "
                        "of x_0), got %d" % (filter, s.times[0]))
    f = core.UIF(s.x0.reshape(-1), s.P0, m=s.at("H", 0).shape[0], p=s.first("G").shape[1],
                  kind=kind)
    ser: Dict[str, list] = {}
    for j, k in enumerate(s.times):
        meas = {"H": s.at("H", j), "R": s.at("R", j)}
        if filter != "nrtsf":
            meas["D"] = s.at("D", j)
        if filter == "nrtsf" or k > 0:
            meas.update(F=s.prev("F", j), G=s.prev("G", j), Q=s.prev("Q", j))
        f.step(s.y(j), **meas)
        for key in ("x_pred", "P_pred", "Rtilde", "d", "Pd", "x", "Px"):
            _put(ser, key, getattr(f, key))
        _put(ser, "Pxd_extra" if filter == "nrtsf" else "Pxd", f.Pxd)
        for key in ("L", "K", "M"):
            _put(ser, key, getattr(f, key))
        ser.setdefault("rank", []).append(int(f.rank))
        _put(ser, "proj", f.proj, as_matrix=True)
        ser.setdefault("estimable", []).append([int(e) for e in f.estimable])
        ser.setdefault("bias_risk", []).append(int(f.bias_risk))
        ser.setdefault("bias_steps", []).append(int(f.bias_steps))
    return {"scenario": file, "filter": filter, "real": real_name(core), "k": list(s.times),
            "outputs": {UIF_LABELS[filter]: ser}}
