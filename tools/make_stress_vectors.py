#!/usr/bin/env python3
"""High-precision references for the covariance-update stress tests.

Writes tests/vectors/stress/<filter>.json (committed; the C tests read them
and never run Python): models in the regimes where a covariance update
that subtracts from P loses its digits, with the filter's results computed
in 60-digit arithmetic (mpmath) from the very inputs the C tests use.

Every input is rounded to IEEE single precision first (numpy.float32), so
it is exactly representable in both builds (DKF_REAL=float and double):
the reference is then the exact answer for the float build's inputs too,
and a tolerance measures the filter's own rounding only.

Regimes (docs/decisions.md, "The covariance update"):
* pinned:   P0 = 1e8 I, R = 1e-8 I, n = m = 4: the measurements pin the
            state, P_{1|1} ~ 1e-8 is 1e16 below P0;
* moderate: P0 SPD with eigenvalues in [1e4, 1e6], R SPD with
            eigenvalues in [1e-4, 1e-3], n = m (4 and 6), five
            predict + update steps;
* near-singular R (float): R = [[1, 1 - 2^-27], [1 - 2^-27, 1]] (exact in
            double, singular once rounded to float) and strong P, for
            the "never OK with an indefinite P" tests; the reference is
            for the double inputs (the float build sees a singular R).

Numbers are written with 17 significant digits (the reference rounded to
double: 1e-17 relative, far below every tolerance).

The filters are written here in mpmath on purpose, not taken from the
Python package: this is an independent test oracle of the C core
(docs/decisions.md item 74).

Usage: python3 tools/make_stress_vectors.py [--check-only]
Requires mpmath and numpy (Debian python3-mpmath, python3-numpy).
Deterministic (fixed seeds).
"""
import json
import os
import sys

import mpmath as mp
import numpy as np

mp.mp.dps = 60
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "tests", "vectors", "stress")


# ---- inputs: float32-exact numbers ----------------------------------------

def f32(a):
    """a rounded to float32, as float64 (exactly representable in both)."""
    return np.asarray(a, dtype=np.float32).astype(np.float64)


def spd_with_eigs(rng, eigs):
    """Q diag(eigs) Q^T with a random orthogonal Q, symmetrised, then
    float32-rounded (symmetric after rounding: both triangles round alike)."""
    n = len(eigs)
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    a = q @ np.diag(eigs) @ q.T
    a = (a + a.T) / 2
    return f32(a)


def logspace_eigs(rng, lo, hi, n):
    return np.exp(rng.uniform(np.log(lo), np.log(hi), n))


# ---- 60-digit linear algebra (mpmath) --------------------------------------

def M(a):
    return mp.matrix([[mp.mpf(float(v)) for v in row] for row in np.atleast_2d(a)])


def V(a):
    return mp.matrix([mp.mpf(float(v)) for v in np.ravel(a)])


def kf_update(x, P, H, R, y):
    """Exact (60-digit) measurement update: S = H P H^T + R,
    K = P H^T S^{-1}, x+ = x + K (y - H x), P+ = (I-KH) P (I-KH)^T + K R K^T
    (at 60 digits every algebraic form agrees to ~40 digits)."""
    S = H * P * H.T + R
    K = P * H.T * mp.inverse(S)
    n = P.rows
    A = mp.eye(n) - K * H
    xn = x + K * (y - H * x)
    Pn = A * P * A.T + K * R * K.T
    Pn = (Pn + Pn.T) / 2
    return xn, Pn


def kf_predict(x, P, F, Q):
    return F * x, F * P * F.T + Q


def tolist(m):
    return [[float(m[i, j]) for j in range(m.cols)] for i in range(m.rows)]


def tovec(v):
    return [float(v[i]) for i in range(v.rows)]


def min_eig(m):
    e = mp.eigsy(m)[0]
    return min(e[i] for i in range(e.rows))


# ---- the KF cases ------------------------------------------------------------

def kf_case(name, note, x0, P0, steps):
    """steps: list of dicts with H, R, y and optionally F, Q (predict
    first). Adds the 60-digit x, P after each step."""
    x, P = V(x0), M(P0)
    out = []
    for st in steps:
        rec = {}
        if "F" in st:
            x, P = kf_predict(x, P, M(st["F"]), M(st["Q"]))
            rec["F"], rec["Q"] = st["F"].tolist(), st["Q"].tolist()
        x, P = kf_update(x, P, M(st["H"]), M(st["R"]), V(st["y"]))
        rec.update(H=st["H"].tolist(), R=st["R"].tolist(), y=st["y"].tolist(),
                   x=tovec(x), P=tolist(P), P_min_eig=float(min_eig(P)),
                   cond_H=float(np.linalg.cond(st["H"])))
        out.append(rec)
    return {"name": name, "note": note, "n": len(x0), "m": len(steps[0]["y"]),
            "x0": list(map(float, x0)), "P0": P0.tolist(), "steps": out}


