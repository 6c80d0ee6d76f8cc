"""run_scenario's weighted-fusion cases (seed 002): the model, and the wfusion
filters local_kf, fusion_scalar, fusion_matrix, fusion_steady, central_kf.

The C side is ports/linux/scenario/scn_wfcases.c (the reader: Q = Gamma Qe
Gamma^T summed in double in one order, the upper triangle mirrored) and
ports/linux/families/wfusion_run.c (every filter runs the local filters and
both fusions at every step; each records its own keys under
outputs.<LABEL>).
"""

from __future__ import annotations

from typing import Any, Dict, List

import numpy as np

from ._scenario import _fail, _matrix, _numbers, real_name

WF_LABELS = {"local_kf": "LOCAL_KF", "fusion_scalar": "FUSION_SCALAR",
             "fusion_matrix": "FUSION_MATRIX", "fusion_steady": "FUSION_STEADY",
             "central_kf": "CENTRAL_KF"}
_CASE_KEYS = {"name", "Phi", "Gamma", "Qe", "H", "R", "H_signal", "x_hat0", "P0", "steps",
              "x_true", "steady_state", "held_out"}


def is_wfcase(cj: Dict[str, Any]) -> bool:
    return all(key in cj for key in ("Phi", "Gamma", "Qe", "H_signal"))


def gamma_q(G: np.ndarray, Qe: np.ndarray) -> List[List[float]]:
    """Gamma Qe Gamma^T as the C reader sums it (Python floats are its doubles)."""
    n, r = G.shape
    g, qe = G.tolist(), Qe.tolist()
    q = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for a in range(r):
                t = 0.0
                for b in range(r):
                    t += qe[a][b] * g[j][b]
                acc += g[i][a] * t
            q[i][j] = q[j][i] = acc
    return q


def canonical(cj: Dict[str, Any], file: str, cpath: str) -> Dict[str, Any]:
    """A weighted-fusion case as the canonical scenario the reader normalises it to."""
    for key, v in cj.items():
        if key not in _CASE_KEYS and not isinstance(v, str):
            raise _fail(file, "%s.%s" % (cpath, key), "unknown key")
    for key in ("H", "R", "x_hat0", "P0", "steps"):
        if key not in cj:
            raise _fail(file, "%s.%s" % (cpath, key), "missing key")
    Phi = _matrix(file, cpath + ".Phi", cj["Phi"])
    G = _matrix(file, cpath + ".Gamma", cj["Gamma"])
    Qe = _matrix(file, cpath + ".Qe", cj["Qe"])
    if Phi.shape[0] != Phi.shape[1] or G.shape[0] != Phi.shape[0] or Qe.shape != (
            G.shape[1], G.shape[1]):
        raise _fail(file, cpath, "Phi (n x n), Gamma (n x r), Qe (r x r): shapes disagree")
    H, R, steps = cj["H"], cj["R"], cj["steps"]
    if not isinstance(H, list) or not H or not isinstance(R, list) or len(R) != len(H):
        raise _fail(file, cpath + ".R", "expected a list of matrices, one per H_i")
    if not isinstance(steps, list) or not steps:
        raise _fail(file, cpath + ".steps", "expected a non-empty list of steps")
    y: List[Dict[str, Any]] = [{"k": [], "values": []} for _ in H]
    for j, t in enumerate(steps):
        if not isinstance(t, dict) or t.get("t") != j + 1:
            raise _fail(file, "%s.steps[%d].t" % (cpath, j), "expected %d" % (j + 1))
        ys = t.get("y")
        if not isinstance(ys, list) or len(ys) != len(H):
            raise _fail(file, "%s.steps[%d].y" % (cpath, j),
                        "expected a list of %d measurements (one per sensor, as H)" % len(H))
        for i, yi in enumerate(ys):
            y[i]["k"].append(j + 1)
            y[i]["values"].append(yi)
    return {"model": {"F": cj["Phi"], "Q": gamma_q(G, Qe),
                      "sensors": [{"H": h, "R": r} for h, r in zip(H, R)]},
            "init": {"x00": cj["x_hat0"], "P00": cj["P0"]}, "y": y, "N": len(steps),
            "_Hs": cj["H_signal"]}


def _blocks(A: np.ndarray, n: int, rows: int, cols: int) -> List[Any]:
    return [[A[i * n:(i + 1) * n, j * n:(j + 1) * n].tolist() for j in range(cols)]
            for i in range(rows)]


