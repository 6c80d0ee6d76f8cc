#!/usr/bin/env python3
"""Seed 002's example, reproduced by driving dkf's C filters through the Python package.

  tools/seed002_example.py [--runs 2000] [--steps 60] [--long 20000] [--st-steps 8000]
                           [--out-dir DIR] [--float32] [--no-plots] [--no-verdict]

Needs the Python package (`pip install .`, docs/guide/python.md): every
estimate is `dkf.run_scenario(scenario, filter=...)`'s (`dkf.float32`'s with
--float32), which gives what `dkf-run --filter` writes, bit for bit; this
script simulates (numpy), makes each run a weighted-fusion case
(tools/make_wf_scenario.py's layout) and does the statistics.

The model (docs/design/weighted-fusion.md): the AR(2)/MA(1) signal s plus the common
coloured noise eta of the paper, 5 sensors y_i = s + eta + v_i with
sigma_vi^2 = 0.1 .. 0.5, in the observer form of tools/make_wf_scenario.py
(common prior x_hat0 = 0, P0 = the stationary covariance, x(0) ~ N(0, P0)).

1. Steady state: the filter fusion_steady (DARE + Stein in the C core)
   gives the local variances P_Sii, the scalar weights, P_S0 and the
   matrix-fused H_s P0 H_s^T; central_kf on a long run the
   centralized steady variance. Compared with the paper's / reference derivation's (docs/design/derivation-seed001-002.md)
   five-digit values.
2. Monte-Carlo (--runs runs of --steps steps, numpy default_rng(2002 + r)):
   every run through local_kf, fusion_scalar, fusion_matrix and central_kf;
   the empirical variance of each estimator's signal error at every t
   against its theoretical variance at t (P_Sii(t), P_S0(t), H_s P0(t) H_s^T,
   the central P(t)), with the standard error sqrt(2 / runs) of a sample
   variance of Gaussian errors; verdict at t = --steps: within 3 standard
   errors. A single --long run (stationary errors, steady filters) gives the
   time-averaged MSE with a batch-means standard error.
3. Self-tuning: one --st-steps run through fusion_selftune (the identifier
   of dkf/selftune.h feeding the filters and weights) and fusion_scalar on
   the true model: the estimates a1, a2, c1, sigma_w^2 over t and the gap
   |s0_selftune - s0_optimal| (RMS per window).

Writes DIR/seed002.json and (unless --no-plots) DIR/seed002_variance.png,
DIR/seed002_selftune_params.png, DIR/seed002_selftune_gap.png. Exit 1 if a
verdict fails (unless --no-verdict, for smoke runs), 2 without the package.
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_wf_scenario as wfs  # noqa: E402
import example_common as ec  # noqa: E402

L = 5
R = [0.1 * (i + 1) for i in range(L)]
# the paper's and the derivation's steady values (5 digits)
PAPER = {"P_Sii": [0.53205, 0.60737, 0.67752, 0.74401, 0.80767],
         "w": [0.4798, 0.2222, 0.1362, 0.0936, 0.0682],
         "P_S0": 0.49409, "matrix": 0.49336, "central": 0.48630}
TRUE_PARAMS = {"a1": -1.5, "a2": 0.56, "c1": 0.4, "sigma_w2": 0.8}


def simulate(rng, steps, P0):
    """x_true [steps + 1, 4], y [steps, L] from the example's model."""
    F, G, Qe = np.array(wfs.PHI), np.array(wfs.GAMMA), np.array(wfs.QE)
    x = rng.multivariate_normal(np.zeros(4), P0)
    xs, ys = [x], []
    sd = np.sqrt(R)
    for _ in range(steps):
        x = F @ x + G @ (np.sqrt(np.diag(Qe)) * rng.standard_normal(2))
        xs.append(x)
        ys.append(x[0] + x[2] + sd * rng.standard_normal(L))
    return np.array(xs), np.array(ys)


def scenario(xs, ys, P0, name):
    H = [[[1.0, 0.0, 1.0, 0.0]] for _ in range(L)]
    Rm = [[[r]] for r in R]
    yl = [[[float(v)] for v in row] for row in ys]
    return wfs.case(wfs.GAMMA, wfs.QE, H, Rm, P0.tolist(), yl, xs.tolist(), name,
                    "seed-002 example (tools/seed002_example.py)")


