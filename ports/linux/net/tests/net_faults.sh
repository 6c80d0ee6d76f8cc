#!/usr/bin/env bash
# net_faults.sh MODE SCENARIO OUTDIR - fault runs of the real processes over
# UDP multicast (udpm://239.255.76.67:7667?ttl=0) inside a private network
# namespace made for this run (tools/netns.sh); docs/design/network.md, "Faults".
# dkf-sim runs in lock-step, so every outcome is deterministic as long as a
# node that is only slow never meets a limit meant for one that is gone: the
# fusion centre's deadline (DEADLINE_MS) and the steps the run may go ahead
# of a node it gave up on (PACE) are derived from how loaded the machine is
# when the test starts (net_common.sh: 40 and 2 x the slowest start of
# dkf-node; the deadline at least 300 ms), so a quiet machine runs the modes
# quickly and a busy one only makes them longer.
#
#   drop        node 1 drops 20 % of its messages (seed 3): isolated drops are
#               recovered by the next message's copy (a revision); two in a
#               row lose a payload: exactly steps 40, 41 and 44, 45 degraded;
#               the run is recorded (lcm-logger) and check_log.py finds what
#               tools/dkf_monitor.py reports of the log (degraded steps, each
#               x_k|k) equal to the result file, and every fused message's
#               meas_utime_first/last a contributor's y_{k+1} publication
#   dupreorder  both nodes duplicate and reorder messages: every step complete
#               and equal to the full-data centralized DKF in the end
#   restart     node 1 dies at step 15 (--exit-at), a second node-1 process joins
#               at step 25 with epoch 1: node 1 absent exactly on 15..24
#   absent      node 1 never starts: every step degraded, node 0 alone
#   late        node 1 joins late, at step 20 (y_1..y_19 ignored)
#   hostile     net_inject publishes 3 bursts of 12 invalid messages during the
#               run: all rejected and counted by reason, fused output identical
#               (bit for bit) to a clean run
#   auth        an authenticated run (dkf-keygen, --key-dir everywhere) and the
#               same run with net_inject --auth sending 3 bursts of 8 datagrams
#               that must be refused: at the fusion centre's transport no
#               trailer, bad MAC, a node speaking for another, an unknown key,
#               a replay, a node's message on an alias of its channel
#               (_NODE_0001): 18 of 18 refused and counted by reason, nothing
#               reaches the codec; at the simulator a status signed by node 1
#               claiming to be the centre (FAILED) or node 0 (FAILED): 6 of 6
#               refused as "not its sender", the run not stopped; the fused
#               output identical (bit for bit) to the clean run
# At the demo's own settings (tools/net_demo.sh: the generated 12-node
# network, N = 100, dkf-sim --rate 50, --deadline-ms 1000; SCENARIO is then
# written by tools/make_net_scenario.py, DKF_GEN):
#   demo_dead   node 3 dies at step 40: it alone is missing, on 40..100 exactly,
#               every other node contributes at every step (a late step costs
#               no other step); the wall time is printed (not asserted)
#   demo_fcrestart  the fusion centre is killed (SIGKILL) after step 30 and a
#               new one started: the new one joins at the current step and
#               publishes every step from there to N, complete once it has
#               heard every node (the in-flight messages around the join may
#               be missed: how many depends on the load); the killed
#               one's journal holds its steps 1..K, each equal to the
#               centralized DKF
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
T=60            # per-process timeout, seconds
DEADLINE_FLOOR_MS=300 # the fusion deadline's least (150 ms gave extra degraded steps at load 8)

. "$(dirname "$0")/net_common.sh"
# the check before the namespace is made; then the rest runs inside it
needs_numpy check_faults.py
in_netns "$0" "$@"
start_run "$out"
DEADLINE_MS=$(derived_ms "$DKF_NODE" $DEADLINE_FLOOR_MS 40)

AUTH=() # --key-dir DIR for every process (mode auth)

fusion() { # TAG
  rm -f "$out/$1.fusion.ready"
  "$DKF_FUSION" --url "$URL" --timeout $T --deadline-ms $DEADLINE_MS "${AUTH[@]}" \
    --ready-file "$out/$1.fusion.ready" --output "$out/$1.fused.json" "$scn" \
    2>"$out/$1.fusion.log" & pids+=($!); fpid=$!
  wait_file "$out/$1.fusion.ready" $T
}

node() { # TAG ID [dkf-node options...]; sets npid
  local tag=$1 id=$2; shift 2
  "$DKF_NODE" --url "$URL" --id "$id" --timeout $T --ready-file "$out/$tag.n$id.ready" \
    "${AUTH[@]}" "$@" \
    "$scn" 2>>"$out/$tag.n$id.log" & pids+=($!); npid=$!
  wait_file "$out/$tag.n$id.ready" $T
}

