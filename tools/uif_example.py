#!/usr/bin/env python3
"""Seed-004 example (Hua, Wang, Zhao 2021, Section 5) through the C filters.

    tools/uif_example.py                      # full (200 runs)
    tools/uif_example.py --quick              # smoke test (python/tests/test_tools.py)
    tools/uif_example.py --float32            # the core built in float (dkf.float32)
    tools/uif_example.py --no-plots           # the tables and checks only (no matplotlib)

Needs the Python package (`pip install .`, docs/guide/python.md). This script
only SIMULATES the paper's system (numpy, fixed seeds: its inputs are fixed
signals, which dkf.simulate does not draw), makes each run a steps-layout
scenario (the layout of the seed-004 vectors, docs/reference/scenario-format.md)
and does the statistics; every estimate comes from the C library through
`dkf.run_scenario(scenario, filter="rtsf"|"nrtsf_df"|"nrtsf")`, which gives
what `dkf-run --filter` writes, bit for bit.

System (paper §5 as corrected by docs/design/derivation-seed003-004.md §5, = the vectors' model):
A (5x5, row 5 = [0 0 0 0 0.1]), G = [e1 e3 0], C = I5, H = [e3 e2 0]
(rank 2: d1 has no path to y), R as printed, Q = 1e-4 x R's pattern.
Protocol (derivation §7): K = 100 steps, x_0 ~ N(0, 0.1 I), P0 = 0.1 I,
d1 = sin(2 pi k / 40), d2 = 2 on k = 10..59, -1 on 60..79, else 0,
d3 = +-1.5 square wave of period 30; RMSE over runs and k = 10..99.
Cases, all on the same simulated runs:
  NRTSF-DF, d1 = sin    the paper's Fig. 2-4 (d1 unestimable; biased, derivation §8)
  NRTSF-DF, d1 = 0      the case where the paper's claim holds
  NRTSF (H = 0)         the paper's Fig. 5-7, d_{k-1|k} (d3 unestimable)
  RTSF, paper H         refused: rank H = 2 < m = 3 (dkf.RankError; dkf-run exits 3)
  RTSF, H[3][0] = 1     full-rank feedthrough baseline (all inputs estimable)

Writes into --out (default build/uif-example): tables.md, results.json,
fig_uif_inputs.png, fig_uif_states.png (unless --no-plots), and the scenario
files of run 0 (work/), which dkf-run reads as they are. Progress goes to
stderr. Prints "CHECKS PASSED" when the checks that do not depend on luck
hold (estimability masks, exact zeros of the unestimable inputs, bias flag
counts, RTSF refusal, finite values).
Exit status: 0 ok; 1 a check failed; 2 bad arguments, no package or a filter failure.
"""
import argparse
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import example_common as ec  # noqa: E402

K = 100
A = [[0.5, 2, 0, 0, 0], [0, 0.2, 1, 0, 1], [0, 0, 0.3, 0, 1], [0, 0, 0, 0.7, 1],
     [0, 0, 0, 0, 0.1]]
G = [[1, 0, 0], [0, 0, 0], [0, 1, 0], [0, 0, 0], [0, 0, 0]]
C = np.eye(5).tolist()
H = [[0, 0, 1], [0, 0, 0], [0, 1, 0], [0, 0, 0], [0, 0, 0]]
H_FULL = [[0, 0, 1], [0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 0]]  # the RTSF vector's H
PATTERN = [[1, 0, 0, 0.5, 0], [0, 1, 0, 0, 0.3], [0, 0, 1, 0, 0], [0.5, 0, 0, 1, 0],
           [0, 0.3, 0, 0, 1]]
R = (1e-2 * np.array(PATTERN)).tolist()
Q = (1e-4 * np.array(PATTERN)).tolist()
P0 = (0.1 * np.eye(5)).tolist()
X0 = [0.0] * 5
FIRST = 10  # RMSE over k = 10..99 (derivation §7)
EST = {0: "none", 1: "partial", 2: "full"}

