"""Seed 001's radar simulation (docs/design/derivation-seed001-002.md §2, the simulation set-up).

The constant-turn target (eq. 62, T = 1), the 12 radars on a 3 x 4 grid, the
turn-rate schedule and the Monte-Carlo draws, written as scenario files in the
nonlinear-cases layout that dkf-run reads (docs/reference/scenario-format.md,
"Nonlinear cases"). Used by tools/seed001_table1.py (the paper's Table 1) and
by the network demo; the filters themselves are dkf's C code.

Set-up (docs/design/derivation-seed001-002.md §2 lists the choices the paper leaves open):
  x = [xi, xi_dot, eta, eta_dot], d = omega (rad/s);
  x_k = F_CT(omega_{k-1}) x_{k-1} + Gamma w_{k-1},  w ~ N(0, 0.04 I2);
  z^i_k = [hypot, atan2, 10 omega_k](x_k relative to radar i) + v,
  R = diag(0.2^2, 0.015^2, sigma_phi^2), sigma_phi = 0.017 deg/s in rad/s;
  omega_k = -3 deg/s (k <= 30, omega_0 included), 6 deg/s (31..60),
  10 deg/s (61..100); x_0 = [-40, 3, 10, 1];
  run m draws, from numpy's default_rng(20140001 + m), x_hat_0 ~ N(x_0, P_0),
  then w, then v (in that order); every filter starts from that x_hat_0,
  omega_hat_0 = -3 deg/s, P_d0 = (sigma_phi / 10)^2, P_xd0 = 0.
"""

import numpy as np

DEG = np.pi / 180.0
T = 1.0
STEPS = 100
SIGMA_PHI = 0.017 * DEG  # rad/s
R_DIAG = np.array([0.2**2, 0.015**2, SIGMA_PHI**2])
GAMMA = np.array([[0.5, 0.0], [1.0, 0.0], [0.0, 0.5], [0.0, 1.0]])
Q_ACC = 0.04
Q = GAMMA @ (Q_ACC * np.eye(2)) @ GAMMA.T
X0 = np.array([-40.0, 3.0, 10.0, 1.0])
P0 = np.diag([4.0, 0.01, 4.0, 0.01])
OMEGA0 = -3.0 * DEG
PD0 = (SIGMA_PHI / 10.0) ** 2
# the 12 radars, row-major on the 3 x 4 grid (sensor i of the paper = index i - 1)
SENSORS = [(x, y) for y in (-40.0, -10.0, 20.0) for x in (-20.0, 20.0, 60.0, 100.0)]


def omega_at(k):
    """The true turn rate omega_k (rad/s)."""
    return (-3.0 if k <= 30 else 6.0 if k <= 60 else 10.0) * DEG


def f_ct(omega):
    """F_CT(omega) of eq. (62), T = 1 (the limit at omega = 0)."""
    wt = omega * T
    if abs(omega) < 1e-12:
        s, c1 = T, 0.0
    else:
        s, c1 = np.sin(wt) / omega, (1.0 - np.cos(wt)) / omega
    c, sn = np.cos(wt), np.sin(wt)
    return np.array([[1.0, s, 0.0, -c1], [0.0, c, 0.0, -sn], [0.0, c1, 1.0, s], [0.0, sn, 0.0, c]])


def g_radar(x, omega, sxy):
    """[range, bearing, 10 omega] of state x seen from radar sxy."""
    dx, dy = x[0] - sxy[0], x[2] - sxy[1]
    return np.array([np.hypot(dx, dy), np.arctan2(dy, dx), 10.0 * omega])


def grid_edges():
    """The 4-neighbour grid of the 3 x 4 layout: 17 edges (i, j), i < j."""
    e = []
    for r in range(3):
        for c in range(4):
            i = 4 * r + c
            if c < 3:
                e.append((i, i + 1))
            if r < 2:
                e.append((i, i + 4))
    return e


def metropolis(n, edges):
    """W_ij = 1 / (1 + max(deg_i, deg_j)) on the edges, W_ii = 1 - sum_j W_ij."""
    deg = np.zeros(n, dtype=int)
    for i, j in edges:
        deg[i] += 1
        deg[j] += 1
    W = np.zeros((n, n))
    for i, j in edges:
        W[i, j] = W[j, i] = 1.0 / (1.0 + max(deg[i], deg[j]))
    for i in range(n):
        W[i, i] = 1.0 - W[i].sum()
    return W


