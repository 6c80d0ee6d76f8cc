#!/usr/bin/env bash
# net_integration.sh MODE SCENARIO OUTDIR - the network processes over real
# UDP multicast (udpm://239.255.76.67:7667?ttl=0) inside a private network
# namespace made for this run (tools/netns.sh): nothing can leave the host.
#
#   lockstep  dkf-sim --lockstep, 2 x dkf-node, dkf-fusion; fused == the
#             vector's central (and fused) series within DKF_REL
#   paced     the same with dkf-sim --rate 200
#   replay    a paced run (100 Hz) recorded by lcm-logger; the node channels of the
#             log replayed by lcm-logplayer into a fresh dkf-fusion must give
#             the same fused output bit for bit
#   split     the paced run with --split-ports on every process: fused == the
#             vector's central, and a logger on the URL's own port saw the
#             fused and status messages but no node message or measurement
#             (they went to the ports + 1 and + 2 + i)
#   direct    the split run with --direct-recv on dkf-fusion, node 0 and dkf-sim
#             (node 1 reads through LCM): fused == the vector's central; before
#             the run, datagrams LCM's format does not allow (short, bad magic,
#             channel without its NUL, empty channel), an LC03 fragment and an
#             LC02 of a channel nobody reads go to the centre's port, and its
#             result file counts each kind (docs/guide/network.md, "Direct receive")
#
# Environment (set by ctest): DKF_SIM DKF_NODE DKF_FUSION DKF_PYTHON
# DKF_COMPARE DKF_LCM_LOGGER DKF_LCM_LOGPLAYER DKF_NETNS DKF_REL DKF_LOGPLOT DKF_LCM_PY.
# Exit 77 (skip) when not root; every process has its own --timeout and the
# script as a whole is bounded by ctest's TIMEOUT.
set -uo pipefail
mode=$1 scn=$2 out=$3
T=60   # per-process timeout, seconds
# Every node runs in every mode, so no step needs its deadline: a stalled
# node (a loaded machine) only delays the run, as long as the process may run.
DEADLINE_MS=$((T * 1000))
SPLIT=()   # --split-ports in modes split and direct
DIRECT=()  # --direct-recv (mode direct: the centre, node 0 and the simulator)

. "$(dirname "$0")/net_common.sh"
in_netns "$0" "$@"
start_run "$out"
probe=$(probe_ms "$DKF_NODE")
quiet_ms=$((20 * probe > 300 ? 20 * probe : 300)) # the logger's (wait_log_quiet)

# Starts the fusion centre and both nodes, waits until they are subscribed.
start_peers() { # TAG
  "$DKF_FUSION" --url "$URL" "${SPLIT[@]}" "${DIRECT[@]}" --timeout $T --deadline-ms $DEADLINE_MS \
    --ready-file "$out/$1.fusion.ready" \
    --output "$out/$1.fused.json" "$scn" 2>"$out/$1.fusion.log" & pids+=($!); fpid=$!
  "$DKF_NODE" --url "$URL" "${SPLIT[@]}" "${DIRECT[@]}" --id 0 --timeout $T --ready-file "$out/$1.n0.ready" \
    "$scn" 2>"$out/$1.n0.log" & pids+=($!); n0=$!
  "$DKF_NODE" --url "$URL" "${SPLIT[@]}" --id 1 --timeout $T --ready-file "$out/$1.n1.ready" \
    "$scn" 2>"$out/$1.n1.log" & pids+=($!); n1=$!
  wait_file "$out/$1.fusion.ready" $T && wait_file "$out/$1.n0.ready" $T &&
    wait_file "$out/$1.n1.ready" $T
}

# Waits for the peers started by start_peers; fails if any failed.
wait_peers() { # TAG
  local rc=0
  wait $fpid || { echo "FAIL: dkf-fusion exited $?"; cat "$out/$1.fusion.log"; rc=1; }
  wait $n0 || { echo "FAIL: dkf-node 0 exited $?"; cat "$out/$1.n0.log"; rc=1; }
  wait $n1 || { echo "FAIL: dkf-node 1 exited $?"; cat "$out/$1.n1.log"; rc=1; }
  cat "$out/$1.fusion.log" "$out/$1.n0.log" "$out/$1.n1.log"
  return $rc
}

