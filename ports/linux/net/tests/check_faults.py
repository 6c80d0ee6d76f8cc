#!/usr/bin/env python3
"""Checks a dkf-fusion result file of a fault run (docs/design/network.md, "Faults").

    check_faults.py FUSED.json SCENARIO.json --rel 1e-9 [expectations...]

The reference for every step is the centralized Difference KF given exactly
the rows the fusion centre says it used: node i's z^i_k enters step k iff i
is in the result's `contributors[k-1]`. It is computed here in numpy, from
the scenario's y, independently of the C library: the DKF in the paper's
printed form (16)-(20) (as tools/make_diffkf_vectors.py) with a time-varying
row selection S_k of the stacked z_k:

    M' = S M,  Ru' = S Ru S^T,  S'_cov = S_cov S^T,  C'_k = S_k C_k S_{k-1}^T,

and a step that keeps no row is the prediction alone (x_{k|k} = x_{k|k-1};
the next step has no previous innovation). With every row kept this is the
full-data centralized DKF; --selftest checks that against the vector's
`central` series and the one-sensor case against its `local[0]`.

Checks (exit 1 on the first failure, with the numbers):
  * every step published, fused == masked reference <= rel (per array, per
    step, relative to max(1, max|ref|));
  * steps before the first lost row equal the full-data filter (they are the
    same filter);
  * the expectations given (--all-complete, --degraded K,..., --absent NODE:FROM:TO,
    --rejected REASON=COUNT, --min-revised R, --no-rejects, --always NODE,...,
    --rejoined NODE,...).
Prints the distance to the full-data filter after the last lost row (how
fast the loss of information is forgotten).
"""
import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), *[os.pardir] * 4,
                                "tools"))
from make_diffkf_vectors import blkdiag  # noqa: E402  (the vectors' reference code)


def mat(spec, k):
    if "const" in spec:
        return np.array(spec["const"], dtype=float)
    return np.array(spec["per_k"][k], dtype=float)


def load_model(scn):
    m = scn["model"]
    sensors = m["sensors"]
    N = scn["N"]
    ys = []
    for i, s in enumerate(sensors):
        y = {k: np.array(v, dtype=float) for k, v in zip(scn["y"][i]["k"], scn["y"][i]["values"])}
        ys.append(y)
    return m, sensors, ys, N


def prior(scn, which, i=0):
    """P_{0|0} as the C loader reads it (docs/reference/scenario-format.md): P00_central
    (which="central") or P00_local[i] (which="local") when given, else P00."""
    init = scn["init"]
    if which == "central" and "P00_central" in init:
        return np.array(init["P00_central"], dtype=float)
    if which == "local" and "P00_local" in init:
        return np.array(init["P00_local"][i], dtype=float)
    return np.array(init["P00"], dtype=float)


