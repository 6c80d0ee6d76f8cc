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
nodes=36 steps=40
# URL, demo_options, demo_tw_programs, demo_mode, loopback_only, start_run, run_tw_nodes,
# demo_timed, demo_processes, demo_auth_exit
. "$(dirname "$0")/../ports/linux/net/tests/net_common.sh"
demo_options tw_net_demo.sh 22 tw-net-demo "$@"
tools=$root/ports/linux/net/tests

# ---- inside the namespace (--inner): every node its own process --------------------
if [[ ${#inner[@]} -gt 0 && ${DKF_TW_DEMO_INNER:-0} == 1 ]]; then
  scn=${inner[0]} alg=${inner[1]} dir=${inner[2]} node=${inner[3]} keys=${inner[4]}
  loopback_only tw_net_demo.sh || exit 1
  N=$(python3 -c 'import json,sys; print(len(json.load(open(sys.argv[1]))["model"]["H"]))' "$scn")
  start_run "$dir"
  run_tw_nodes "$N" "$dir" "$node" "$scn" "$keys" --alg "$alg"
  exit $?
fi

demo_tw_programs tw_net_demo.sh
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

"$keygen" --edges "$out/keys" "$nodes" # a key per edge (docs/guide/network.md, Authentication)
demo_mode tw_net_demo.sh node "the in-process simulation (dkf-run --filter tw2|tw3)" "$out"

rows=()
for alg in 2 3; do
  demo_timed "$out/inproc$alg.wall" \
    "$run" --filter tw$alg --quiet --output "$out/inproc$alg.json" "$scn"
  demo_timed "$out/big$alg.wall" \
    "$run" --filter tw$alg --quiet --metrics-only --output "$out/big$alg.json" "$big"
  if [[ $mode == udpm ]]; then
    echo "== alg $alg: $nodes dkf-tw-node processes over $URL (namespace)"
    demo_processes tw_net_demo.sh DKF_TW_DEMO_INNER \
      "a node process failed (see $out/proc$alg/node*.log)" \
      "$scn" $alg "$out/proc$alg" "$node" "$out/keys"
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
demo_auth_exit $?
