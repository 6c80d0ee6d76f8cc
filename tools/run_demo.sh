#!/usr/bin/env bash
# tools/run_demo.sh - build dkf (double) and run its filters on the built-in
# demo scenario, printing a small result table. Safe to run again: it reuses
# build/demo and only rebuilds what changed.
#
#   tools/run_demo.sh            # scenario: scenarios/demo_cv2d.json
#   tools/run_demo.sh FILE.json  # any multi-sensor scenario with truth
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
scenario="${1:-$root/scenarios/demo_cv2d.json}"
build="$root/build/demo"
out="$build/out"

# ---- 1. prerequisites ------------------------------------------------------------
# bootstrap.sh installs everything the whole project needs (cross compilers
# too); the demo needs only the host toolchain, so a bootstrap that cannot
# install the rest is not fatal as long as those are present.
if [[ -x "$root/tools/bootstrap.sh" ]]; then
  DKF_BOOTSTRAP_NO_ARMHF=1 DKF_BOOTSTRAP_NO_PYTHON=1 "$root/tools/bootstrap.sh" ||
    echo "run_demo: bootstrap.sh reported missing packages; checking what the demo needs" >&2
fi
missing=()
for tool in cmake gcc make pkg-config python3; do
  command -v "$tool" >/dev/null 2>&1 || missing+=("$tool")
done
if command -v pkg-config >/dev/null 2>&1 && ! pkg-config --exists jansson; then
  missing+=(libjansson-dev)
fi
if (( ${#missing[@]} )); then
  echo "run_demo: missing: ${missing[*]}" >&2
  echo "run_demo: install with:" >&2
  echo "  sudo apt-get update && sudo apt-get install -y cmake gcc make pkg-config python3 libjansson-dev" >&2
  exit 1
fi

# ---- 2. build (double, no unit tests: the demo needs dkf-run only) ----------
cmake -S "$root" -B "$build" -DDKF_REAL=double -DDKF_BUILD_TESTS=OFF \
      -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" --target dkf-run -j2 >/dev/null
dkf_run="$build/ports/linux/dkf-run"

# ---- 3. run ------------------------------------------------------------------------
mkdir -p "$out"
for filter in kf info; do
  "$dkf_run" --quiet --filter "$filter" --output "$out/$filter.json" "$scenario"
done

# ---- 4. table ----------------------------------------------------------------------
python3 - "$scenario" "$out/kf.json" "$out/info.json" <<'EOF'
import json, math, sys

scn = json.load(open(sys.argv[1]))
truth = {k: x for k, x in zip(scn["truth"]["k"], scn["truth"]["x"])}

def rmse(xs, ks, comps):
    e = [(x[i] - truth[k][i]) ** 2 for x, k in zip(xs, ks) for i in comps]
    return math.sqrt(sum(e) / len(e))

def maxdiff(a, b):
    if isinstance(a, list):
        return max(maxdiff(p, q) for p, q in zip(a, b))
    return abs(a - b)

print("scenario: %s (%d steps, %d sensors)" % (sys.argv[1], len(scn["k"]), len(scn["y"])))
print("%-6s %-10s %12s %12s %14s %16s" % ("filter", "estimator", "RMSE pos[m]",
                                           "RMSE vel[m/s]", "trace P_N|N", "max|fused-centr|"))
for path in sys.argv[2:]:
    doc = json.load(open(path))
    outs, ks = doc["outputs"], doc["k"]
    rows = [("local[%d]" % i, o) for i, o in enumerate(outs.get("local", []))]
    rows += [(name, outs[name]) for name in ("central", "fused") if name in outs]
    for name, o in rows:
        extra = ""
        if name == "fused":
            c = outs["central"]
            extra = "%.3g" % max(maxdiff(o[key], c[key]) for key in ("xf", "Pf", "xp", "Pp"))
        Pn = o["Pf"][-1]
        print("%-6s %-10s %12.4f %12.4f %14.4f %16s" % (
            doc["filter"], name, rmse(o["xf"], ks, (0, 2)), rmse(o["xf"], ks, (1, 3)),
            sum(Pn[i][i] for i in range(len(Pn))), extra))
EOF
echo "outputs: $out/kf.json $out/info.json (compare with tools/dkf_compare.py)"
