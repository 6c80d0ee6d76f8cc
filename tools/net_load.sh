#!/usr/bin/env bash
# tools/net_load.sh - the load the fusion centre holds (docs/design/network.md, "Load").
#
#   tools/net_load.sh [--build-dir DIR] [--rates "100 300 600 1000 2000"]
#                     [--runs 5] [--nodes 12] [--steps 500] [--drops "0 1"]
#
# For every (drop %, rate) it runs --runs times: the generated --nodes-node
# network (tools/make_net_scenario.py, seed 12, --steps steps), dkf-fusion at
# the demo's deadline (1000 ms), one dkf-node per sensor (each dropping that %
# of its messages, seed = run), dkf-sim --rate HZ, every process separate,
# over udpm://239.255.76.67:7667?ttl=0 in a private network namespace
# (tools/netns.sh; root only). A run succeeds when dkf-sim and dkf-fusion exit
# 0 (every step published and seen). The table: runs that succeeded, runs
# with every step complete in the end, node
# messages per second at the fusion centre, steps degraded in the end (mean),
# node restarts (a node that lost a measurement restarts its filter; mean),
# latency p50/p99 (measurement publication -> fused publication, all runs),
# wall time. Progress goes to stderr. Measures only; asserts nothing.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
build=$root/build/double rates="100 300 600 1000 2000" runs=5 nodes=12 steps=500 drops="0 1"
URL='udpm://239.255.76.67:7667?ttl=0'
while [[ $# -gt 0 ]]; do
  case $1 in
    --build-dir) build=$(realpath -m "$2"); shift 2 ;;
    --rates) rates=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --nodes) nodes=$2; shift 2 ;;
    --steps) steps=$2; shift 2 ;;
    --drops) drops=$2; shift 2 ;;
    --inner) shift; break ;;
    -h|--help) sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "net_load.sh: $1: unknown option (see --help)" >&2; exit 2 ;;
  esac
done

# ---- inside the namespace: one run ---------------------------------------------
if [[ ${DKF_LOAD_INNER:-0} == 1 ]]; then
  scn=$1 out=$2 bin=$3 rate=$4 drop=$5 seed=$6 nodes=$7
  if ip -o link | grep -qv ': lo:'; then
    echo "net_load.sh: the namespace has a non-loopback interface; refusing" >&2; exit 1
  fi
  pids=()
  trap 'for p in "${pids[@]}"; do kill $p 2>/dev/null || true; done' EXIT
  rm -f "$out.ready" "$out.fused.json"
  "$bin/dkf-fusion" --url "$URL" --timeout 120 --quiet --ready-file "$out.ready" \
    --output "$out.fused.json" "$scn" & pids+=($!); fpid=$!
  for ((i = 0; i < nodes; ++i)); do
    "$bin/dkf-node" --url "$URL" --id $i --timeout 120 --quiet --drop "$drop" --seed "$seed" \
      "$scn" & pids+=($!)
  done
  for ((i = 0; i < 1000; ++i)); do [[ -e $out.ready ]] && break; sleep 0.01; done
  t0=$(date +%s%N)
  rc=0
  "$bin/dkf-sim" --url "$URL" --rate "$rate" --timeout 120 --quiet "$scn" 2>"$out.sim.log" || rc=1
  wait $fpid || rc=1
  echo $(( ($(date +%s%N) - t0) / 1000000 )) >"$out.wall_ms"
  # the nodes are not waited for: one that lost y_{N+1} waits for it until
  # its --timeout (the EXIT trap ends them)
  exit $rc
fi

bin=$build/ports/linux/net
for p in dkf-sim dkf-node dkf-fusion; do
  [[ -x $bin/$p ]] || { echo "net_load.sh: $bin/$p missing (build first, or --build-dir)" >&2; exit 2; }
done
"$here/netns.sh" check || exit $?
out=$build/net-load
rm -rf "$out" && mkdir -p "$out"
python3 "$here/make_net_scenario.py" --nodes "$nodes" --steps "$steps" --seed 12 --out "$out/scn.json"
for drop in $drops; do
  for rate in $rates; do
    for ((r = 1; r <= runs; ++r)); do
      tag=$out/d${drop}_r${rate}_$r
      if DKF_LOAD_INNER=1 "$here/netns.sh" exec -- "$0" --inner "$out/scn.json" "$tag" "$bin" \
           "$rate" "$drop" "$r" "$nodes" >"$tag.log" 2>&1; then ok=ok; else ok=FAIL; fi
      echo "$ok" >"$tag.ok"
      echo "net_load.sh: drop $drop %, $rate Hz, run $r/$runs: $ok ($(cat "$tag.wall_ms" 2>/dev/null || echo ?) ms)" >&2
    done
  done
done

python3 - "$out" "$nodes" "$steps" "$runs" "$rates" "$drops" <<'PY'
import json, os, sys
import numpy as np
out, nodes, steps, runs = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
rates, drops = sys.argv[5].split(), sys.argv[6].split()
print(f"{nodes} nodes, N = {steps}, deadline 1000 ms, {runs} runs per row, udpm ttl=0 in a namespace")
print(f"{'drop %':>6} {'rate Hz':>8} {'ok':>5} {'complete':>9} {'node msgs/s':>12} {'degraded':>9} {'restarts':>9} {'p50 ms':>8} {'p99 ms':>8} {'wall s':>7}")
for drop in drops:
    for rate in rates:
        ok, lat, deg, wall, msgs, rst = 0, [], [], [], [], []
        for r in range(1, runs + 1):
            tag = f"{out}/d{drop}_r{rate}_{r}"
            if open(tag + ".ok").read().strip() == "ok":
                ok += 1
            if os.path.exists(tag + ".fused.json"):
                d = json.load(open(tag + ".fused.json"))
                lat += [v / 1000 for v in d["latency_us"]["first"] if v >= 0]
                deg.append(d["counters"]["degraded_steps"])
                # node restarts after a lost measurement (new epochs announced)
                rst.append(sum(1 for e in d["epochs"] for x in e if x["epoch"] > 0))
                msgs.append(sum(d["counters"]["received"]) / (steps / float(rate)))
            if os.path.exists(tag + ".wall_ms"):
                wall.append(int(open(tag + ".wall_ms").read()) / 1000)
        f = lambda v, fmt: (fmt % v) if v is not None else "-"
        print(f"{drop:>6} {rate:>8} {ok:>3}/{runs} {sum(1 for x in deg if x == 0):>7}/{runs} {f(np.mean(msgs) if msgs else None, '%12.0f')} "
              f"{f(np.mean(deg) if deg else None, '%9.1f')} {f(np.mean(rst) if rst else None, '%9.1f')} "
              f"{f(np.percentile(lat, 50) if lat else None, '%8.2f')} "
              f"{f(np.percentile(lat, 99) if lat else None, '%8.2f')} {f(np.mean(wall) if wall else None, '%7.2f')}")
PY
