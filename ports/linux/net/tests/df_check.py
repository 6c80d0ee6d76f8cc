#!/usr/bin/env python3
"""df_check.py - checks the result files of seed 001's consensus network run
as one dkf-tw-node process per node (tw_net.sh df* modes).

  df_check.py --nodes-dir D --nodes N --runner R.json --label LABEL [--rel 0]
  df_check.py --nodes-dir D --nodes N --expect-absent I --neighbours J,K

First form: every node finished every step, none degraded, one model id,
and node i's x, Px, d of every step equal dkf-run's in-process run of the
same case (outputs.LABEL.{x,Px,d}[step][node]) within --rel (0: bit for bit,
the documented exactness of df_agent.h). Prints the largest difference.
Second form: node I never started; nodes J, K (its neighbours) are degraded
at every step with I missing, every other node at none; all finished."""
import argparse
import glob
import json
import os
import sys


def flat(v):
    if isinstance(v, list):
        for e in v:
            yield from flat(e)
    else:
        yield float(v)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--nodes-dir", required=True)
    ap.add_argument("--nodes", type=int, required=True)
    ap.add_argument("--runner")
    ap.add_argument("--label")
    ap.add_argument("--rel", type=float, default=0.0)
    ap.add_argument("--expect-absent", type=int)
    ap.add_argument("--neighbours", default="")
    a = ap.parse_args()
    res = {}
    for f in glob.glob(os.path.join(a.nodes_dir, "node*.json")):
        d = json.load(open(f))
        res[d["node"]] = d
    bad = []
    want = [i for i in range(a.nodes) if i != a.expect_absent]
    if sorted(res) != want:
        sys.exit(f"FAIL: result files of nodes {sorted(res)}, expected {want}")
    steps = {d["steps"] for d in res.values()}
    ids = {d["model_id"] for d in res.values()}
    if len(ids) != 1:
        bad.append(f"model ids differ: {sorted(ids)}")
    for i, d in sorted(res.items()):
        if d.get("exit") != "done" or len(d["k"]) != d["steps"]:
            bad.append(f"node {i}: exit {d.get('exit')}, {len(d['k'])}/{d['steps']} steps")
    if a.expect_absent is None:
        doc = json.load(open(a.runner))
        out = doc["outputs"][a.label]
        worst = 0.0
        for i, d in sorted(res.items()):
            if any(d["degraded"]):
                bad.append(f"node {i}: degraded steps {[k for k, g in zip(d['k'], d['degraded']) if g]}")
            for key in ("x", "Px", "d"):
                for j, got in enumerate(d[key]):
                    ref = out[key][j][i]
                    for g, r in zip(flat(got), flat(ref)):
                        err = abs(g - r)
                        worst = max(worst, err)
                        if err > a.rel * max(1.0, abs(r)):
                            bad.append(f"node {i} step {j + 1} {key}: {g!r} vs in-process {r!r}")
                            break
        print(f"{len(res)} node processes x {steps.pop()} steps: largest |process - in-process| "
              f"= {worst:.3g} (allowed {a.rel:g} relative)")
    else:
        nb = {int(v) for v in a.neighbours.split(",") if v}
        for i, d in sorted(res.items()):
            deg = sum(d["degraded"])
            if i in nb:
                if deg != len(d["k"]) or not all(a.expect_absent in m for m in d["missing"]):
                    bad.append(f"node {i}: {deg}/{len(d['k'])} degraded, expected all with "
                               f"{a.expect_absent} missing")
            elif deg:
                bad.append(f"node {i}: {deg} degraded steps, expected none")
        print(f"node {a.expect_absent} absent: neighbours {sorted(nb)} degraded at every step, "
              f"the others at none")
    if bad:
        print("\n".join("FAIL: " + b for b in bad[:20]))
        sys.exit(1)


if __name__ == "__main__":
    main()
