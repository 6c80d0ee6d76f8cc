"""dkf.simulate: a scenario (truth and measurements) drawn from a linear model.

The model is the canonical layout's (docs/reference/scenario-format.md):
x_{k+1} = F_k x_k + v_k, v_k ~ N(0, Q_k); sensor i measures
y^i_k = H^i_k x_k + D^i_k d^i_k + w^i_k, w^i_k ~ N(0, R^i_k), where its unknown
input, if it has a D, follows d^i_{k+1} = B^i_k d^i_k + wd^i_k,
wd^i_k ~ N(0, Rd^i_k). The result is a scenario dict that dkf-run and
dkf.run_scenario read as it is.
"""

from __future__ import annotations

import ast
import copy
import json
import math
import os
from typing import Any, Callable, Dict, List, Optional, Union

import numpy as np

from ._scenario import _Mat, _Scenario


def _draw(rng: np.random.Generator, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
    # numpy's SVD method: a positive semidefinite cov (a Q with zero blocks) is fine
    return rng.multivariate_normal(mean, cov)


def simulate(model: Union[str, "os.PathLike[str]", Dict[str, Any]], steps: int,
             seed: Optional[int] = None) -> Dict[str, Any]:
    """A scenario of `steps` steps drawn from `model`, with numpy's default_rng(seed).

    model: a dict (or the path of a JSON file) with the canonical layout's
    "model" and "init" (docs/reference/scenario-format.md): F, Q and H, R (one
    sensor) or "sensors": [{H, R, ...}, ...], each matrix a bare matrix,
    {"const": M} or {"per_k": [M_0, M_1, ...]} (entries up to k = steps + 1);
    optionally per sensor D, B, Rd (an unknown input d^i with
    d_{k+1} = B d_k + wd_k, entering y^i through D). init: x00 and P00 (or
    P00_central): x_0 ~ N(x00, P00); d^i_0 ~ N(d00, Pd00) when init has them
    (one sensor), else d^i_0 = 0.

    Returns a scenario: the model's "model" and "init", "N" = steps, "seed",
    "y" (k = 1..steps + 1, so the Difference KF has its y_{N+1}) and "truth"
    (x for k = 0..steps + 1, and the inputs: "d" for one sensor,
    "d_stacked" for several).

    A model with G (one sensor, constant matrices: x_{k+1} = F x_k + G d_k
    + w_k, y_k = H x_k + D d_k + v_k, the input drawn from B, Rd and
    init d00, Pd00 or 0) gives the seed-004 steps layout instead, which
    the filters rtsf and nrtsf_df read (steps k = 0..steps - 1), or without D
    nrtsf (k = 1..steps): "init" {x0, P0}, "model" {F, G, Q, H, D, R} and
    per step "inputs" {y} and "truth" {x, d} (nrtsf: {x, d_prev}).

    A model with "expr" (the nonlinear cases' expression model, f and g in
    x1..xn, d1..dp: docs/guide/nl-models.md; arithmetic only) and init x0,
    Px0, d0, Pd0 (Pxd0) gives a one-case nonlinear-cases scenario:
    x_k = f(x_{k-1}, d_{k-1}) + w, d_k = B d_{k-1} + wd (B, Rd in model:
    default I and 0), z_k = g(x_k, d_k) + v, with x_true, d_true for
    k = 1..steps, for dkf-run's nonlinear filters (nertsif, ...).
    """
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ValueError("simulate: steps %r: expected an integer >= 1" % (steps,))
    if isinstance(model, dict):
        doc = model
    else:
        with open(os.fspath(model), encoding="utf-8") as fh:
            doc = json.load(fh)
    if not isinstance(doc, dict) or "model" not in doc or "init" not in doc:
        raise ValueError("simulate: expected a dict with the scenario keys \"model\" and "
                         "\"init\"")
    if isinstance(doc["model"], dict) and "G" in doc["model"]:
        return _simulate_steps(doc, steps, seed)
    if isinstance(doc["model"], dict) and "expr" in doc["model"]:
        return _simulate_expr(doc, steps, seed)
    base = {"model": doc["model"], "init": doc["init"], "N": steps}
    L = len(doc["model"]["sensors"]) if isinstance(doc["model"], dict) and isinstance(
        doc["model"].get("sensors"), list) else 1
    # the reader's checks and matrices, over a placeholder y
    probe = dict(base)
    probe["y"] = [{"k": [], "values": []}] * L if "sensors" in doc["model"] else {
        "k": [], "values": []}
    s = _Scenario(probe, "simulate", 0)
    n = s.n
    rng = np.random.default_rng(seed)
    P0 = s.P00_central()
    x = _draw(rng, s.init["x00"].reshape(-1), P0)
    has_d = [("D" in s.sensors[i] or "D" in s.model) for i in range(L)]
    d: List[np.ndarray] = []
    for i in range(L):
        p = s.sensor("D", i).shape[1] if has_d[i] else 0
        if p and "d00" in s.init and "Pd00" in s.init and L == 1:
            d.append(_draw(rng, s.init["d00"].reshape(-1), s.init["Pd00"]))
        else:
            d.append(np.zeros(p))
    truth_x = [x]
    truth_d = [np.concatenate(d) if d else np.zeros(0)]
    ys: List[List[List[float]]] = [[] for _ in range(L)]
    for k in range(1, steps + 2):
        x = s.mat("F").at(k - 1) @ x + _draw(rng, np.zeros(n), s.mat("Q").at(k - 1))
        for i in range(L):
            if has_d[i]:
                p = d[i].shape[0]
                d[i] = s.sensor("B", i).at(k - 1) @ d[i] + _draw(rng, np.zeros(p),
                                                                  s.sensor("Rd", i).at(k - 1))
        for i in range(L):
            H, R = s.sensor("H", i).at(k), s.sensor("R", i).at(k)
            y = H @ x + _draw(rng, np.zeros(H.shape[0]), R)
            if has_d[i]:
                y = y + s.sensor("D", i).at(k) @ d[i]
            ys[i].append(y.tolist())
        truth_x.append(x)
        truth_d.append(np.concatenate(d) if d else np.zeros(0))
    ks = list(range(1, steps + 2))
    ylist = [{"k": ks, "values": v} for v in ys]
    out = copy.deepcopy(base)
    out["generator"] = "dkf.simulate(steps=%d, seed=%r)" % (steps, seed)
    if seed is not None:
        out["seed"] = seed
    out["y"] = ylist if "sensors" in doc["model"] else ylist[0]
    truth: Dict[str, Any] = {"k": list(range(0, steps + 2)), "x": [t.tolist() for t in truth_x]}
    if any(has_d):
        truth["d" if L == 1 and "sensors" not in doc["model"] else "d_stacked"] = [
            t.tolist() for t in truth_d]
    out["truth"] = truth
    return out


_STEPS_MODEL = ("F", "G", "Q", "H", "D", "R")


def _simulate_steps(doc: Dict[str, Any], steps: int, seed: Optional[int]) -> Dict[str, Any]:
    """A model with G: a seed-004 steps-layout scenario (rtsf, nrtsf_df; nrtsf without D)."""
    model, init = doc["model"], doc["init"]
    for key, v in model.items():
        if key not in _STEPS_MODEL + ("B", "Rd") and not isinstance(v, str):
            raise ValueError("simulate: model.%s: unknown key of a model with G (F, G, Q, H, "
                             "D, R and the input's B, Rd)" % key)
    for key in ("F", "G", "Q", "H", "R", "B", "Rd"):
        if key not in model:
            raise ValueError("simulate: model.%s: missing key (a model with G needs F, G, Q, "
                             "H, R, and B, Rd to draw its input d)" % key)
    mats = {}
    for key in model:
        if isinstance(model[key], str):
            continue
        m = _Mat("simulate", "model." + key, model[key])
        if m.const is None:
            raise ValueError("simulate: model.%s: per_k: a model with G is constant in time "
                             "(the steps layout's model)" % key)
        mats[key] = m.const
    for key in ("x00", "P00"):
        if key not in init:
            raise ValueError("simulate: init.%s: missing key" % key)
    F, G, Q, H, R, B, Rd = (mats[k] for k in ("F", "G", "Q", "H", "R", "B", "Rd"))
    D = mats.get("D")
    n, p = F.shape[0], G.shape[1]
    if G.shape[0] != n or H.shape[1] != n or B.shape != (p, p) or Rd.shape != (p, p) or (
            D is not None and D.shape != (H.shape[0], p)):
        raise ValueError("simulate: model: shapes disagree (F n x n, G n x p, H m x n, D m x p, "
                         "B and Rd p x p)")
    x00 = np.array(init["x00"], dtype=np.float64).reshape(-1)
    P00 = np.array(init["P00"], dtype=np.float64)
    rng = np.random.default_rng(seed)
    x = _draw(rng, x00, P00)
    d = (_draw(rng, np.array(init["d00"], dtype=np.float64).reshape(-1),
               np.array(init["Pd00"], dtype=np.float64))
         if "d00" in init and "Pd00" in init else np.zeros(p))
    k0 = 0 if D is not None else 1  # rtsf, nrtsf_df update with y_0; nrtsf starts at 1
    out_steps = []
    for k in range(0, steps + k0):
        if k > 0:
            x, d_prev = F @ x + G @ d + _draw(rng, np.zeros(n), Q), d
            d = B @ d + _draw(rng, np.zeros(p), Rd)
        y = H @ x + _draw(rng, np.zeros(H.shape[0]), R)
        if D is not None:
            y = y + D @ d
        if k >= k0:
            truth = {"x": x.tolist()}
            if D is not None:
                truth["d"] = d.tolist()
            else:
                truth["d_prev"] = d_prev.tolist()  # nrtsf's d at step k is d_{k-1|k}
            out_steps.append({"k": k, "inputs": {"y": y.tolist()}, "truth": truth})
    out: Dict[str, Any] = {
        "generator": "dkf.simulate(steps=%d, seed=%r): x_{k+1} = F x_k + G d_k + w_k, "
                     "d_{k+1} = B d_k + wd_k" % (steps, seed),
        "init": {"x0": init["x00"], "P0": init["P00"]},
        "model": {key: model[key] for key in _STEPS_MODEL if key in model},
        "steps": out_steps}
    if seed is not None:
        out["seed"] = seed
    return out



# ---- expression models (the nonlinear cases' model.expr, muparser's syntax) ----

_FUNCS = {name: getattr(math, name) for name in (
    "sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh", "asinh", "acosh",
    "atanh", "exp", "sqrt", "atan2", "hypot")}
_FUNCS.update({"ln": math.log, "log": math.log, "log10": math.log10, "log2": math.log2,
               "abs": abs, "sign": lambda v: float((v > 0) - (v < 0)), "rint": round,
               "min": min, "max": max, "sum": lambda *v: sum(v),
               "avg": lambda *v: sum(v) / len(v)})
_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Call, ast.Name, ast.Constant, ast.Load,
          ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub, ast.UAdd)