def masked_dkf(scn, keep, P00=None, sensors_used=None):
    """keep[k-1] = set of node indices whose rows enter step k."""
    m, sensors, ys, N = load_model(scn)
    l = len(sensors)
    idx = list(range(l)) if sensors_used is None else sensors_used
    F = lambda k: mat(m["F"], k)
    Q = lambda k: mat(m["Q"], k)
    H = lambda k: np.vstack([mat(sensors[i]["H"], k) for i in idx])
    feed = [sensors[i]["D"] for i in idx]
    A = lambda k: blkdiag([mat(D, k) for D in feed])
    B = lambda k: blkdiag([mat(sensors[i]["B"], k) for i in idx])
    Rd = lambda k: blkdiag([mat(sensors[i]["Rd"], k) for i in idx])
    R = lambda k: blkdiag([mat(sensors[i]["R"], k) for i in idx])
    p = [mat(D, 1).shape[1] for D in feed]
    off = np.cumsum([0] + p)
    y = lambda k: np.concatenate([ys[i][k] for i in idx])
    inv, pinv = np.linalg.inv, np.linalg.pinv
    x00 = np.array(scn["init"]["x00"], dtype=float)
    if P00 is None:
        P00 = prior(scn, "central")
    out = {key: [] for key in ("xp", "Pp", "xf", "Pf")}
    xp = F(0) @ x00
    Pp = F(0) @ P00 @ F(0).T + Q(0)
    prev = None  # (J, L, dz, S', F, rows) of step k-1 with at least one row
    for k in range(1, N + 1):
        rows = [r for j, i in enumerate(idx) if i in keep[k - 1]
                for r in range(off[j], off[j + 1])]
        Binv = inv(B(k))
        G = Binv @ pinv(A(k + 1))
        Apk = pinv(A(k))
        M = G @ H(k + 1) @ F(k) - Apk @ H(k)
        S = Q(k) @ H(k + 1).T @ G.T
        Ru = (G @ H(k + 1) @ Q(k) @ H(k + 1).T @ G.T + Binv @ Rd(k) @ Binv.T
              + G @ R(k + 1) @ G.T + Apk @ R(k) @ Apk.T)
        z = G @ y(k + 1) - Apk @ y(k)
        out["xp"].append(xp)
        out["Pp"].append(Pp)
        if not rows:
            xf, Pf = xp, Pp
            xp = F(k) @ xf
            Pp = F(k) @ Pf @ F(k).T + Q(k)
            Pp = 0.5 * (Pp + Pp.T)
            prev = None
            out["xf"].append(xf)
            out["Pf"].append(Pf)
            continue
        Ms, Rus, Ss, zs = M[rows], Ru[np.ix_(rows, rows)], S[:, rows], z[rows]
        if prev is None:
            dz = zs - Ms @ xp
            J = Pp @ Ms.T
            L = Ms @ Pp @ Ms.T + Rus
        else:
            Jp, Lp, dzp, Sp, Fp, prow = prev
            Gp = inv(B(k - 1)) @ pinv(A(k))
            C = (-Apk @ R(k) @ Gp.T)[np.ix_(rows, prow)]
            Lpi = inv(Lp)
            dz = zs - Ms @ xp - C @ Lpi @ dzp
            J = Pp @ Ms.T - (Fp @ Jp @ Lpi + Sp @ Lpi) @ C.T
            L = Ms @ J - C @ Lpi @ (Jp.T @ Fp.T + Sp.T) @ Ms.T + Rus - C @ Lpi @ C.T
            L = 0.5 * (L + L.T)
        Li = inv(L)
        xf = xp + J @ Li @ dz
        Pf = Pp - J @ Li @ J.T
        out["xf"].append(xf)
        out["Pf"].append(Pf)
        Fk = F(k)
        xp = Fk @ xf + Ss @ Li @ dz
        Pp = Fk @ Pf @ Fk.T + Q(k) - Fk @ J @ Li @ Ss.T - Ss @ Li @ J.T @ Fk.T - Ss @ Li @ Ss.T
        Pp = 0.5 * (Pp + Pp.T)
        prev = (J, L, dz, Ss, Fk, rows)
    return out


def step_rel(a, b):
    """max over xf, xp, Pf, Pp of max|a-b| / max(1, max|b|) at one step."""
    w = 0.0
    for key in ("xf", "xp", "Pf", "Pp"):
        x, y = np.array(a[key]), np.array(b[key])
        w = max(w, float(np.max(np.abs(x - y))) / max(1.0, float(np.max(np.abs(y)))))
    return w


def at(series, j):
    return {key: series[key][j] for key in ("xf", "xp", "Pf", "Pp")}


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def selftest(scn, rel):
    N = scn["N"]
    l = len(scn["model"]["sensors"])
    full = masked_dkf(scn, [set(range(l))] * N)
    cen = scn["outputs"]["central"]
    w = max(step_rel(at(full, j), at(cen, j)) for j in range(N))
    print(f"selftest: numpy full-data DKF vs the vector's central: {w:.2e}")
    if w > rel:
        fail("the reference does not reproduce the vector's central series")
    if "local" in scn["outputs"] and np.allclose(prior(scn, "local", 0), prior(scn, "central")):
        one = masked_dkf(scn, [{0}] * N)
        w = max(step_rel(at(one, j), at(scn["outputs"]["local"][0], j)) for j in range(N))
        print(f"selftest: numpy DKF with node 0's rows only vs the vector's local[0]: {w:.2e}")
        if w > rel:
            fail("the masked reference does not reproduce local[0]")


