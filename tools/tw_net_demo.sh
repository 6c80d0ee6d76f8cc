#!/usr/bin/env bash
# tools/tw_net_demo.sh - the seed-003 diffusion / consensus filters with one
# process per node over LCM, on this machine.
#
#   tools/tw_net_demo.sh [--build-dir DIR] [--no-build] [--nodes N] [--steps T]
#                        [--in-process]
#
# Builds dkf-tw-node and dkf-run, generates a random geometric graph with
# N nodes (default 36, fixed seed; ports/linux/net/tests/tw_make_scenario.py)
# and runs Algorithm 2 (diffusion) and Algorithm 3 (consensus, eta 10) with
# one dkf-tw-node process per node talking over UDP multicast
# udpm://239.255.76.67:7667?ttl=0 inside a private network namespace
# (tools/netns.sh; root only), so nothing can leave the machine; each node
# subscribes only to its neighbours' channels. The same scenario runs in
# process (dkf-run --filter tw2|tw3: the whole graph simulated by
# dkf_tw_net_*), and so does the full 200-node, 732-edge graph of the
# seed-003 vectors. Without root (or with --in-process) it says so and runs
# only the in-process simulations. Table: nodes, edges, steps, RMSE of the
# state and of the input against the truth, max |process - in-process|
# (relative, x P z; must be 0: the processes compute the same bits),
# packets and reals sent per node per step, retransmissions, wall time.
# Exit 0 only if every process run equals the in-process one.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
build=$root/build/tw-net-demo
do_build=1 nodes=36 steps=40 inproc=0
URL='udpm://239.255.76.67:7667?ttl=0'
tools=$root/ports/linux/net/tests

while [[ $# -gt 0 ]]; do
  case $1 in
    --build-dir) build=$(realpath -m "$2"); shift 2 ;;
    --no-build) do_build=0; shift ;;
    --nodes) nodes=$2; shift 2 ;;
    --steps) steps=$2; shift 2 ;;
    --in-process) inproc=1; shift ;;
    --inner) shift; break ;;   # internal: the processes, inside the namespace
    -h|--help) sed -n '2,24p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "tw_net_demo.sh: $1: unknown option (see --help)" >&2; exit 2 ;;
  esac
done

# ---- inside the namespace: every node its own process ------------------------------
if [[ ${1:-} != "" && ${DKF_TW_DEMO_INNER:-0} == 1 ]]; then
  scn=$1 alg=$2 dir=$3 node=$4 keys=$5
  if ip -o link | grep -qv ': lo:'; then
    echo "tw_net_demo.sh: the namespace has a non-loopback interface; refusing" >&2; exit 1
  fi
  N=$(python3 -c 'import json,sys; print(len(json.load(open(sys.argv[1]))["model"]["H"]))' "$scn")
  pids=()
  trap 'for p in "${pids[@]}"; do kill $p 2>/dev/null || true; done' EXIT
  rm -rf "$dir" && mkdir -p "$dir"
  t0=$(date +%s.%N)
  for ((i = 0; i < N; ++i)); do
    "$node" --url "$URL" --id $i --alg "$alg" --timeout 300 --quiet --key-dir "$keys" \
      --output "$dir/node$i.json" \
      "$scn" 2>"$dir/node$i.log" & pids+=($!)
  done
  rc=0
  for p in "${pids[@]}"; do wait "$p" || rc=1; done
  echo "$(date +%s.%N) - $t0" | bc > "$dir/wall_s"
  pids=()
  exit $rc
fi

if (( do_build )); then
  echo "== building dkf-tw-node, dkf-run in $build"
  cmake -S "$root" -B "$build" >/dev/null
  cmake --build "$build" -j2 --target dkf-tw-node dkf-run dkf-keygen >/dev/null
fi
node=$build/ports/linux/net/dkf-tw-node
run=$build/ports/linux/dkf-run
keygen=$build/ports/linux/net/dkf-keygen
for p in "$node" "$run" "$keygen"; do
  [[ -x $p ]] || { echo "tw_net_demo.sh: $p missing (build first, or --build-dir)" >&2; exit 2; }
done
out=$build/tw-net-demo
mkdir -p "$out"
scn=$out/rgg$nodes.json
python3 "$tools/tw_make_scenario.py" --nodes "$nodes" --steps "$steps" --seed 36 --eta 10 --out "$scn"
# the full 200-node, 732-edge graph of the seed-003 vectors, 100 simulated steps
# (tools/tw_example.py's model, input profile and simulation, seed 3)
big=$out/g200.json
python3 - "$root/tests/vectors/uif/s003_200node_alg1.json" "$big" "$root/tools" <<'PY'
import json, sys
sys.path.insert(0, sys.argv[3])
import tw_example
base = json.load(open(sys.argv[1]))
x, y, z = tw_example.simulate(base, 100, 3)
json.dump(tw_example.scenario(base, x, y, z, 100, 10), open(sys.argv[2], "w"))
PY

mode=udpm
"$keygen" --edges "$out/keys" "$nodes" # a key per edge (docs/network.md, Authentication)
if (( inproc )); then
  mode=inproc
elif ! "$here/netns.sh" check 2>"$out/netns.err"; then
  echo "tw_net_demo.sh: $(sed 's/^netns.sh: //' "$out/netns.err")"
  echo "tw_net_demo.sh: one process per node needs a private network namespace (root), so"
  echo "                that nothing can leave this machine; running the in-process"
  echo "                simulation (dkf-run --filter tw2|tw3) only."
  mode=inproc