def kf_cases():
    rng = np.random.default_rng(20261201)
    cases = []
    # pinned: P0 = 1e8 I, R = 1e-8 I (float32-rounded), n = m = 4
    n = 4
    H = f32(rng.standard_normal((n, n)))
    cases.append(kf_case(
        "pinned_n4", "P0 = 1e8 I, R = 1e-8 I, n = m = 4, one update",
        f32(rng.standard_normal(n)), f32(1e8 * np.eye(n)),
        [{"H": H, "R": f32(1e-8 * np.eye(n)), "y": f32(rng.standard_normal(n))}]))
    # moderate: P0 eigenvalues in [1e4, 1e6], R in [1e-4, 1e-3], n = m
    for n in (4, 6):
        P0 = spd_with_eigs(rng, logspace_eigs(rng, 1e4, 1e6, n))
        steps = []
        for k in range(5):
            st = {"H": f32(rng.standard_normal((n, n))),
                  "R": spd_with_eigs(rng, logspace_eigs(rng, 1e-4, 1e-3, n)),
                  "y": f32(100 * rng.standard_normal(n))}
            if k > 0:
                st["F"] = f32(np.eye(n) + 0.1 * rng.standard_normal((n, n)))
                st["Q"] = spd_with_eigs(rng, logspace_eigs(rng, 1e3, 1e5, n))
            steps.append(st)
        cases.append(kf_case(
            "moderate_n%d" % n,
            "P0 eigenvalues in [1e4, 1e6], R in [1e-4, 1e-3], n = m = %d, 5 steps" % n,
            f32(rng.standard_normal(n)), P0, steps))
    # near-singular R: exact in double, singular in float
    c = 1.0 - 2.0 ** -27
    R = np.array([[1.0, c], [c, 1.0]])
    for n, p0 in ((2, 1e6), (4, 1e6)):
        H = f32(rng.standard_normal((2, n)))
        steps = [{"H": H, "R": R, "y": f32(rng.standard_normal(2))} for _ in range(3)]
        for st in steps[1:]:
            st["F"] = f32(np.eye(n))
            st["Q"] = f32(np.zeros((n, n)))
        cases.append(kf_case(
            "singular_r_float_n%d" % n,
            "R = [[1, 1-2^-27], [1-2^-27, 1]] (singular in float), P0 = %g I, "
            "3 updates of the same H" % p0,
            f32(rng.standard_normal(n)), f32(p0 * np.eye(n)), steps))
    return cases


# ---- ASKF / OTSKF: the augmented KF on [x; d] ---------------------------------

def aug_cases():
    """x_{k+1} = F x + v, d_{k+1} = B d + wd, y = H x + A d + w: the ASKF is
    the KF on [x; d] (Phi = diag(F, B), Qa = diag(Q, Rd), Ha = [H A]) and
    the OTSKF is algebraically equal to it (same prior, Pxd0 = 0). m = n + p,
    so each update pins the augmented state: P0 eigenvalues in [1e4, 1e6],
    Pd0 = 1e4 I, R eigenvalues in [1e-4, 1e-3]; 5 steps."""
    rng = np.random.default_rng(20261202)
    cases = []
    for n, p in ((2, 1), (3, 2)):
        m = n + p
        P0 = spd_with_eigs(rng, logspace_eigs(rng, 1e4, 1e6, n))
        Pd0 = f32(1e4 * np.eye(p))
        x0, d0 = f32(rng.standard_normal(n)), f32(rng.standard_normal(p))
        N = n + p
        xa = V(np.concatenate([x0, d0]))
        Pa = mp.zeros(N, N)
        for i in range(n):
            for j in range(n):
                Pa[i, j] = mp.mpf(float(P0[i, j]))
        for i in range(p):
            for j in range(p):
                Pa[n + i, n + j] = mp.mpf(float(Pd0[i, j]))
        steps = []
        for k in range(5):
            st = {"H": f32(rng.standard_normal((m, n))), "A": f32(rng.standard_normal((m, p))),
                  "R": spd_with_eigs(rng, logspace_eigs(rng, 1e-4, 1e-3, m)),
                  "y": f32(100 * rng.standard_normal(m))}
            if k > 0:
                st["F"] = f32(np.eye(n) + 0.1 * rng.standard_normal((n, n)))
                st["Q"] = spd_with_eigs(rng, logspace_eigs(rng, 1e-1, 1e1, n))
                st["B"] = f32(np.eye(p) + 0.05 * rng.standard_normal((p, p)))
                st["Rd"] = spd_with_eigs(rng, logspace_eigs(rng, 1e-1, 1e1, p))
                Phi = np.zeros((N, N)); Phi[:n, :n] = st["F"]; Phi[n:, n:] = st["B"]
                Qa = np.zeros((N, N)); Qa[:n, :n] = st["Q"]; Qa[n:, n:] = st["Rd"]
                xa, Pa = kf_predict(xa, Pa, M(Phi), M(Qa))
            Ha = np.hstack([st["H"], st["A"]])
            prior = max(abs(Pa[i, j]) for i in range(N) for j in range(N))
            xa, Pa = kf_update(xa, Pa, M(Ha), M(st["R"]), V(st["y"]))
            post = max(abs(Pa[i, j]) for i in range(N) for j in range(N))
            rec = {kk: v.tolist() for kk, v in st.items()}
            rec.update(x=[float(xa[i]) for i in range(n)],
                       d=[float(xa[n + i]) for i in range(p)],
                       P=[[float(Pa[i, j]) for j in range(n)] for i in range(n)],
                       Pd=[[float(Pa[n + i, n + j]) for j in range(p)] for i in range(p)],
                       cond_H=float(np.linalg.cond(Ha)), rho=float(prior / post))
            steps.append(rec)
        cases.append({"name": "aug_n%d_p%d" % (n, p), "n": n, "m": m, "p": p,
                      "note": "augmented state pinned each update (m = n + p), 5 steps",
                      "x0": x0.tolist(), "P0": P0.tolist(), "d0": d0.tolist(),
                      "Pd0": Pd0.tolist(), "steps": steps})
    return cases


