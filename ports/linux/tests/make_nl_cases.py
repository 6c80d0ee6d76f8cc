#!/usr/bin/env python3
"""Writes the generated nonlinear-cases test inputs of tests/runs.table and tests/cases/.

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
  df_no_edges.json   its case 3 without `edges` (the graph of W), and
  df_w_sparse.json   the same with W as W_sparse triplets
  pendulum.json      a model of no vector file, written as expressions: a
                     pendulum driven by an unknown torque d1, measured as
                     angle (an angle channel), rate and d1 + 0.1 rate;
                     the truth simulated here (fixed seed)
  bad_*.json         one deliberate error each, refused with one line (the
                     bad_nl_node_*, n_plus_p and cf_f ones from
                     nl_mixed_expr.json: what a network of different
                     sensors still may not have; bad_nl_z_nodes,
                     z_node_len and no_nodes from df_dnertsif.json's
                     first case)
"""
import copy
import json
import math
import os
import random
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


def pendulum(steps=40, seed=20260001):
    """theta' = omega, omega' = -(g/L) sin theta + d; T = 0.1, g/L = 4."""
    T, a = 0.1, 4.0
    rng = random.Random(seed)
    q = [[1e-6, 0.0], [0.0, 1e-4]]
    r = [[1e-4, 0.0, 0.0], [0.0, 4e-4, 0.0], [0.0, 0.0, 1e-4]]
    x = [1.0, 0.0]
    xs, ds, st = [], [], []
    for k in range(1, steps + 1):
        d_prev = 0.5 * math.sin(0.3 * (k - 1))  # the torque, unknown to the filter
        x = [x[0] + T * x[1] + rng.gauss(0, 1e-3),
             x[1] - T * a * math.sin(x[0]) + T * d_prev + rng.gauss(0, 1e-2)]
        d = 0.5 * math.sin(0.3 * k)
        z = [math.atan2(math.sin(x[0]), math.cos(x[0])) + rng.gauss(0, 1e-2),
             x[1] + rng.gauss(0, 2e-2), d + 0.1 * x[1] + rng.gauss(0, 1e-2)]
        xs.append(x)
        ds.append([d])
        st.append({"k": k, "z": z})
    return {"cases": [{
        "name": "pendulum",
        "model": {"expr": {"f": ["x1 + 0.1*x2", "x2 - 0.1*4*sin(x1) + 0.1*d1"],
                           "g": ["x1", "x2", "d1 + 0.1*x2"],
                           "angles": [0]},
                  "Q": q, "R": r},
        "init": {"x0": [0.9, 0.1], "Px0": [[0.01, 0.0], [0.0, 0.01]], "d0": [0.0],
                 "Pd0": [[1.0]], "Pxd0": [[0.0], [0.0]]},
        "x_true": xs, "d_true": ds, "steps": st}]}


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

    write(out, "pendulum.json", pendulum())

    # the graph from W alone (no edges), and W as sparse triplets
    c1 = copy.deepcopy(df["cases"][3])
    for s_ in c1["steps"]:
        s_.pop("expected_per_node", None)
    del c1["edges"]
    write(out, "df_no_edges.json", {"cases": [c1]})
    c2 = copy.deepcopy(c1)
    W = c2.pop("W")
    c2["W_sparse"] = [[i, j, w] for i, row in enumerate(W) for j, w in enumerate(row) if w != 0]
    write(out, "df_w_sparse.json", {"cases": [c2]})

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
    bad("bad_nl_truth_len.json", lambda c: c["x_true"].__setitem__(5, [0.1, 0.2]))
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
    q = copy.deepcopy(net)
    q["node_models"][2]["Q"] = [[2 * v for v in row] for row in q["node_models"][2]["Q"]]
    write(out, "bad_nl_cf_q.json", {"cases": [q]})
    z = copy.deepcopy(net)
    z["steps"][2]["z"].pop()
    write(out, "bad_nl_z_nodes.json", {"cases": [z]})
    z = copy.deepcopy(net)
    z["steps"][1]["z"][2] = [1.0, 2.0]
    write(out, "bad_nl_z_node_len.json", {"cases": [z]})
    z = copy.deepcopy(net)
    z["node_models"] = []
    write(out, "bad_nl_no_nodes.json", {"cases": [z]})
    net["W"] = net["W"][:3]
    write(out, "bad_nl_w_shape.json", {"cases": [net]})

    # what the network filters cannot run, refused by key (the mixed network
    # of scenarios/nl_mixed_expr.json: nodes may differ in m, g, R, ...)
    mixed = json.load(open(os.path.join(sdir, "nl_mixed_expr.json")))

    def bad_mixed(name, change):
        c = copy.deepcopy(mixed["cases"][0])
        change(c)
        write(out, name, {"cases": [c]})

    def node_n2(c):  # node 1's state of 2 values
        c["init_per_node"][1] = dict(c["init_per_node"][0], x0=[0.0, 0.0],
                                     Px0=[[0.1, 0.0], [0.0, 0.1]], Pxd0=[[0.0], [0.0]])

    def node_p0(c):  # node 2 without the unknown input
        c["init_per_node"][2] = dict(c["init_per_node"][0], d0=[], Pd0=[], Pxd0=[[], [], []])

    def m_below_p(c):  # p = 2, node 2 measures one value
        c["init_per_node"] = [dict(c["init_per_node"][0], d0=[0.0, 0.0],
                                   Pd0=[[0.25, 0.0], [0.0, 0.25]],
                                   Pxd0=[[0.0, 0.0]] * 3)] * 3
        for md in c["node_models"]:
            md["expr"]["g"][-1] += " + d2"
        c["node_models"][2]["expr"]["g"] = ["d1 + d2 + x1"]
        c["node_models"][2]["R"] = [[0.02]]
        for st in c["steps"]:
            st["z"][2] = st["z"][2][:1]
        del c["truth"]

    def n_plus_p(c):  # n = 40, p = 10: [x; d] of 50 values
        n, p = 40, 10
        eye = lambda k, v: [[v if i == j else 0.0 for j in range(k)] for i in range(k)]
        c["init_per_node"] = [{"x0": [0.0] * n, "Px0": eye(n, 0.1), "d0": [0.0] * p,
                               "Pd0": eye(p, 0.1), "Pxd0": [[0.0] * p] * n}] * 3
        for md in c["node_models"]:
            md["expr"] = {"f": ["x%d" % (i + 1) for i in range(n)],
                          "g": ["x1 + d%d" % (j + 1) for j in range(p)]}
            md["Q"], md["R"] = eye(n, 0.01), eye(p, 0.01)
        for st in c["steps"]:
            st["z"] = [[0.0] * p] * 3
        del c["truth"]

    def other_f(c):  # node 1's dynamics differ (cf_dnertsf runs node 0's for all)
        c["node_models"][1]["expr"]["f"][0] = "x1 + 0.2*x2"

    bad_mixed("bad_nl_node_n.json", node_n2)
    bad_mixed("bad_nl_node_p.json", node_p0)
    bad_mixed("bad_nl_node_m_lt_p.json", m_below_p)
    bad_mixed("bad_nl_n_plus_p.json", n_plus_p)
    bad_mixed("bad_nl_cf_f.json", other_f)


if __name__ == "__main__":
    main()
