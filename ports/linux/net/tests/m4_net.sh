#!/usr/bin/env bash
# m4_net.sh SCENARIO OUTDIR - the emulated Cortex-M4F node in a live LCM
# network (docs/guide/network.md, "A firmware node in the network"), over
# udpm://239.255.76.67:7667?ttl=0 in a private network namespace
# (tools/netns.sh):
#
#   1. the live node image (ports/cortex-m4, dkf_m4_live.elf of this build's
#      DKF_REAL, built in $DKF_M4_BUILD when arm-none-eabi-gcc is here) refuses, with its
#      refusal frame and exit status 2, a step frame before any start,
#      frames whose byte count is above or below their dimensions' and a header of
#      another real type: every length from the bridge is checked before use;
#   2. m4_role_check: for every sensor, the image's node role (started at
#      k = 1, restarted at k = 20 as after a gap) gives dkf-node's messages
#      bit for bit;
#   3. authenticated (dkf-keygen, --key-dir everywhere): dkf-sim --lockstep,
#      dkf-fusion, dkf-node for node 0 and dkf-m4-bridge for the last node;
#      fused == the vector's central within DKF_REL, every step complete
#      with every node, nothing rejected, every datagram authenticated; the
#      image's messages equal the vector's node messages within DKF_REL.
#
# Environment (set by ctest): DKF_SIM DKF_NODE DKF_FUSION DKF_KEYGEN
# DKF_M4_BRIDGE DKF_M4_ROLE_CHECK DKF_M4_BUILD DKF_SRC DKF_REAL DKF_PYTHON DKF_COMPARE
# DKF_NETNS DKF_REL. Exit 77 (skip) when not root, or when qemu-system-arm
# is missing, or arm-none-eabi-gcc and a built image both are (said which).
set -uo pipefail
scn=$1 out=$2
T=120 # per-process timeout, seconds (QEMU starts in ~0.1 s; a step takes ms)
image=$DKF_M4_BUILD/dkf_m4_live.elf

. "$(dirname "$0")/net_common.sh"
if [[ ${DKF_IN_NETNS:-0} != 1 ]]; then
  command -v qemu-system-arm >/dev/null ||
    { echo "SKIP: qemu-system-arm missing (Debian: apt-get install qemu-system-arm)"; exit 77; }
  "$DKF_NETNS" check || exit $?
  # built (or brought up to date: its sources may have changed) when the cross compiler
  # is here; an image already built is used as it is otherwise
  if command -v arm-none-eabi-gcc >/dev/null; then
    echo "building $image (ports/cortex-m4, DKF_REAL=$DKF_REAL)"
    { [[ -f $DKF_M4_BUILD/CMakeCache.txt ]] ||
        cmake -S "$DKF_SRC/ports/cortex-m4" -B "$DKF_M4_BUILD" -DDKF_REAL="$DKF_REAL"; } \
      >"$DKF_M4_BUILD.log" 2>&1 &&
      cmake --build "$DKF_M4_BUILD" -j2 --target dkf_m4_live >>"$DKF_M4_BUILD.log" 2>&1 ||
      { tail -30 "$DKF_M4_BUILD.log"; echo "FAIL: could not build $image"; exit 1; }
  elif [[ ! -f $image ]]; then
    echo "SKIP: arm-none-eabi-gcc missing: cannot build $image"; exit 77
  fi
fi
in_netns "$0" "$@"
start_run "$out"

# ---- 1. the image's own checks, driven through its pipes ---------------------------
"$DKF_PYTHON" - "$image" "$out" "$DKF_REAL" <<'PY' || exit 1
import os, struct, subprocess, sys
image, out, real = sys.argv[1], sys.argv[2], sys.argv[3]
rs, rf = (4, "f") if real == "float" else (8, "d")
n, m, p = 2, 2, 1
rec_reals = 2 * n * n + 2 * p * p + m * n + m * m + m * p + m

