#!/usr/bin/env bash
# tools/seed001_net_demo.sh - seed 001's 12 radars with one process per node
# over LCM, on this machine.
#
#   tools/seed001_net_demo.sh [--build-dir DIR] [--no-build] [--steps T] [--in-process]
#
# Builds dkf-tw-node and dkf-run, writes seed 001's radar scenario
# (tools/seed001_model.py: Monte-Carlo run 0, T steps (default 100), the 3 x 4
# grid, Metropolis W, T_p = 45) and runs DF-DNERTSIF literally (s = 1) and
# N-scaled (s = 12) with one `dkf-tw-node --filter df_dnertsif` process per
# radar talking over UDP multicast udpm://239.255.76.67:7667?ttl=0 inside a
# private network namespace (tools/netns.sh; root only), so nothing can
# leave the machine; each node subscribes only to its neighbours' channels.
# The same runs in process (dkf-run --filter df_dnertsif, dkf_dfnerts_net_*),
# and the centralised CF-DNERTSF (dkf-run --filter cf_dnertsf). Without root
# (or with --in-process) it says so and runs the in-process filters only.
# Table: ARMSE of position and velocity over the steps of this run (the
# 50-run Table 1 is tools/seed001_table1.py), max |process - in-process|
# over every node, step and x, Px, d (must be 0: the processes compute the
# same bits), packets and reals per node per step, wall time.
# Exit 0 only if every process run equals the in-process one.
set -euo pipefail
steps=100
# URL, demo_options, demo_tw_programs, demo_mode, loopback_only, start_run, run_tw_nodes,
# demo_timed, demo_processes, demo_auth_exit
. "$(dirname "$0")/../ports/linux/net/tests/net_common.sh"
demo_options seed001_net_demo.sh 21 seed001-demo "$@"

# ---- inside the namespace (--inner): every radar its own process ---------------------
if [[ ${#inner[@]} -gt 0 && ${DKF_S001_DEMO_INNER:-0} == 1 ]]; then
  scn=${inner[0]} cs=${inner[1]} dir=${inner[2]} node=${inner[3]} keys=${inner[4]}
  loopback_only seed001_net_demo.sh || exit 1
  start_run "$dir"
  run_tw_nodes 12 "$dir" "$node" "$scn" "$keys" --filter df_dnertsif --case "$cs"
  exit $?
fi

demo_tw_programs seed001_net_demo.sh
out=$build/seed001-demo
mkdir -p "$out"
scn=$out/radar12.json
python3 "$here/seed001_model.py" --run 0 --steps "$steps" --tp 45 --scale both --out "$scn"

"$keygen" --edges "$out/keys" 12 # a key per edge (docs/guide/network.md, Authentication)
demo_mode seed001_net_demo.sh radar "the in-process filters" "$out"

"$run" --filter cf_dnertsf --case 0 --quiet --output "$out/cf.json" "$scn"
for cs in 0 1; do
  demo_timed "$out/inproc$cs.wall" \
    "$run" --filter df_dnertsif --case $cs --quiet --output "$out/inproc$cs.json" "$scn"
  if [[ $mode == udpm ]]; then
    echo "== DF-DNERTSIF case $cs: 12 dkf-tw-node processes over $URL (namespace), T_p = 45"
    demo_processes seed001_net_demo.sh DKF_S001_DEMO_INNER \
      "a node process failed (see $out/proc$cs/node*.log)" \
      "$scn" $cs "$out/proc$cs" "$node" "$out/keys"
  fi
done

python3 - "$mode" "$out" "$scn" <<'PY'
import glob, json, sys
import numpy as np
mode, out, scn_path = sys.argv[1:4]
scn = json.load(open(scn_path))
X = np.array(scn["cases"][0]["truth"]["X"])[1:]
def armse(x):  # x [steps, nodes, 4] -> ARMSE pos, vel (node mean) over the steps of this run
    e = x - X[:, None, :]
    return (float(np.sqrt(e[..., 0] ** 2 + e[..., 2] ** 2).mean()),
            float(np.sqrt(e[..., 1] ** 2 + e[..., 3] ** 2).mean()))
def flat(v):
    return np.array(v, dtype=float).ravel()
ok = True
rows = []
cf = json.load(open(f"{out}/cf.json"))["outputs"]["CF_DNERTSF"]
rows.append(("CF-DNERTSF (36-dim stacked)", "in-process", armse(np.array(cf["x"])[:, None, :]), None, None, None))
for cs, name in ((0, "DF-DNERTSIF literal s=1"), (1, "DF-DNERTSIF N-scaled s=12")):
    d = json.load(open(f"{out}/inproc{cs}.json"))
    o = d["outputs"]["DF_DNERTSIF"]
    wall = float(open(f"{out}/inproc{cs}.wall").read())
    c = d.get("communication", {})
    rows.append((name, "in-process", armse(np.array(o["x"])), None, None, wall))
    if mode != "udpm":
        continue
    res = {}
    for f in glob.glob(f"{out}/proc{cs}/node*.json"):
        r = json.load(open(f))
        res[r["node"]] = r
    if sorted(res) != list(range(12)) or any(r.get("exit") != "done" for r in res.values()):
        ok = False
        rows.append((name, "12 processes", None, None, None, None))
        continue
    gap = 0.0
    for i, r in res.items():
        for key in ("x", "Px", "d"):
            a = np.concatenate([flat(v) for v in r[key]])
            b = np.concatenate([flat(o[key][j][i]) for j in range(len(r[key]))])
            gap = max(gap, float(np.max(np.abs(a - b))))
    ok &= gap == 0.0 and not any(any(r["degraded"]) for r in res.values())
    xs = np.stack([np.array(res[i]["x"]) for i in range(12)], axis=1)
    steps = len(res[0]["k"])
    pk = sum(r["counters"]["sent"] - r["counters"]["retransmits"] - r["counters"]["answers"]
             for r in res.values()) / (12 * steps)
    reals = sum(r["counters"]["reals_sent"] for r in res.values()) / (12 * steps)
    rows.append((name, "12 processes", armse(xs), gap, (pk, reals),
                 float(open(f"{out}/proc{cs}/wall_s").read())))
print()
print("transport: " + ("udpm://239.255.76.67:7667?ttl=0 in a private network namespace, one "
                       "dkf-tw-node per radar" if mode == "udpm" else "none (in-process only)"))
print(f"{'filter':<28}{'run':<14}{'ARMSE pos':>10}{'ARMSE vel':>10}{'max|proc-inproc|':>18}"
      f"{'pkts/node/step':>16}{'reals/node/step':>17}{'wall s':>8}")
for name, how, a, gap, pr, wall in rows:
    if a is None:
        print(f"{name:<28}{how:<14}  FAILED (no complete result)")
        continue
    g = "-" if gap is None else f"{gap:.1e}"
    p = ("-", "-") if pr is None else (f"{pr[0]:.1f}", f"{pr[1]:.1f}")
    w = "-" if wall is None else f"{wall:.2f}"
    print(f"{name:<28}{how:<14}{a[0]:>10.4f}{a[1]:>10.4f}{g:>18}{p[0]:>16}{p[1]:>17}{w:>8}")
print(f"(one Monte-Carlo run, {len(X)} steps, T_p = 45; ARMSE: mean over the steps of the position /"
      " velocity error, node mean for DF; the 50-run table: tools/seed001_table1.py."
      " max|proc-inproc|: absolute, over every node, step and x, Px, d; packets: first"
      " publications per node per step (DONE and loss recovery excluded))")
sys.exit(0 if ok else 1)
PY
demo_auth_exit $?
