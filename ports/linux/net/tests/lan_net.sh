#!/usr/bin/env bash
# lan_net.sh MODE OUTDIR - dkf-sim, dkf-fusion and 12 dkf-node processes on an
# emulated LAN of several hosts (docs/guide/network.md, "Several hosts"):
# every process runs with --lan and keys over a ttl=0 udpm URL, which --lan
# sends with one hop (ttl=1; with ttl=0 nothing would cross the bridge, so the
# run passing shows it), and only inside the namespaces this script makes.
#
# The LAN: 4 host namespaces (dkflan-h0..h3), each with one veth (eth0,
# 10.201.0.<h+1>/24, the route 239.0.0.0/8 dev eth0) into a bridge (br0) that
# lives in a namespace of its own (dkflan-br). The whole test runs inside
# `unshare -m -n` (a private mount namespace, /run/netns a tmpfs of its own, and
# a network namespace of its own), so no real interface, link or route is ever
# touched and every namespace disappears with the test, whatever ends it; the
# trap also kills the processes and deletes the namespaces on every exit.
# Host 0 runs dkf-fusion and dkf-sim (every key: node-<i>.key and infra.key),
# hosts 1..3 run nodes 0-3, 4-7, 8-11, each host with only its own nodes'
# node-<i>.key. The scenario is the demo's generated 12-node network
# (tools/make_net_scenario.py --nodes 12 --steps 100 --seed 12).
#
#   hosts   lock-step: every step complete, all 12 nodes, fused == the numpy
#           centralized DKF (check_faults.py --all-complete), every datagram
#           authenticated, nothing refused; datagrams crossed the bridge; a node
#           given another host's key directory refuses to start
#   loss    nftables in every host namespace drops P = 3 % of the UDP datagrams
#           going out of eth0 and P % of those coming in (numgen random mod 100
#           < P; the netdev egress and ingress hooks of eth0: lost on the wire,
#           as a LAN loses them, whereas a drop in the output hook would fail
#           the sender's sendto with EPERM), paced at 50 Hz: every step published, fused == the masked centralized
#           DKF given the rows the centre used (check_faults.py), drops counted
#           at every host, node messages recovered from their successor's copy
#           and nodes restarted after a lost measurement (the draws are the
#           kernel's, not seeded: every assertion holds for any draw but these
#           two counts, which are 0 with a probability below 1e-30). A node whose y_{N+1} was dropped never finishes step
#           N: once the centre is done it is stopped (exit 4 accepted here only)
#   cut     paced at 50 Hz; host 3 is cut off the bridge (its veth moved off
#           br0, eth0 stays up) after step 30 for 0.6 s and reconnected: its
#           nodes rejoin (contribute again at step N), every node of hosts 1
#           and 2 contributes at every step, fused == the masked centralized DKF
#   clock   as hosts, twice: without offsets, then with every process's clock
#           off by its own amount (--clock-offset-ms: the centre -3600 s,
#           dkf-sim +600 s, node i (i - 7) s): both runs complete, the fused
#           estimates identical (bit for bit); the centre's result file names the
#           clock of its latencies and its offset, and its latencies moved by
#           the offsets' difference
#
# Environment (set by ctest): DKF_SIM DKF_NODE DKF_FUSION DKF_KEYGEN DKF_PYTHON
# DKF_NETNS DKF_GEN DKF_CHECK DKF_REL. Exit 77 (skip) when not root, without
# numpy, or (loss) without nft; every process has its own --timeout.
set -uo pipefail
mode=$1 out=$2
T=60           # per-process timeout, seconds
HOSTS=4 NODES=12 PER=4 # host 0: the centre and the simulator; host h > 0: nodes PER*(h-1)..
LOSS=3         # loss mode: % of the UDP datagrams dropped each way at every host
BR=dkflan-br

. "$(dirname "$0")/net_common.sh"
URL='udpm://239.255.76.67:7667?ttl=0' # --lan sends it with one hop (ttl=1): across the bridge

# ---- outside: the checks, then the rest in a private mount + network namespace ----------
if [[ ${DKF_IN_LAN:-0} != 1 ]]; then
  needs_numpy check_faults.py
  "$DKF_NETNS" check || exit $?
  if [[ $mode == loss ]] && ! command -v nft >/dev/null; then
    echo "SKIP: nft missing (nftables; tools/bootstrap.sh installs it)"; exit 77
  fi
  if ! unshare -m -n --propagation private true 2>/dev/null; then
    echo "SKIP: unshare -m -n is not permitted here"; exit 77
  fi
  mkdir -p /run/netns # ip's directory; ours is a tmpfs mounted over it, seen by us alone
  DKF_IN_LAN=1 exec unshare -m -n --propagation private "$0" "$@"
