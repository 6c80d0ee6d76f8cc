#!/usr/bin/env python3
"""Writes the generated seed-002 inputs of the wfusion tests from the
vector tests/vectors/infofusion/s2_weighted_fusion.json (tests/runs.table
and tests/cases/, "Seed 002"):

  wf_generated.json      the case as a generated scenario would be: per step
                         only t and y, no x_true, no steady_state (the same
                         numbers must come out)
  bad_wf_H_shape.json    H[2] of 3 columns (n = 4)
  bad_wf_R_not_spd.json  R[3] = [[-0.5]]
  bad_wf_y_missing.json  steps[4] without y
  bad_wf_R_count.json    4 R for 5 H (a sensor count that disagrees)
  bad_wf_y_count.json    steps[2].y of 4 measurements for 5 sensors
  bad_wf_y_len.json      steps[3].y[2] of 2 values (H[2] has 1 row)
  bad_wf_truth_len.json  x_true[7] of 3 values (n = 4)
  bad_wf_no_steps.json   steps = []
  bad_wf_big.json        12 sensors of n = 4: n l + n = 52 > DKF_MAX_DIM (48)
  bad_wf_selftune_form.json  Phi[0][1] = 0.9: not the observer form of dkf/selftune.h
  wf_long.json           4000 steps simulated from the case's model (x(0) = 0,
                         Gaussian w, xi, v_i; random.Random(2002)), with x_true:
                         the self-tuning filter's input (check_selftune.py)

usage: make_wf_cases.py VECTOR_DIR OUT_DIR
"""
import copy
import json
import math
import os
import random
import sys

LONG_STEPS = 4000


def simulate(c, steps, seed):
    """The case's model driven by fresh noise: steps of {t, y}, x_true k = 0..steps."""
    rng = random.Random(seed)
    Phi, G, Qe = c["Phi"], c["Gamma"], c["Qe"]
    n, r = len(Phi), len(Qe)
    x = [0.0] * n
    xs, out = [list(x)], []
    for t in range(1, steps + 1):
        w = [rng.gauss(0.0, math.sqrt(Qe[a][a])) for a in range(r)]  # Qe diagonal
        x = [sum(Phi[i][j] * x[j] for j in range(n)) + sum(G[i][a] * w[a] for a in range(r))
             for i in range(n)]
        xs.append(list(x))
        y = []
        for H, R in zip(c["H"], c["R"]):
            y.append([sum(H[0][j] * x[j] for j in range(n)) + rng.gauss(0.0, math.sqrt(R[0][0]))])
        out.append({"t": t, "y": y})
    return out, xs


def main():
    vec, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(vec, "infofusion", "s2_weighted_fusion.json")) as f:
        base = json.load(f)

    def write(name, edit):
        d = copy.deepcopy(base)
        edit(d["cases"][0])
        with open(os.path.join(out, name), "w") as f:
            json.dump(d, f)

    def generated(c):
        for key in ("x_true", "steady_state"):
            c.pop(key)
        c["steps"] = [{"t": st["t"], "y": st["y"]} for st in c["steps"]]

    def big(c):
        while len(c["H"]) < 12:
            c["H"].append(c["H"][0])
            c["R"].append(c["R"][0])
        for st in c["steps"]:
            while len(st["y"]) < 12:
                st["y"].append(st["y"][0])

    def long_run(c):
        c.pop("steady_state")
        c["steps"], c["x_true"] = simulate(c, LONG_STEPS, 2002)

    write("wf_generated.json", generated)
    write("wf_long.json", long_run)
    write("bad_wf_H_shape.json", lambda c: c["H"].__setitem__(2, [[1.0, 0.0, 0.0]]))
    write("bad_wf_R_not_spd.json", lambda c: c["R"].__setitem__(3, [[-0.5]]))
    write("bad_wf_y_missing.json", lambda c: c["steps"][4].pop("y"))
    write("bad_wf_R_count.json", lambda c: c["R"].pop())
    write("bad_wf_y_count.json", lambda c: c["steps"][2]["y"].pop())
    write("bad_wf_y_len.json", lambda c: c["steps"][3]["y"].__setitem__(2, [0.1, 0.2]))
    write("bad_wf_truth_len.json", lambda c: c["x_true"].__setitem__(7, c["x_true"][7][:3]))
    write("bad_wf_no_steps.json", lambda c: c.__setitem__("steps", []))
    write("bad_wf_big.json", big)
    write("bad_wf_selftune_form.json", lambda c: c["Phi"][0].__setitem__(1, 0.9))


if __name__ == "__main__":
    main()
