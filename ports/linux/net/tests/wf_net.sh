#!/usr/bin/env bash
# wf_net.sh MODE OUTDIR - seed 002's weighted-fusion network as real
# processes over UDP multicast (udpm://239.255.76.67:7667?ttl=0) inside a
# private network namespace made for this run (tools/netns.sh), on a
# 5-sensor, 200-step scenario written by tools/make_wf_scenario.py (numpy
# seed 2): dkf-fusion (the weighted fusion centre, chosen by the scenario),
# five `dkf-node --filter local_kf`, dkf-sim --lockstep. docs/design/network.md,
# "The weighted-fusion centre".
#
#   full    every node: every step complete, the fusion == the in-process
#           core fusion (wf_check: max |difference| == 0) and == dkf-run
#           --filter fusion_matrix / fusion_scalar (the registry, in process)
#           exactly
#   absent  node 2 never starts: every step degraded, nodes 0 1 3 4 fused,
#           == the in-process fusion with x[2] = NULL (bit for bit)
#   killed  node 3 dies at step 100 (--exit-at; a crash): steps 1..99
#           complete, 100..200 degraded without node 3, each == the
#           in-process fusion over the nodes present (bit for bit)
#
# Environment (set by ctest): DKF_SIM DKF_NODE DKF_FUSION DKF_RUN DKF_WFCHECK
# DKF_PYTHON DKF_NETNS DKF_GEN. Exit 77 (skip) when not root or without numpy.
set -uo pipefail
mode=$1 out=$2
T=60            # per-process timeout, seconds
DEADLINE_FLOOR_MS=300 # the fault tests' deadline's least (net_faults.sh)

. "$(dirname "$0")/net_common.sh"
needs_numpy make_wf_scenario.py
in_netns "$0" "$@"
start_run "$out"
DEADLINE_MS=$(derived_ms "$DKF_NODE" $DEADLINE_FLOOR_MS 40)
# lock-step at most one step per 2 x the slowest start of dkf-node, as in
# net_faults.sh (its PACE): a node given up on cannot be outrun
probe=$(probe_ms "$DKF_NODE")
rate=$(awk -v p="$probe" 'BEGIN { printf "%.3f", 1000 / (2 * p) }')

scn=$out/wf5.json
"$DKF_PYTHON" "$DKF_GEN" --steps 200 --sensors 5 --seed 2 --out "$scn" || exit 1

"$DKF_FUSION" --url "$URL" --timeout $T --deadline-ms $DEADLINE_MS \
  --ready-file "$out/fusion.ready" --output "$out/fused.json" "$scn" \
  2>"$out/fusion.log" & pids+=($!); fpid=$!
wait_file "$out/fusion.ready" $T || exit 1

node() { # ID [dkf-node options...]; sets npid
  local id=$1; shift
  "$DKF_NODE" --url "$URL" --filter local_kf --id "$id" --timeout $T \
    --ready-file "$out/n$id.ready" "$@" "$scn" 2>"$out/n$id.log" & pids+=($!); npid=$!
  wait_file "$out/n$id.ready" $T
}

npids=() simopt=()
for i in 0 1 2 3 4; do
  case "$mode:$i" in
    absent:2) simopt=(--optional-node 2); continue ;;
    killed:3) node 3 --exit-at 100 || exit 1 ;;
    *) node "$i" || exit 1 ;;
  esac
  npids+=($npid)
done
"$DKF_SIM" --url "$URL" --timeout $T --lockstep --rate "$rate" --step-timeout $T "${simopt[@]}" \
  "$scn" 2>"$out/sim.log" \
  || { cat "$out"/*.log; echo "FAIL: dkf-sim exited $?"; exit 1; }
rc=0
wait $fpid || { echo "FAIL: dkf-fusion exited $?"; rc=1; }
for p in "${npids[@]}"; do wait "$p" || { echo "FAIL: a dkf-node exited $?"; rc=1; }; done
cat "$out"/*.log
(( rc == 0 )) || exit 1

case "$mode" in
  full)
    "$DKF_WFCHECK" "$scn" "$out/fused.json" --complete || exit 1
    # the registry's in-process run (dkf-run) gives the same numbers exactly
    "$DKF_RUN" --filter fusion_matrix --output "$out/inproc_matrix.json" "$scn" >/dev/null || exit 1
    "$DKF_RUN" --filter fusion_scalar --output "$out/inproc_scalar.json" "$scn" >/dev/null || exit 1
    "$DKF_PYTHON" - "$out/fused.json" "$out/inproc_matrix.json" "$out/inproc_scalar.json" <<'PY' || exit 1
import json, sys
import numpy as np
net = json.load(open(sys.argv[1]))["outputs"]["wfusion"]
mat = json.load(open(sys.argv[2]))["outputs"]["FUSION_MATRIX"]
sca = json.load(open(sys.argv[3]))["outputs"]["FUSION_SCALAR"]
pairs = [("x0", mat["x_fused_matrix"]), ("P0", mat["P0_matrix"]), ("s0", sca["s_fused"]),
         ("PS0", sca["P_S0"]), ("w", sca["w"])]
worst = max(float(np.max(np.abs(np.array(net[a], float) - np.array(b, float)))) for a, b in pairs)
print(f"max |process - dkf-run in process| over x0, P0, s0, PS0, w (200 steps): {worst:.3g}")
assert worst == 0, worst
PY
    ;;
  absent) "$DKF_WFCHECK" "$scn" "$out/fused.json" --absent 2:1:200 || exit 1 ;;
  killed) "$DKF_WFCHECK" "$scn" "$out/fused.json" --absent 3:100:200 || exit 1 ;;
  *) echo "wf_net.sh: unknown mode $mode" >&2; exit 2 ;;
esac
echo "PASS: wf_net.sh $mode"