# ---- information filter: the KF on the stacked measurement -------------------

def info_cases():
    """Two sensors (m_j = n/2 rows each, together n), P0 eigenvalues in
    [1e4, 1e6], R_j eigenvalues in [1e-4, 1e-3]: the fused step equals the
    KF update on the stacked (C, blockdiag R, z); 5 predict + fuse steps."""
    rng = np.random.default_rng(20261203)
    cases = []
    for n in (4, 6):
        mj = n // 2
        P0 = spd_with_eigs(rng, logspace_eigs(rng, 1e4, 1e6, n))
        x0 = f32(rng.standard_normal(n))
        x, P = V(x0), M(P0)
        steps = []
        for k in range(5):
            sens = [{"C": f32(rng.standard_normal((mj, n))),
                     "R": spd_with_eigs(rng, logspace_eigs(rng, 1e-4, 1e-3, mj)),
                     "z": f32(100 * rng.standard_normal(mj))} for _ in range(2)]
            rec = {}
            if k > 0:
                F = f32(np.eye(n) + 0.1 * rng.standard_normal((n, n)))
                Q = spd_with_eigs(rng, logspace_eigs(rng, 1e3, 1e5, n))
                x, P = kf_predict(x, P, M(F), M(Q))
                rec["F"], rec["Q"] = F.tolist(), Q.tolist()
            C = np.vstack([s_["C"] for s_ in sens])
            R = np.zeros((n, n))
            R[:mj, :mj], R[mj:, mj:] = sens[0]["R"], sens[1]["R"]
            z = np.concatenate([s_["z"] for s_ in sens])
            x, P = kf_update(x, P, M(C), M(R), V(z))
            rec["sensors"] = [{kk: v.tolist() for kk, v in s_.items()} for s_ in sens]
            rec.update(x=tovec(x), P=tolist(P), cond_H=float(np.linalg.cond(C)))
            steps.append(rec)
        cases.append({"name": "info_n%d" % n, "n": n, "note": "2 sensors of n/2 rows, 5 steps",
                      "x0": x0.tolist(), "P0": P0.tolist(), "steps": steps})
    return cases


# ---- uif RTSF, NRTSF-DF, NRTSF: joint state and input -------------------------

def joint_time_update(x, P, Pd, Pxd, dyn):
    """The feedthrough filters' time update (27) = (9), (11) at 60 digits:
    x_{k|k-1} = A x + G d, P_{k|k-1} = [A G] [[P, Pxd], [Pxd^T, Pd]] [A G]^T
    + Q, with dyn = (A, G, Q, d_{k-1|k-1}); dyn None: the prior as is."""
    if dyn is None:
        return x, P
    A, G, Q = dyn[:3]
    AG = mp.matrix(A.rows, A.cols + G.cols)
    for i in range(A.rows):
        for j in range(A.cols):
            AG[i, j] = A[i, j]
        for j in range(G.cols):
            AG[i, A.cols + j] = G[i, j]
    n, m = A.rows, G.cols
    J = mp.matrix(n + m, n + m)
    for i in range(n + m):
        for j in range(n + m):
            if i < n and j < n:
                J[i, j] = P[i, j]
            elif i < n:
                J[i, j] = Pxd[i, j - n]
            elif j < n:
                J[i, j] = Pxd[j, i - n]
            else:
                J[i, j] = Pd[i - n, j - n]
    xd = mp.matrix(n + m, 1)
    for i in range(n):
        xd[i] = x[i]
    for i in range(m):
        xd[n + i] = dyn[3][i]
    return AG * xd, AG * J * AG.T + Q


