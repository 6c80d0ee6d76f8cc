#!/usr/bin/env python3
"""Writes the generated test inputs of tests/runs.table and tests/cases/ into OUTDIR.

    make_steps_cases.py VECTOR_DIR OUTDIR

Each file is a golden vector (tests/vectors/uif/s00{3,4}_*.json), in the
library's letters (docs/reference/scenario-format.md, "Letters"), with one
deliberate change: either a bad input that dkf-run must refuse with a
one-line "FILE: KEY: problem" message, or (tv_*.json) the same data in the
time-varying per-step `inputs` form (tests/vectors/uif/README.md: "`model`
(time invariant) or per-step `inputs` (time varying)"), which must give the
vector's numbers. A few files above the reader's limits (limit_*.json) are
built from scratch.
"""
import copy
import json
import os
import sys


def load(vdir, name):
    with open(os.path.join(vdir, name)) as f:
        return json.load(f)


def save(outdir, name, doc):
    with open(os.path.join(outdir, name), "w") as f:
        json.dump(doc, f)


def time_varying_s004(doc, model_form="empty"):
    """Every model matrix given per step: F_prev, G_prev, Q_prev (k >= 1), H, D, R.
    model_form: what is left of `model`: "empty" ({}), "null" or "absent"."""
    tv = copy.deepcopy(doc)
    model = tv.pop("model")
    if model_form == "empty":
        tv["model"] = {}
    elif model_form == "null":
        tv["model"] = None
    tv["time_varying"] = True
    for st in tv["steps"]:
        inp = st["inputs"]
        if st["k"] >= 1:
            for key in ("F", "G", "Q"):
                inp[key + "_prev"] = model[key]
        for key in ("H", "D", "R"):
            if key in model:
                inp[key] = model[key]
    return tv


def time_varying_s003(doc, full=False):
    """F_prev, G_prev, Q_prev at every step; model keeps the per-node H, R,
    or (full) they too are per step (lists of one matrix per node) and
    model is null."""
    tv = copy.deepcopy(doc)
    model = tv["model"]
    tv["model"] = None if full else {"H": model["H"], "R": model["R"]}
    tv["time_varying"] = True
    for st in tv["steps"]:
        for key in ("F", "G", "Q"):
            st["inputs"][key + "_prev"] = model[key]
        if full:
            st["inputs"]["H"] = model["H"]
            st["inputs"]["R"] = model["R"]
    return tv


def limit_cases(out):
    """Files just above the reader's limits (scenario.h DKF_SCN_MAX_*)."""
    one = {"F": {"const": [[1]]}, "Q": {"const": [[1]]}}
    init = {"x00": [0], "P00": [[1]]}
    y1 = {"k": [1], "values": [[0.5]]}
    d = {"N": 1, "model": dict(one, sensors=[{"H": [[1]], "R": [[1]]}] * 4097), "init": init,
         "y": [y1] * 4097}
    save(out, "limit_sensors.json", d)
    d = {"N": 1, "model": dict(one, H={"const": [[1]]}, R={"const": [[1]]}), "init": init,
         "runs": [{"y": y1}] * 100001}
    save(out, "limit_runs.json", d)