fi

rows=()
for alg in 2 3; do
  t0=$(date +%s.%N)
  "$run" --filter tw$alg --quiet --output "$out/inproc$alg.json" "$scn"
  echo "$(date +%s.%N) - $t0" | bc > "$out/inproc$alg.wall"
  t0=$(date +%s.%N)
  "$run" --filter tw$alg --quiet --metrics-only --output "$out/big$alg.json" "$big"
  echo "$(date +%s.%N) - $t0" | bc > "$out/big$alg.wall"
  if [[ $mode == udpm ]]; then
    echo "== alg $alg: $nodes dkf-tw-node processes over $URL (namespace)"
    DKF_TW_DEMO_INNER=1 "$here/netns.sh" exec -- "$0" --inner "$scn" $alg "$out/proc$alg" "$node" \
      "$out/keys" ||
      echo "tw_net_demo.sh: a node process failed (see $out/proc$alg/node*.log)"
    python3 "$tools/tw_check.py" --scenario "$scn" --alg $alg --nodes-dir "$out/proc$alg" \
      --runner "$out/inproc$alg.json" --runner-rel 0 --json > "$out/proc$alg.check" || true
  fi
done

python3 - "$mode" "$out" "$scn" "$big" <<'PY'
import json, math, os, sys
mode, out, scn_path, big_path = sys.argv[1:5]
ok = True
def inproc_row(path, scn_path, wall):
    d = json.load(open(path)); o = d["outputs"]["alg" + d["filter"][-1]]
    scn = json.load(open(scn_path))
    mx = o["mse_x"]; mz = o["mse_z"]
    rx = math.sqrt(sum(sum(v) for v in mx) / sum(len(v) for v in mx))
    rz = math.sqrt(sum(sum(v) for v in mz) / sum(len(v) for v in mz))
    c = d["communication"]
    return dict(nodes=len(scn["model"]["H"]), edges=len(scn["graph"]["edges"]), steps=len(scn["steps"]),
                rmse_x=rx, rmse_z=rz, gap=None, pk=c.get("messages_per_node_step"),
                reals=c.get("reals_per_node_step"), rt=None, wall=float(open(wall).read()))
rows = []
for alg in (2, 3):
    name = os.path.basename(scn_path)[:-5]
    if mode == "udpm":
        try:
            c = json.load(open(f"{out}/proc{alg}.check"))
        except Exception:
            c = None
        if c is None:
            ok = False
            rows.append((f"alg{alg} {name} processes", None))
        else:
            ok &= c["ok"]
            rows.append((f"alg{alg} {name} processes", dict(
                nodes=c["nodes"], edges=c["edges"], steps=c["steps"], rmse_x=c["rmse_x"],
                rmse_z=c["rmse_z"], gap=c["gap_runner"], pk=c["packets_per_node_step"],
                reals=c["reals_per_node_step"], rt=c["retransmits"],
                wall=float(open(f"{out}/proc{alg}/wall_s").read()), ok=c["ok"])))
    rows.append((f"alg{alg} {name} in-process", inproc_row(f"{out}/inproc{alg}.json", scn_path, f"{out}/inproc{alg}.wall")))
    rows.append((f"alg{alg} 200-node in-process", inproc_row(f"{out}/big{alg}.json", big_path, f"{out}/big{alg}.wall")))
print()
print("transport: " + ("udpm://239.255.76.67:7667?ttl=0 in a private network namespace, one dkf-tw-node per node"
                       if mode == "udpm" else "none (in-process simulation only)"))
h = ("run", "nodes", "edges", "steps", "RMSE x", "RMSE z", "max|proc-inproc|", "pkts/node/step",
     "reals/node/step", "retransmits", "wall s")
print(f"{h[0]:<28}{h[1]:>6}{h[2]:>6}{h[3]:>6}{h[4]:>9}{h[5]:>9}{h[6]:>18}{h[7]:>16}{h[8]:>17}{h[9]:>12}{h[10]:>8}")
f = lambda v, fmt: "-" if v is None else format(v, fmt)
for name, r in rows:
    if r is None:
        print(f"{name:<28}  FAILED (no result)"); continue
    print(f"{name:<28}{r['nodes']:>6}{r['edges']:>6}{r['steps']:>6}{r['rmse_x']:>9.4f}{r['rmse_z']:>9.4f}"
          f"{f(r['gap'], '.2e'):>18}{f(r['pk'], '.1f'):>16}{f(r['reals'], '.1f'):>17}{f(r['rt'], 'd'):>12}"
          f"{r['wall']:>8.2f}" + ("" if r.get("ok", True) else "  FAIL"))
print("(RMSE: root mean over steps, nodes, components against the truth; z against z_{n-1}."
      " max|proc-inproc|: max over steps, nodes and x, P, z of |a-b| / max(1, max|b|);"
      " packets/reals: first publications per node per step (DONE and loss recovery excluded);"
      " the 200-node rows: the graph and sensors of s003_200node_alg1.json, 100 steps simulated by tools/tw_example.py, in process only)")
sys.exit(0 if ok else 1)
PY
rc=$?
if [[ $mode == udpm ]]; then # every process authenticated: nothing may be rejected
  python3 "$here/auth_summary.py" --what "a key per edge of the graph" "$out"/proc*/node*.json || rc=1
fi
exit $rc