def nrtsf_df_step(x, P, Pd, Pxd, dyn, C, Hb, Tp, R, y):
    """One NRTSF-DF step at 60 digits from docs/design/uif.md (H = Hb T a
    full-rank decomposition, Tp = T^+, B = Hb; the RTSF step is Hb = H,
    Tp = I); dyn = (A, G, Q, d_{k-1|k-1}) or None (the first step: x, P
    are the prior of x_0).
    Time update (27) with the minimum-norm d, Pd, Pxd of the step before;
    R~ = C P C^T + R (14); Pdbar = (Hb^T R~^-1 Hb)^-1, Mbar = Pdbar Hb^T
    R~^-1, dbar = Mbar ytil (15)-(16), (28); K = P C^T R~^-1, Z = -K Hb,
    x = x_pred + K ytil + Z dbar, L = K + Z Mbar (= K (I - Hb Mbar), (21));
    P = (I - L C) P_pred (I - L C)^T + L R L^T (20); d = T^+ dbar, Pd =
    T^+ Pdbar T^+T, Pxd = Z Pdbar T^+T (29). Checks at 60 digits that the
    short form P_pred - K R~ K^T + Z Pdbar Z^T ((24)/(29)) agrees and that
    L Hb = 0 (19)."""
    xp, Pp = joint_time_update(x, P, Pd, Pxd, dyn)
    Rt = C * Pp * C.T + R
    Ri = mp.inverse(Rt)
    Pdb = mp.inverse(Hb.T * Ri * Hb)
    Mb = Pdb * Hb.T * Ri
    yt = y - C * xp
    db = Mb * yt
    K = Pp * C.T * Ri
    Z = -K * Hb
    L = K + Z * Mb
    A_ = mp.eye(P.rows) - L * C
    Pn = A_ * Pp * A_.T + L * R * L.T
    Ps = Pp - K * Rt * K.T + Z * Pdb * Z.T
    scale = mp.mnorm(Pn, 1)
    assert mp.mnorm(Pn - Ps, 1) < mp.mpf(10) ** -30 * scale, "Joseph and short forms differ"
    assert mp.mnorm(L * Hb, 1) < mp.mpf(10) ** -30 * mp.mnorm(L, 1) * mp.mnorm(Hb, 1)
    Pd = Tp * Pdb * Tp.T
    return (xp + K * yt + Z * db, (Pn + Pn.T) / 2, Tp * db, (Pd + Pd.T) / 2,
            Z * Pdb * Tp.T, Pp)


def uif_record(st, x, P, d, Pd, Pxd, Pp, cond_H):
    """A uif.json step: the inputs st, the reference after the step,
    P_min_eig, cond_H and rho = max|P_{k|k-1}| / max|P_{k|k}|."""
    n = P.rows
    prior = max(abs(Pp[i, j]) for i in range(n) for j in range(n))
    post = max(abs(P[i, j]) for i in range(n) for j in range(n))
    rec = {kk: v.tolist() for kk, v in st.items()}
    rec.update(x=tovec(x), P=tolist(P), d=tovec(d), Pd=tolist(Pd), Pxd=tolist(Pxd),
               P_min_eig=float(min_eig(P)), cond_H=cond_H, rho=float(prior / post))
    return rec


def rank_deficient(rng, rows, r, m):
    """A rows x m input matrix of rank r with a full-rank decomposition
    Bbar T: Bbar random (float32); r = m: the matrix is Bbar, T = I; r = 2,
    m = 3: Bbar T with T = [[1, 0, -2], [0, 1, 0]] (the third column is -2
    times the first, exact in float32). Returns (matrix, Bbar, T^+ = T^T
    (T T^T)^-1 at 60 digits)."""
    Bb = f32(rng.standard_normal((rows, r)))
    if r == m:
        return Bb, Bb, mp.eye(m)
    T = np.array([[1.0, 0.0, -2.0], [0.0, 1.0, 0.0]])
    Tm = M(T)
    return Bb @ T, Bb, Tm.T * mp.inverse(Tm * Tm.T)


def nrtsf_step(x, P, A, G1, Tp, Q, C, R, y):
    """One NRTSF step at 60 digits from docs/design/uif.md (no feedthrough; G =
    G1 T a full-rank decomposition, Tp = T^+, B = F = C G1): x_pred = A x,
    P_pred = A P A^T + Q (51); R~ = C P C^T + R (42); Pdbar = (F^T R~^-1
    F)^-1, Mbar = Pdbar F^T R~^-1, dbar = Mbar ytil (43)-(44); K = P C^T
    R~^-1, Z = G1 - K F, L = K + Z Mbar (48), x = x_pred + L ytil;
    P = (I - L C) P_pred (I - L C)^T + L R L^T (47); d = T^+ dbar, Pd =
    T^+ Pdbar T^+T, Pxd = Z Pdbar T^+T (53, note)."""
    xp, Pp = A * x, A * P * A.T + Q
    Rt = C * Pp * C.T + R
    Ri = mp.inverse(Rt)
    F = C * G1
    Pdb = mp.inverse(F.T * Ri * F)
    Mb = Pdb * F.T * Ri
    yt = y - C * xp
    K = Pp * C.T * Ri
    Z = G1 - K * F
    L = K + Z * Mb
    A_ = mp.eye(P.rows) - L * C
    Pn = A_ * Pp * A_.T + L * R * L.T
    Pd = Tp * Pdb * Tp.T
    return (xp + L * yt, (Pn + Pn.T) / 2, Tp * (Mb * yt), (Pd + Pd.T) / 2,
            Z * Pdb * Tp.T, Pp)