run_live() { # TAG SIM-MODE-ARGS...
  local tag=$1; shift
  start_peers "$tag" || return 1
  [[ -z ${BEFORE_SIM:-} ]] || $BEFORE_SIM || return 1
  "$DKF_SIM" --url "$URL" "${SPLIT[@]}" "${DIRECT[@]}" --timeout $T "$@" "$scn" ||
    { echo "FAIL: dkf-sim exited $?"; return 1; }
  wait_peers "$tag"
}

compare_central() { # FUSED.json
  "$DKF_PYTHON" "$DKF_COMPARE" "$1" "$scn" --a-keys outputs.fused --b-keys outputs.central \
    --rel "$DKF_REL" &&
  "$DKF_PYTHON" "$DKF_COMPARE" "$1" "$scn" --a-keys outputs.fused --b-keys outputs.fused \
    --rel "$DKF_REL" &&
  "$DKF_PYTHON" - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
n = d["N"]
assert len(d["k"]) == n, "not every step published"
assert all(s == "complete" for s in d["status"]), "a step is degraded"
assert all(len(c) == 2 for c in d["contributors"]), "a node is missing from a step"
assert d["counters"]["rejected"] == 0, d["counters"]
print("every step complete, both nodes contributed, nothing rejected")
PY
}

case "$mode" in
  lockstep)
    run_live live --lockstep || exit 1
    compare_central "$out/live.fused.json" || exit 1
    ;;
  paced)
    run_live live --rate 200 || exit 1
    compare_central "$out/live.fused.json" || exit 1
    ;;
  replay)
    [[ -x $DKF_LCM_LOGGER && -x $DKF_LCM_LOGPLAYER ]] ||
      { echo "FAIL: lcm-logger / lcm-logplayer not found"; exit 1; }
    log=$out/run.lcmlog
    start_logger "$URL" "$log"
    start_peers live || exit 1
    # the heartbeats reach the log only once the logger is subscribed
    for ((i = 0; i < 1000; ++i)); do [[ -s $log ]] && break; sleep 0.01; done
    [[ -s $log ]] || { echo "FAIL: lcm-logger recorded nothing"; exit 1; }
    # paced, not lock-step: a lock-step run sends its 300 datagrams within
    # ~30 ms, and a logger descheduled that long under load lost 10 of them
    # from its receive buffer (capped by net.core.rmem_max), so the log then
    # could not replay the run it recorded
    "$DKF_SIM" --url "$URL" --timeout $T --rate 100 "$scn" || { echo "FAIL: dkf-sim"; exit 1; }
    wait_peers live || exit 1
    # let the logger take in and flush the last messages (not a fixed guess)
    wait_log_quiet "$log" $quiet_ms
    kill -INT $logger; wait $logger
    compare_central "$out/live.fused.json" || exit 1
    # the log holds every node message the live centre received (Python lcm
    # reads it; without it the replay's comparison below still decides)
    "$DKF_PYTHON" -c 'import lcm' 2>/dev/null &&
    { "$DKF_PYTHON" - "$log" "$out/live.fused.json" <<'PY' || exit 1; }