def run(tag, header_real, frames):
    d = os.path.join(out, "refuse-" + tag)
    os.mkdir(d)
    for f in ("m4_live.in", "m4_live.out"):
        os.mkfifo(os.path.join(d, f))
    q = subprocess.Popen(["qemu-system-arm", "-M", "mps2-an386", "-display", "none", "-monitor",
                          "none", "-serial", "none", "-semihosting-config", "enable=on,target=native",
                          "-kernel", image], cwd=d, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    fi = open(os.path.join(d, "m4_live.in"), "wb", buffering=0)
    fo = open(os.path.join(d, "m4_live.out"), "rb", buffering=0)
    fi.write(struct.pack("<5I", 0x314C4B44, header_real, n, m, p))
    if header_real == rs:
        fi.write(struct.pack(f"<{n + n * n}{rf}", 0, 0, 1, 0, 0, 1))
        ready = fo.read(16)
        assert struct.unpack("<4I", ready) == (0x314D4B44, 0, 0, n), ready
    for fr in frames:
        fi.write(fr)
    heads = fo.read()
    rc = q.wait(timeout=30)
    console = q.stdout.read().decode().strip()
    got = struct.unpack("<4I", heads[:16]) if len(heads) >= 16 else None
    ok = rc == 2 and got is not None and got[:2] == (0x314D4B44, 3) and "m4 live:" in console
    print(f"{'ok' if ok else 'FAIL'}: {tag}: exit {rc}, answer {got}, console: {console}")
    return ok

body = struct.pack(f"<{rec_reals}{rf}", *([1.0] * rec_reals))
good = all([
    run("step-before-start", rs, [struct.pack("<3I", 2, 1, len(body)) + body]),
    run("bytes-long", rs, [struct.pack("<3I", 1, 1, len(body) + rs) + body]),
    run("bytes-short", rs, [struct.pack("<3I", 1, 1, len(body) - rs) + body]),
    run("real-type", 12 - rs, []),
])
sys.exit(0 if good else 1)
PY

# ---- 2. the image's node role == the host's (dkf-node's), bit for bit, every sensor -----
nodes=$("$DKF_PYTHON" -c 'import json,sys; print(len(json.load(open(sys.argv[1]))["model"]["sensors"]))' "$scn")
for ((i = 0; i < nodes; ++i)); do
  "$DKF_M4_ROLE_CHECK" "$image" "$scn" $i 20 0 || exit 1
done

# ---- 3. the live network ------------------------------------------------------------
m4=$((nodes - 1))
keys=$out/keys
"$DKF_KEYGEN" "$keys" "$nodes" || { echo "FAIL: dkf-keygen"; exit 1; }
AUTH=(--key-dir "$keys")
"$DKF_FUSION" --url "$URL" "${AUTH[@]}" --timeout $T --deadline-ms $((T * 1000)) \
  --ready-file "$out/fusion.ready" --output "$out/fused.json" "$scn" 2>"$out/fusion.log" &
pids+=($!); fpid=$!
npids=()
for ((i = 0; i < m4; ++i)); do
  "$DKF_NODE" --url "$URL" "${AUTH[@]}" --id $i --timeout $T --ready-file "$out/n$i.ready" \
    "$scn" 2>"$out/n$i.log" & pids+=($!); npids+=($!)
done
"$DKF_M4_BRIDGE" --url "$URL" "${AUTH[@]}" --id $m4 --image "$image" --timeout $T \
  --ready-file "$out/m4.ready" --output "$out/m4.json" "$scn" 2>"$out/m4.log" &
pids+=($!); bpid=$!
wait_file "$out/fusion.ready" $T && wait_file "$out/m4.ready" $T || { cat "$out"/*.log; exit 1; }
for ((i = 0; i < m4; ++i)); do wait_file "$out/n$i.ready" $T || exit 1; done
"$DKF_SIM" --url "$URL" "${AUTH[@]}" --lockstep --timeout $T "$scn" ||
  { echo "FAIL: dkf-sim exited $?"; cat "$out"/*.log; exit 1; }
rc=0
wait $fpid || { echo "FAIL: dkf-fusion exited $?"; rc=1; }
for p in "${npids[@]}"; do wait "$p" || { echo "FAIL: a dkf-node exited $?"; rc=1; }; done
wait $bpid || { echo "FAIL: dkf-m4-bridge exited $?"; rc=1; }
cat "$out"/*.log
((rc == 0)) || exit 1
if grep -l UNAUTHENTICATED "$out"/*.log; then echo "FAIL: a process ran unauthenticated"; exit 1; fi

"$DKF_PYTHON" "$DKF_COMPARE" "$out/fused.json" "$scn" --a-keys outputs.fused \
  --b-keys outputs.central --rel "$DKF_REL" || exit 1
"$DKF_PYTHON" - "$out/fused.json" "$out/m4.json" "$scn" "$m4" "$DKF_REL" <<'PY' || exit 1
import json, sys
fu, m4, s = (json.load(open(p)) for p in sys.argv[1:4])
i, rel = int(sys.argv[4]), float(sys.argv[5])
n_nodes = len(s["model"]["sensors"])
N = fu["N"]
assert len(fu["k"]) == N, "not every step published"
assert all(st == "complete" for st in fu["status"]), "a step is degraded"
assert all(len(c) == n_nodes for c in fu["contributors"]), "a node is missing from a step"
assert fu["counters"]["rejected"] == 0, fu["counters"]
au = fu["auth"]
assert au["mode"] != "off" and au["datagrams"]["accepted"] > 0, au
assert all(v == 0 for r, v in au["datagrams"].items() if r != "accepted"), au
assert m4["state"] == "done" and m4["rejected"] == 0 and m4["sent"] == N, m4
assert m4["auth"]["mode"] != "off", m4["auth"]
msg = m4["messages"]
assert msg["k"] == list(range(1, N + 1)), msg["k"]
assert 0 < msg["stack_bytes"] < 32768, msg["stack_bytes"]
# the image's node messages == the vector's node i messages (outputs.messages[step][node])
want = s["outputs"]["messages"]
d = 0.0
for j, k in enumerate(msg["k"]):
    w = want[s["k"].index(k)][i]
    for key in ("xf", "xp"):
        scale = max(1.0, max(abs(v) for v in w[key]))
        d = max(d, max(abs(a - b) for a, b in zip(msg[key][j], w[key])) / scale)
assert d <= rel, f"the image's messages differ from the vector's by {d:.2e} (> {rel})"
print(f"fused == central; every step complete with all {n_nodes} nodes, node {i} on the emulated "
      f"Cortex-M4F; {au['datagrams']['accepted']} datagrams authenticated at the centre, none "
      f"rejected; the image's {N} messages == the vector's within {d:.1e} relative; "
      f"the image's stack {msg['stack_bytes']} bytes")
PY
echo "PASS: m4node"