def main():
    vdir, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    df = load(vdir, "s004_nrtsf_df.json")
    nr = load(vdir, "s004_nrtsf.json")
    rt = load(vdir, "s004_rtsf.json")
    six = load(vdir, "s003_6node.json")
    # cases layout (infofusion): Q per step instead of per case
    lif = load(os.path.join(vdir, "..", "infofusion"), "lif_central_fusion.json")
    d = copy.deepcopy(lif)
    for c in d["cases"]:
        for st in c["steps"]:
            st["Q"] = c["Q"]
        del c["Q"]
    save(out, "cases_step_Q.json", d)

    save(out, "tv_nrtsf_df.json", time_varying_s004(df))
    save(out, "tv_nrtsf_df_model_null.json", time_varying_s004(df, "null"))
    save(out, "tv_nrtsf.json", time_varying_s004(nr, "absent"))
    save(out, "tv_rtsf.json", time_varying_s004(rt, "absent"))
    save(out, "tv_tw_6node.json", time_varying_s003(six))
    save(out, "tv_tw_6node_full.json", time_varying_s003(six, full=True))
    d = time_varying_s003(six, full=True); d["steps"][5]["inputs"]["R"] = six["model"]["R"][:5]
    save(out, "bad_tw_tv_Sw_nodes.json", d)
    d = time_varying_s003(six); d["steps"][0]["inputs"]["H"] = six["model"]["H"]
    save(out, "bad_tw_tv_H_dup.json", d)
    # the time-varying form with Q changed at one step only must differ
    tvq = time_varying_s004(df)
    tvq["steps"][10]["inputs"]["Q_prev"] = [[10 * v for v in row] for row in df["model"]["Q"]]
    save(out, "tv_nrtsf_df_q10.json", tvq)

    d = copy.deepcopy(df); del d["model"]["G"]; save(out, "bad_uif_no_G.json", d)
    d = copy.deepcopy(df); d["model"]["R"] = [[1, 0], [0, 1]]; save(out, "bad_uif_R_shape.json", d)
    d = copy.deepcopy(df); d["steps"][2]["inputs"]["y"] = d["steps"][2]["inputs"]["y"][:4]
    save(out, "bad_uif_y_len.json", d)
    d = copy.deepcopy(df); d["steps"][2]["k"] = 5; save(out, "bad_uif_time.json", d)
    d = time_varying_s004(df); del d["steps"][3]["inputs"]["H"]; save(out, "bad_uif_tv_gap.json", d)
    d = time_varying_s004(df); d["model"]["H"] = df["model"]["H"]; save(out, "bad_uif_tv_dup.json", d)
    d = copy.deepcopy(df); d["steps"][0]["inputs"]["F_prev"] = df["model"]["F"]
    save(out, "bad_uif_prev_at_0.json", d)
    d = copy.deepcopy(rt); d["model"]["D"] = rt["expect_error_case"]["H"]  # the vector's letter
    save(out, "rtsf_rank_deficient_H.json", d)
    d = copy.deepcopy(df); del d["steps"][4]["truth"]["x"]; save(out, "bad_uif_truth.json", d)

    d = copy.deepcopy(six); d["graph"]["edges"][3] = [2, 9]; save(out, "bad_tw_edge.json", d)
    d = copy.deepcopy(six); d["graph"]["edges"][3] = [2, 2]; save(out, "bad_tw_loop.json", d)
    d = copy.deepcopy(six); d["W_consensus"][0][0] += 0.25; save(out, "bad_tw_W.json", d)
    d = copy.deepcopy(six); d["W_consensus"][0][3] = 0.1; save(out, "bad_tw_W_offgraph.json", d)
    d = copy.deepcopy(six); d["steps"][1]["inputs"]["y"] = d["steps"][1]["inputs"]["y"][:5]
    save(out, "bad_tw_y_nodes.json", d)
    d = copy.deepcopy(six); d["model"]["R"] = d["model"]["R"][:5]; save(out, "bad_tw_Sw.json", d)
    d = copy.deepcopy(six); del d["eta"]; save(out, "bad_tw_no_eta.json", d)
    d = copy.deepcopy(six); del d["W_consensus"]; d["W_consensus_sparse"] = [[0, 0, 1.0]]
    d["alpha_diffusion"] = six["alpha_diffusion"]; d["W_consensus"] = six["W_consensus"]
    save(out, "bad_tw_W_both.json", d)
    # no weights at all: the library's defaults (uniform alpha, Metropolis W);
    # the 6-node vector uses exactly those, so the numbers must not change
    d = copy.deepcopy(six); del d["W_consensus"]; del d["alpha_diffusion"]
    save(out, "tw_default_weights.json", d)
    d = copy.deepcopy(six); d["eta"] = 10 ** 12; save(out, "bad_tw_eta_huge.json", d)
    d = copy.deepcopy(six); d["model"]["H"] = d["model"]["H"] * 683  # 4098 nodes
    save(out, "limit_nodes.json", d)
    d = copy.deepcopy(six); d["steps"][2]["n"] = 9223372036854775808.0
    save(out, "bad_tw_time_2p63.json", d)
    d = copy.deepcopy(nr); d["model"]["Q"][0][1] += 1e-3; save(out, "bad_uif_Q_asym.json", d)
    d = copy.deepcopy(six); d["model"]["R"][4][0][1] += 1e-3; save(out, "bad_tw_Sw_asym.json", d)
    d = copy.deepcopy(df); d["init"]["P0"][1][0] += 1e-3; save(out, "bad_uif_P0_asym.json", d)
    # the overflow class: a steps file without H whose y has p > 1 values
    d = copy.deepcopy(df); del d["model"]["H"]; save(out, "bad_uif_no_C.json", d)
    d = copy.deepcopy(six); del d["model"]["H"]; save(out, "bad_tw_no_H.json", d)
    limit_cases(out)
    print("wrote %s" % out)


if __name__ == "__main__":
    main()
