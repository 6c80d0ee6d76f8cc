#!/usr/bin/env bash
# net_faults.sh MODE SCENARIO OUTDIR - fault runs of the real processes over
# UDP multicast (udpm://239.255.76.67:7667?ttl=0) inside a private network
# namespace made for this run (tools/netns.sh); docs/network.md, "Faults".
# dkf-sim runs in lock-step, so every outcome is deterministic; the fusion
# centre's deadline is short (DEADLINE_MS) so that degraded steps are quick.
#
#   drop        node 1 drops 20 % of its messages (seed 3): isolated drops are
#               recovered by the next message's copy (a revision); two in a
#               row lose a payload: exactly steps 40, 41 and 44, 45 degraded
#   dupreorder  both nodes duplicate and reorder messages: every step complete
#               and equal to the full-data centralized DKF in the end
#   restart     node 1 dies at step 15 (--exit-at), a new node-1 process joins
#               at step 25 with epoch 1: node 1 absent exactly on 15..24
#   absent      node 1 never starts: every step degraded, node 0 alone
#   late        node 1 is started after the others and joins at step 20
#   hostile     net_inject publishes 3 bursts of 12 invalid messages during the
#               run: all rejected and counted by reason, fused output identical
#               (bit for bit) to a clean run
# Every mode: every step published; fused == the centralized DKF given the
# rows the fusion centre used (check_faults.py, numpy, independent of the C
# library) within DKF_REL; steps before the first lost row == the full-data
# filter.
#
# Environment (set by ctest): DKF_SIM DKF_NODE DKF_FUSION DKF_INJECT DKF_PYTHON
# DKF_NETNS DKF_REL DKF_CHECK. Exit 77 (skip) when not root (or no numpy);
# every process has its own --timeout, ctest a TIMEOUT.
set -uo pipefail
mode=$1 scn=$2 out=$3
URL='udpm://239.255.76.67:7667?ttl=0'
T=60            # per-process timeout, seconds
DEADLINE_MS=150 # fusion deadline per step

if [[ ${DKF_IN_NETNS:-0} != 1 ]]; then
  "$DKF_NETNS" check || exit $?
  "$DKF_PYTHON" -c 'import numpy' 2>/dev/null || { echo "SKIP: numpy missing (check_faults.py)"; exit 77; }
  DKF_IN_NETNS=1 exec "$DKF_NETNS" exec -- "$0" "$@"
fi

# Inside the namespace: refuse to run if anything but loopback exists.
if ip -o link | grep -qv ': lo:'; then
  echo "FAIL: the namespace has a non-loopback interface; not sending anything" >&2
  exit 1
fi

rm -rf "$out" && mkdir -p "$out"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; wait 2>/dev/null; }
trap cleanup EXIT

wait_file() { # FILE SECONDS
  local i
  for ((i = 0; i < $2 * 100; ++i)); do [[ -e $1 ]] && return 0; sleep 0.01; done
  echo "FAIL: $1 did not appear within $2 s" >&2; return 1
}

fusion() { # TAG
  "$DKF_FUSION" --url "$URL" --timeout $T --deadline-ms $DEADLINE_MS \
    --ready-file "$out/$1.fusion.ready" --output "$out/$1.fused.json" "$scn" \
    2>"$out/$1.fusion.log" & pids+=($!); fpid=$!
  wait_file "$out/$1.fusion.ready" 10
}

node() { # TAG ID [dkf-node options...]; sets npid
  local tag=$1 id=$2; shift 2
  "$DKF_NODE" --url "$URL" --id "$id" --timeout $T --ready-file "$out/$tag.n$id.ready" "$@" \
    "$scn" 2>>"$out/$tag.n$id.log" & pids+=($!); npid=$!
  wait_file "$out/$tag.n$id.ready" 10
}

sim() { # [dkf-sim options...]
  "$DKF_SIM" --url "$URL" --timeout $T --lockstep "$@" "$scn" || { echo "FAIL: dkf-sim exited $?"; return 1; }
}