def run_filter(mod, flt, scn):
    """The filter over one scenario: outputs.<LABEL> of dkf-run's document."""
    return next(iter(mod.run_scenario(scn, filter=flt)["outputs"].values()))


def simulated(name, seed, steps, P0):
    """A run of steps simulated with default_rng(seed) as scenario `name`: (x_true, the
    scenario)."""
    xs, ys = simulate(np.random.default_rng(seed), steps, P0)
    return xs, scenario(xs, ys, P0, name)


def signal_errors(mod, r, steps, P0):
    """One Monte-Carlo run: squared signal errors and theoretical variances per t."""
    xs, scn = simulated(f"mc{r}", 2002 + r, steps, P0)
    s = xs[1:, 0]
    loc, sca, mat, cen = (run_filter(mod, f, scn)
                          for f in ("local_kf", "fusion_scalar", "fusion_matrix", "central_kf"))
    e2 = {f"local {i + 1}": (np.array(loc["s_local"])[:, i] - s) ** 2 for i in range(L)}
    th = {f"local {i + 1}": np.array(loc["P_ij"])[:, i, i, 0, 0] for i in range(L)}
    e2["scalar-fused"] = (np.array(sca["s_fused"]) - s) ** 2
    th["scalar-fused"] = np.array(sca["P_S0"])
    e2["matrix-fused"] = (np.array(mat["x_fused_matrix"])[:, 0] - s) ** 2
    th["matrix-fused"] = np.array(mat["P0_matrix"])[:, 0, 0]
    e2["centralized"] = (np.array(cen["x_central"])[:, 0] - s) ** 2
    th["centralized"] = np.array(cen["P_central"])[:, 0, 0]
    return e2, th


def batch_se(e2, batches=40):
    """Standard error of mean(e2) by batch means (the errors are autocorrelated)."""
    b = np.array_split(e2, batches)
    m = np.array([x.mean() for x in b])
    return m.std(ddof=1) / np.sqrt(batches)


