#!/usr/bin/env python3
"""Checks an lcm-logger log of a fault run against dkf-fusion's result file.

    check_log.py RUN.lcmlog FUSED.json --types DIR [--prefix DKF]

* tools/dkf_monitor.py's Run (what dkf_monitor.py and dkf_logplot.py report),
  fed every event of the log, must end with the result file's final state:
  the same degraded steps (a complete revision clears a degraded first
  publication) and, per step, the same x_{k|k} bit for bit.
* Every fused message's meas_utime_first / meas_utime_last is, as
  docs/guide/network.md says, the publication time of a measurement y^i_{k+1} of a
  node i that contributed to step k (the one that completed node i's step k),
  or 0; first <= last.
Exit 1 on the first failure, with the numbers.
"""
import argparse
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..",
                                "..", "tools"))
from dkf_monitor import Run, import_types  # noqa: E402


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("log")
    ap.add_argument("fused")
    ap.add_argument("--types", required=True)
    ap.add_argument("--prefix", default="DKF")
    a = ap.parse_args()
    t = import_types(a.types)
    import lcm
    d = json.load(open(a.fused))
    run = Run(t, a.prefix)
    meas = {}      # (node, j) -> utime of y^node_j
    fused = []     # every fused message, in log order
    for ev in lcm.EventLog(a.log, "r"):
        run.handle(ev.channel, ev.data)
        if ev.channel.startswith(a.prefix + "_MEAS_"):
            m = t.measurement_t.decode(ev.data)
            meas[(m.node, m.k)] = m.utime
        elif ev.channel == a.prefix + "_FUSED":
            fused.append(t.fused_t.decode(ev.data))
    want = {k for k, st in zip(d["k"], d["status"]) if st == "degraded"}
    print(f"log: {len(fused)} fused messages ({sum(1 for m in fused if m.revision)} revisions); "
          f"monitor: {len(run.fused)} steps, {len(run.degraded)} degraded; result file: "
          f"{len(d['k'])} steps, {len(want)} degraded")
    if run.degraded != want:
        fail(f"monitor's degraded steps {sorted(run.degraded)} != the result's {sorted(want)}")
    for k, xf in zip(d["k"], d["outputs"]["fused"]["xf"]):
        if run.fused.get(k) != xf:
            fail(f"step {k}: the monitor's last x_k|k {run.fused.get(k)} != the result's {xf}")
    print("monitor == result file: degraded steps and every x_k|k")
    checked = 0
    for m in fused:
        who = [i for i, c in enumerate(list(m.contributed)) if c]
        allowed = {meas[(i, m.k + 1)] for i in who if (i, m.k + 1) in meas}
        for name in ("meas_utime_first", "meas_utime_last"):
            v = getattr(m, name)
            if v != 0 and v not in allowed:
                near = {j: meas[(i, j)] for i in who for j in (m.k, m.k + 1, m.k + 2)
                        if meas.get((i, j)) == v}
                fail(f"step {m.k} revision {m.revision}: {name} = {v} is not the publication "
                     f"of a contributor's y_(k+1) (it is that of {near or 'no measurement'})")
        if m.meas_utime_first > m.meas_utime_last:
            fail(f"step {m.k}: meas_utime_first > meas_utime_last")
        checked += 1
    print(f"meas_utime_first/last of all {checked} fused messages: a contributor's y_(k+1)")
    print("PASS")


if __name__ == "__main__":
    main()
