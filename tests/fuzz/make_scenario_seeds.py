#!/usr/bin/env python3
"""Writes the seed corpus of fuzz_scenario (tests/fuzz/corpus/scenario/):
each layout the reader accepts (the weighted-fusion cases of seed 002 too),
cut from a golden vector of tests/vectors/
to 3 steps without its expected outputs, the reproducers of the reader bugs
of the hardening work, plus the small refused files of ports/linux/tests/cases/
(docs/guide/fuzzing.md).

usage: make_scenario_seeds.py [OUT_DIR]
"""
import json
import os
import shutil
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
STEPS = 3


def load(rel):
    with open(os.path.join(ROOT, rel)) as f:
        return json.load(f)


def cut_series(s, keep):
    """A {k: [...], <values>: [...]} series cut to the times in keep."""
    idx = [j for j, k in enumerate(s["k"]) if k in keep]
    return {key: ([v[j] for j in idx] if isinstance(v, list) else v) for key, v in s.items()}


def canonical(rel):
    d = load(rel)
    d.pop("outputs", None)
    d["N"] = STEPS
    keep = set(range(0, STEPS + 2))
    d["k"] = [k for k in d["k"] if k in keep]
    d["y"] = [cut_series(s, keep) for s in d["y"]] if isinstance(d["y"], list) else cut_series(d["y"], keep)
    if "truth" in d:
        d["truth"] = cut_series(d["truth"], keep)
    for name, m in d["model"].items():  # per_k lists
        if isinstance(m, dict) and "per_k" in m:
            m["per_k"] = m["per_k"][: STEPS + 2]
    return d


def cases(rel):
    d = load(rel)
    for c in d["cases"]:
        c["steps"] = c["steps"][:STEPS]
        for st in c["steps"]:
            st.pop("expected", None)
    return d


def nl_case(rel, index):
    """Case `index` of a nonlinear cases file (seed 001) alone, cut to STEPS
    steps, its truth to STEPS + 1 times."""
    c = load(rel)["cases"][index]
    c["steps"] = c["steps"][:STEPS]
    for st in c["steps"]:
        st.pop("expected", None)
        st.pop("expected_per_node", None)
    for key in ("x_true", "d_true"):
        if key in c:
            c[key] = c[key][:STEPS]
    if isinstance(c.get("truth"), dict):
        c["truth"] = {k: v[:STEPS + 1] for k, v in c["truth"].items() if k in ("X", "omega")}
    return {"cases": [c]}


def wf_case(rel):
    """The weighted-fusion cases (seed 002) cut to STEPS steps without
    expected or steady_state, x_true to k = 0..STEPS."""
    d = load(rel)
    for c in d["cases"]:
        c["steps"] = c["steps"][:STEPS]
        for st in c["steps"]:
            st.pop("expected", None)
        c.pop("steady_state", None)
        if "x_true" in c:
            c["x_true"] = c["x_true"][:STEPS + 1]
    return d


def steps(rel):
    d = load(rel)
    d["steps"] = d["steps"][:STEPS]
    for st in d["steps"]:
        st.pop("expected", None)
    d.pop("expect_error_case", None)
    return d


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "tests", "fuzz", "corpus", "scenario")
    os.makedirs(out, exist_ok=True)
    seeds = {
        "canonical_ex1.json": canonical("tests/vectors/diffkf/ex1_single.json"),
        "canonical_ex3_multi.json": canonical("tests/vectors/diffkf/ex3_multi.json"),
        "cases_lif.json": cases("tests/vectors/infofusion/lif_central_fusion.json"),
        "steps_uif_rtsf.json": steps("tests/vectors/uif/s004_rtsf.json"),
        "steps_uif_nrtsf_df.json": steps("tests/vectors/uif/s004_nrtsf_df.json"),
        "steps_tw_6node.json": steps("tests/vectors/uif/s003_6node.json"),
    }
    # nonlinear cases (seed 001): built-in families, a network, p = 0, expressions
    seeds["nl_nertsif.json"] = nl_case("tests/vectors/infofusion/nertsif.json", 0)
    seeds["nl_dnertsif_radar.json"] = nl_case("tests/vectors/infofusion/dnertsif_single.json", 0)
    seeds["nl_df_network.json"] = nl_case("tests/vectors/infofusion/df_dnertsif.json", 0)
    seeds["nl_df_ckf.json"] = nl_case("tests/vectors/infofusion/df_dnertsif.json", 4)
    seeds["nl_expr_lin.json"] = nl_case("scenarios/nl_lin_x_sin_d_expr.json", 0)
    seeds["nl_expr_radar.json"] = nl_case("scenarios/nl_radar_expr.json", 0)
    # weighted-fusion cases (seed 002): the vector, and a generated form
    # (no x_true) whose sensor 1 measures two components (m differs)
    seeds["wf_seed002.json"] = wf_case("tests/vectors/infofusion/s2_weighted_fusion.json")
    d = wf_case("tests/vectors/infofusion/s2_weighted_fusion.json")
    c = d["cases"][0]
    c.pop("x_true")
    c["H"][1] = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]
    c["R"][1] = [[2.0, 0.5], [0.5, 1.0]]
    for st in c["steps"]:
        st["y"][1] = [st["y"][1][0], -1.0]
    seeds["wf_generated_mixed_m.json"] = d
    # a steps file whose model has no H, D (the reader then sizes y as one
    # value per step): y of one value
    d = steps("tests/vectors/uif/s004_rtsf.json")
    for key in ("H", "D"):
        d["model"].pop(key)
    for st in d["steps"]:
        st["inputs"]["y"] = st["inputs"]["y"][:1]
    seeds["steps_uif_no_CH_m1.json"] = d
    # reproducers of fixed reader bugs (scenario.c): the same file with y of two
    # values (y was sized one value per step, then m copied per step), and
    # N = 2^63 as a JSON real (get_integer let it through to the cast)
    d = json.loads(json.dumps(seeds["steps_uif_no_CH_m1.json"]))
    for st in d["steps"]:
        st["inputs"]["y"] = [1.0, 2.0]
    seeds["fixed_steps_no_CH_y2.json"] = d
    d = canonical("tests/vectors/diffkf/ex1_single.json")
    d["N"] = 9.223372036854775808e18
    seeds["fixed_canonical_N_2p63.json"] = d
    for name, d in seeds.items():
        with open(os.path.join(out, name), "w") as f:
            json.dump(d, f, separators=(",", ":"))
    bad = os.path.join(ROOT, "ports", "linux", "tests", "bad")
    for name in sorted(os.listdir(bad)):
        if name.endswith(".json"):
            shutil.copy(os.path.join(bad, name), os.path.join(out, "bad_" + name))


if __name__ == "__main__":
    main()