def read_journal(path):
    """A dkf-fusion journal as a result document: the last line of each step
    (a later run of the centre, after its header line, supersedes)."""
    last = {}
    for line in open(path):
        o = json.loads(line)
        if "k" in o:
            last[o["k"]] = o
    ks = sorted(last)
    d = {"k": ks, "contributors": [last[k]["contributors"] for k in ks],
         "revisions": [last[k]["revision"] for k in ks],
         "status": [last[k]["status"] for k in ks], "counters": {},
         "outputs": {"fused": {key: [last[k][key] for k in ks] for key in ("xf", "xp", "Pf", "Pp")}}}
    return d


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("fused")
    ap.add_argument("scenario")
    ap.add_argument("--rel", type=float, required=True)
    ap.add_argument("--selftest", action="store_true")
    ap.add_argument("--all-complete", action="store_true")
    ap.add_argument("--degraded", default=None, help="K,K,...: exactly these steps degraded")
    ap.add_argument("--absent", action="append", default=[],
                    help="NODE:FROM:TO: node absent from steps FROM..TO (inclusive), present elsewhere")
    ap.add_argument("--never", type=int, default=None, help="NODE: absent from every step")
    ap.add_argument("--rejected", action="append", default=[], help="REASON=COUNT")
    ap.add_argument("--no-rejects", action="store_true")
    ap.add_argument("--min-revised", type=int, default=0)
    ap.add_argument("--compare", default=None, help="another result file: outputs must be identical")
    ap.add_argument("--journal", action="store_true",
                    help="FUSED is a dkf-fusion journal (JSON lines): check the steps 1..K it holds")
    ap.add_argument("--others-complete", type=int, action="append", default=[],
                    help="NODE: every other node contributes at every step")
    ap.add_argument("--always", default=None,
                    help="NODE,NODE,...: each of these nodes contributes at every step")
    ap.add_argument("--rejoined", default=None,
                    help="NODE,NODE,...: each of these nodes is missing from a step and "
                         "contributes again at the last one")
    ap.add_argument("--complete-from", type=int, default=None, help="K: every step >= K complete")
    ap.add_argument("--complete-once-heard", action="store_true",
                    help="every step after the one at which the last node was first heard is complete")
    a = ap.parse_args()
    scn = json.load(open(a.scenario))
    d = read_journal(a.fused) if a.journal else json.load(open(a.fused))
    N, l = scn["N"], len(scn["model"]["sensors"])
    if a.selftest:
        selftest(scn, a.rel)
    Np = len(d["k"])  # steps checked: all N, or the journal's 1..Np
    if d["k"] != list(range(1, Np + 1)) or (Np != N and not a.journal) or Np == 0:
        fail(f"steps {d['k'][:3]}..{d['k'][-3:]} published, expected 1..{N}")
    keep = [set(c) for c in d["contributors"]] + [set(range(l))] * (N - Np)
    ref = masked_dkf(scn, keep)
    full = masked_dkf(scn, [set(range(l))] * N)
    fu = d["outputs"]["fused"]
    dm = [step_rel(at(fu, j), at(ref, j)) for j in range(Np)]
    df = [step_rel(at(fu, j), at(full, j)) for j in range(Np)]
    if "central" in scn.get("outputs", {}):
        wv = max(step_rel(at(full, j), at(scn["outputs"]["central"], j)) for j in range(N))
        if wv > a.rel:
            fail(f"reference vs the vector's central {wv:.2e}")
    lost = [j + 1 for j in range(Np) if len(keep[j]) < l]
    pattern = "".join("D" if len(keep[j]) < l else ("r" if d["revisions"][j] else ".")
                      for j in range(Np))
    print(f"steps (. complete, r complete after a revision, D degraded): {pattern}")
    print(f"fused vs masked centralized DKF: max {max(dm):.2e} over {Np} steps "
          f"(degraded steps: {len(lost)}, revised: {sum(1 for r in d['revisions'] if r)})")
    if max(dm) > a.rel:
        j = int(np.argmax(dm))
        fail(f"step {j + 1}: fused vs masked reference {dm[j]:.2e} > {a.rel:g}")
    before = (lost[0] - 1) if lost else Np
    if before:
        w = max(df[:before])
        print(f"fused vs full-data centralized DKF on steps 1..{before} (before any row was lost): {w:.2e}")
        if w > a.rel:
            fail(f"steps before the first loss differ from the full-data filter: {w:.2e}")
    if lost and lost[-1] < Np:
        last = lost[-1]
        tail = [(k, df[k - 1]) for k in range(last, Np + 1)]
        marks = [t for t in tail if t[0] in (last, last + 1, last + 2, last + 5, last + 10, last + 20, Np)]
        print("distance to the full-data filter after the last lost row (k: rel): "
              + ", ".join(f"{k}: {v:.2e}" for k, v in marks))
    c = d["counters"]
    if c:
        print("counters: " + json.dumps({key: c[key] for key in ("received", "sent_by_node", "not_received",
                                                                "rejected", "stale", "degraded_steps",
                                                                "revised_steps")})
              + " faults: " + json.dumps(c["faults"]))
    for node in a.others_complete:
        bad = [j + 1 for j in range(Np) if set(range(l)) - keep[j] - {node}]
        if bad:
            fail(f"steps {bad[:10]}{'...' if len(bad) > 10 else ''}: a node other than {node} is missing")
        print(f"every node but {node} contributes at every step")
    for node in (int(v) for v in a.always.split(",")) if a.always else ():
        bad = [j + 1 for j in range(Np) if node not in keep[j]]
        if bad:
            fail(f"node {node} missing from steps {bad[:10]}{'...' if len(bad) > 10 else ''}")
    if a.always:
        print(f"nodes {a.always} contribute at every step")
    for node in (int(v) for v in a.rejoined.split(",")) if a.rejoined else ():
        gone = [j + 1 for j in range(Np) if node not in keep[j]]
        if not gone or node not in keep[Np - 1]:
            fail(f"node {node}: missing from steps {gone[:10]}, at the last step "
                 f"{'present' if node in keep[Np - 1] else 'missing'}: not a rejoin")
        print(f"node {node} missing from {len(gone)} steps ({gone[0]}..{gone[-1]}), "
              f"contributing again at step {Np}")
    if a.complete_from is not None:
        bad = [k for k in lost if k >= a.complete_from]
        if bad:
            fail(f"degraded steps {bad[:10]} at or after {a.complete_from}")
        print(f"every step from {a.complete_from} on complete")
    if a.complete_once_heard:
        # A centre that joins mid-run may miss the in-flight messages of the
        # steps around its join (how many depends on how far the nodes lag
        # each other, i.e. on the machine's load); once it has heard every
        # node, nothing may be lost.
        first = [next((j + 1 for j in range(Np) if node in keep[j]), None) for node in range(l)]
        if None in first or max(first) >= Np:
            fail(f"not every node was heard before the last step (first steps heard: {first})")
        heard = max(first)
        bad = [k for k in lost if k > heard]
        if bad:
            fail(f"degraded steps {bad[:10]} after step {heard}, when every node had been heard")
        print(f"every node heard by step {heard}; every step after it complete")
    if a.all_complete and lost:
        fail(f"degraded steps {lost}")
    if a.degraded is not None:
        want = [int(x) for x in a.degraded.split(",") if x]
        if lost != want:
            fail(f"degraded steps {lost}, expected {want}")
    for spec in a.absent:
        node, k0, k1 = (int(x) for x in spec.split(":"))
        for j in range(Np):
            inside = k0 <= j + 1 <= k1
            if (node in keep[j]) == inside:
                fail(f"node {node} {'contributes' if inside else 'is absent'} at step {j + 1} "
                     f"(expected absent exactly on {k0}..{k1})")
        print(f"node {node} absent exactly on steps {k0}..{k1}")
    if a.never is not None:
        if any(a.never in s for s in keep):
            fail(f"node {a.never} contributed")
        if not all(len(s) == l - 1 for s in keep):
            fail("another node is missing somewhere")
        print(f"node {a.never} absent from every step, every other node present")
    if a.no_rejects and c["rejected"]:
        fail(f"rejected {c['rejected']}")
    for spec in a.rejected:
        reason, count = spec.rsplit("=", 1)
        got = c["rejected_by_reason"].get(reason)
        if got != int(count):
            fail(f"rejected as '{reason}': {got}, expected {count}")
    if a.rejected:
        print("rejected by reason: " + json.dumps(c["rejected_by_reason"]))
    if sum(1 for r in d["revisions"] if r) < a.min_revised:
        fail(f"fewer than {a.min_revised} revised steps")
    if a.compare:
        o = json.load(open(a.compare))["outputs"]["fused"]
        for key in ("xf", "xp", "Pf", "Pp"):
            if o[key] != fu[key]:
                fail(f"outputs.fused.{key} differs from {a.compare}")
        print(f"outputs identical to {a.compare} (bit for bit)")
    print("PASS")


if __name__ == "__main__":
    main()
