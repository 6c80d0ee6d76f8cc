#!/usr/bin/env python3
"""Writes the steps-layout test inputs of ports/linux/CMakeLists.txt into OUTDIR.

    make_steps_cases.py VECTOR_DIR OUTDIR

Each file is a golden vector (tests/vectors/uif/s00{3,4}_*.json) with one
deliberate change: either a bad input that dkf-run must refuse with a
one-line "FILE: KEY: problem" message, or (tv_*.json) the same data in the
time-varying per-step `inputs` form, which must give the vector's numbers.
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


def time_varying_s004(doc):
    """Every model matrix given per step: A_prev, G_prev, Q_prev (k >= 1), C, H, R."""
    tv = copy.deepcopy(doc)
    model = tv.pop("model")
    tv["model"] = {}
    tv["time_varying"] = True
    for st in tv["steps"]:
        inp = st["inputs"]
        if st["k"] >= 1:
            for key in ("A", "G", "Q"):
                inp[key + "_prev"] = model[key]
        for key in ("C", "H", "R"):
            if key in model:
                inp[key] = model[key]
    return tv


def main():
    vdir, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    df = load(vdir, "s004_nrtsf_df.json")
    nr = load(vdir, "s004_nrtsf.json")
    rt = load(vdir, "s004_rtsf.json")
    six = load(vdir, "s003_6node.json")

    save(out, "tv_nrtsf_df.json", time_varying_s004(df))
    save(out, "tv_nrtsf.json", time_varying_s004(nr))
    # the time-varying form with Q changed at one step only must differ
    tvq = time_varying_s004(df)
    tvq["steps"][10]["inputs"]["Q_prev"] = [[10 * v for v in row] for row in df["model"]["Q"]]
    save(out, "tv_nrtsf_df_q10.json", tvq)

    d = copy.deepcopy(df); del d["model"]["G"]; save(out, "bad_uif_no_G.json", d)
    d = copy.deepcopy(df); d["model"]["R"] = [[1, 0], [0, 1]]; save(out, "bad_uif_R_shape.json", d)
    d = copy.deepcopy(df); d["steps"][2]["inputs"]["y"] = d["steps"][2]["inputs"]["y"][:4]
    save(out, "bad_uif_y_len.json", d)
    d = copy.deepcopy(df); d["steps"][2]["k"] = 5; save(out, "bad_uif_time.json", d)
    d = time_varying_s004(df); del d["steps"][3]["inputs"]["C"]; save(out, "bad_uif_tv_gap.json", d)
    d = time_varying_s004(df); d["model"]["C"] = df["model"]["C"]; save(out, "bad_uif_tv_dup.json", d)
    d = copy.deepcopy(df); d["steps"][0]["inputs"]["A_prev"] = df["model"]["A"]
    save(out, "bad_uif_prev_at_0.json", d)
    d = copy.deepcopy(rt); d["model"]["H"] = rt["expect_error_case"]["H"]
    save(out, "rtsf_rank_deficient_H.json", d)
    d = copy.deepcopy(df); del d["steps"][4]["truth"]["x"]; save(out, "bad_uif_truth.json", d)

    d = copy.deepcopy(six); d["graph"]["edges"][3] = [2, 9]; save(out, "bad_tw_edge.json", d)
    d = copy.deepcopy(six); d["graph"]["edges"][3] = [2, 2]; save(out, "bad_tw_loop.json", d)
    d = copy.deepcopy(six); d["W_consensus"][0][0] += 0.25; save(out, "bad_tw_W.json", d)
    d = copy.deepcopy(six); d["W_consensus"][0][3] = 0.1; save(out, "bad_tw_W_offgraph.json", d)
    d = copy.deepcopy(six); d["steps"][1]["inputs"]["y"] = d["steps"][1]["inputs"]["y"][:5]
    save(out, "bad_tw_y_nodes.json", d)
    d = copy.deepcopy(six); d["model"]["Sw"] = d["model"]["Sw"][:5]; save(out, "bad_tw_Sw.json", d)
    d = copy.deepcopy(six); del d["eta"]; save(out, "bad_tw_no_eta.json", d)
    d = copy.deepcopy(six); del d["W_consensus"]; d["W_consensus_sparse"] = [[0, 0, 1.0]]
    d["alpha_diffusion"] = six["alpha_diffusion"]; d["W_consensus"] = six["W_consensus"]
    save(out, "bad_tw_W_both.json", d)
    # no weights at all: the library's defaults (uniform alpha, Metropolis W);
    # the 6-node vector uses exactly those, so the numbers must not change
    d = copy.deepcopy(six); del d["W_consensus"]; del d["alpha_diffusion"]
    save(out, "tw_default_weights.json", d)
    print("wrote %s" % out)


if __name__ == "__main__":
    main()
