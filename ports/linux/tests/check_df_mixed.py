#!/usr/bin/env python3
"""Seed 001's consensus network with mixed sensors (scenarios/nl_mixed_expr.json:
nodes of 2, 3 and 2 measurements) through dkf-run, against an independent
computation of the consensus in numpy (docs/design/dfnerts.md):

  1. every node's contribution from its own statistics, each of its own
     size m_l (C m_l x n, Hd m_l x p, Rbar m_l x m_l): Pi = Rbar^-1 -
     Rbar^-1 Hd (Hd^T Rbar^-1 Hd)^-1 Hd^T Rbar^-1, I = C^T Pi C,
     i = C^T Pi (nu + C x_pred) (56)-(57), and Y_pred = P_pred^-1;
  2. the T_p rounds (61) with the case's W and s, written here:
     PAPER  Y(0) = Y_pred, y(0) = y_pred, at tau = 1 + s (I, i); Px = Y^-1,
            x = Px y; d, Pd, Pxd the node's own (M = (Hd^T R_tilde^-1
            Hd)^-1 Hd^T R_tilde^-1: d = M nu, Pd = M R_tilde M^T,
            Pxd = -Pxz M^T, eqs. 13-15, 20);
     JOINT  Y_X(0) = blkdiag(Y_pred, 0), y_X(0) = [y_pred; 0], at tau = 1
            + s (J, j), J = [C Hd]^T Rbar^-1 [C Hd], j = [C Hd]^T Rbar^-1
            (nu + C x_pred); P_X = Y_X^-1, [x; d] = P_X y_X, Px, Pxd, Pd
            its blocks;
     against the node's Y, y, x, Px, d, Pd, Pxd, every node and step, for
     df_dnertsif and df_dnertsif_joint on cases 0 and 1 (path graph, T_p 2,
     s = 1 and 3) and df_ckf on case 3 (p = 0);
  3. case 2 (W = 1 1^T / 3, T_p 2, s = N, sensors linear in x): the joint
     variant at every node equals cf_dnertsf, the centralised DNERTSF on the
     stacked 7 sensors (x, Px, d, Pd, Pxd).

Errors are |a - b| / max(1, max|b| of that array). Tolerances:
items 1-2 take the C's recorded inputs (17 digits) of one step and redo
its algebra in another order: they differ by rounding times the
conditioning of the inverted matrices (cond(Rbar), cond(P_X) <= 50 here),
a few eps x 50 = 3e-14 in double, 3e-5 in float (eps 6e-8); bounds 1e-12
and 1e-4 (measured worst 2.9e-15 and 3.4e-6, in i). Item 3 compares two
filters that run 25 steps apart (information and covariance forms), so
their rounding differences are carried by the model's dynamics: bounds
1e-10 and 1e-4 (measured 1.5e-12 and 1.4e-6, in d; test_dfnerts_props'
centralised equalities use 1e-9 and 1e-3).

usage: check_df_mixed.py DKF_RUN SCENARIO OUT_DIR REAL
"""
import json
import os
import subprocess
import sys

import numpy as np


def run(dkf_run, filt, case, path, out):
    subprocess.run([dkf_run, "--quiet", "--filter", filt, "--case", str(case), "--output", out,
                    path], check=True)
    with open(out) as f:
        return next(iter(json.load(f)["outputs"].values()))


def arr(v, rows=None, cols=None):
    """A recorded value as a float array of the given shape (empty lists: 0 size)."""
    a = np.array(v, dtype=float)
    if rows is not None:
        a = a.reshape(rows, cols)
    return a


class Worst:
    def __init__(self):
        self.err, self.where = 0.0, ""

    def __call__(self, what, got, ref):
        got, ref = np.asarray(got, float), np.asarray(ref, float)
        if ref.size == 0:
            return
        assert got.shape == ref.shape, (what, got.shape, ref.shape)
        e = float(np.max(np.abs(got - ref))) / max(1.0, float(np.max(np.abs(ref))))
        if e > self.err:
            self.err, self.where = e, what


def pi_of(Rbar, Hd):
    """Pi(Rbar, Hd) = Rbar^-1 - Rbar^-1 Hd (Hd^T Rbar^-1 Hd)^-1 Hd^T Rbar^-1."""
    Ri = np.linalg.inv(Rbar)
    if Hd.shape[1] == 0:
        return Ri
    RH = Ri @ Hd
    return Ri - RH @ np.linalg.solve(Hd.T @ RH, RH.T)


def node_stats(out, k, l, n, p):
    """Node l's recorded statistics of step k, each of its own size m_l."""
    g = {key: out[key][k][l] for key in out}
    m = len(g["nu"])
    st = {"m": m, "x_pred": arr(g["x_pred"]), "P_pred": arr(g["P_pred"]),
          "Y_pred": arr(g["Y_pred"]), "y_pred": arr(g["y_pred"]), "nu": arr(g["nu"]),
          "C": arr(g["C"], m, n), "Hd": arr(g["H"], m, p), "Rbar": arr(g["Rbar"]),
          "R_tilde": arr(g["R_tilde"]), "Pxz": arr(g["Pxz"], n, m), "i": arr(g["i"]),
          "I": arr(g["I"])}
    return st


def consensus(W, packets, contrib, s, Tp):
    """T_p rounds of (61): every node's (Y, y) <- sum_j W_lj (Y_j, y_j), at
    tau = 1 plus s times its own contribution."""
    cur = packets
    for tau in range(Tp):
        nxt = []
        for l in range(len(cur)):
            Y = sum(W[l][j] * cur[j][0] for j in range(len(cur)))
            y = sum(W[l][j] * cur[j][1] for j in range(len(cur)))
            if tau == 0:
                Y, y = Y + s * contrib[l][0], y + s * contrib[l][1]
            nxt.append((Y, y))
        cur = nxt
    return cur


