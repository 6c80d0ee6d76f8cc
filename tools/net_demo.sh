#!/usr/bin/env bash
# tools/net_demo.sh - the sensor network over LCM, end to end, on this machine.
#
#   tools/net_demo.sh [--build-dir DIR] [--no-build] [--rate HZ] [--memq] [--realtime]
#
# --realtime: as root, run the multicast demo's processes at real-time FIFO
# priority (chrt -f 20), so that a woken process runs at once instead of
# queueing behind the machine's ordinary load (docs/guide/network.md, "Where the
# latency goes"); they can then starve everything else on the machine
# while they run. Without it they run at the ordinary priority.
#
# Builds dkf (DKF_MAX_DIM = 1024: the host's centre is sized by its build,
# docs/decisions.md item 23), then runs seed-000 Example 3 (2 nodes) and
# generated networks of 12 and 50 nodes (tools/make_net_scenario.py, fixed
# seeds; every node with its own H/R, several with p_i < m_i; the 50 nodes in
# lock step), 200 nodes (in one process over memq://) and the 12 nodes again for
# 1000 steps at 100 Hz (the latency target, p99 <= 1 ms):
# dkf-sim --rate HZ, one dkf-node per sensor
# and dkf-fusion as separate processes talking over UDP multicast
# udpm://239.255.76.67:7667?ttl=0 inside a private network namespace
# (tools/netns.sh; root only), so nothing can leave the machine. Without
# root (or with --memq) it says so and runs the same agents in one process
# over memq:// instead (dkf-net-local; no latency then). It ends with a
# table: fused RMSE, the centralized DKF's RMSE computed offline by dkf-run
# from the same measurements, max |fused - central| (must be <= 1e-9
# relative), node messages sent / lost / rejected, and the latency p50/p99
# from a measurement's publication to the fused estimate's publication.
# With qemu-system-arm (and arm-none-eabi-gcc to build the image), Example 3
# runs once more with node 1 on an emulated Cortex-M4F: ports/cortex-m4's live
# node image fed and published by dkf-m4-bridge (row m4node; docs/guide/network.md,
# "A firmware node in the network"); without them the row says why it was skipped.
# Exit 0 only if every fused step is complete and equals the central one.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
build=$root/build/net-demo
do_build=1 rate=50 memq=0 realtime=0
# the host's centre is sized by its build's DKF_MAX_DIM (docs/decisions.md, item 23):
# 200 nodes of make_net_scenario.py stack 616 measurements (seed 200)
maxdim=1024
URL='udpm://239.255.76.67:7667?ttl=0'

while [[ $# -gt 0 ]]; do
  case $1 in
    --build-dir) build=$(realpath -m "$2"); shift 2 ;;
    --no-build) do_build=0; shift ;;
    --rate) rate=$2; shift 2 ;;
    --memq) memq=1; shift ;;
    --realtime) realtime=1; shift ;;
    --inner) shift; break ;;   # internal: run one scenario inside the namespace
    -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"; exit 0 ;;
    *) echo "net_demo.sh: $1: unknown option (see --help)" >&2; exit 2 ;;
  esac
done