finish() { # TAG PID... : waits for the fusion centre and the given nodes
  local tag=$1 rc=0 p; shift
  wait $fpid || { echo "FAIL: dkf-fusion exited $?"; rc=1; }
  for p in "$@"; do wait "$p" || { echo "FAIL: a dkf-node exited $?"; rc=1; }; done
  cat "$out/$tag".*.log
  return $rc
}

check() { # TAG [check_faults.py options...]
  local tag=$1; shift
  "$DKF_PYTHON" "$DKF_CHECK" "$out/$tag.fused.json" "$scn" --rel "$DKF_REL" "$@"
}

case "$mode" in
  drop)
    fusion run || exit 1
    node run 0 || exit 1; a=$npid
    node run 1 --drop 20 --seed 3 || exit 1; b=$npid
    sim || exit 1
    finish run $a $b || exit 1
    check run --selftest --degraded 40,41,44,45 --min-revised 5 || exit 1
    ;;
  dupreorder)
    fusion run || exit 1
    node run 0 --dup 30 --reorder 30 --seed 5 || exit 1; a=$npid
    node run 1 --dup 20 --reorder 20 --seed 6 || exit 1; b=$npid
    sim || exit 1
    finish run $a $b || exit 1
    check run --all-complete --min-revised 5 || exit 1
    "$DKF_PYTHON" - "$out/run.fused.json" <<'PY' || exit 1
import json, sys
f = json.load(open(sys.argv[1]))["counters"]["faults"]
assert f["duplicates"] > 0, f
print(f"duplicates counted and ignored: {f['duplicates']}")
PY
    ;;
  restart)
    fusion run || exit 1
    node run 0 || exit 1; a=$npid
    node run 1 --exit-at 15 || exit 1; b=$npid
    # the restarted process: started once the first one is gone, joins at 25
    (
      while kill -0 $b 2>/dev/null; do sleep 0.01; done
      exec "$DKF_NODE" --url "$URL" --id 1 --epoch 1 --join-at 25 --timeout $T \
        --ready-file "$out/run.n1b.ready" "$scn" 2>"$out/run.n1b.log"
    ) & pids+=($!); c=$!
    sim || exit 1
    finish run $a $b $c || exit 1
    check run --absent 1:15:24 || exit 1
    ;;
  absent)
    fusion run || exit 1
    node run 0 || exit 1; a=$npid
    sim --optional-node 1 || exit 1
    finish run $a || exit 1
    check run --never 1 || exit 1
    ;;
  late)
    fusion run || exit 1
    node run 0 || exit 1; a=$npid
    # node 1 starts after the others (0.3 s into the run: every step before
    # 20 waits for the deadline, so y_20 is still seconds away) and joins at 20
    (sleep 0.3; exec "$DKF_NODE" --url "$URL" --id 1 --join-at 20 --timeout $T "$scn" \
       2>"$out/run.n1.log") & pids+=($!); b=$!
    sim --optional-node 1 || exit 1
    finish run $a $b || exit 1
    check run --absent 1:1:19 || exit 1
    ;;
  hostile)
    for tag in clean hostile; do
      fusion $tag || exit 1
      node $tag 0 || exit 1; a=$npid
      node $tag 1 || exit 1; b=$npid
      if [[ $tag == hostile ]]; then
        "$DKF_INJECT" --url "$URL" --at 3 --at 20 --at 40 --timeout $T "$scn" \
          2>"$out/$tag.inject.log" & pids+=($!); inj=$!
        sleep 0.2 # the injector subscribes before the first fused step
      fi
      sim || exit 1
      finish $tag $a $b || exit 1
      if [[ $tag == hostile ]]; then
        wait $inj || { echo "FAIL: net_inject"; cat "$out/$tag.inject.log"; exit 1; }
        cat "$out/$tag.inject.log"
      fi
    done
    check clean --all-complete --no-rejects || exit 1
    check hostile --all-complete --compare "$out/clean.fused.json" \
      --rejected malformed=12 --rejected "unknown node=6" --rejected "wrong model id=3" \
      --rejected "wrong dimension=3" --rejected "step out of range=6" \
      --rejected "non-finite number=6" || exit 1
    ;;
  *)
    echo "net_faults.sh: $mode: unknown mode" >&2; exit 2
    ;;
esac
echo "PASS: $mode"
