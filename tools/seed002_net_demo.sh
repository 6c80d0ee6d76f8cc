#!/usr/bin/env bash
# tools/seed002_net_demo.sh - seed 002's example (5 sensors, weighted fusion of
# local Kalman filters) with one process per sensor over LCM, on this machine.
#
#   tools/seed002_net_demo.sh [--build-dir DIR] [--no-build] [--steps T] [--in-process]
#
# Builds dkf-sim, dkf-node, dkf-fusion and dkf-run, writes the example's
# scenario (tools/make_wf_scenario.py: 5 sensors, T steps (default 2000),
# numpy seed 2, x(0) from the stationary covariance) and runs it as
# processes talking over UDP multicast udpm://239.255.76.67:7667?ttl=0 inside
# a private network namespace (tools/netns.sh; root only), so nothing can
# leave the machine: dkf-sim publishes every sensor's y, one
# `dkf-node --filter local_kf` per sensor runs its local Kalman filter and
# publishes x_i(t|t), and dkf-fusion (the weighted-fusion centre) computes
# every gain and cross covariance from the model and fuses the estimates
# with scalar and matrix weights. The same scenario runs in process
# (dkf-run --filter fusion_scalar, fusion_matrix, local_kf, central_kf).
# Without root (or with --in-process) it says so and runs in process only.
# Table: max |process - in-process| over x0, P0, s0, PS0, w (must be 0), the
# empirical signal-error variance of every estimator over t > 20 (with a
# batch-means standard error) beside its theoretical variance, i.e. local,
# fused (scalar, matrix) and centralized MSE. Exit 0 only if the process run
# equals the in-process one and every step fused all 5 sensors.
set -euo pipefail
steps=2000
# URL, demo_options, demo_build, demo_require, demo_mode, loopback_only, start_run,
# wall_since, demo_processes
. "$(dirname "$0")/../ports/linux/net/tests/net_common.sh"
demo_options seed002_net_demo.sh 23 seed002-demo "$@"
[[ $steps =~ ^[0-9]+$ ]] && (( steps >= 50 && steps <= 100000 )) ||
  { echo "seed002_net_demo.sh: --steps must be 50..100000" >&2; exit 2; }

