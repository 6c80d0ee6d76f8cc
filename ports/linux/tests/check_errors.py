#!/usr/bin/env python3
"""check_errors.py DKF_RUN VECTOR.json OUTDIR FILTER [dkf-run options...]

End-to-end check of dkf-run's Monte-Carlo error mode (--errors) and of the
`runs` layout: builds a 3-run scenario from a vector file (run r has the
vector's y + 0.25 r and truth x + 0.1 r, so the runs differ), runs
`--errors` once over all runs and `--run r --output` for each run, and
checks that errors.<est>.xf[r][k-1] == ||xf_k - x_k||^2 and .xp likewise
(xp = x_{k|k-1}) for every estimator, and that mean_xf / mean_xp are the
means over runs. Tolerance 1e-12 relative: both sides come from the same
binary and the same double-precision estimates (the error mode computes
the squared error in double from the filter's reals, this script from
the 17-digit JSON of the same reals), so only the summation order differs.
Exit 0 pass, 1 mismatch, 2 usage/tool failure.
"""
import copy
import json
import math
import os
import subprocess
import sys


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        print("FAIL: %s exited %d\n%s" % (" ".join(cmd), p.returncode, p.stderr))
        sys.exit(2)


def shifted(series, dy):
    return {"k": series["k"], "values": [[v + dy for v in y] for y in series["values"]]}


def make_runs(vec, nruns=3):
    doc = {key: copy.deepcopy(vec[key]) for key in ("N", "model", "init") if key in vec}
    runs = []
    for r in range(nruns):
        y = vec["y"]
        y = [shifted(s, 0.25 * r) for s in y] if isinstance(y, list) else shifted(y, 0.25 * r)
        t = vec["truth"]
        truth = {"k": t["k"], "x": [[v + 0.1 * r for v in x] for x in t["x"]]}
        runs.append({"y": y, "truth": truth})
    doc["runs"] = runs
    return doc


def estimators(outputs):
    """{name: series} for outputs.<LABEL> or local[i], central, fused."""
    out = {}
    for key, val in outputs.items():
        if key == "local":
            for i, s in enumerate(val):
                out["local[%d]" % i] = s
        elif isinstance(val, dict) and "xf" in val:
            out[key] = val
    return out


def main():
    if len(sys.argv) < 5:
        print(__doc__)
        return 2
    dkf_run, vector, outdir, filt = sys.argv[1:5]
    extra = sys.argv[5:]
    os.makedirs(outdir, exist_ok=True)
    with open(vector) as f:
        vec = json.load(f)
    scn = make_runs(vec)
    stem = os.path.join(outdir, "check_errors_%s_%s" % (filt, os.path.basename(vector)[:-5]))
    with open(stem + ".runs.json", "w") as f:
        json.dump(scn, f)
    run([dkf_run, "--filter", filt, "-q", "--errors", stem + ".err.json"] + extra +
        [stem + ".runs.json"])
    with open(stem + ".err.json") as f:
        err = json.load(f)
    errs = estimators(err["errors"])
    worst, compared, bad = 0.0, 0, 0
    for r, rd in enumerate(scn["runs"]):
        run([dkf_run, "--filter", filt, "-q", "--run", str(r), "--output",
             stem + ".run%d.json" % r] + extra + [stem + ".runs.json"])
        with open(stem + ".run%d.json" % r) as f:
            outs = estimators(json.load(f)["outputs"])
        truth = dict(zip(rd["truth"]["k"], rd["truth"]["x"]))
        if set(outs) != set(errs):
            print("FAIL: estimators differ: %s vs %s" % (sorted(outs), sorted(errs)))
            return 1
        for name, s in outs.items():
            for which in ("xf", "xp"):
                for j, x in enumerate(s[which]):
                    want = sum((a - b) ** 2 for a, b in zip(x, truth[j + 1]))
                    got = errs[name][which][r][j]
                    rel = abs(got - want) / max(1.0, abs(want))
                    worst = max(worst, rel)
                    compared += 1
                    if not rel <= 1e-12:
                        bad += 1
                        if bad <= 5:
                            print("FAIL: %s %s run %d k=%d: %r vs %r" % (name, which, r, j + 1,
                                                                        got, want))
    for name, e in errs.items():
        for which in ("xf", "xp"):
            rows = e[which]
            for j, m in enumerate(e["mean_" + which]):
                want = sum(row[j] for row in rows) / len(rows)
                if not abs(m - want) <= 1e-12 * max(1.0, abs(want)):
                    bad += 1
                    print("FAIL: %s mean_%s k=%d: %r vs %r" % (name, which, j + 1, m, want))
    if err.get("runs") != len(scn["runs"]) or compared == 0:
        print("FAIL: runs = %r, compared %d" % (err.get("runs"), compared))
        return 1
    print("%s: %d squared errors compared over %d runs, estimators %s, worst rel %.2e" %
          ("FAIL" if bad else "PASS", compared, len(scn["runs"]), sorted(errs), worst))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