def nrtsf_cases():
    """NRTSF with p = n (C pins x_k; d_{k-1} is seen through x_k - A
    x_{k-1}): P0 = x_{0|0} covariance with eigenvalues in [1e6, 1e8], R in
    [1e-4, 1e-3], Q in [1e3, 1e5], 5 steps; G of full column rank (n3_m2)
    or of rank 2 of 3 (n4_m3, G = [g1, g2, -2 g1] = G1 T, exact in
    float32; T^+ = T^T (T T^T)^-1, which docs/design/uif.md says the outputs do
    not depend on)."""
    rng = np.random.default_rng(20261207)
    cases = []
    for n, m, r in ((3, 2, 2), (4, 3, 2)):
        p = n
        P0 = spd_with_eigs(rng, logspace_eigs(rng, 1e6, 1e8, n))
        x0 = f32(rng.standard_normal(n))
        x, P = V(x0), M(P0)
        steps = []
        for k in range(5):
            G, G1, Tpm = rank_deficient(rng, n, r, m)
            G1m = M(G1)
            st = {"A": f32(np.eye(n) + 0.1 * rng.standard_normal((n, n))), "G": G,
                  "Q": spd_with_eigs(rng, logspace_eigs(rng, 1e3, 1e5, n)),
                  "C": f32(rng.standard_normal((p, n))),
                  "R": spd_with_eigs(rng, logspace_eigs(rng, 1e-4, 1e-3, p)),
                  "y": f32(100 * rng.standard_normal(p))}
            x, P, d, Pd, Pxd, Pp = nrtsf_step(x, P, M(st["A"]), G1m, Tpm, M(st["Q"]),
                                              M(st["C"]), M(st["R"]), V(st["y"]))
            steps.append(uif_record(st, x, P, d, Pd, Pxd, Pp,
                                    float(np.linalg.cond(st["C"]))))
        cases.append({"name": "nrtsf_n%d_m%d_r%d" % (n, m, r), "n": n, "m": m, "p": p,
                      "rank": r,
                      "note": "NRTSF, p = n, rank G = %d, P0 in [1e6, 1e8], R in [1e-4, 1e-3], "
                              "Q in [1e3, 1e5], 5 steps" % r,
                      "x0": x0.tolist(), "P0": P0.tolist(), "steps": steps})
    return cases


def cond_on_rank(a, r):
    """sigma_1 / sigma_r of a (its condition number on its rank r; for [C
    H] with rank H = r_H it is cond([C Hbar]) for an Hbar = H T^T with
    orthonormal-row T, the decomposition src/uif.c uses, and for every
    other T the same up to T's own conditioning)."""
    s = np.linalg.svd(a, compute_uv=False)
    return float(s[0] / s[r - 1])


def nrtsf_df_cases():
    """NRTSF-DF with p = n + r (y pins x and dbar; [C Hbar] of full column
    rank), H of full column rank (n3_m2_r2, Hbar = H, T = I) or of rank 2
    of 3 (n4_m3_r2, H = [h1, h2, -2 h1] = Hbar T, exact in float32, Hbar =
    [h1, h2], T^+ = T^T (T T^T)^-1). G is a random n x m (the time update
    carries the minimum-norm d; the bias it may inject into the true state
    is not the reference's business)."""
    return feedthrough_cases("nrtsf_df", 20261208, ((3, 2, 2), (4, 3, 2)))


def feedthrough_cases(kind, seed, shapes):
    """RTSF or NRTSF-DF (kind "rtsf" / "nrtsf_df") with p = n + r (the
    measurements pin x and dbar): for (n, m, r) in shapes, P0 (the prior of
    x_0) eigenvalues log-uniform in [1e6, 1e8], R in [1e-4, 1e-3], Q in
    [1e3, 1e5] (so every prior P_{k|k-1} stays ~1e3..1e5 while P_{k|k} ~
    1e-4), 5 steps, the first without a time update; H = Hbar T of rank r
    (rank_deficient: H random for r = m)."""
    rng = np.random.default_rng(seed)
    cases = []
    for n, m, r in shapes:
        p = n + r
        P0 = spd_with_eigs(rng, logspace_eigs(rng, 1e6, 1e8, n))
        x0 = f32(rng.standard_normal(n))
        x, P = V(x0), M(P0)
        Pd, Pxd, d = mp.zeros(m, m), mp.zeros(n, m), mp.zeros(m, 1)
        steps = []
        for k in range(5):
            C = f32(rng.standard_normal((p, n)))
            H, Hb, Tpm = rank_deficient(rng, p, r, m)
            st = {"C": C, "H": H, "R": spd_with_eigs(rng, logspace_eigs(rng, 1e-4, 1e-3, p)),
                  "y": f32(100 * rng.standard_normal(p))}
            dyn = None
            if k > 0:
                st["A"] = f32(np.eye(n) + 0.1 * rng.standard_normal((n, n)))
                st["G"] = f32(rng.standard_normal((n, m)))
                st["Q"] = spd_with_eigs(rng, logspace_eigs(rng, 1e3, 1e5, n))
                dyn = (M(st["A"]), M(st["G"]), M(st["Q"]), d)
            x, P, d, Pd, Pxd, Pp = nrtsf_df_step(x, P, Pd, Pxd, dyn, M(C), M(Hb), Tpm,
                                                 M(st["R"]), V(st["y"]))
            steps.append(uif_record(st, x, P, d, Pd, Pxd, Pp,
                                    cond_on_rank(np.hstack([C, H]), n + r)))
        if kind == "rtsf":
            case = {"name": "rtsf_n%d_m%d" % (n, m), "n": n, "m": m, "p": p,
                    "note": "RTSF, p = n + m, P0 in [1e6, 1e8], R in [1e-4, 1e-3], 5 steps"}
        else:
            case = {"name": "nrtsf_df_n%d_m%d_r%d" % (n, m, r), "n": n, "m": m, "p": p,
                    "rank": r,
                    "note": "NRTSF-DF, p = n + r, rank H = %d, P0 (prior of x_0) in [1e6, "
                            "1e8], R in [1e-4, 1e-3], Q in [1e3, 1e5], 5 steps" % r}
        case.update(x0=x0.tolist(), P0=P0.tolist(), steps=steps)
        cases.append(case)
    return cases