# ---- inside the namespace (--inner): every sensor its own process ----------------------
if [[ ${#inner[@]} -gt 0 && ${DKF_S002_DEMO_INNER:-0} == 1 ]]; then
  scn=${inner[0]} dir=${inner[1]} bin=${inner[2]}
  loopback_only seed002_net_demo.sh || exit 1
  start_run "$dir"
  # every datagram authenticated (docs/guide/network.md, Authentication)
  "$bin/dkf-keygen" "$dir/keys" 5 || exit 1
  auth=(--key-dir "$dir/keys")
  wait_ready() { for _ in $(seq 3000); do [[ -e $1 ]] && return 0; sleep 0.1; done; return 1; }
  # every node runs, so no step needs the deadline: a loaded machine delays the
  # lock-step run, it never degrades a step
  "$bin/dkf-fusion" --url "$URL" --timeout 300 --deadline-ms 300000 "${auth[@]}" \
    --ready-file "$dir/fusion.ready" \
    --output "$dir/fused.json" "$scn" 2>"$dir/fusion.log" & fpid=$!; pids+=($fpid)
  wait_ready "$dir/fusion.ready"
  npids=()
  for ((i = 0; i < 5; ++i)); do
    "$bin/dkf-node" --url "$URL" --filter local_kf --id $i --timeout 300 "${auth[@]}" \
      --ready-file "$dir/n$i.ready" "$scn" 2>"$dir/node$i.log" & npids+=($!); pids+=($!)
    wait_ready "$dir/n$i.ready"
  done
  t0=$(date +%s.%N)
  "$bin/dkf-sim" --url "$URL" --timeout 300 --lockstep "${auth[@]}" "$scn" 2>"$dir/sim.log"
  rc=0
  wait $fpid || rc=1
  for p in "${npids[@]}"; do wait "$p" || rc=1; done
  wall_since "$t0" "$dir/wall_s"
  pids=()
  exit $rc
fi

demo_build "$build" dkf-sim dkf-node dkf-fusion dkf-run dkf-keygen
bin=$build/ports/linux/net
run=$build/ports/linux/dkf-run
demo_require seed002_net_demo.sh "$bin/dkf-sim" "$bin/dkf-node" "$bin/dkf-fusion" "$bin/dkf-keygen" "$run"
out=$build/seed002-demo
mkdir -p "$out"
scn=$out/wf5.json
python3 "$here/make_wf_scenario.py" --steps "$steps" --sensors 5 --seed 2 --out "$scn"

demo_mode seed002_net_demo.sh sensor "in process" "$out"

for f in fusion_scalar fusion_matrix local_kf central_kf; do
  "$run" --filter $f --quiet --output "$out/inproc_$f.json" "$scn"
done
if [[ $mode == udpm ]]; then
  echo "== seed 002: dkf-sim + 5 dkf-node --filter local_kf + dkf-fusion over $URL (namespace), $steps steps"
  demo_processes seed002_net_demo.sh DKF_S002_DEMO_INNER "a process failed (see $out/proc/*.log)" \
    "$scn" "$out/proc" "$bin"
fi

python3 - "$mode" "$out" "$scn" <<'PY'
import json, sys
import numpy as np
mode, out, scn_path = sys.argv[1:4]
c = json.load(open(scn_path))["cases"][0]
s = np.array(c["x_true"])[1:, 0]
ld = lambda f, k: json.load(open(f"{out}/inproc_{f}.json"))["outputs"][k]
sca, mat = ld("fusion_scalar", "FUSION_SCALAR"), ld("fusion_matrix", "FUSION_MATRIX")
loc, cen = ld("local_kf", "LOCAL_KF"), ld("central_kf", "CENTRAL_KF")
burn = 20
def mse(e):  # mean and batch-means standard error of e^2 over t > burn
    e2 = np.asarray(e)[burn:] ** 2
    b = np.array([x.mean() for x in np.array_split(e2, 20)])
    return float(e2.mean()), float(b.std(ddof=1) / np.sqrt(len(b)))
rows = [(f"local {i + 1}", mse(np.array(loc["s_local"])[:, i] - s), np.array(loc["P_ij"])[-1, i, i, 0, 0])
        for i in range(5)]
rows.append(("scalar-fused", mse(np.array(sca["s_fused"]) - s), sca["P_S0"][-1]))
rows.append(("matrix-fused", mse(np.array(mat["x_fused_matrix"])[:, 0] - s), mat["P0_matrix"][-1][0][0]))
rows.append(("centralized", mse(np.array(cen["x_central"])[:, 0] - s), cen["P_central"][-1][0][0]))
ok = True
gap = None
if mode == "udpm":
    try:
        net = json.load(open(f"{out}/proc/fused.json"))["outputs"]["wfusion"]
        pairs = [("x0", mat["x_fused_matrix"]), ("P0", mat["P0_matrix"]), ("s0", sca["s_fused"]),
                 ("PS0", sca["P_S0"]), ("w", sca["w"])]
        gap = max(float(np.max(np.abs(np.array(net[a], float) - np.array(b, float)))) for a, b in pairs)
        used = set(net["used"])
        wall = float(open(f"{out}/proc/wall_s").read())
        ok = gap == 0.0 and used == {5}
    except (OSError, KeyError, ValueError) as e:
        print(f"seed002_net_demo.sh: no complete process result ({e})")
        ok = False
print()
print("transport: " + ("udpm://239.255.76.67:7667?ttl=0 in a private network namespace: dkf-sim,"
                       " 5 dkf-node --filter local_kf, dkf-fusion (weighted-fusion centre)"
                       if mode == "udpm" else "none (in process only)"))
if gap is not None:
    print(f"fused (processes) vs in process (dkf-run): max |difference| over x0, P0, s0, PS0, w = "
          f"{gap:.1e} over {len(s)} steps; sensors fused per step: {sorted(used)}; wall {wall:.2f} s")
print(f"{'estimator':<14}{'empirical MSE (t>20)':>22}{'+- s.e.':>9}{'theory':>10}")
for name, (m, se), th in rows:
    print(f"{name:<14}{m:>22.5f}{se:>9.5f}{th:>10.5f}")
print("(signal s = H_s x; empirical: mean of (estimate - s)^2 over one run, batch-means standard"
      " error; theory: the filters' own variance at the last step: P_Sii, P_S0, H_s P0 H_s^T, the"
      " centralized P; the 2000-run Monte-Carlo: tools/seed002_example.py)")
sys.exit(0 if ok else 1)
PY