# ---- inside the namespace: one scenario, every process separate -------------
if [[ ${1:-} != "" && ${DKF_DEMO_INNER:-0} == 1 ]]; then
  scn=$1 out=$2 bin=$3 rate=$4 keys=$5 m4img=${6:-}
  # node messages and each node's measurements on ports of their own: a process
  # wakes only for what it reads (docs/guide/network.md, "Split ports"); each reads its
  # sockets itself, one wake-up per datagram instead of LCM's two ("Direct receive")
  opts=(--key-dir "$keys" --split-ports --direct-recv)
  # --realtime: FIFO priority (root), a woken process runs at once instead of queueing
  # behind the ordinary load (docs/design/network.md, "Where the latency goes")
  rt=()
  if [[ ${DKF_DEMO_RT:-0} == 1 ]]; then
    if chrt -f 20 true 2>/dev/null; then rt=(chrt -f 20)
    else echo "net_demo.sh: --realtime: chrt -f 20 refused; ordinary priority" >&2; fi
  fi
  if ip -o link | grep -qv ': lo:'; then
    echo "net_demo.sh: the namespace has a non-loopback interface; refusing" >&2; exit 1
  fi
  nodes=$(python3 -c 'import json,sys; m=json.load(open(sys.argv[1]))["model"]; print(len(m.get("sensors",[0])))' "$scn")
  pids=()
  trap 'for p in "${pids[@]}"; do kill $p 2>/dev/null || true; done' EXIT
  "${rt[@]}" "$bin/dkf-fusion" --url "$URL" --timeout 120 --quiet "${opts[@]}" --ready-file "$out.fusion.ready" \
    --output "$out.fused.json" "$scn" & pids+=($!); fpid=$!
  for ((i = 0; i < nodes; ++i)); do
    node=("$bin/dkf-node")
    # the m4node row: the last node on the emulated Cortex-M4F (dkf-m4-bridge)
    [[ -n $m4img && $i == $((nodes - 1)) ]] && node=("$bin/dkf-m4-bridge" --image "$m4img")
    "${rt[@]}" "${node[@]}" --url "$URL" --id $i --timeout 120 --quiet "${opts[@]}" "$scn" & pids+=($!)
  done
  for ((i = 0; i < 1000; ++i)); do [[ -e $out.fusion.ready ]] && break; sleep 0.01; done
  pace=(--rate "$rate")
  [[ $rate == lockstep ]] && pace=(--lockstep)
  "${rt[@]}" "$bin/dkf-sim" --url "$URL" "${pace[@]}" --timeout 120 --quiet "${opts[@]}" "$scn"
  wait $fpid
  for p in "${pids[@]:1}"; do wait $p; done
  exit 0
fi

# ---- dependencies and build ------------------------------------------------------
if (( do_build )); then
  . "$here/progress.sh"
  # installs what is missing when root, else prints the command and stops;
  # the demo does not need the armhf cross libraries
  DKF_BOOTSTRAP_NO_ARMHF=1 "$root/tools/bootstrap.sh"
  echo "== building dkf in $build (DKF_MAX_DIM = $maxdim: the 50- and 200-node centres;"
  echo "   a few minutes the first time, progress below, full log $build/net_demo.build.log)"
  step_t0=$SECONDS
  say build "configuring"
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DDKF_MAX_DIM="$maxdim" >/dev/null
  # every program of this demo and of the three below (their own builds are then no-ops)
  cmake --build "$build" -j2 --target dkf-run dkf-sim dkf-node dkf-fusion dkf-net-local \
    dkf-keygen dkf-tw-node dkf-m4-bridge 2>&1 | progress_build build "$build/net_demo.build.log"
  (( PIPESTATUS[0] == 0 )) || { echo "net_demo.sh: the build failed (see $build/net_demo.build.log)" >&2; exit 2; }
  say build "done"
fi
bin=$build/ports/linux/net
run=$build/ports/linux/dkf-run
for p in "$bin/dkf-sim" "$bin/dkf-node" "$bin/dkf-fusion" "$bin/dkf-net-local" "$bin/dkf-keygen" "$run"; do
  [[ -x $p ]] || { echo "net_demo.sh: $p missing (build first, or --build-dir)" >&2; exit 2; }
done
out=$build/net-demo
mkdir -p "$out"

# ---- scenarios ----------------------------------------------------------------
python3 "$here/make_net_scenario.py" --nodes 12 --steps 100 --seed 12 --out "$out/net12.json"
python3 "$here/make_net_scenario.py" --nodes 50 --steps 100 --seed 50 --max-dim "$maxdim" \
  --out "$out/net50.json"
python3 "$here/make_net_scenario.py" --nodes 200 --steps 50 --seed 200 --max-dim "$maxdim" \
  --out "$out/net200.json"
# the latency target (docs/design/network.md, "Where the latency goes"): the 12-node network
# again, 1000 steps at 100 Hz, so that its p99 is not just its first (cold) step
python3 "$here/make_net_scenario.py" --nodes 12 --steps 1000 --seed 12 --out "$out/lat12.json"
scenarios=("ex3:$root/tests/vectors/diffkf/ex3_multi.json" "net12:$out/net12.json"
           "net50:$out/net50.json" "net200:$out/net200.json" "lat12:$out/lat12.json")