def _compile_expr(text: str, names: List[str], path: str) -> Any:
    """muparser's arithmetic (+ - * / ^, the functions above, pi) as a Python code object;
    comparisons and `c ? a : b` are refused (simulate evaluates only the arithmetic)."""
    if not isinstance(text, str) or "?" in text or any(c in text for c in "<>=!&|"):
        raise ValueError("simulate: %s: %r: simulate evaluates arithmetic expressions only "
                         "(no comparisons or c ? a : b)" % (path, text))
    try:
        tree = ast.parse(text.replace("^", "**"), mode="eval")
    except SyntaxError:
        raise ValueError("simulate: %s: %r: not an expression" % (path, text)) from None
    for node in ast.walk(tree):
        if not isinstance(node, _NODES):
            raise ValueError("simulate: %s: %r: %s not allowed" % (path, text,
                                                                  type(node).__name__))
        if isinstance(node, ast.Name) and node.id not in names and node.id not in _FUNCS and (
                node.id != "pi"):
            raise ValueError("simulate: %s: %r: unknown variable or function %r (variables: "
                             "%s)" % (path, text, node.id, ", ".join(names)))
        if isinstance(node, ast.Call) and not (isinstance(node.func, ast.Name)
                                               and node.func.id in _FUNCS):
            raise ValueError("simulate: %s: %r: unknown function" % (path, text))
    return compile(tree, path, "eval")