def uif_cases():
    """RTSF = NRTSF-DF with T = I (docs/design/uif.md: Hbar = H, T = I), p = n + m
    (the measurements pin [x; d]), (n, m) = (3, 1) and (4, 2)."""
    return feedthrough_cases("rtsf", 20261204, ((3, 1, 1), (4, 2, 2)))


# ---- the Difference KF (seed 000): differenced measurements, correlated noise --

def pinv_fcr(A):
    """A^+ = (A^T A)^{-1} A^T for A of full column rank."""
    return mp.inverse(A.T * A) * A.T


def diffkf_cases():
    """Theorem 1 of docs/design/diffkf.md, (8)-(20) with the corrected lag of C_k,
    at 60 digits, from the prior (x_{1|0}, P_{1|0}) = (x0, P0) (the start
    with F0 = Q0 = NULL). p = n, so each z_k pins the state: P0 eigenvalues
    in [1e6, 1e8], Q, R, Rd eigenvalues in [1e-4, 1e-3]; 5 steps. Step k
    takes dyn_k (F, Q, B, Rd) and the model at k+1 (H, A, R) with y_{k+1};
    the first (H, A, R, y) are the start's (meas_1, y_1)."""
    rng = np.random.default_rng(20261205)
    cases = []
    for n, m in ((3, 4), (4, 4)):
        p = n
        P0 = spd_with_eigs(rng, logspace_eigs(rng, 1e6, 1e8, n))
        x0 = f32(rng.standard_normal(n))

        def meas():
            return {"H": f32(rng.standard_normal((m, n))), "A": f32(rng.standard_normal((m, p))),
                    "R": spd_with_eigs(rng, logspace_eigs(rng, 1e-4, 1e-3, m)),
                    "y": f32(100 * rng.standard_normal(m))}
        first = meas()
        xp, P = V(x0), M(P0)
        Hk, Ak, Rk, yk = M(first["H"]), M(first["A"]), M(first["R"]), V(first["y"])
        Akp = pinv_fcr(Ak)
        Gprev = Linv = dz_prev = Wprev = None
        steps = []
        for k in range(5):
            st = {"F": f32(np.eye(n) + 0.1 * rng.standard_normal((n, n))),
                  "Q": spd_with_eigs(rng, logspace_eigs(rng, 1e-4, 1e-3, n)),
                  "B": f32(np.eye(p) + 0.1 * rng.standard_normal((p, p))),
                  "Rd": spd_with_eigs(rng, logspace_eigs(rng, 1e-4, 1e-3, p))}
            st.update(meas())
            F, Q, B, Rd = M(st["F"]), M(st["Q"]), M(st["B"]), M(st["Rd"])
            H1, A1, R1, y1 = M(st["H"]), M(st["A"]), M(st["R"]), V(st["y"])
            A1p, Bi = pinv_fcr(A1), mp.inverse(B)
            G = Bi * A1p                                            # (8)
            z = G * y1 - Akp * yk                                   # (8)
            Mk = G * H1 * F - Akp * Hk                              # (11)
            S = Q * H1.T * G.T                                      # (13)
            Ru = (G * H1 * Q * H1.T * G.T + Bi * Rd * Bi.T + G * R1 * G.T
                  + Akp * Rk * Akp.T)                               # (14)
            dz = z - Mk * xp                                        # (18)
            J = P * Mk.T                                            # (19)
            L = Mk * P * Mk.T + Ru                                  # (20)
            if Gprev is not None:
                C = -Akp * Rk * Gprev.T                             # (15), lag k-1
                dz = dz - C * Linv * dz_prev
                J = J - Wprev * C.T
                L = L - Mk * Wprev * C.T - C * Wprev.T * Mk.T - C * Linv * C.T
            Li = mp.inverse(L)
            K = J * Li
            xf, Pf = xp + K * dz, P - K * J.T
            W = (F * J + S) * Li
            xn, Pn = F * xp + W * dz, F * P * F.T + Q - W * L * W.T  # (16), (17)
            Pf, Pn = (Pf + Pf.T) / 2, (Pn + Pn.T) / 2
            big = max(abs(P[i, j]) for i in range(n) for j in range(n))
            rec = {kk: v.tolist() for kk, v in st.items()}
            rec.update(xf=tovec(xf), Pf=tolist(Pf), xn=tovec(xn), Pn=tolist(Pn),
                       Pf_min_eig=float(min_eig(Pf)), Pn_min_eig=float(min_eig(Pn)),
                       cond_M=float(mp.svd_r(Mk, compute_uv=False)[0]
                                    / mp.svd_r(Mk, compute_uv=False)[Mk.rows - 1]),
                       rho=float(big / max(abs(Pf[i, j]) for i in range(n) for j in range(n))))
            steps.append(rec)
            xp, P = xn, Pn
            Gprev, Linv, dz_prev, Wprev = G, Li, dz, W
            Hk, Ak, Rk, yk, Akp = H1, A1, R1, y1, A1p
        cases.append({"name": "diffkf_n%d_m%d" % (n, m), "n": n, "m": m, "p": p,
                      "note": "p = n (z pins the state), P0 in [1e6, 1e8], Q, R, Rd in "
                              "[1e-4, 1e-3], 5 steps from the prior (x_{1|0}, P_{1|0})",
                      "x0": x0.tolist(), "P0": P0.tolist(),
                      "meas1": {kk: v.tolist() for kk, v in first.items()}, "steps": steps})
    return cases