# in one process over memq:// whatever the mode (200 node processes would be 200 LCM
# sockets each reading every datagram of the group: a 2-core machine's scheduler, not the centre)
export DKF_DEMO_INPROC="net200"
# 52 processes on a small machine: paced, a node starved past a step loses measurements and
# restarts (docs/design/network.md, "Load the fusion centre holds"); in lock step every step is whole
export DKF_DEMO_LOCKSTEP="net50"
# paced at a rate of its own (tag:Hz)
export DKF_DEMO_RATES="lat12:100"

mode=udpm
if (( memq )); then
  mode=memq
elif ! "$here/netns.sh" check 2>"$out/netns.err"; then
  echo "net_demo.sh: $(sed 's/^netns.sh: //' "$out/netns.err")"
  echo "net_demo.sh: the multicast demo needs a private network namespace (root), so that"
  echo "             nothing can leave this machine; running every agent in one process"
  echo "             over memq:// instead (same code, no sockets, no latency figures)."
  mode=memq
fi

for e in "${scenarios[@]}"; do
  tag=${e%%:*} scn=${e#*:}
  rm -f "$out/$tag".*.ready "$out/$tag.fused.json"
  echo "== $tag: $(python3 -c 'import json,sys; print(json.load(open(sys.argv[1])).get("scenario",""))' "$scn")"
  if [[ $mode == udpm && " $DKF_DEMO_INPROC " != *" $tag "* ]]; then
    r=$rate
    [[ " $DKF_DEMO_LOCKSTEP " == *" $tag "* ]] && r=lockstep
    for tr in $DKF_DEMO_RATES; do [[ ${tr%%:*} == "$tag" ]] && r=${tr#*:}; done
    # every datagram authenticated (docs/guide/network.md, Authentication): a key per node
    nn=$(python3 -c 'import json,sys; print(len(json.load(open(sys.argv[1]))["model"]["sensors"]))' "$scn")
    "$bin/dkf-keygen" "$out/keys-$tag" "$nn"
    DKF_DEMO_INNER=1 DKF_DEMO_RT=$realtime "$here/netns.sh" exec -- "$0" --inner "$scn" "$out/$tag" "$bin" "$r" \
      "$out/keys-$tag"
  else
    "$bin/dkf-net-local" --quiet --output "$out/$tag.fused.json" "$scn"
  fi
  "$run" --filter dkf --quiet --output "$out/$tag.central.json" "$scn"
done

# ---- m4node: Example 3 again, node 1 on the emulated Cortex-M4F ---------------------
# (docs/guide/network.md, "A firmware node in the network"): ports/cortex-m4's live image
# of this build's DKF_REAL under qemu-system-arm, fed and published by dkf-m4-bridge
m4skip=""
if ! command -v qemu-system-arm >/dev/null; then m4skip="no qemu-system-arm"
elif [[ $mode != udpm ]]; then m4skip="needs the multicast processes (root)"
elif [[ ! -x $bin/dkf-m4-bridge ]]; then m4skip="$bin/dkf-m4-bridge not built"
else
  m4dir=$build/m4-live
  real=$(sed -n 's/^DKF_REAL:[A-Z]*=//p' "$build/CMakeCache.txt")
  if command -v arm-none-eabi-gcc >/dev/null &&
     { [[ -f $m4dir/CMakeCache.txt ]] || cmake -S "$root/ports/cortex-m4" -B "$m4dir" -DDKF_REAL="${real:-double}"; } \
       >"$m4dir.log" 2>&1 && cmake --build "$m4dir" -j2 --target dkf_m4_live >>"$m4dir.log" 2>&1; then
    tag=m4node scn=$root/tests/vectors/diffkf/ex3_multi.json
    echo "== $tag: Example 3, node 1 on the emulated Cortex-M4F (qemu-system-arm -M mps2-an386)"
    rm -f "$out/$tag".*.ready "$out/$tag.fused.json"
    "$bin/dkf-keygen" "$out/keys-$tag" 2
    DKF_DEMO_INNER=1 DKF_DEMO_RT=$realtime "$here/netns.sh" exec -- "$0" --inner "$scn" "$out/$tag" "$bin" "$rate" \
      "$out/keys-$tag" "$m4dir/dkf_m4_live.elf"
    "$run" --filter dkf --quiet --output "$out/$tag.central.json" "$scn"
    scenarios+=("$tag:$scn")
  else
    m4skip="the live image did not build (arm-none-eabi-gcc; $m4dir.log)"
  fi
fi
export DKF_DEMO_M4="m4node" DKF_DEMO_M4_SKIP="$m4skip"

# ---- the table ------------------------------------------------------------------
python3 - "$mode" "$rate" "$out" "${scenarios[@]}" <<'PY'
import json, os, sys
import numpy as np
mode, rate, out = sys.argv[1], sys.argv[2], sys.argv[3]
inproc = set(os.environ.get("DKF_DEMO_INPROC", "").split())
lockstep = set(os.environ.get("DKF_DEMO_LOCKSTEP", "").split())
rates = dict(e.split(":", 1) for e in os.environ.get("DKF_DEMO_RATES", "").split())
m4 = set(os.environ.get("DKF_DEMO_M4", "").split())
ok = True
rows, parts, auths = [], [], []
for e in sys.argv[4:]:
    tag, scn = e.split(":", 1)
    s = json.load(open(scn))
    fu = json.load(open(f"{out}/{tag}.fused.json"))
    ce = json.load(open(f"{out}/{tag}.central.json"))["outputs"]["central"]
    f = fu["outputs"]["fused"]
    N = s["N"]
    tk = s["truth"]["k"]
    truth = {k: np.array(x) for k, x in zip(tk, s["truth"]["x"])}
    X = np.array([truth[k] for k in fu["k"]])
    rmse = lambda xf: float(np.sqrt(np.mean((np.array(xf)[: len(X)] - X) ** 2)))
    dmax = 0.0
    for key in ("xf", "xp", "Pf", "Pp"):
        a, b = np.array(f[key]), np.array(ce[key])[: len(f[key])]
        dmax = max(dmax, float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b))))))
    c = fu["counters"]
    sent, lost, rej = sum(c["sent_by_node"]), sum(c["not_received"]), c["rejected"]
    lat = np.array([v for v in fu["latency_us"]["first"] if v >= 0]) / 1000.0
    procs = mode == "udpm" and tag not in inproc
    p50, p99 = (np.percentile(lat, 50), np.percentile(lat, 99)) if procs else (None, None)
    degraded = sum(1 for st in fu["status"] if st != "complete")
    complete = len(fu["k"]) == N and degraded == 0
    au = fu.get("auth", {"mode": "off", "datagrams": {}})
    au_rej = sum(v for r, v in au["datagrams"].items() if r != "accepted")
    good = complete and dmax <= 1e-9 and (not procs or (au["mode"] != "off" and au_rej == 0))
    ok &= good
    auths.append((tag, au["mode"], au["datagrams"].get("accepted", 0), au_rej))
    rows.append((tag, len(s["model"]["sensors"]), N, rmse(f["xf"]), rmse(ce["xf"]), dmax,
                 sent, lost, rej, degraded, p50, p99,
                 ("ok" if good else "FAIL") + ("" if procs else " (one process, memq://)")
                 + (" (lock step)" if procs and tag in lockstep else "")
                 + (f" ({rates[tag]} Hz)" if procs and tag in rates else "")
                 + (" (node 1 on the emulated Cortex-M4F)" if tag in m4 else "")))
    lp = fu["latency_us"]["last_parts"]
    parts.append((tag, procs, [("last", fu["latency_us"]["last"])] + [(w, lp[w]) for w in
                                                              ("arrive", "wait", "compute", "publish")]))