def truth_from_draws(w, v):
    """States x_0..x_N and measurements z_k^i (k = 1..N) from the noise
    draws w (N x 2) and v (N x nsensors x 3)."""
    n_steps = w.shape[0]
    X = np.zeros((n_steps + 1, 4))
    X[0] = X0
    Z = np.zeros((n_steps, v.shape[1], 3))
    for k in range(1, n_steps + 1):
        X[k] = f_ct(omega_at(k - 1)) @ X[k - 1] + GAMMA @ w[k - 1]
        for i in range(v.shape[1]):
            Z[k - 1, i] = g_radar(X[k], omega_at(k), SENSORS[i]) + v[k - 1, i]
    return X, Z


def draw_run(run, steps=STEPS, nsensors=12):
    """Run `run`'s initial estimate, truth and measurements."""
    rng = np.random.default_rng(20140001 + run)
    x_hat0 = X0 + np.sqrt(np.diag(P0)) * rng.standard_normal(4)
    w = np.sqrt(Q_ACC) * rng.standard_normal((steps, 2))
    v = np.sqrt(R_DIAG) * rng.standard_normal((steps, nsensors, 3))
    X, Z = truth_from_draws(w, v)
    return x_hat0, X, Z


def network_case(name, x_hat0, X, Z, tp, scale, ckf=False):
    """One case of the nonlinear-cases layout: 12 nodes, the grid, W, T_p and
    the consensus scale; with ckf the DF-CKF's nodes (p = 0, omega frozen at
    omega_hat_0, range and bearing only)."""
    n = len(SENSORS)
    edges = grid_edges()
    W = metropolis(n, edges)
    models, inits = [], []
    for i in range(n):
        if ckf:
            models.append({"family": "s1_ckf", "sensor": i, "sensor_xy": list(SENSORS[i]),
                           "omega_fixed": OMEGA0, "Q": Q.tolist(),
                           "R": np.diag(R_DIAG[:2]).tolist()})
            inits.append({"x0": x_hat0.tolist(), "Px0": P0.tolist(), "d0": [], "Pd0": [],
                          "Pxd0": [[]] * 4})
        else:
            models.append({"family": "s1_radar", "sensor": i, "sensor_xy": list(SENSORS[i]),
                           "Q": Q.tolist(), "R": np.diag(R_DIAG).tolist()})
            inits.append({"x0": x_hat0.tolist(), "Px0": P0.tolist(), "d0": [OMEGA0],
                          "Pd0": [[PD0]], "Pxd0": [[0.0]] * 4})
    steps = []
    for k in range(1, Z.shape[0] + 1):
        z = Z[k - 1][:, :2] if ckf else Z[k - 1]
        steps.append({"k": k, "z": z.tolist()})
    return {"name": name, "held_out": False, "node_models": models,
            "edges": [list(e) for e in edges], "W": W.tolist(), "Tp": tp, "scale": scale,
            "init_per_node": inits,
            "truth": {"X": X.tolist(), "omega": [omega_at(k) for k in range(Z.shape[0] + 1)]},
            "steps": steps}


def scenario_file(cases, description):
    return {"schema": "infofusion-golden-v1", "file": "generated by tools/seed001_model.py",
            "description": description, "conventions": [], "cases": cases}


def main():
    import argparse
    import json
    ap = argparse.ArgumentParser(description="Writes seed 001's 12-radar scenario (one "
                                 "Monte-Carlo run) in the nonlinear-cases layout.")
    ap.add_argument("--run", type=int, default=0, help="Monte-Carlo run (its seed: 20140001 + run)")
    ap.add_argument("--steps", type=int, default=STEPS)
    ap.add_argument("--tp", type=int, default=45, help="consensus rounds per step")
    ap.add_argument("--scale", default="both",
                    help="consensus scale: 1, N, or both (two cases: literal, N-scaled)")
    ap.add_argument("--ckf", action="store_true", help="DF-CKF nodes (p = 0) instead")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    if not 1 <= a.steps <= STEPS or not 1 <= a.tp <= 100000:
        ap.error("--steps in 1..100, --tp in 1..100000")
    x_hat0, X, Z = draw_run(a.run)
    X, Z = X[: a.steps + 1], Z[: a.steps]
    scales = {"1": [1.0], "N": [12.0], "both": [1.0, 12.0]}.get(a.scale)
    if scales is None:
        ap.error("--scale: 1, N or both")
    kind = "ckf" if a.ckf else "dnertsif"
    cases = [network_case(f"radar12_run{a.run}_{kind}_Tp{a.tp}_s{int(s)}", x_hat0, X, Z, a.tp, s,
                          ckf=a.ckf) for s in scales]
    with open(a.out, "w") as f:
        json.dump(scenario_file(cases, "seed 001's 12 radars, tools/seed001_model.py"), f)


if __name__ == "__main__":
    main()