fi
mount -t tmpfs -o mode=0755 dkflan /run/netns || { echo "FAIL: cannot mount /run/netns"; exit 1; }
loopback_only FAIL || exit 1 # our own network namespace: nothing but lo before we start

hostns() { echo "dkflan-h$1"; }
# on HOST CMD...: CMD in the host's network namespace. A process started in the
# background is `nsenter --net=$(netns HOST) CMD... &` (nsenter execs CMD, so $!
# is the program's pid, whereas a function put in the background is a subshell).
netns() { echo "/run/netns/$(hostns "$1")"; }
on() { local h=$1; shift; nsenter --net="$(netns "$h")" "$@"; }

lan_down() {
  local h
  for ((h = 0; h < HOSTS; ++h)); do ip netns del "$(hostns $h)" 2>/dev/null; done
  ip netns del $BR 2>/dev/null
  return 0
}
cleanup() { kill_run; lan_down; }

lan_up() {
  local h ns
  ip netns add $BR && ip -n $BR link set lo up &&
    ip -n $BR link add br0 type bridge mcast_snooping 0 && ip -n $BR link set br0 up || return 1
  for ((h = 0; h < HOSTS; ++h)); do
    ns=$(hostns $h)
    ip netns add "$ns" &&
      ip -n $BR link add veth$h type veth peer name eth0 netns "$ns" &&
      ip -n $BR link set veth$h master br0 up &&
      ip -n "$ns" link set lo up &&
      ip -n "$ns" addr add 10.201.0.$((h + 1))/24 dev eth0 &&
      ip -n "$ns" link set eth0 up multicast on &&
      ip -n "$ns" route add 239.0.0.0/8 dev eth0 || return 1
  done
  echo "LAN: $HOSTS hosts (10.201.0.1-$HOSTS/24) on bridge br0 in $BR"
}

host_of() { echo $(( $1 / PER + 1 )); } # NODE: its host

# keys: every key in $out/keys (hosts 0: dkf-sim and dkf-fusion); host h > 0 gets
# $out/keys-h<h> with node-<i>.key of its own nodes only
make_keys() {
  local h i d
  "$DKF_KEYGEN" "$out/keys" $NODES || { echo "FAIL: dkf-keygen"; return 1; }
  for ((h = 1; h < HOSTS; ++h)); do
    d=$out/keys-h$h
    mkdir -m 700 "$d" || return 1
    for ((i = (h - 1) * PER; i < h * PER; ++i)); do cp -p "$out/keys/node-$i.key" "$d/" || return 1; done
  done
}

# ---- the run ----------------------------------------------------------------------------
start_run "$out"
trap cleanup EXIT
trap 'exit 1' INT TERM
lan_up || exit 1
make_keys || exit 1
scn=$out/net12.json
"$DKF_PYTHON" "$DKF_GEN" --nodes $NODES --steps 100 --seed 12 --out "$scn" || exit 1
DEADLINE_MS=$(derived_ms "$DKF_NODE" 1000 40)
probe=$(probe_ms "$DKF_NODE")
# lock-step, at most a step per 2 x the slowest start (net_faults.sh says why)
LOCKSTEP=(--lockstep --rate "$(awk -v p="$probe" 'BEGIN { printf "%.3f", 1000 / (2 * p) }')"
          --step-timeout $T)
PACED=(--rate 50)
CLK=() # clock mode: --clock-offset-ms of each process (clock_of)

clock_of() { # WHO: the --clock-offset-ms options of fusion, sim or node I (clock mode)
  (( ${#CLK[@]} )) || return 0
  case $1 in
    fusion) echo --clock-offset-ms -3600000 ;;
    sim) echo --clock-offset-ms 600000 ;;
    *) echo --clock-offset-ms $(( ($1 * 1000) - 7000 )) ;;
  esac
}

fusion() { # TAG
  nsenter --net="$(netns 0)" "$DKF_FUSION" --url "$URL" --lan --key-dir "$out/keys" --timeout $T \
    --deadline-ms "$DEADLINE_MS" $(clock_of fusion) --ready-file "$out/$1.fusion.ready" \
    --output "$out/$1.fused.json" "$scn" 2>"$out/$1.fusion.log" & pids+=($!); fpid=$!
  wait_file "$out/$1.fusion.ready" $T
}