print()
print(f"transport: {'udpm://239.255.76.67:7667?ttl=0 in a private network namespace' if mode == 'udpm' else 'memq:// (one process)'}"
      + (f", dkf-sim --rate {rate}" if mode == "udpm" else ""))
hdr = ("scenario", "nodes", "N", "fused RMSE", "central RMSE", "max|fused-central|",
       "sent", "lost", "rejected", "degraded", "latency p50", "p99", "")
print(f"{hdr[0]:<9}{hdr[1]:>6}{hdr[2]:>5}{hdr[3]:>12}{hdr[4]:>14}{hdr[5]:>20}{hdr[6]:>6}{hdr[7]:>6}{hdr[8]:>9}{hdr[9]:>9}{hdr[10]:>13}{hdr[11]:>9}")
for r in rows:
    lat = (f"{r[10]:10.3f} ms{r[11]:7.3f} ms" if r[10] is not None else f"{'-':>13}{'-':>9}")
    print(f"{r[0]:<9}{r[1]:>6}{r[2]:>5}{r[3]:>12.6f}{r[4]:>14.6f}{r[5]:>20.2e}{r[6]:>6}{r[7]:>6}{r[8]:>9}{r[9]:>9}{lat}  {r[12]}")
if os.environ.get("DKF_DEMO_M4_SKIP"):
    print(f"{'m4node':<9}  skipped: {os.environ['DKF_DEMO_M4_SKIP']}")