# Lock-step, at most one step per 2 x the slowest start of dkf-node
# (net_common.sh, probe_ms): a node the centre gives up on while it is
# silent (its first message dropped, dead, not yet joined) makes it publish
# without waiting, and in lock-step alone the run would then go as fast as
# the other node, leaving a node that is only slow on a loaded machine more
# than the 8 revisable steps behind when it speaks; capped, it has 16 of
# those to speak in (measured: its next message 4.6 ms after the give-up,
# under six CPU-bound processes, when the run did 30 steps in that time).
probe=$(probe_ms "$DKF_NODE")
PACE=(--lockstep --rate "$(awk -v p="$probe" 'BEGIN { printf "%.3f", 1000 / (2 * p) }')"
      --step-timeout $T)
echo "lock-step at most ${PACE[2]} steps/s (a step per 2 x ${probe} ms)"
simtag=run # sim's log: $out/$simtag.sim.log
sim() { # [dkf-sim options...]
  "$DKF_SIM" --url "$URL" --timeout $T "${PACE[@]}" "${AUTH[@]}" "$@" "$scn" \
    2>"$out/$simtag.sim.log" || { echo "FAIL: dkf-sim exited $?"; cat "$out/$simtag.sim.log"; return 1; }
}

finish() { # TAG PID... : waits for the fusion centre and the given nodes
  local tag=$1 rc=0 p; shift
  wait $fpid || { echo "FAIL: dkf-fusion exited $?"; rc=1; }
  for p in "$@"; do wait "$p" || { echo "FAIL: a dkf-node exited $?"; rc=1; }; done
  cat "$out/$tag".*.log
  return $rc
}

demo_scenario() { # the 12-node network of tools/net_demo.sh, at its settings
  scn=$out/net12.json
  "$DKF_PYTHON" "$DKF_GEN" --nodes 12 --steps 100 --seed 12 --out "$scn" || exit 1
  DEADLINE_MS=$(derived_ms "$DKF_NODE" 1000 40)
}

