#!/usr/bin/env python3
"""dkf-run --filter central_kf (the stacked Kalman filter beside the
weighted fusion) on the seed-002 vector file, against an independent
computation and the fusions:

  1. x_central and P_central equal a plain Kalman filter of the stacked
     measurements written here in double (textbook form
     P- = F P F^T + Q, K = P- H^T (H P- H^T + R)^-1, P = (I - K H) P-):
     max |difference| <= REL * max(1, max|.|), REL 1e-10 in double (measured
     ~1e-15: the two differ only by rounding), 1e-4 in float;
  2. the chain the fusion promises, at every step, on the signal:
     central <= matrix-fused <= scalar-fused (fusion_matrix's P0_matrix[0][0],
     fusion_scalar's P_S0), within 1e-12 (1e-5 in float) of P_S0;
  3. the last step's central variance is the derivation's (docs/design/derivation-seed001-002.md) 0.48630 to
     5 digits.

usage: check_central.py DKF_RUN VECTOR OUT_DIR REAL
"""
import json
import os
import subprocess
import sys


def run(dkf_run, filt, path, out):
    subprocess.run([dkf_run, "--quiet", "--filter", filt, "--output", out, path], check=True)
    with open(out) as f:
        return next(iter(json.load(f)["outputs"].values()))


def mat(a):
    return [list(map(float, r)) for r in a]


def mul(A, B):
    return [[sum(A[i][k] * B[k][j] for k in range(len(B))) for j in range(len(B[0]))]
            for i in range(len(A))]


def tr(A):
    return [list(r) for r in zip(*A)]


def inv(A):
    n = len(A)
    M = [list(A[i]) + [1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(M[r][c]))
        M[c], M[p] = M[p], M[c]
        d = M[c][c]
        M[c] = [v / d for v in M[c]]
        for r in range(n):
            if r != c:
                f = M[r][c]
                M[r] = [a - f * b for a, b in zip(M[r], M[c])]
    return [row[n:] for row in M]


def main():
    dkf_run, vec, out, real = sys.argv[1:5]
    rel = 1e-4 if real == "float" else 1e-10
    chain_tol = 1e-5 if real == "float" else 1e-12
    os.makedirs(out, exist_ok=True)
    c = json.load(open(vec))["cases"][0]
    F, G, Qe = mat(c["Phi"]), mat(c["Gamma"]), mat(c["Qe"])
    Q = mul(mul(G, Qe), tr(G))
    H = [row for h in c["H"] for row in mat(h)]
    ms = len(H)
    Rc = [[0.0] * ms for _ in range(ms)]
    row = 0
    for r in c["R"]:
        for a in range(len(r)):
            for b in range(len(r)):
                Rc[row + a][row + b] = float(r[a][b])
        row += len(r)
    x = [[v] for v in c["x_hat0"]]
    P = mat(c["P0"])
    cen = run(dkf_run, "central_kf", vec, os.path.join(out, "central.json"))
    sca = run(dkf_run, "fusion_scalar", vec, os.path.join(out, "scalar.json"))
    mtx = run(dkf_run, "fusion_matrix", vec, os.path.join(out, "matrix.json"))
    worst = 0.0
    bad = []
    for t, st in enumerate(c["steps"]):
        y = [[float(v)] for yi in st["y"] for v in (yi if isinstance(yi, list) else [yi])]
        xp, Pp = mul(F, x), [[a + b for a, b in zip(r1, r2)] for r1, r2 in zip(mul(mul(F, P), tr(F)), Q)]
        S = [[a + b for a, b in zip(r1, r2)] for r1, r2 in zip(mul(mul(H, Pp), tr(H)), Rc)]
        K = mul(mul(Pp, tr(H)), inv(S))
        nu = [[a[0] - b[0]] for a, b in zip(y, mul(H, xp))]
        x = [[a[0] + b[0]] for a, b in zip(xp, mul(K, nu))]
        KH = mul(K, H)
        IKH = [[(1.0 if i == j else 0.0) - KH[i][j] for j in range(len(KH))] for i in range(len(KH))]
        P = mul(IKH, Pp)
        gx, gP = cen["x_central"][t], cen["P_central"][t]
        sc = max(1.0, max(abs(v[0]) for v in x), max(abs(v) for r in P for v in r))
        e = max(max(abs(gx[i] - x[i][0]) for i in range(len(x))),
                max(abs(gP[i][j] - P[i][j]) for i in range(len(P)) for j in range(len(P)))) / sc
        worst = max(worst, e)
        pc, pm, ps = gP[0][0], mtx["P0_matrix"][t][0][0], sca["P_S0"][t]
        if not (pc <= pm + chain_tol and pm <= ps + chain_tol):
            bad.append(f"t={t + 1}: central {pc} matrix {pm} scalar {ps}")
    print(f"central_kf vs the independent stacked KF: worst {worst:.3g} (bound {rel:g})")
    print(f"last step: central {cen['P_central'][-1][0][0]:.6f}, matrix "
          f"{mtx['P0_matrix'][-1][0][0]:.6f}, scalar {sca['P_S0'][-1]:.6f}")
    if worst > rel:
        bad.append(f"central_kf differs from the stacked KF by {worst:.3g}")
    if abs(round(cen["P_central"][-1][0][0], 5) - 0.48630) > 1e-9:
        bad.append(f"central steady variance {cen['P_central'][-1][0][0]} is not 0.48630")
    if bad:
        print("FAILED: " + "; ".join(bad))
        sys.exit(1)
    print("CHECKS PASSED")


if __name__ == "__main__":
    main()