print("(max|fused-central| is relative: max|a-b| / max(1, max|b|) over xf, xp, Pf, Pp;"
      " sent/lost/rejected count node messages at the fusion centre; degraded: steps not"
      " complete in the end (docs/design/network.md, Faults);"
      " latency: measurement publication -> fused publication, oldest measurement of the step)")
print("authentication at the fusion centre: " + "; ".join(
    f"{t} {m}" + (f" ({a} datagrams accepted, {r} rejected)" if m != "off" else " (in process)")
    for t, m, a, r in auths))
print()
print("where the latency goes, p50 / p99 in us over the steps (docs/design/network.md, 'Where the latency goes'):")
print(f"{'scenario':<9}" + "".join(f"{w:>18}" for w, _ in parts[0][2]))
for tag, procs, cols in parts:
    cells = []
    for w, v in cols:
        a = np.array([x for x in v if x >= 0], dtype=float)
        shown = w == "compute" or procs
        cells.append(f"{np.percentile(a, 50):>9.0f} /{np.percentile(a, 99):>7.0f}"
                     if shown and len(a) else f"{'-':>18}")
    print(f"{tag:<9}" + "".join(cells))
print("(last: the step's newest measurement -> fused publication = arrive + wait + compute + publish;"
      " arrive: -> its node message at the centre (the node's wake-up and step, two LCM hops);"
      " wait: -> the centre starts the step; compute: the fusion-centre step itself, per step)")
sys.exit(0 if ok else 1)
PY

# ---- seed-003 graph filters, one process per node (tools/tw_net_demo.sh) ----------
# Added for the graph-filter processes: same build directory, same transport rule
# (namespace when root, else the in-process simulation only).
tw_args=(--build-dir "$build")
(( do_build )) || tw_args+=(--no-build)
(( memq )) && tw_args+=(--in-process)
echo
echo "== seed-003 diffusion / consensus filters, one process per node"
"$here/tw_net_demo.sh" "${tw_args[@]}"

# ---- seed 001's 12 radars, one process per node (tools/seed001_net_demo.sh) ---------
s001_args=(--build-dir "$build")
(( do_build )) || s001_args+=(--no-build)
(( memq )) && s001_args+=(--in-process)
echo
echo "== seed 001: DF-DNERTSIF on 12 radars, one process per node"
"$here/seed001_net_demo.sh" "${s001_args[@]}"

# ---- seed 002's 5 sensors, weighted fusion (tools/seed002_net_demo.sh) --------------
s002_args=(--build-dir "$build")
(( do_build )) || s002_args+=(--no-build)
(( memq )) && s002_args+=(--in-process)
echo
echo "== seed 002: weighted fusion of 5 local Kalman filters, one process per sensor"
"$here/seed002_net_demo.sh" "${s002_args[@]}"
