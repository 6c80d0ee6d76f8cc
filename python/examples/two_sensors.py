#!/usr/bin/env python3
"""Two sensors with drifting biases: a Difference KF per sensor, the fusion
centre, and a plain Kalman filter for comparison (docs/guide/python.md,
"Worked example: two biased sensors").

    python/examples/two_sensors.py [--steps 200] [--seed 4] [--out-dir docs/guide/img]
    python/examples/two_sensors.py --no-plot      # the numbers and the checks only

A target moves along a line with a nearly constant velocity, x = [position,
velocity]. Two sensors measure its position, each with a bias of its own
that drifts (d_{k+1} = 0.8 d_k + wd_k: a bias of a standard deviation of
1.18 that wanders over a few steps, five times the sensors' noise). The
plain KF on both sensors' measurements knows nothing of the biases and
takes them for position; the Difference KF removes each sensor's bias by
differencing its measurements, and the fusion centre combines the two
nodes' messages into the centralized Difference-KF estimate.

The script checks what the guide says and exits 1 if one does not hold:
the fused estimate's position RMSE is below the plain KF's and below each
single sensor's Difference KF, and the fusion centre equals the central
Difference KF on the stacked measurements.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Dict

import numpy as np

import dkf

MODEL = {
    "model": {
        "F": [[1.0, 1.0], [0.0, 1.0]],                   # unit time step
        "Q": [[0.0025, 0.005], [0.005, 0.01]],           # white acceleration
        "B": [[0.8]],                                    # each bias: d_{k+1} = 0.8 d_k + wd_k,
        "Rd": [[0.5]],                                   # standard deviation 1.18 in the long run
        "sensors": [
            {"H": [[1.0, 0.0]], "R": [[0.05]], "D": [[1.0]]},  # position + its bias + noise
            {"H": [[1.0, 0.0]], "R": [[0.1]], "D": [[1.0]]},
        ],
    },
    "init": {"x00": [0.0, 1.0], "P00": [[1.0, 0.0], [0.0, 0.25]]},
}


def rmse(est, truth) -> float:
    return float(np.sqrt(np.mean((np.asarray(est) - truth) ** 2)))


def run(steps: int, seed: int) -> Dict[str, object]:
    scn = dkf.simulate(MODEL, steps, seed=seed)
    truth = np.array(scn["truth"]["x"])[1:steps + 1]          # x_1..x_N
    bias = np.array(scn["truth"]["d_stacked"])[1:steps + 1]  # d^0, d^1
    kf = dkf.run_scenario(scn, filter="kf")["outputs"]
    dk = dkf.run_scenario(scn, filter="dkf")["outputs"]
    est = {
        "KF (both sensors)": np.array(kf["central"]["xf"]),
        "DKF sensor 0": np.array(dk["local"][0]["xf"]),
        "DKF sensor 1": np.array(dk["local"][1]["xf"]),
        "DKF fused": np.array(dk["fused"]["xf"]),
    }
    central = np.array(dk["central"]["xf"])
    return {"truth": truth, "bias": bias, "est": est, "central": central,
            "rmse": {name: rmse(x[:, 0], truth[:, 0]) for name, x in est.items()}}


def check(r: Dict[str, object]) -> list:
    e = r["rmse"]
    fused = e["DKF fused"]
    gap = float(np.max(np.abs(r["est"]["DKF fused"] - r["central"])))
    claims = [
        ("fused RMSE below the plain KF's", fused < e["KF (both sensors)"]),
        ("fused RMSE below each sensor's DKF", fused < min(e["DKF sensor 0"],
                                                            e["DKF sensor 1"])),
        ("fusion centre = central DKF (max gap %.1e)" % gap, gap < 1e-9),
    ]
    return claims


def plot(r: Dict[str, object], out_dir: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    truth, est = r["truth"], r["est"]
    k = np.arange(1, truth.shape[0] + 1)
    fig, ax = plt.subplots(figsize=(8, 3.2))
    for name, x in est.items():
        ax.plot(k, x[:, 0] - truth[:, 0], lw=1.2 if "fused" in name or "KF " in name else 0.7,
                label="%s (RMSE %.2f)" % (name, r["rmse"][name]))
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("k")
    ax.set_ylabel("position error")
    ax.legend(fontsize="small", ncol=2)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "two_sensors_error.png"), dpi=80)
    fig, ax = plt.subplots(figsize=(8, 2.6))
    for i in range(r["bias"].shape[1]):
        ax.plot(k, r["bias"][:, i], label="bias of sensor %d" % i)
    ax.set_xlabel("k")
    ax.set_ylabel("bias (simulated)")
    ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "two_sensors_bias.png"), dpi=80)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--seed", type=int, default=4)
    ap.add_argument("--out-dir", default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                      "..", "..", "docs", "guide", "img"))
    ap.add_argument("--no-plot", action="store_true", help="numbers and checks only")
    a = ap.parse_args(argv)
    r = run(a.steps, a.seed)
    print("position RMSE over k = 1..%d (seed %d):" % (a.steps, a.seed))
    for name, v in r["rmse"].items():
        print("  %-18s %.3f" % (name, v))
    ok = True
    for text, holds in check(r):
        print("  %s: %s" % (text, "yes" if holds else "NO"))
        ok = ok and holds
    if not a.no_plot:
        os.makedirs(a.out_dir, exist_ok=True)
        plot(r, a.out_dir)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