def check_case(out, cs, joint, w):
    """Items 1 and 2 over every step and node of one recorded run."""
    W, s, Tp = np.array(cs["W"]), float(cs.get("scale", 1.0)), cs["Tp"]
    N, n, p = len(cs["node_models"]), len(cs["init_per_node"][0]["x0"]), \
        len(cs["init_per_node"][0]["d0"])
    sizes = set()
    for k in range(len(out["x"])):
        stats = [node_stats(out, k, l, n, p) for l in range(N)]
        packets, contrib = [], []
        for l, st in enumerate(stats):
            sizes.add(st["m"])
            tag = f"step {k + 1} node {l} (m = {st['m']})"
            C, Hd, Pi = st["C"], st["Hd"], pi_of(st["Rbar"], st["Hd"])
            zt = st["nu"] + C @ st["x_pred"]
            w(tag + " I", C.T @ Pi @ C, st["I"])
            w(tag + " i", C.T @ Pi @ zt, st["i"])
            w(tag + " Y_pred", np.linalg.inv(st["P_pred"]), st["Y_pred"])
            if joint:
                q = n + p
                Y0, y0 = np.zeros((q, q)), np.zeros(q)
                Y0[:n, :n], y0[:n] = st["Y_pred"], st["y_pred"]
                CH = np.hstack([C, Hd])
                Ri = np.linalg.inv(st["Rbar"])
                packets.append((Y0, y0))
                contrib.append((CH.T @ Ri @ CH, CH.T @ Ri @ zt))
            else:
                packets.append((st["Y_pred"], st["y_pred"]))
                contrib.append((st["I"], st["i"]))
        agreed = consensus(W, packets, contrib, s, Tp)
        for l, (Y, y) in enumerate(agreed):
            g = {key: out[key][k][l] for key in out}
            tag = f"step {k + 1} node {l} (m = {stats[l]['m']})"
            P = np.linalg.inv(Y)
            X = P @ y
            if joint:
                Px = P[:n, :n]
                w(tag + " x", X[:n], g["x"])
                w(tag + " Px", Px, g["Px"])
                w(tag + " Y", np.linalg.inv(Px), g["Y"])
                w(tag + " y", np.linalg.solve(Px, X[:n]), g["y"])
                if p:
                    w(tag + " d", X[n:], g["d"])
                    w(tag + " Pd", P[n:, n:], g["Pd"])
                    w(tag + " Pxd", P[:n, n:], g["Pxd"])
            else:
                w(tag + " Y", Y, g["Y"])
                w(tag + " y", y, g["y"])
                w(tag + " x", X, g["x"])
                w(tag + " Px", P, g["Px"])
                if p:
                    st = stats[l]
                    Rt, Hd = st["R_tilde"], st["Hd"]
                    RtH = np.linalg.solve(Rt, Hd)
                    M = np.linalg.solve(Hd.T @ RtH, RtH.T)
                    w(tag + " d", M @ st["nu"], g["d"])
                    w(tag + " Pd", M @ Rt @ M.T, g["Pd"])
                    w(tag + " Pxd", -st["Pxz"] @ M.T, g["Pxd"])
    return sorted(sizes)


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    dkf_run, scn, out_dir, real = sys.argv[1:]
    os.makedirs(out_dir, exist_ok=True)
    cases = json.load(open(scn))["cases"]
    tol = 1e-4 if real == "float" else 1e-12
    tol_cf = 1e-4 if real == "float" else 1e-10
    bad = 0
    runs = [("df_dnertsif", 0, False), ("df_dnertsif", 1, False), ("df_dnertsif_joint", 0, True),
            ("df_dnertsif_joint", 1, True), ("df_ckf", 3, False)]
    for filt, c, joint in runs:
        out = run(dkf_run, filt, c, scn, os.path.join(out_dir, f"{filt}_{c}.json"))
        w = Worst()
        sizes = check_case(out, cases[c], joint, w)
        ok = w.err <= tol
        bad += not ok
        print(f"{'PASS' if ok else 'FAIL'}: {filt} case {c} ({cases[c]['name']}, m_l in {sizes}, "
              f"s = {cases[c]['scale']:g}): worst error against the oracle {w.err:.3g} at "
              f"{w.where} (bound {tol:g})")
    # 3. the joint variant at consensus == the centralised filter on all sensors
    dj = run(dkf_run, "df_dnertsif_joint", 2, scn, os.path.join(out_dir, "joint_2.json"))
    cf = run(dkf_run, "cf_dnertsf", 2, scn, os.path.join(out_dir, "cf_2.json"))
    w = Worst()
    for k in range(len(cf["x"])):
        for l in range(len(cases[2]["node_models"])):
            for key in ("x", "Px", "d", "Pd", "Pxd"):
                w(f"step {k + 1} node {l} {key}", dj[key][k][l], cf[key][k])
    ok = w.err <= tol_cf
    bad += not ok
    print(f"{'PASS' if ok else 'FAIL'}: df_dnertsif_joint case 2 (W = 11^T/3, T_p 2, s = 3) == "
          f"cf_dnertsf on the 7 stacked sensors: worst error {w.err:.3g} at {w.where} "
          f"(bound {tol_cf:g})")
    print(f"check_df_mixed: {6 - bad} passed, {bad} failed")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