def _expr_fn(exprs: Any, names: List[str], path: str) -> Callable[[Dict[str, float]], np.ndarray]:
    if not isinstance(exprs, list) or not exprs:
        raise ValueError("simulate: %s: expected a list of expressions" % path)
    code = [_compile_expr(e, names, "%s[%d]" % (path, i)) for i, e in enumerate(exprs)]
    env = dict(_FUNCS, pi=math.pi, __builtins__={})

    def fn(values: Dict[str, float]) -> np.ndarray:
        scope = dict(env, **values)
        return np.array([float(eval(c, scope)) for c in code])  # noqa: S307 (checked AST)

    return fn


def _simulate_expr(doc: Dict[str, Any], steps: int, seed: Optional[int]) -> Dict[str, Any]:
    """A model.expr (a nonlinear case): x_k = f(x_{k-1}, d_{k-1}) + w, z_k = g(x_k, d_k) + v,
    d_k = B d_{k-1} + wd; a one-case nonlinear-cases scenario."""
    model, init = doc["model"], doc["init"]
    for key in ("x0", "Px0", "d0", "Pd0"):
        if key not in init:
            raise ValueError("simulate: init.%s: missing key (a model.expr needs x0, Px0, d0, "
                             "Pd0)" % key)
    x0 = np.array(init["x0"], dtype=np.float64).reshape(-1)
    d0 = np.array(init["d0"], dtype=np.float64).reshape(-1)
    n, p = x0.shape[0], d0.shape[0]
    names = ["x%d" % (i + 1) for i in range(n)] + ["d%d" % (i + 1) for i in range(p)]
    expr = model["expr"]
    f = _expr_fn(expr.get("f"), names, "model.expr.f")
    g = _expr_fn(expr.get("g"), names, "model.expr.g")
    Q = np.array(model["Q"], dtype=np.float64)
    R = np.array(model["R"], dtype=np.float64)
    B = np.array(model.get("B", np.eye(p)), dtype=np.float64).reshape(p, p)
    Rd = np.array(model.get("Rd", np.zeros((p, p))), dtype=np.float64).reshape(p, p)
    P = np.zeros((n + p, n + p))
    P[:n, :n] = np.array(init["Px0"], dtype=np.float64)
    P[n:, n:] = np.array(init["Pd0"], dtype=np.float64).reshape(p, p)
    if p and "Pxd0" in init and np.size(init["Pxd0"]):
        P[:n, n:] = np.array(init["Pxd0"], dtype=np.float64).reshape(n, p)
        P[n:, :n] = P[:n, n:].T
    rng = np.random.default_rng(seed)
    xd = _draw(rng, np.concatenate([x0, d0]), P)
    x, d = xd[:n], xd[n:]
    xs, ds, zs = [], [], []

    def at(xv: np.ndarray, dv: np.ndarray) -> Dict[str, float]:
        return dict(zip(names, [float(v) for v in np.concatenate([xv, dv])]))

    for k in range(1, steps + 1):
        x = f(at(x, d)) + _draw(rng, np.zeros(n), Q)
        d = B @ d + (_draw(rng, np.zeros(p), Rd) if p else np.zeros(0))
        z = g(at(x, d)) + _draw(rng, np.zeros(R.shape[0]), R)
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(z))):
            raise ValueError("simulate: step k=%d: the model gave a value that is not finite"
                             % k)
        xs.append(x.tolist())
        ds.append(d.tolist())
        zs.append({"k": k, "z": z.tolist()})
    out_model = {key: v for key, v in model.items() if key not in ("B", "Rd")}
    case = {"name": "simulated", "model": out_model, "init": init, "x_true": xs,
            "d_true": ds, "steps": zs}
    out: Dict[str, Any] = {"description": "dkf.simulate(steps=%d, seed=%r) of a model.expr"
                           % (steps, seed), "cases": [case]}
    return out
