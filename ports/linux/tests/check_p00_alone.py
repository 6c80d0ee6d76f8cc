#!/usr/bin/env python3
"""A several-sensor scenario with `init.P00` alone (what tools/make_net_scenario.py
writes) runs every multi-sensor filter exactly as the same file with
P00_local = [P00] * L and P00_central = P00 written out.

    check_p00_alone.py DKF_RUN MAKE_NET_SCENARIO OUTDIR

docs/reference/scenario-format.md: P00 alone serves every filter, local and central.
Both files describe the same computation, so the outputs must be identical
(compared exactly: the same operations on the same doubles).
"""
import copy
import json
import os
import subprocess
import sys


def main():
    dkf_run, make_net, out = sys.argv[1:4]
    os.makedirs(out, exist_ok=True)
    alone = os.path.join(out, "net.json")
    subprocess.run([sys.executable, make_net, "--nodes", "3", "--steps", "20", "--out", alone],
                   check=True, stdout=subprocess.DEVNULL)
    doc = json.load(open(alone))
    init = {k: v for k, v in doc["init"].items() if not isinstance(v, str)}
    if sorted(init) != ["P00", "x00"]:
        print("FAIL: make_net_scenario.py no longer writes init.P00 alone: %s" % sorted(init))
        return 1
    explicit = copy.deepcopy(doc)
    L = len(doc["model"]["sensors"])
    explicit["init"] = {"x00": doc["init"]["x00"], "P00_local": [doc["init"]["P00"]] * L,
                        "P00_central": doc["init"]["P00"]}
    explicit_path = os.path.join(out, "net_explicit.json")
    with open(explicit_path, "w") as f:
        json.dump(explicit, f)
    bad = 0
    for flt in ("kf", "info", "dkf"):
        res = []
        for path in (alone, explicit_path):
            o = os.path.join(out, "%s_%s" % (flt, os.path.basename(path)))
            subprocess.run([dkf_run, "--filter", flt, "-o", o, path], check=True,
                           stdout=subprocess.DEVNULL)
            res.append(json.load(open(o))["outputs"])
        same = res[0] == res[1]
        bad += not same
        print("%-4s P00 alone == P00_local/P00_central written out: %s"
              % (flt, "ok" if same else "FAIL"))
    print("FAIL" if bad else "PASS")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