import json, re, sys
import lcm
got = sum(1 for e in lcm.EventLog(sys.argv[1], "r") if re.fullmatch(r"DKF_NODE_[0-9]+", e.channel))
want = sum(json.load(open(sys.argv[2]))["counters"]["received"])
print(f"the log holds {got} node messages; the live centre received {want}")
sys.exit(0 if got == want else 1)
PY
    # replay only the node messages into a fresh fusion centre
    "$DKF_FUSION" --url "$URL" --timeout $T --deadline-ms $DEADLINE_MS --ready-file "$out/replay.ready" \
      --output "$out/replay.fused.json" "$scn" 2>"$out/replay.fusion.log" & pids+=($!); fpid=$!
    wait_file "$out/replay.ready" $T || exit 1
    "$DKF_LCM_LOGPLAYER" --lcm-url="$URL" -e 'DKF_NODE_[0-9]+' "$log" || { echo "FAIL: lcm-logplayer"; exit 1; }
    wait $fpid || { echo "FAIL: replay dkf-fusion exited $?"; cat "$out/replay.fusion.log"; exit 1; }
    cat "$out/replay.fusion.log"
    "$DKF_PYTHON" "$DKF_COMPARE" "$out/replay.fused.json" "$out/live.fused.json" \
      --keys outputs.fused --rel 0 || { echo "FAIL: replay differs from the live run"; exit 1; }
    echo "replay == live run, bit for bit"
    # the log plots (tools/dkf_logplot.py) when Python has lcm and matplotlib
    if "$DKF_PYTHON" -c 'import lcm, matplotlib, numpy' 2>/dev/null; then
      "$DKF_PYTHON" "$DKF_LOGPLOT" "$log" --png "$out/run.png" --types "$DKF_LCM_PY" &&
        [[ -s $out/run.png ]] || { echo "FAIL: dkf_logplot.py"; exit 1; }
    else
      echo "note: Python lcm/matplotlib missing: dkf_logplot.py not exercised"
    fi
    ;;
  split)
    SPLIT=(--split-ports)
    log=$out/base.lcmlog
    start_logger "$URL" "$log"
    run_live live --rate 200 || exit 1
    wait_log_quiet "$log" $quiet_ms
    kill -INT $logger; wait $logger
    compare_central "$out/live.fused.json" || exit 1
    "$DKF_PYTHON" - "$log" <<'PY' || exit 1
import collections, re, sys
import lcm
seen = collections.Counter(re.sub(r"_[0-9]+$", "_<i>", e.channel) for e in lcm.EventLog(sys.argv[1], "r"))
print("the URL's own port carried:", dict(seen))
assert seen["DKF_FUSED"] > 0 and seen["DKF_STATUS"] > 0, "no fused or status message on the URL's port"
assert seen["DKF_NODE_<i>"] == 0 and seen["DKF_MEAS_<i>"] == 0, "node messages or measurements on the URL's port"
PY
    ;;
  direct)
    SPLIT=(--split-ports) DIRECT=(--direct-recv)
    # the node messages' port (the URL's + 1): what the centre reads
    inject() {
      "$DKF_PYTHON" - <<'PY'
import socket, struct
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
short = lambda ch, body: struct.pack(">II", 0x4C433032, 7) + ch + b"\0" + body
bad = [b"LC0", struct.pack(">II", 0x4C433031, 1) + b"DKF_NODE_0\0xx",
       struct.pack(">II", 0x4C433032, 2) + b"X" * 64 + b"\0",   # a 64-byte channel
       struct.pack(">II", 0x4C433032, 3) + b"DKF_NODE_0",        # no NUL
       short(b"", b"body")]                                       # empty channel
frag = [struct.pack(">IIIIHH", 0x4C433033, 9, 100000, 0, 0, 2) + b"DKF_NODE_0\0" + b"z" * 64]
other = [short(b"DKF_NODE_0x", b"body"), short(b"XDKF_NODE_0", b"body")]  # anchored: no match
for d in bad + frag + other:
    s.sendto(d, ("239.255.76.67", 7668))
print(f"sent {len(bad)} malformed, {len(frag)} fragment, {len(other)} of no subscribed channel")
PY
    }
    BEFORE_SIM=inject
    run_live live --rate 200 || exit 1
    compare_central "$out/live.fused.json" || exit 1
    "$DKF_PYTHON" - "$out/live.fused.json" <<'PY' || exit 1
import json, sys
r = json.load(open(sys.argv[1]))["receive"]
print("the centre's direct receive:", r)
assert r["mode"] == "direct", r
assert (r["malformed"], r["fragments"], r["unmatched"]) == (5, 1, 2), r
# every node message of the run was read: 2 nodes x N steps, plus status heartbeats
assert r["datagrams"] >= 8 + 2 * json.load(open(sys.argv[1]))["N"], r
assert r["rcvbuf"] > 0, r
PY
    ;;
  *)
    echo "net_integration.sh: $mode: unknown mode" >&2; exit 2
    ;;
esac
echo "PASS: $mode"