nodes() { # TAG: nodes 0..NODES-1 on their hosts, each with its host's keys; sets npids
  local i h
  npids=()
  for ((i = 0; i < NODES; ++i)); do
    h=$(host_of $i)
    nsenter --net="$(netns "$h")" "$DKF_NODE" --url "$URL" --lan --key-dir "$out/keys-h$h" --id $i --timeout $T \
      $(clock_of $i) --ready-file "$out/$1.n$i.ready" "$scn" 2>"$out/$1.n$i.log" & pids+=($!)
    npids+=($!)
  done
  for ((i = 0; i < NODES; ++i)); do wait_file "$out/$1.n$i.ready" $T || return 1; done
}

sim() { # TAG OPTIONS...
  local tag=$1; shift
  on 0 "$DKF_SIM" --url "$URL" --lan --key-dir "$out/keys" --timeout $T $(clock_of sim) "$@" \
    "$scn" 2>"$out/$tag.sim.log" || { echo "FAIL: dkf-sim exited $?"; cat "$out/$tag.sim.log"; return 1; }
}

finish() { # TAG [STOPPED_OK]: waits for the centre, then the nodes (with STOPPED_OK=1 a
  local tag=$1 ok4=${2:-0} rc=0 p i=0 r # node still running 3 s later is stopped, exit 4 accepted)
  wait $fpid || { echo "FAIL: dkf-fusion exited $?"; rc=1; }
  if (( ok4 )); then
    sleep 3
    for p in "${npids[@]}"; do kill -TERM "$p" 2>/dev/null; done
  fi
  for p in "${npids[@]}"; do
    wait "$p"; r=$?
    if (( r != 0 && !(ok4 && r == 4) )); then echo "FAIL: node $i exited $r"; rc=1; fi
    ((++i))
  done
  pids=()
  cat "$out/$tag.fusion.log" "$out/$tag.sim.log"
  grep -h 'dkf-node' "$out/$tag".n*.log | grep -v 'done;' || true
  return $rc
}

check() { # TAG [check_faults.py options...]
  local tag=$1; shift
  "$DKF_PYTHON" "$DKF_CHECK" "$out/$tag.fused.json" "$scn" --rel "$DKF_REL" "$@"
}

authenticated() { # TAG: every process authenticated, nothing refused at the centre
  if grep -l UNAUTHENTICATED "$out/$1".*.log; then echo "FAIL: a process ran unauthenticated"; return 1; fi
  "$DKF_PYTHON" - "$out/$1.fused.json" <<'PY'
import json, sys
a = json.load(open(sys.argv[1]))["auth"]
assert a["mode"] == "hmac-sha512-256", a
bad = {r: v for r, v in a["datagrams"].items() if r != "accepted" and v}
assert not bad, f"datagrams refused: {bad}"
print(f"authenticated: {a['datagrams']['accepted']} datagrams accepted at the centre, none refused")
PY
}

crossed() { # every host's veth carried datagrams both ways (the run crossed the bridge)
  local h
  for ((h = 0; h < HOSTS; ++h)); do
    read -r rx tx < <(ip -n $BR -s -j link show veth$h | "$DKF_PYTHON" -c \
      'import json,sys; s=json.load(sys.stdin)[0]["stats64"]; print(s["rx"]["packets"], s["tx"]["packets"])')
    echo "host $h: $rx datagrams sent onto the bridge, $tx received from it"
    (( rx > 100 && tx > 100 )) || { echo "FAIL: host $h's traffic did not cross the bridge"; return 1; }
  done
}

case "$mode" in
  hosts)
    fusion run || exit 1
    nodes run || exit 1
    sim run "${LOCKSTEP[@]}" || exit 1
    finish run || exit 1
    check run --all-complete --no-rejects || exit 1
    authenticated run || exit 1
    crossed || exit 1
    # host 1 holds node 0..3's keys only: node 5 cannot start there
    on 1 "$DKF_NODE" --url "$URL" --lan --key-dir "$out/keys-h1" --id 5 --timeout 1 "$scn" \
      2>"$out/wrongkey.log"
    r=$?
    grep -q 'node-5.key' "$out/wrongkey.log" && (( r == 2 )) ||
      { echo "FAIL: node 5 on host 1 (exit $r):"; cat "$out/wrongkey.log"; exit 1; }
    echo "node 5 refused on host 1: $(cat "$out/wrongkey.log")"
    ;;
  loss)
    for ((h = 0; h < HOSTS; ++h)); do
      on $h nft -f - <<EOF || { echo "FAIL: nft on host $h"; exit 1; }
