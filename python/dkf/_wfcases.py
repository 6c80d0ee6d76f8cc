"""run_scenario's weighted-fusion cases (seed 002): the model, and the wfusion
filters local_kf, fusion_scalar, fusion_matrix, fusion_steady,
fusion_selftune, central_kf.

The C side is ports/linux/scenario/scn_wfcases.c (the reader: Q = Gamma Qe
Gamma^T summed in double in one order, the upper triangle mirrored) and
ports/linux/families/wfusion_run.c (every filter runs the local filters and
both fusions at every step; each records its own keys under
outputs.<LABEL>). fusion_selftune feeds dkf.SelfTuning every y_i(t) and
steps the fusion on the observer-form model of its current estimate.
"""

from __future__ import annotations

from typing import Any, Dict, List

import numpy as np

from ._scenario import _fail, _matrix, _numbers, real_name

WF_LABELS = {"local_kf": "LOCAL_KF", "fusion_scalar": "FUSION_SCALAR",
             "fusion_matrix": "FUSION_MATRIX", "fusion_steady": "FUSION_STEADY",
             "fusion_selftune": "FUSION_SELFTUNE", "central_kf": "CENTRAL_KF"}
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
            "_Hs": cj["H_signal"], "_Gamma": G, "_Qe": Qe}


def _selftune(core: Any, doc: Dict[str, Any], file: str, F: np.ndarray, Q: np.ndarray,
              H: List[np.ndarray], R: List[np.ndarray], Hs: np.ndarray) -> Any:
    """The identifier of the case's self-tuning form (wfusion_run.c's st_setup): its
    orders from H_i = (1 0..0 1 0..0), P(q^-1) from Phi's noise block, sigma_xi^2 = Qe[1][1],
    sigma_v^2 = R_i; the file's model checked to be the observer form of its own a, c_1,
    sigma_w^2 = Qe[0][0] up to the real type's rounding."""
    n, l = F.shape[0], len(H)
    G, Qe = doc["_Gamma"], doc["_Qe"]
    na = 0
    for i, Hi in enumerate(H):
        row = Hi[0].tolist()
        nz = [j for j in range(1, n) if row[j] != 0.0]
        if (Hi.shape[0] != 1 or row[0] != 1.0 or len(nz) != 1 or row[nz[0]] != 1.0
                or (i > 0 and nz[0] != na)):
            raise _fail(file, "H[%d]" % i, "filter fusion_selftune needs every H_i = (1 0..0 1 "
                        "0..0) (y_i = s + eta + v_i, one row; the same for every sensor)")
        na = nz[0]
    np_ = n - na
    if na > 4 or np_ > 4:
        raise _fail(file, "H", "filter fusion_selftune identifies A of order na = %d with P of "
                    "order %d: at most 4 and 4" % (na, np_))
    hs = Hs.reshape(-1).tolist()
    if n > 1 and (hs[0] != 1.0 or any(v != 0.0 for v in hs[1:])):
        raise _fail(file, "H_signal", "filter fusion_selftune needs H_signal = (1 0..0) (s = the "
                    "first state)")
    if G.shape[1] != 2:
        raise _fail(file, "Gamma", "filter fusion_selftune needs two noises (w, xi), got %d "
                    "columns" % G.shape[1])
    nc = 1 if na > 1 else 0
    real = np.dtype(core.dtype).type
    p = [float(real(-F[na + j, na])) for j in range(np_)]
    sxi2 = float(real(Qe[1, 1]))
    st = core.SelfTuning(L=l, sigma_v2=[float(Ri[0, 0]) for Ri in R], p=p or None,
                         sigma_xi2=float(Qe[1, 1]), na=na, nc=nc, lags=max(5, na + nc))
    # the observer form of the file's own a, c_1, sigma_w^2 (dkf_selftune_model's)
    a = [float(real(-F[j, 0])) for j in range(na)]
    c1 = float(real(G[1, 0])) if nc else 0.0
    sw2 = float(real(Qe[0, 0]))
    ne = max(np_, 1)
    Fo, Qo = np.zeros((na + ne, na + ne)), np.zeros((na + ne, na + ne))
    for i in range(na):
        Fo[i, 0] = -a[i]
        if i + 1 < na:
            Fo[i, i + 1] = 1.0
    for i in range(ne):
        Fo[na + i, na] = -p[i] if np_ else 0.0
        if i + 1 < ne:
            Fo[na + i, na + i + 1] = 1.0
    gam = [1.0, c1 if nc else 0.0] + [0.0] * na
    for i in range(na):
        for j in range(na):
            Qo[i, j] = (gam[i] * sw2) * gam[j]
    Qo[na, na] = sxi2
    eps = float(np.finfo(core.dtype).eps)
    if Fo.shape != F.shape:
        raise _fail(file, "Phi", "filter fusion_selftune: the observer form of na = %d, np = %d "
                    "is %dx%d, the case's Phi %dx%d" % (na, np_, Fo.shape[0], Fo.shape[1], n, n))
    scale = max(1.0, float(np.max(np.maximum(np.abs(F), np.abs(Q)))))
    worst = float(np.max(np.maximum(np.abs(Fo - F), np.abs(Qo - Q))))
    if not worst <= 64.0 * eps * scale:
        raise _fail(file, "Phi", "filter fusion_selftune needs the observer form of "
                    "dkf/selftune.h (F = blkdiag([-a | I; 0], [-p | I; 0]), Gamma = blkdiag([1; "
                    "c_1; 0..], [1; 0..]), Qe = diag(sigma_w^2, sigma_xi^2)): off by %.3g"
                    % worst)
    return st


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

    st = _selftune(core, doc, file, F, Q, H, R, Hs) if filter == "fusion_selftune" else None
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
        if st is not None:  # the identifier on y(t), the step on its estimate's model
            st.update([yi[0] for yi in y])
            est = st.estimate()
            Ft, Qt = st.model()
            w.step(Ft, Qt, H, R, y)
        else:
            w.step(F, Q, H, R, y)
        w.fuse_scalar()
        w.fuse_matrix()
        if st is not None:
            put(ser, "a_hat", np.asarray(est["a"]).tolist(), False)
            put(ser, "c1_hat", est["c1"], False)
            put(ser, "sigma_w2_hat", est["sigma_w2"], False)
            put(ser, "guard", int(est["guard"]), False)
            scalar(ser, False)
            put(ser, "x_fused_matrix", np.reshape(w.xf, -1).tolist(), False)
        elif kf is not None:
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