nodes12() { # TAG [ID OPTION...]: nodes 0..11, node ID with the options; sets npids
  local tag=$1 i; shift
  npids=()
  for ((i = 0; i < 12; ++i)); do
    if [[ $# -gt 0 && $1 == "$i" ]]; then node "$tag" "$i" "${@:2}" || return 1
    else node "$tag" "$i" || return 1; fi
    npids+=($npid)
  done
}

clean_and_injected() { # TAG [net_inject options...]: a clean run, then run TAG while
  local tag inj            # net_inject sends its bursts at steps 3, 20 and 40
  for tag in clean "$1"; do
    fusion $tag || return 1
    node $tag 0 || return 1; a=$npid
    node $tag 1 || return 1; b=$npid
    if [[ $tag != clean ]]; then
      "$DKF_INJECT" "${@:2}" --url "$URL" --at 3 --at 20 --at 40 --timeout $T "$scn" \
        2>"$out/$tag.inject.log" & pids+=($!); inj=$!
      sleep 0.2 # the injector subscribes before the first fused step
    fi
    simtag=$tag
    sim || return 1
    finish $tag $a $b || return 1
    if [[ $tag != clean ]]; then
      wait $inj || { echo "FAIL: net_inject"; cat "$out/$tag.inject.log"; return 1; }
      cat "$out/$tag.inject.log"
    fi
  done
}

check() { # TAG [check_faults.py options...]
  local f=$out/$1.fused.json; shift
  [[ $f == *.jsonl.fused.json ]] && f=${f%.fused.json}
  "$DKF_PYTHON" "$DKF_CHECK" "$f" "$scn" --rel "$DKF_REL" "$@"
}

case "$mode" in
  drop)
    logged=0
    if [[ -x ${DKF_LCM_LOGGER:-} ]] && "$DKF_PYTHON" -c 'import lcm' 2>/dev/null; then
      logged=1 log=$out/run.lcmlog
      start_logger "$URL" "$log"
    fi
    fusion run || exit 1
    node run 0 || exit 1; a=$npid
    node run 1 --drop 20 --seed 3 || exit 1; b=$npid
    if (( logged )); then # the heartbeats reach the log once the logger is subscribed
      for ((i = 0; i < 1000; ++i)); do [[ -s $log ]] && break; sleep 0.01; done
    fi
    sim || exit 1
    finish run $a $b || exit 1
    check run --selftest --degraded 40,41,44,45 --min-revised 5 || exit 1
    if (( logged )); then
      # the log of the run: what dkf_monitor.py / dkf_logplot.py make of it
      # equals the result file; meas_utime_* as docs/guide/network.md says
      wait_log_quiet "$log" $((20 * probe > 300 ? 20 * probe : 300))
      kill -INT $logger; wait $logger
      "$DKF_PYTHON" "$(dirname "$0")/check_log.py" "$log" "$out/run.fused.json" \
        --types "$DKF_LCM_PY" || exit 1
    else
      echo "note: lcm-logger or Python lcm missing: the log checks (check_log.py) not run"
    fi
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
    # The restarted process (epoch 1) is up before the run and joins at 25:
    # a process started only after the death could still be starting when
    # step 25 is 8 steps in the past.
    node run.b 1 --epoch 1 --join-at 25 || exit 1; c=$npid
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
    # node 1 ignores y_1..y_19 and joins at 20 (it is up before the run, for
    # the reason given under restart)
    node run 1 --join-at 20 || exit 1; b=$npid
    sim --optional-node 1 || exit 1
    finish run $a $b || exit 1
    check run --absent 1:1:19 || exit 1
    ;;
  hostile)
    clean_and_injected hostile || exit 1
    check clean --all-complete --no-rejects || exit 1
    check hostile --all-complete --compare "$out/clean.fused.json" \
      --rejected malformed=12 --rejected "unknown node=6" --rejected "wrong model id=3" \
      --rejected "wrong dimension=3" --rejected "step out of range=6" \
      --rejected "non-finite number=6" || exit 1
    ;;
  auth)
    keys=$out/keys
    "$DKF_KEYGEN" "$keys" 2 || { echo "FAIL: dkf-keygen"; exit 1; }
    AUTH=(--key-dir "$keys")
    clean_and_injected attacked --auth "$keys" || exit 1
    if grep -l UNAUTHENTICATED "$out"/*.log; then echo "FAIL: a process ran unauthenticated"; exit 1; fi
    check clean --all-complete --no-rejects || exit 1
    check attacked --all-complete --no-rejects --compare "$out/clean.fused.json" || exit 1
    "$DKF_PYTHON" - "$out/clean.fused.json" "$out/attacked.fused.json" <<'PY' || exit 1
import json, sys
clean, att = (json.load(open(p))["auth"] for p in sys.argv[1:])
want = {"no trailer": 3, "bad MAC": 3, "foreign": 3, "unknown key": 3, "replayed": 3,
        "bad channel": 3}
assert clean["mode"] == att["mode"] == "hmac-sha512-256", (clean, att)
assert all(v == 0 for r, v in clean["datagrams"].items() if r != "accepted"), clean
got = {r: v for r, v in att["datagrams"].items() if r != "accepted"}
assert got == want, got
print(f"authenticated: {clean['datagrams']['accepted']} datagrams accepted in the clean run; "
      f"attacked: {sum(got.values())} of 18 injected rejected ({got}), "
      f"{att['datagrams']['accepted']} accepted, fused output identical")
PY
    # the simulator refused every impostor status (6) and went on
    grep -q 'refused: not its sender=6\b' "$out/attacked.sim.log" ||
      { echo "FAIL: dkf-sim did not refuse the 6 impostor statuses:"; cat "$out/attacked.sim.log"; exit 1; }
    if grep -q 'refused:' "$out/clean.sim.log"; then
      echo "FAIL: the clean run's simulator refused something:"; cat "$out/clean.sim.log"; exit 1
    fi
    grep 'refused:' "$out/attacked.sim.log"
    ;;
  demo_dead)
    demo_scenario
    fusion run || exit 1
    nodes12 run 3 --exit-at 40 || exit 1
    t0=$(date +%s%N)
    "$DKF_SIM" --url "$URL" --timeout $T --rate 50 "$scn" || { echo "FAIL: dkf-sim exited $?"; exit 1; }
    finish run "${npids[@]}" || exit 1
    echo "wall time of the run (dkf-sim start to the fused step N): $(( ($(date +%s%N) - t0) / 1000000 )) ms"
    check run --absent 3:40:100 --others-complete 3 || exit 1
    ;;
  demo_fcrestart)
    demo_scenario
    fusion first || exit 1; first=$fpid
    nodes12 run || exit 1
    "$DKF_SIM" --url "$URL" --timeout $T --rate 50 "$scn" & pids+=($!); spid=$!
    # kill the centre once its journal holds step 30 (header line + 30 steps)
    for ((i = 0; i < 1000; ++i)); do
      [[ -e $out/first.fused.json.jsonl ]] && (( $(wc -l <"$out/first.fused.json.jsonl") > 30 )) && break
      sleep 0.01
    done
    kill -KILL $first; wait $first 2>/dev/null
    fusion second || exit 1
    wait $spid || { echo "FAIL: dkf-sim exited $?"; exit 1; }
    finish second "${npids[@]}" || exit 1
    [[ ! -e $out/first.fused.json ]] || { echo "FAIL: the killed centre wrote its result file"; exit 1; }
    echo "killed centre: journal of $(( $(wc -l <"$out/first.fused.json.jsonl") - 1 )) lines"
    check first.fused.json.jsonl --journal --all-complete || exit 1
    join=$("$DKF_PYTHON" -c 'import json,sys; print(json.load(open(sys.argv[1]))["joined_at"])' \
           "$out/second.fused.json")
    echo "restarted centre joined at step $join"
    (( join > 1 )) || { echo "FAIL: the restarted centre did not join mid-run (joined_at $join)"; exit 1; }
    check second --complete-once-heard || exit 1
    ;;
  *)
    echo "net_faults.sh: $mode: unknown mode" >&2; exit 2
    ;;
esac
echo "PASS: $mode"