def run_wfusion(core: Any, doc: Dict[str, Any], file: str, case_name: str,
                filter: str) -> Dict[str, Any]:
    """The document dkf-run --filter <wfusion filter> writes for a weighted-fusion case."""
    n = len(doc["init"]["x00"])
    F = _matrix(file, "Phi", doc["model"]["F"])
    Q = np.array(doc["model"]["Q"], dtype=np.float64)
    Hs = _matrix(file, "H_signal", doc["_Hs"])
    sensors = doc["model"]["sensors"]
    H = [_matrix(file, "H[%d]" % i, s["H"]) for i, s in enumerate(sensors)]
    R = [_matrix(file, "R[%d]" % i, s["R"]) for i, s in enumerate(sensors)]
    m = [h.shape[0] for h in H]
    l = len(H)
    x0 = _numbers(file, "x_hat0", doc["init"]["x00"], 1)
    P0 = _matrix(file, "P0", doc["init"]["P00"])
    w = core.WeightedFusion(x0, P0, Hs.reshape(-1), m=m)
    ser: Dict[str, Any] = {}
    once: Dict[str, Any] = {}
    kf = None
    if filter == "central_kf":
        Hc, Rc = np.vstack(H), np.zeros((sum(m), sum(m)))
        r0 = 0
        for Ri, mi in zip(R, m):
            Rc[r0:r0 + mi, r0:r0 + mi] = Ri
            r0 += mi
        kf = core.KalmanFilter(F=F, Q=Q, H=Hc, R=Rc, x0=x0, P0=P0)
    # s_local sums Hs_j x_j in double over the core's reals (wfusion_run.c's per_node)
    hs = Hs.reshape(-1).astype(core.dtype).astype(np.float64).tolist()

    def put(dst: Dict[str, Any], key: str, value: Any, steady: bool) -> None:
        if steady:
            dst[key] = value
        else:
            dst.setdefault(key, []).append(value)

    def x_local() -> List[List[float]]:
        return np.reshape(w.x_local, (l, n)).tolist()

    def s_local() -> List[float]:
        out = []
        for x in x_local():
            sv = 0.0
            for a, b in zip(hs, x):
                sv += a * b
            out.append(sv)
        return out

    def local(dst: Dict[str, Any], steady: bool) -> None:
        if not steady:
            put(dst, "x_local", x_local(), steady)
            put(dst, "s_local", s_local(), steady)
        put(dst, "K", [np.reshape(k, (n, mi)).tolist() for k, mi in zip(w.K, m)], steady)
        put(dst, "Sigma_pred", np.reshape(w.Sigma_pred, (l, n, n)).tolist(), steady)
        put(dst, "P_ij", _blocks(np.asarray(w.Pj), n, l, l), steady)

    def scalar(dst: Dict[str, Any], steady: bool) -> None:
        put(dst, "w", np.reshape(w.w, -1).tolist(), steady)
        put(dst, "P_S", np.asarray(w.PS).tolist(), steady)
        if not steady:
            put(dst, "s_fused", float(w.s0), steady)
        put(dst, "P_S0", float(w.PS0), steady)

    def matrix(dst: Dict[str, Any], steady: bool) -> None:
        put(dst, "matrix_weights", _blocks(np.asarray(w.A), n, 1, l)[0], steady)
        if not steady:
            put(dst, "matrix_weights_unique", bool(w.A_unique), steady)
            put(dst, "x_fused_matrix", np.reshape(w.xf, -1).tolist(), steady)
        put(dst, "P0_matrix", np.asarray(w.Pf).tolist(), steady)

    if filter == "fusion_steady":
        w.steady(F, Q, H, R)
        w.fuse_scalar()
        w.fuse_matrix()
        local(once, True)
        scalar(once, True)
        matrix(once, True)
    N = doc["N"]
    for t in range(1, N + 1):
        y = [np.asarray(doc["y"][i]["values"][t - 1], dtype=np.float64) for i in range(l)]
        w.step(F, Q, H, R, y)
        w.fuse_scalar()
        w.fuse_matrix()
        if kf is not None:
            kf.predict(F=F, Q=Q)
            kf.update(np.concatenate(y))
            put(ser, "x_central", np.reshape(kf.x, -1).tolist(), False)
            put(ser, "P_central", np.asarray(kf.P).tolist(), False)
        elif filter == "local_kf":
            local(ser, False)
        elif filter == "fusion_scalar":
            scalar(ser, False)
        elif filter == "fusion_matrix":
            matrix(ser, False)
        else:
            put(ser, "steps_x_local", x_local(), False)
            put(ser, "steps_s_fused", float(w.s0), False)
            put(ser, "steps_x_fused_matrix", np.reshape(w.xf, -1).tolist(), False)
    once.update(ser)
    return {"scenario": file, "case": case_name, "filter": filter, "real": real_name(core),
            "k": list(range(1, N + 1)), "outputs": {WF_LABELS[filter]: once}}
