#!/usr/bin/env python3
"""Checks the result files of dkf-tw-node processes (one per node) of one run.

    tw_check.py --scenario S.json --alg 2 --nodes-dir DIR [--runner RUN.json]
                [--vector-rel R] [--runner-rel R] [--expect-absent 5] [--json]

DIR holds node<l>.json for every node l (missing files: nodes in
--expect-absent). Checks: every started node exited "done" with every step;
--runner (dkf-run --filter tw2|tw3 --output, the in-process whole-graph
simulation): max over steps, nodes and fields x, P, z of |process - runner| /
max(1, max|runner|) <= --runner-rel; if the scenario has steps[].expected.alg2/3
(the vector files): the same rule against them <= --vector-rel. Without
--expect-absent no step may be degraded; with it, exactly the absent nodes'
neighbours are degraded, at every step. Prints one summary line (or a JSON
object with --json): nodes, edges, steps, RMSE of x and z against the
truth, the two gaps, packets and reals sent per node per step.
Exit 0 all checks hold, 1 otherwise.
"""
import argparse
import json
import math
import os
import sys


def flat(v):
    if isinstance(v, list):
        out = []
        for e in v:
            out.extend(flat(e))
        return out
    return [float(v)]


def gap(got, ref):
    """max |got - ref| / max(1, max |ref|) (the vectors' rule)."""
    g, r = flat(got), flat(ref)
    assert len(g) == len(r), (len(g), len(r))
    scale = max([1.0] + [abs(v) for v in r])
    return max(abs(a - b) for a, b in zip(g, r)) / scale


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenario", required=True)
    ap.add_argument("--alg", type=int, required=True)
    ap.add_argument("--nodes-dir", required=True)
    ap.add_argument("--runner")
    ap.add_argument("--vector-rel", type=float, default=1e-9)
    ap.add_argument("--runner-rel", type=float, default=0.0)
    ap.add_argument("--expect-absent", type=int, nargs="*", default=[])
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    scn = json.load(open(a.scenario))
    N = len(scn["model"]["H"])
    edges = scn["graph"]["edges"]
    T = len(scn["steps"])
    nb = {l: set() for l in range(N)}
    for i, j in edges:
        nb[i].add(j)
        nb[j].add(i)
    key = "alg%d" % a.alg
    ok = True
    msgs = []
    res = {}
    for l in range(N):
        path = os.path.join(a.nodes_dir, "node%d.json" % l)
        if l in a.expect_absent:
            continue
        if not os.path.exists(path):
            msgs.append("node %d: no result file" % l)
            ok = False
            continue
        d = json.load(open(path))
        res[l] = d
        if d["exit"] != "done" or len(d["n"]) != T:
            msgs.append("node %d: exit %s after %d of %d steps" % (l, d["exit"], len(d["n"]), T))
            ok = False
    if not ok:
        print("tw_check: FAIL: " + "; ".join(msgs))
        return 1
    # degraded steps
    must = {l for l in res if nb[l] & set(a.expect_absent)}
    for l, d in res.items():
        deg = sum(1 for v in d["degraded"] if v)
        want = T if l in must else 0
        if deg != want:
            msgs.append("node %d: %d degraded steps, expected %d" % (l, deg, want))
            ok = False
        if l in must and any(set(m) != nb[l] & set(a.expect_absent) for m in d["missing"]):
            msgs.append("node %d: missing lists %s" % (l, d["missing"][:3]))
            ok = False
    # comparisons
    gr = gv = None
    if a.runner and not a.expect_absent:
        run = json.load(open(a.runner))["outputs"][key]
        gr = 0.0
        for f in ("x", "P", "z"):
            for k in range(T):
                for l in res:
                    gr = max(gr, gap(res[l][f][k], run[f][k][l]))
        if gr > a.runner_rel:
            msgs.append("max |process - in-process| %.3g > %.3g" % (gr, a.runner_rel))
            ok = False
    if "expected" in scn["steps"][0] and not a.expect_absent:
        gv = 0.0
        for f in ("x", "P", "z"):
            for k in range(T):
                ex = scn["steps"][k]["expected"][key][f]
                got = [res[l][f][k] for l in range(N)]
                gv = max(gv, gap(got, ex))
        if gv > a.vector_rel:
            msgs.append("max |process - vector| %.3g > %.3g" % (gv, a.vector_rel))
            ok = False
    # RMSE against the truth (x_n; z against z_{n-1})
    sx = sz = 0.0
    nx = nz = 0
    for k, st in enumerate(scn["steps"]):
        tr = st.get("truth", {})
        for l in res:
            if "x" in tr:
                sx += sum((g - t) ** 2 for g, t in zip(res[l]["x"][k], tr["x"]))
                nx += len(tr["x"])
            if "z_prev" in tr:
                sz += sum((g - t) ** 2 for g, t in zip(res[l]["z"][k], tr["z_prev"]))
                nz += len(tr["z_prev"])
    sent = sum(d["counters"]["sent"] - d["counters"]["retransmits"] - d["counters"]["answers"]
               for d in res.values())
    reals = sum(d["counters"]["reals_sent"] for d in res.values())
    out = {"alg": a.alg, "nodes": N, "edges": len(edges), "steps": T,
           "eta": next(iter(res.values()))["eta"],
           "rmse_x": math.sqrt(sx / nx) if nx else None, "rmse_z": math.sqrt(sz / nz) if nz else None,
           "gap_runner": gr, "gap_vector": gv,
           # DONE (1 per node) is not a filter packet
           "packets_per_node_step": (sent - len(res)) / (len(res) * T),
           "reals_per_node_step": reals / (len(res) * T),
           "retransmits": sum(d["counters"]["retransmits"] for d in res.values()),
           "answers": sum(d["counters"]["answers"] for d in res.values()),
           "rejected": sum(d["counters"]["rejected"] for d in res.values()),
           "degraded_steps": sum(d["counters"]["degraded_steps"] for d in res.values()),
           "wall_s_max": max(d["wall_s"] for d in res.values()), "ok": ok}
    if a.json:
        print(json.dumps(out))
    else:
        f = lambda v: "-" if v is None else "%.3g" % v
        print("tw_check: alg %d, %d nodes, %d edges, %d steps: rmse x %s z %s, "
              "|proc - in-process| %s, |proc - vector| %s, %.1f packets / %.1f reals per node "
              "per step, %d retransmits, %d degraded node-steps, %d rejected" %
              (a.alg, N, len(edges), T, f(out["rmse_x"]), f(out["rmse_z"]), f(gr), f(gv),
               out["packets_per_node_step"], out["reals_per_node_step"], out["retransmits"],
               out["degraded_steps"], out["rejected"]))
    if not ok:
        print("tw_check: FAIL: " + "; ".join(msgs))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