# derivation §7 (500 runs): RMSE over k = 10..99 of x and d (reference values).
NOTE = {
    "nrtsf_df_sin": {"x": [1.421, 0.072, 0.115, 0.020, 0.010], "d": [0.711, 0.151, 1.424]},
    "nrtsf_df_zero": {"x": [0.149, 0.072, 0.115, 0.020, 0.010], "d": [0, 0.151, 0.171]},
    "nrtsf": {"x": [0.087, 0.070, 0.100, 0.020, 0.010], "d": [0.169, 0.103, 1.500]},
}


def inputs(d1_sin):
    """d_k for k = 0..K-1 (3 x K)."""
    k = np.arange(K)
    d1 = np.sin(2 * np.pi * k / 40) if d1_sin else np.zeros(K)
    d2 = np.where((k >= 10) & (k <= 59), 2.0, np.where((k >= 60) & (k <= 79), -1.0, 0.0))
    d3 = np.where((k // 15) % 2 == 0, 1.5, -1.5)
    return np.vstack([d1, d2, d3])


def simulate(rng, d, feedthrough):
    """x_k, y_k for k = 0..K-1: x_{k+1} = A x_k + G d_k + w_k, y_k = C x_k + H d_k + v_k."""
    An, Gn, Hn = np.array(A), np.array(G), np.array(feedthrough)
    Lq, Lr = np.linalg.cholesky(np.array(Q)), np.linalg.cholesky(np.array(R))
    x = np.zeros((5, K))
    y = np.zeros((5, K))
    x[:, 0] = np.array(X0) + math.sqrt(0.1) * rng.standard_normal(5)
    for k in range(K):
        y[:, k] = x[:, k] + Hn @ d[:, k] + Lr @ rng.standard_normal(5)
        if k + 1 < K:
            x[:, k + 1] = An @ x[:, k] + Gn @ d[:, k] + Lq @ rng.standard_normal(5)
    return x, y


def scenario(name, x, y, d, feedthrough, nrtsf):
    """Steps-layout scenario: DF filters k = 0..K-1; NRTSF k = 1..K-1 (truth d_prev)."""
    # the library's letters (docs/reference/scenario-format.md, "Letters"); the paper's
    # A, C, H are F, H, D
    model = {"F": A, "G": G, "Q": Q, "H": C, "R": R}
    if not nrtsf:
        model["D"] = feedthrough
    steps = []
    for k in range(1 if nrtsf else 0, K):
        truth = {"x": x[:, k].tolist()}
        truth["d_prev" if nrtsf else "d"] = d[:, k - 1 if nrtsf else k].tolist()
        steps.append({"k": k, "inputs": {"y": y[:, k].tolist()}, "truth": truth})
    return {"name": name, "description": "tools/uif_example.py, seed-004 example",
            "init": {"x0": X0, "P0": P0}, "model": model, "steps": steps}


def run_filter(dkf, filt, scn):
    """The filter over one scenario: outputs.<LABEL> of dkf-run's document."""
    return dkf.run_scenario(scn, filter=filt, name=scn["name"])["outputs"][filt.upper()]


CASES = [  # key, title, filter, d1 = sin?, feedthrough H, NRTSF layout
    ("nrtsf_df_sin", "NRTSF-DF, paper H, d1 = sin", "nrtsf_df", True, H, False),
    ("nrtsf_df_zero", "NRTSF-DF, paper H, d1 = 0", "nrtsf_df", False, H, False),
    ("nrtsf", "NRTSF, H = 0", "nrtsf", True, None, True),
    ("rtsf_full", "RTSF, H[3][0] = 1 (full rank)", "rtsf", True, H_FULL, False),
    ("rtsf_paper", "RTSF, paper H (rank 2)", "rtsf", True, H, False),
]


class Acc:
    """Sums over runs for one case."""

    def __init__(self, nsteps):
        self.runs = 0
        self.se_x = np.zeros((nsteps, 5))
        self.se_d = np.zeros((nsteps, 3))
        self.Px = np.zeros((nsteps, 5))
        self.Pd = np.zeros((nsteps, 3))
        self.nees = 0.0
        self.nees_n = 0
        self.bias_steps = []
        self.est = None
        self.est_constant = True
        self.d_zero = [True, True, True]
        self.finite = True
        self.refused = None


def accumulate(acc, out, x, d, k0, nrtsf):
    xs = np.array(out["x"])
    ds = np.array(out["d"])
    Px = np.array(out["Px"])
    Pd = np.array(out["Pd"])
    ks = np.arange(k0, K)
    xt = x[:, ks].T
    dt = d[:, ks - 1].T if nrtsf else d[:, ks].T
    acc.runs += 1
    acc.se_x += (xs - xt) ** 2
    acc.se_d += (ds - dt) ** 2
    acc.Px += np.diagonal(Px, axis1=1, axis2=2)
    acc.Pd += np.diagonal(Pd, axis1=1, axis2=2)
    for j, k in enumerate(ks):
        if k >= FIRST:
            e = xs[j] - xt[j]
            acc.nees += float(e @ np.linalg.solve(Px[j], e)) / 5
            acc.nees_n += 1
    acc.bias_steps.append(out["bias_steps"][-1])
    est = np.array(out["estimable"])
    if acc.est is None:
        acc.est = est[0].tolist()
    acc.est_constant &= bool(np.all(est == est[0]))
    for i in range(3):
        acc.d_zero[i] &= bool(np.all(ds[:, i] == 0.0))
    acc.finite &= bool(np.all(np.isfinite(xs)) and np.all(np.isfinite(ds)))


def rmse(acc, k0):
    sel = slice(FIRST - k0, None)
    return (np.sqrt(acc.se_x[sel].mean(axis=0) / acc.runs),
            np.sqrt(acc.se_d[sel].mean(axis=0) / acc.runs),
            np.sqrt(acc.Px[sel].mean(axis=0) / acc.runs),
            np.sqrt(acc.Pd[sel].mean(axis=0) / acc.runs))


def fmt(v, w=6, p=3):
    return " ".join("%*.*f" % (w, p, a) for a in v)


def case_grid(plt, third):
    """A 3 x 3 figure, one column per plotted case (the third titled `third`): fig, ax and
    the (case, title) pairs."""
    fig, ax = plt.subplots(3, 3, figsize=(10, 7), sharex=True)
    return fig, ax, [("nrtsf_df_sin", "NRTSF-DF d1=sin"), ("nrtsf_df_zero", "NRTSF-DF d1=0"),
                     ("nrtsf", third)]


def label_grid(ax):
    """The 3 x 3 grid's legend (top left) and k axis labels (bottom row)."""
    ax[0, 0].legend(fontsize=7)
    for a in ax[2]:
        a.set_xlabel("k", fontsize=8)


def plots(outdir, run0, d_sin):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax, cases = case_grid(plt, "NRTSF (H=0), d_{k-1|k}")
    for c, (key, title) in enumerate(cases):
        x, d, out, k0, nrtsf = run0[key]
        ks = np.arange(k0, K)
        dt = d[:, ks - 1] if nrtsf else d[:, ks]
        ds = np.array(out["d"])
        est = out["estimable"][0]
        for i in range(3):
            a = ax[i, c]
            a.plot(ks, dt[i], "k-", lw=1.2, label="true")
            a.plot(ks, ds[:, i], "r-", lw=0.9, label="estimate")
            a.set_title("%s: d%d (%s)" % (title, i + 1, EST[est[i]]), fontsize=8)
            a.tick_params(labelsize=7)
    label_grid(ax)
    ec.save_figure(plt, fig, outdir, "fig_uif_inputs.png")

    fig, ax, cases = case_grid(plt, "NRTSF (H=0)")
    for c, (key, title) in enumerate(cases):
        x, d, out, k0, nrtsf = run0[key]
        ks = np.arange(k0, K)
        xs = np.array(out["x"])
        sd = np.sqrt(np.diagonal(np.array(out["Px"]), axis1=1, axis2=2))
        for i in range(3):
            a = ax[i, c]
            a.plot(ks, x[i, ks], "k-", lw=1.2, label="true")
            a.plot(ks, xs[:, i], "r-", lw=0.9, label="x_{k|k}")
            a.fill_between(ks, xs[:, i] - 2 * sd[:, i], xs[:, i] + 2 * sd[:, i], color="r",
                           alpha=0.15, lw=0, label="+-2 sqrt(Px)")
            a.set_title("%s: x%d" % (title, i + 1), fontsize=8)
            a.tick_params(labelsize=7)
    label_grid(ax)
    ec.save_figure(plt, fig, outdir, "fig_uif_states.png")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="build/uif-example", help="output directory")
    ap.add_argument("--runs", type=int, default=200, help="Monte-Carlo runs (default 200)")
    ap.add_argument("--seed", type=int, default=4, help="base seed (run r uses seed + r)")
    ap.add_argument("--quick", action="store_true", help="10 runs (smoke test)")
    ec.package_options(ap)
    args = ap.parse_args(argv)
    runs = 10 if args.quick else args.runs
    if runs < 1:
        print("uif_example: --runs must be >= 1", file=sys.stderr)
        return 2
    dkf = ec.package("uif_example")
    if dkf is None:
        return 2
    mod = dkf.float32 if args.float32 else dkf
    work = os.path.join(args.out, "work")
    os.makedirs(work, exist_ok=True)

    accs = {c[0]: Acc(K - (1 if c[5] else 0)) for c in CASES}
    run0 = {}
    t0 = time.time()
    for r in range(runs):
        rng = np.random.default_rng(args.seed + r)
        d_sin, d_zero = inputs(True), inputs(False)
        # one noise realisation per run, shared by the cases with the same y equation
        state = rng.bit_generator.state
        sims = {}
        for key, title, filt, sin, fth, nrtsf in CASES:
            d = d_sin if sin else d_zero
            fkey = (sin, json.dumps(fth))
            if fkey not in sims:
                rng.bit_generator.state = state
                sims[fkey] = simulate(rng, d, fth if fth is not None else np.zeros((5, 3)))
            x, y = sims[fkey]
            scn = scenario(key, x, y, d, fth, nrtsf)
            if r == 0:  # run 0's files, for dkf-run or a look
                with open(os.path.join(work, key + ".json"), "w") as f:
                    json.dump(scn, f)
            acc = accs[key]
            try:
                out = run_filter(mod, filt, scn)
            except dkf.Error as e:
                if key == "rtsf_paper" and isinstance(e, dkf.RankError):
                    acc.refused = str(e)
                    acc.runs += 1
                    continue
                print("uif_example: %s failed: %s" % (filt, e), file=sys.stderr)
                return 2
            if key == "rtsf_paper":
                print("uif_example: RTSF on the paper's H: expected a refusal (dkf.RankError), "
                      "it ran", file=sys.stderr)
                return 1
            accumulate(acc, out, x, d, 1 if nrtsf else 0, nrtsf)
            if r == 0:
                run0[key] = (x, d, out, 1 if nrtsf else 0, nrtsf)
        if r == 0 or (r + 1) % max(1, runs // 10) == 0 or r + 1 == runs:
            el = time.time() - t0
            print("uif_example: run %d/%d (%.1f s, ~%.0f s left)" %
                  (r + 1, runs, el, el / (r + 1) * (runs - r - 1)), file=sys.stderr)

    # ---- tables -------------------------------------------------------------------------
    lines = ["# Seed-004 example through dkf.run_scenario (%d runs, seed %d..%d, %s)" %
             (runs, args.seed, args.seed + runs - 1, "float" if args.float32 else "double"),
             ""]
    lines += ["## Which inputs are estimable (dkf_uif_t.estimable, every step of every run)", "",
              "| case | filter | rank | d1 | d2 | d3 | unestimable d_i returned as exactly 0 |",
              "|---|---|---|---|---|---|---|"]
    results = {"runs": runs, "seed": args.seed, "cases": {}}
    checks = []
    for key, title, filt, sin, fth, nrtsf in CASES:
        acc = accs[key]
        if key == "rtsf_paper":
            lines.append("| %s | rtsf | 2 | refused | refused | refused | dkf.RankError: `%s` |"
                         % (title, acc.refused))
            continue
        est = [EST[e] for e in acc.est]
        zeros = ", ".join("d%d" % (i + 1) for i in range(3) if acc.d_zero[i]) or "-"
        rank = 3 - est.count("none")
        lines.append("| %s | %s | %d | %s | %s | %s | %s |" %
                     ((title, filt, rank) + tuple(est) + (zeros,)))
    lines += ["", "Paper: NRTSF-DF \"can estimate d2, d3 but has no effect on d1\"; NRTSF \"has no "
              "effect on d3\". RTSF needs rank H = m.", ""]
    lines += ["## RMSE over runs and k = %d..%d, and the filter's own sqrt(P)" % (FIRST, K - 1),
              "", "| case | | x1 | x2 | x3 | x4 | x5 | d1 | d2 | d3 | NEES_x/n | bias-flag steps |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for key, title, filt, sin, fth, nrtsf in CASES:
        if key == "rtsf_paper":
            continue
        acc = accs[key]
        k0 = 1 if nrtsf else 0
        rx, rd, sx, sdd = rmse(acc, k0)
        nees = acc.nees / max(1, acc.nees_n)
        bias = "%d of %d per run" % (int(np.median(acc.bias_steps)), K - k0)
        lines.append("| %s | RMSE | %s | %s | %.3f | %s |" %
                     (title, " | ".join("%.3f" % v for v in rx),
                      " | ".join("%.3f" % v for v in rd), nees, bias))
        lines.append("| | sqrt(P) | %s | %s | | |" %
                     (" | ".join("%.3f" % v for v in sx), " | ".join("%.3f" % v for v in sdd)))
        if key in NOTE:
            lines.append("| | derivation §7 | %s | %s | | |" %
                         (" | ".join("%.3f" % v for v in NOTE[key]["x"]),
                          " | ".join("%.3f" % v for v in NOTE[key]["d"])))
        results["cases"][key] = {
            "title": title, "filter": filt, "estimable": acc.est,
            "rmse_x": rx.tolist(), "rmse_d": rd.tolist(), "sqrtP_x": sx.tolist(),
            "sqrtPd": sdd.tolist(), "nees_x_over_n": nees,
            "bias_steps_per_run": sorted(set(acc.bias_steps)), "d_exact_zero": acc.d_zero}
    lines += ["", "d of NRTSF is d_{k-1|k} against d_{k-1}. sqrt(Pd) of an unestimable component "
              "is 0: Pd is the covariance of the estimable part (d_hat - T+T d).", ""]
    with open(os.path.join(args.out, "tables.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    print("\n".join(lines))
    if not args.no_plots:
        plots(args.out, run0, inputs(True))

    # ---- checks that do not depend on luck ------------------------------------------------
    a = accs
    checks.append(("NRTSF-DF: estimable = none, full, full at every step",
                   a["nrtsf_df_sin"].est == [0, 2, 2] and a["nrtsf_df_sin"].est_constant))
    checks.append(("NRTSF: estimable = full, full, none at every step",
                   a["nrtsf"].est == [2, 2, 0] and a["nrtsf"].est_constant))
    checks.append(("RTSF (full-rank H): all full", a["rtsf_full"].est == [2, 2, 2]))
    checks.append(("NRTSF-DF d1 and NRTSF d3 exactly 0 (minimum norm)",
                   a["nrtsf_df_sin"].d_zero == [True, False, False]
                   and a["nrtsf"].d_zero == [False, False, True]))
    checks.append(("bias flag: NRTSF-DF every step after the first; NRTSF, RTSF never",
                   set(a["nrtsf_df_sin"].bias_steps) == {K - 1}
                   and set(a["nrtsf"].bias_steps) == {0} and set(a["rtsf_full"].bias_steps) == {0}))
    checks.append(("RTSF refuses the paper's H (dkf.RankError, rank condition)",
                   a["rtsf_paper"].refused is not None and "rank" in a["rtsf_paper"].refused))
    checks.append(("every estimate finite", all(a[c[0]].finite for c in CASES
                                                if c[0] != "rtsf_paper")))
    if not args.no_plots:
        checks += ec.wrote_checks(args.out, ("fig_uif_inputs.png", "fig_uif_states.png"))
    ec.print_checks(checks, 70)
    print("uif_example: %.1f s" % (time.time() - t0), file=sys.stderr)
    return ec.verdict(checks)


if __name__ == "__main__":
    sys.exit(main())