# ---- tw: seed 003's centralized two-stage filter (Algorithm 1) ----------------

def tw_cases():
    """Algorithm 1 (dkf/tw.h, docs/design/graph-filters.md) at 60 digits, in the
    forms the header prints rather than the information form src/tw.c
    uses: phi+, Phi+ as the KF update of (phi-, Phi-) on the stacked
    sensors, G = (I - Phi+ Q) B (8a), S = B^T (Q - Q Phi+ Q) B (11)-(12),
    z^ = S^-1 G^T (s - Q phi-) (18), psi = phi+ + G z^, Ploc = Phi+ +
    G S^-1 G^T ((8b), (8c) corrected). N = 3 sensors of 2 rows (the stacked
    H has full column rank: they pin x_n; z_{n-1} is then seen through
    x_n - A x_{n-1}, S ~ B^T Phi-^-1 B): P0 eigenvalues in [1e6, 1e8], Sw in [1e-4, 1e-3],
    Sv in [1e3, 1e5] (every prior stays large), 5 steps."""
    rng = np.random.default_rng(20261206)
    cases = []
    for n, m in ((4, 1), (3, 2)):
        N, pl = 3, 2
        P0 = spd_with_eigs(rng, logspace_eigs(rng, 1e6, 1e8, n))
        x0 = f32(rng.standard_normal(n))
        x, P = V(x0), M(P0)
        steps = []
        for k in range(5):
            st = {"A": f32(np.eye(n) + 0.1 * rng.standard_normal((n, n))),
                  "B": f32(rng.standard_normal((n, m))),
                  "Sv": spd_with_eigs(rng, logspace_eigs(rng, 1e3, 1e5, n)),
                  "sensors": [{"H": f32(rng.standard_normal((pl, n))),
                               "Sw": spd_with_eigs(rng, logspace_eigs(rng, 1e-4, 1e-3, pl)),
                               "y": f32(100 * rng.standard_normal(pl))} for _ in range(N)]}
            A, B = M(st["A"]), M(st["B"])
            phim, Phim = A * x, A * P * A.T + M(st["Sv"])                    # (6a)-(6b)
            Hs = np.vstack([se["H"] for se in st["sensors"]])
            Rs = np.zeros((N * pl, N * pl))
            for i, se in enumerate(st["sensors"]):
                Rs[i * pl:(i + 1) * pl, i * pl:(i + 1) * pl] = se["Sw"]
            ys = np.concatenate([se["y"] for se in st["sensors"]])
            Hm, Rm, ym = M(Hs), M(Rs), V(ys)
            Ri = mp.inverse(Rm)
            Q, sv = Hm.T * Ri * Hm, Hm.T * Ri * ym                            # (17), (21)
            phip, Phip = kf_update(phim, Phim, Hm, Rm, ym)                   # (7b), (20)
            G = (mp.eye(n) - Phip * Q) * B                                   # (8a)
            S = B.T * (Q - Q * Phip * Q) * B                                 # (11)-(12)
            Si = mp.inverse(S)
            z = Si * G.T * (sv - Q * phim)                                   # (18)
            x = phip + G * z                                                 # (8b)
            P = Phip + G * Si * G.T                                          # (8c)
            P = (P + P.T) / 2
            big = max(abs(Phim[i, j]) for i in range(n) for j in range(n))
            rec = {"A": st["A"].tolist(), "B": st["B"].tolist(), "Sv": st["Sv"].tolist(),
                   "sensors": [{kk: v.tolist() for kk, v in se.items()} for se in st["sensors"]]}
            rec.update(x=tovec(x), P=tolist(P), z=tovec(z), Phi_post=tolist(Phip),
                       S=tolist(S), P_min_eig=float(min_eig(P)),
                       cond_H=float(np.linalg.cond(Hs)),
                       rho=float(big / max(abs(P[i, j]) for i in range(n) for j in range(n))))
            steps.append(rec)
        cases.append({"name": "tw_n%d_m%d" % (n, m), "n": n, "m": m, "N": N, "p": pl,
                      "note": "Algorithm 1, 3 sensors of 2 rows, P0 in [1e6, 1e8], Sw in "
                              "[1e-4, 1e-3], Sv in [1e3, 1e5], 5 steps",
                      "x0": x0.tolist(), "P0": P0.tolist(), "steps": steps})
    return cases