table netdev dkflan {
  chain in { type filter hook ingress device "eth0" priority 0; policy accept;
    ip protocol udp numgen random mod 100 < $LOSS counter drop; }
  chain out { type filter hook egress device "eth0" priority 0; policy accept;
    ip protocol udp numgen random mod 100 < $LOSS counter drop; }
}
EOF
    done
    fusion run || exit 1
    nodes run || exit 1
    sim run "${PACED[@]}" || exit 1
    finish run 1 || exit 1
    check run || exit 1
    # both kinds of loss happened: a node message lost and recovered from the next
    # one's copy of its payload, a measurement lost and its node restarted (mirrored)
    "$DKF_PYTHON" - "$out/run.fused.json" <<'PY' || exit 1
import json, sys
f = json.load(open(sys.argv[1]))["counters"]["faults"]
assert f["recovered_by_redundancy"] > 0 and f["restarts_applied"] > 0, f
print(f"node messages recovered from the next one's copy: {f['recovered_by_redundancy']}, "
      f"node restarts after a lost measurement mirrored: {f['restarts_applied']}")
PY
    for ((h = 0; h < HOSTS; ++h)); do
      d=$(on $h nft list table netdev dkflan | grep -o 'packets [0-9]*' | awk '{ s += $2 } END { print s + 0 }')
      echo "host $h: $d UDP datagrams dropped by nftables"
      (( d > 0 )) || { echo "FAIL: nothing dropped at host $h"; exit 1; }
    done
    ;;
  cut)
    fusion run || exit 1
    nodes run || exit 1
    nsenter --net="$(netns 0)" "$DKF_SIM" --url "$URL" --lan --key-dir "$out/keys" --timeout $T \
      "${PACED[@]}" "$scn" 2>"$out/run.sim.log" & pids+=($!); spid=$!
    journal=$out/run.fused.json.jsonl # a header line, then a line per step computed
    for ((i = 0; i < 3000; ++i)); do
      [[ -e $journal ]] && (( $(wc -l <"$journal") > 30 )) && break
      sleep 0.01
    done
    ip -n $BR link set veth3 nomaster || exit 1
    echo "host 3 cut off the bridge (the centre's journal: $(( $(wc -l <"$journal") - 1 )) steps)"
    sleep 0.6
    ip -n $BR link set veth3 master br0 || exit 1
    echo "host 3 reconnected (the centre's journal: $(( $(wc -l <"$journal") - 1 )) steps)"
    wait $spid || { echo "FAIL: dkf-sim exited $?"; cat "$out/run.sim.log"; exit 1; }
    finish run || exit 1
    check run --always "$(seq -s, 0 $((2 * PER - 1)))" \
      --rejoined "$(seq -s, $((2 * PER)) $((NODES - 1)))" || exit 1
    ;;
  clock)
    for tag in ref off; do # the same run without, then with the offsets
      [[ $tag == off ]] && CLK=(on)
      fusion $tag || exit 1
      nodes $tag || exit 1
      sim $tag "${LOCKSTEP[@]}" || exit 1
      finish $tag || exit 1
    done
    check ref --all-complete --no-rejects || exit 1
    check off --all-complete --no-rejects --compare "$out/ref.fused.json" || exit 1
    # The centre's latencies: its wall clock minus dkf-sim's measurement stamps.
    # With its clock 3600 s behind and dkf-sim's 600 s ahead they move by
    # -4200 s; no latency of a run can exceed its processes' timeout (T).
    "$DKF_PYTHON" - "$out/ref.fused.json" "$out/off.fused.json" $T <<'PY' || exit 1
import json, statistics, sys
ref, off = (json.load(open(p)) for p in sys.argv[1:3])
T = float(sys.argv[3]) * 1e6
assert ref["clock"] == {"latency_us": "CLOCK_REALTIME", "offset_us": 0}, ref["clock"]
assert off["clock"] == {"latency_us": "CLOCK_REALTIME", "offset_us": -3600 * 10**6}, off["clock"]
lr = [v for v in ref["latency_us"]["last"] if v != -1]
lo = [v for v in off["latency_us"]["last"] if v != -1]
assert len(lr) == len(lo) == ref["N"], (len(lr), len(lo))
assert all(abs(v) < T for v in lr), "a latency beyond the timeout without offsets"
assert all(abs(v + 4200e6) < T for v in lo), "latencies not on the offset clocks"
print(f"clock: {off['clock']}; median latency {statistics.median(lr) / 1e3:.1f} ms without "
      f"offsets, {statistics.median(lo) / 1e6:.3f} s with them (the centre 3600 s behind, "
      f"dkf-sim 600 s ahead); fused estimates identical")
PY
    ;;
  *)
    echo "lan_net.sh: $mode: unknown mode" >&2; exit 2
    ;;
esac
echo "PASS: $mode"
