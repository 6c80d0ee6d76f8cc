#!/usr/bin/env python3
"""Writes the generated nonlinear-cases test inputs of ports/linux/CMakeLists.txt.

    make_nl_cases.py VECTOR_DIR SCENARIO_DIR OUTDIR

From the seed-001 vectors (VECTOR_DIR/infofusion) and the expression
scenarios (SCENARIO_DIR/nl_*_expr.json):

  nl_lin_noj.json    nl_lin_x_sin_d_expr.json without its Jacobians A, G, C,
                     H: the core differences f and g (DKF_NL_FD_STEP)
  cf12_nodes.json    dnertsif_single.json's s1_centralised_12_sensors case
                     split into a 12-node network case (one s1_radar model
                     and z per node, the same initial estimate at every
                     node, W = 11^T / 12): cf_dnertsf stacks the nodes back
                     and must give the case's numbers
  df_expr.json       df_dnertsif.json's first case with every node's
                     s1_radar model written as expressions (for the
                     network filters)
  bad_*.json         one deliberate error each, refused with one line
"""
import copy
import json
import os
import sys


def radar_expr(sx, sy, with_phi=True, omega=None):
    """seed 001's coordinated turn and radar at (sx, sy) as expressions."""
    w = "d1" if omega is None else repr(omega)
    a, b = "sin(%s)/%s" % (w, w), "(1 - cos(%s))/%s" % (w, w)
    f = ["x1 + %s*x2 - %s*x4" % (a, b), "cos(%s)*x2 - sin(%s)*x4" % (w, w),
         "%s*x2 + x3 + %s*x4" % (b, a), "sin(%s)*x2 + cos(%s)*x4" % (w, w)]
    dx, dy = "x1 - (%r)" % sx, "x3 - (%r)" % sy
    g = ["hypot(%s, %s)" % (dx, dy), "atan2(%s, %s)" % (dy, dx)]
    if with_phi:
        g.append("10*d1")
    return {"f": f, "g": g, "angles": [1]}


def write(out, name, doc):
    with open(os.path.join(out, name), "w") as fh:
        json.dump(doc, fh)


def main():
    vdir, sdir, out = sys.argv[1], sys.argv[2], sys.argv[3]
    os.makedirs(out, exist_ok=True)
    lin = json.load(open(os.path.join(sdir, "nl_lin_x_sin_d_expr.json")))
    noj = copy.deepcopy(lin)
    for k in "AGCH":
        del noj["cases"][0]["model"]["expr"][k]
    write(out, "nl_lin_noj.json", noj)

    single = json.load(open(os.path.join(vdir, "infofusion", "dnertsif_single.json")))
    cf = single["cases"][1]
    one = single["cases"][0]["model"]  # one sensor's R (the same for every sensor)
    L = len(cf["model"]["sensor_xy"])
    nodes = [{"family": "s1_radar", "sensor_xy": xy, "Q": cf["model"]["Q"], "R": one["R"]}
             for xy in cf["model"]["sensor_xy"]]
    steps = [{"k": s["k"], "z": [s["z"][3 * i:3 * i + 3] for i in range(L)]}
             for s in cf["steps"]]
    write(out, "cf12_nodes.json", {"cases": [{
        "name": "s1_12_nodes", "node_models": nodes,
        "init_per_node": [cf["init"]] * L,
        "W": [[1.0 / L] * L for _ in range(L)], "Tp": 1, "scale": float(L),
        "steps": steps}]})

    df = json.load(open(os.path.join(vdir, "infofusion", "df_dnertsif.json")))
    c0 = copy.deepcopy(df["cases"][0])
    for i, m in enumerate(c0["node_models"]):
        sx, sy = m["sensor_xy"]
        c0["node_models"][i] = {"expr": radar_expr(sx, sy), "Q": m["Q"], "R": m["R"]}
    for s in c0["steps"]:
        s.pop("expected_per_node", None)
    write(out, "df_expr.json", {"cases": [c0]})

    # bad inputs: (file, change of the lin expression case)
    def bad(name, change):
        doc = copy.deepcopy(lin)
        change(doc["cases"][0])
        write(out, name, doc)
    bad("bad_nl_unknown_var.json",
        lambda c: c["model"]["expr"]["g"].__setitem__(1, "x3 + 0.5*d2"))
    bad("bad_nl_syntax.json",
        lambda c: c["model"]["expr"]["f"].__setitem__(0, "x1 + (0.1*x2"))
    bad("bad_nl_div0.json",
        lambda c: c["model"]["expr"]["f"].__setitem__(2, "0.9*x3/(x1 - x1)"))
    bad("bad_nl_z_len.json", lambda c: c["steps"][3].__setitem__("z", [0.1, 0.2]))
    bad("bad_nl_init.json", lambda c: c["init"].__setitem__("Px0", [[0.1, 0], [0, 0.1]]))
    bad("bad_nl_asym.json", lambda c: c["init"]["Px0"][0].__setitem__(1, 0.05))
    bad("bad_nl_family.json",
        lambda c: c.__setitem__("model", {"family": "ct_radar", "Q": c["model"]["Q"]}))
    # run time: finite at x0 = 0, a division by zero once the estimate has x1 > 0.05
    bad("bad_nl_div0_run.json",
        lambda c: c["model"]["expr"]["f"].__setitem__(
            0, "x1 + 0.1*x2 + (x1 > 0.05 ? 1/(x1 - x1) : 0)"))
    net = copy.deepcopy(df["cases"][0])
    for s in net["steps"]:
        s.pop("expected_per_node", None)
    net["Tp"] = 0
    write(out, "bad_nl_tp.json", {"cases": [net]})
    net["Tp"] = 3
    net["W"] = net["W"][:3]
    write(out, "bad_nl_w_shape.json", {"cases": [net]})


if __name__ == "__main__":
    main()