def write(name, doc):
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, name + ".json")
    text = json.dumps(doc, separators=(",", ":")) + "\n"
    if "--check-only" in sys.argv:
        with open(path) as f:
            if f.read() != text:
                sys.exit("make_stress_vectors: %s differs from a fresh run" % path)
        return
    with open(path, "w") as f:
        f.write(text)


def main():
    write("kf", {
        "generator": "tools/make_stress_vectors.py (mpmath, 60 digits)",
        "layout": "cases[]: n, m, x0, P0, steps[] {F, Q (predict first, if present), "
                  "H, R, y, and the reference x, P after the update, P_min_eig, "
                  "cond_H (2-norm condition number of H, for the tests' bounds)}",
        "cases": kf_cases()})
    write("aug", {
        "generator": "tools/make_stress_vectors.py (mpmath, 60 digits)",
        "layout": "cases[]: n, m, p, x0, P0, d0, Pd0, steps[] {F, Q, B, Rd (predict first, "
                  "if present), H, A, R, y, reference x, P, d, Pd after the update, cond_H "
                  "(of [H A]), rho = max|P^a_{k|k-1}| / max|P^a_{k|k}|}",
        "cases": aug_cases()})
    write("info", {
        "generator": "tools/make_stress_vectors.py (mpmath, 60 digits)",
        "layout": "cases[]: n, x0, P0, steps[] {F, Q (predict first, if present), sensors[] "
                  "{C, R, z}, reference x, P after the fusion, cond_H (of the stacked C)}",
        "cases": info_cases()})
    write("uif", {
        "generator": "tools/make_stress_vectors.py (mpmath, 60 digits)",
        "layout": "cases[]: n, m, p, x0, P0, steps[] {A, G, Q (time update first, if "
                  "present), C, H, R, y, reference x, P (Px), d, Pd, Pxd after the step, "
                  "P_min_eig, cond_H (of [C H]), rho = max|P_{k|k-1}| / max|P_{k|k}|}",
        "nrtsf_layout": "cases named nrtsf_*: n, m, p, rank, x0, P0 (x_{0|0}), steps[] {A, G, "
                        "Q, C, R, y (no H), reference x, P, d (d_{k-1|k}), Pd, Pxd, "
                        "P_min_eig, cond_H (of C), rho}",
        "nrtsf_df_layout": "cases named nrtsf_df_*: n, m, p, rank, x0, P0 (the prior of x_0), "
                           "steps[] as the RTSF's (H may be rank-deficient: H = Hbar T), "
                           "reference d, Pd, Pxd minimum norm (d = T^+ dbar), cond_H = "
                           "sigma_1 / sigma_{n+rank} of [C H]",
        "cases": uif_cases() + nrtsf_cases() + nrtsf_df_cases()})
    write("diffkf", {
        "generator": "tools/make_stress_vectors.py (mpmath, 60 digits)",
        "layout": "cases[]: n, m, p, x0, P0 (the prior x_{1|0}, P_{1|0}), meas1 {H, A, R, y} "
                  "(the start's y_1), steps[] {F, Q, B, Rd (dynamics at k), H, A, R, y (model "
                  "and measurement at k+1), reference xf, Pf (x_{k|k}), xn, Pn (x_{k+1|k}), "
                  "Pf_min_eig, Pn_min_eig, cond_M (2-norm condition number of M_k), rho = "
                  "max|P_{k|k-1}| / max|P_{k|k}|}",
        "cases": diffkf_cases()})
    write("tw", {
        "generator": "tools/make_stress_vectors.py (mpmath, 60 digits)",
        "layout": "cases[]: n, m, N (sensors), p (rows per sensor), x0, P0, steps[] {A, B, Sv "
                  "(the model of n-1), sensors[] {H, Sw, y}, reference x (psi), P (Ploc), z "
                  "(z^ of z_{n-1}), Phi_post, S, P_min_eig, cond_H (of the stacked H), rho = max|Phi_{n|n-1}| / max|P_{n|n}|}",
        "cases": tw_cases()})


if __name__ == "__main__":
    main()