def main(argv=None):
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = ec.seed_parser(__doc__, root, "seed002",
                        (("--runs", 2000), ("--steps", 60), ("--long", 20000), ("--st-steps", 8000)),
                        "exit 0 even if a value is off (a smoke run of a few runs)")
    a = ap.parse_args(argv)
    if not (2 <= a.runs <= 100000 and 2 <= a.steps <= 100000 and 200 <= a.long <= 1000000
            and 100 <= a.st_steps <= 1000000):
        ap.error("--runs 2..1e5, --steps 2..1e5, --long 200..1e6, --st-steps 100..1e6")
    mod = ec.package_module(a, "seed002_example")
    if mod is None:
        return 2
    os.makedirs(a.out_dir, exist_ok=True)
    F, G, Qe = np.array(wfs.PHI), np.array(wfs.GAMMA), np.array(wfs.QE)
    P0 = wfs.stationary(F, G @ Qe @ G.T)
    verdicts = []
    res = {"paper": PAPER}

    # ---- 1. steady state and the long run --------------------------------------
    sys.stderr.write(f"seed 002: steady state and one {a.long}-step run ...\n")
    xs, scn = simulated("long", 2002, a.long, P0)
    st = run_filter(mod, "fusion_steady", scn)
    cen = run_filter(mod, "central_kf", scn)
    steady = {"P_Sii": [st["P_S"][i][i] for i in range(L)], "w": st["w"],
              "P_S0": st["P_S0"], "matrix": st["P0_matrix"][0][0],
              "central": cen["P_central"][-1][0][0]}
    res["steady"] = steady
    print("\nseed 002 steady state (dkf: DARE + Stein)   dkf       paper/note  agrees (5 digits)")
    for key in ("P_Sii", "w", "P_S0", "matrix", "central"):
        got, want = np.atleast_1d(steady[key]), np.atleast_1d(PAPER[key])
        dig = 4 if key == "w" else 5
        ok = bool(np.all(np.abs(np.round(got, dig) - want) <= 0.5 * 10 ** -dig + 1e-12))
        verdicts.append((f"steady {key}", ok))
        print(f"  {key:8s} {' '.join(f'{v:.{dig}f}' for v in got):44s} "
              f"{' '.join(f'{v:.{dig}f}' for v in want):44s} {'yes' if ok else 'NO'}")
    # stationary errors of the steady filters: time-averaged MSE over the long run
    s = xs[1:, 0]
    burn = 100
    long_mse = {}
    e_st = (np.array(st["steps_s_fused"]) - s)[burn:] ** 2
    e_mat = (np.array(st["steps_x_fused_matrix"])[:, 0] - s)[burn:] ** 2
    e_loc = (np.array(st["steps_x_local"])[:, :, 0] - s[:, None])[burn:] ** 2
    e_cen = (np.array(cen["x_central"])[:, 0] - s)[burn:] ** 2
    for name, e2, th in ([(f"local {i + 1}", e_loc[:, i], steady["P_Sii"][i]) for i in range(L)]
                         + [("scalar-fused", e_st, steady["P_S0"]),
                            ("matrix-fused", e_mat, steady["matrix"]),
                            ("centralized", e_cen, steady["central"])]):
        long_mse[name] = {"mse": float(e2.mean()), "se": float(batch_se(e2)), "theory": th}
    res["long_run"] = {"steps": a.long, "burn_in": burn, "mse": long_mse}

    # ---- 2. Monte-Carlo over runs ----------------------------------------------------
    prog = ec.Progress(a.runs, f"seed 002 Monte-Carlo: {a.runs} runs x {a.steps} steps x 4 filters")
    out = []
    for r in range(a.runs):
        out.append(signal_errors(mod, r, a.steps, P0))
        prog.step()
    names = list(out[0][0].keys())
    emp = {n: np.mean([o[0][n] for o in out], axis=0) for n in names}
    theo = {n: out[0][1][n] for n in names}  # the same in every run (data-independent)
    se_rel = np.sqrt(2.0 / a.runs)
    print(f"\nseed 002 Monte-Carlo, {a.runs} runs: signal error variance at t = {a.steps} "
          f"(s.e. {100 * se_rel:.1f} % of theory) and the {a.long}-step time average")
    print(f"  {'estimator':13s} {'empirical':>10s} {'theory':>9s} {'z':>6s}   "
          f"{'long-run MSE':>12s} {'+- s.e.':>8s} {'theory':>9s}")
    mc = {}
    for n in names:
        e, t = float(emp[n][-1]), float(theo[n][-1])
        z = (e - t) / (t * se_rel)
        lm = long_mse[n]
        mc[n] = {"empirical": emp[n].tolist(), "theory": theo[n].tolist(), "z_last": z}
        print(f"  {n:13s} {e:10.5f} {t:9.5f} {z:6.2f}   {lm['mse']:12.5f} {lm['se']:8.5f} "
              f"{lm['theory']:9.5f}")
        if n in ("scalar-fused", "matrix-fused", "centralized"):
            verdicts.append((f"MC {n} within 3 s.e.", abs(z) <= 3))
            verdicts.append((f"long-run {n} within 3 s.e.",
                             abs(lm["mse"] - lm["theory"]) <= 3 * lm["se"]))
    chain = bool(np.all(theo["centralized"] <= theo["matrix-fused"] + 1e-12) and
                 np.all(theo["matrix-fused"] <= theo["scalar-fused"] + 1e-12) and
                 np.all(theo["scalar-fused"] <=
                        np.min([theo[f"local {i + 1}"] for i in range(L)], axis=0) + 1e-12))
    verdicts.append(("central <= matrix <= scalar <= min local at every t", chain))
    res["monte_carlo"] = {"runs": a.runs, "steps": a.steps, "series": mc}

    # ---- 3. self-tuning -----------------------------------------------------------------
    sys.stderr.write(f"seed 002: self-tuning run of {a.st_steps} steps ...\n")
    xs, scn = simulated("selftune", 2003, a.st_steps, P0)
    stt = run_filter(mod, "fusion_selftune", scn)
    opt = run_filter(mod, "fusion_scalar", scn)
    ah = np.array(stt["a_hat"])
    est = {"a1": ah[:, 0], "a2": ah[:, 1], "c1": np.array(stt["c1_hat"]),
           "sigma_w2": np.array(stt["sigma_w2_hat"])}
    gap = np.array(stt["s_fused"]) - np.array(opt["s_fused"])
    edges = [e for e in (0, 500, 1000, 2000, 4000, 8000, 16000, 40000, 1000000) if e < a.st_steps]
    edges.append(a.st_steps)
    windows = [(lo, hi, float(np.sqrt(np.mean(gap[lo:hi] ** 2))))
               for lo, hi in zip(edges[:-1], edges[1:])]
    print(f"\nseed 002 self-tuning ({a.st_steps} steps): estimates at the end "
          f"(truth a1 -1.5, a2 0.56, c1 0.4, sigma_w^2 0.8)")
    print("  " + "  ".join(f"{k} {v[-1]:+.4f}" for k, v in est.items()))
    print("  RMS(s0_selftune - s0_optimal) per window: " +
          ", ".join(f"[{lo}, {hi}) {g:.4f}" for lo, hi, g in windows))
    res["selftune"] = {"steps": a.st_steps, "final": {k: float(v[-1]) for k, v in est.items()},
                       "gap_windows": windows}
    verdicts.append(("self-tuning gap shrinks (last window < first / 5)",
                     windows[-1][2] < windows[0][2] / 5))
    verdicts.append(("self-tuning estimates within 0.1 of the truth",
                     all(abs(v[-1] - TRUE_PARAMS[k]) < 0.1 for k, v in est.items())))

    with open(os.path.join(a.out_dir, "seed002.json"), "w") as f:
        json.dump(res, f, indent=1)
    if not a.no_plots:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        t = np.arange(1, a.steps + 1)
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for n, c in (("local 1", "C0"), ("scalar-fused", "C1"), ("matrix-fused", "C2"),
                     ("centralized", "C3")):
            ax.plot(t, emp[n], c + ".", label=f"{n}: empirical")
            ax.plot(t, theo[n], c + "-", label=f"{n}: theory")
        ax.set_xlabel("t")
        ax.set_ylabel("signal error variance")
        ax.set_ylim(0.4, 1.0)
        ax.set_title(f"seed 002: empirical ({a.runs} runs) and theoretical variances")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        fig.savefig(os.path.join(a.out_dir, "seed002_variance.png"), dpi=110)
        tt = np.arange(1, a.st_steps + 1)
        fig, axs = plt.subplots(2, 2, figsize=(9, 5.5), sharex=True)
        for axx, (k, v) in zip(axs.flat, est.items()):
            axx.plot(tt, v, lw=0.8, label="estimate")
            axx.axhline(TRUE_PARAMS[k], color="k", lw=0.8, label="truth")
            axx.set_title(k)
            axx.set_ylim(TRUE_PARAMS[k] - 0.5, TRUE_PARAMS[k] + 0.5)
            axx.grid(True, alpha=0.3)
        axs[1, 0].set_xlabel("t")
        axs[1, 1].set_xlabel("t")
        axs[0, 0].legend(fontsize=8)
        fig.suptitle("seed 002: self-tuning estimates (dkf/selftune.h)")
        fig.tight_layout()
        fig.savefig(os.path.join(a.out_dir, "seed002_selftune_params.png"), dpi=110)
        fig, ax = plt.subplots(figsize=(8, 4))
        ax.semilogy(tt, np.abs(gap) + 1e-12, lw=0.5)
        ax.set_xlabel("t")
        ax.set_ylabel("|s0 self-tuning - s0 optimal|")
        ax.set_title("seed 002: the self-tuning fused signal against the optimal fusion")
        ax.grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        fig.savefig(os.path.join(a.out_dir, "seed002_selftune_gap.png"), dpi=110)
        print(f"plots: {a.out_dir}/seed002_variance.png, seed002_selftune_params.png, "
              f"seed002_selftune_gap.png")
    bad = [w for w, ok in verdicts if not ok]
    print("\nverdicts: " + ("all hold" if not bad else "FAILED: " + "; ".join(bad)))
    return 1 if bad and not a.no_verdict else 0


if __name__ == "__main__":
    sys.exit(main())
