#!/usr/bin/env bash
# net_local.sh OUTDIR - dkf-net-local (every agent in one process over
# memq://) on a generated 12-node network (with DKF_STEADY: the centre's
# steady gain, 400 steps): the generator is reproducible,
# every one of the N steps is fused complete by all 12 nodes, and
# check_faults.py (which must read the generator's init.P00-only prior)
# finds the fused estimate equal to its numpy centralized DKF within DKF_REL.
set -euo pipefail
out=$1
rm -rf "$out" && mkdir -p "$out"
if ! "$DKF_PYTHON" -c 'import numpy' 2>/dev/null; then
  echo "SKIP: numpy missing (tools/make_net_scenario.py)"; exit 77
fi
# With DKF_STEADY=TOL: 400 steps, the centre's steady gain on (--steady TOL),
# and at least one step must have reused it.
steps=100 steady=()
[[ -n "${DKF_STEADY:-}" ]] && steps=400 steady=(--steady "$DKF_STEADY")
"$DKF_PYTHON" "$DKF_GEN" --nodes 12 --steps "$steps" --seed 12 --out "$out/a.json"
"$DKF_PYTHON" "$DKF_GEN" --nodes 12 --steps "$steps" --seed 12 --out "$out/b.json"
cmp "$out/a.json" "$out/b.json" || { echo "FAIL: make_net_scenario.py is not reproducible"; exit 1; }
"$DKF_LOCAL" "${steady[@]}" --output "$out/fused.json" "$out/a.json"
"$DKF_PYTHON" - "$out/fused.json" "$steps" "${DKF_STEADY:-}" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
steps, steady = int(sys.argv[2]), sys.argv[3]
assert len(d["k"]) == d["N"] == steps, "not every step fused"
assert all(s == "complete" for s in d["status"]), "a degraded step"
assert all(len(c) == 12 for c in d["contributors"]), "a node missing"
reused = d["counters"]["steady_gain_steps"]
if steady:
    assert reused > 0, "the steady gain never settled"
else:
    assert reused == 0, "a step reused a gain without --steady"
print("PASS: %d steps, all complete with 12 nodes; %d reused the settled gain" % (steps, reused))
PY
"$DKF_PYTHON" "$DKF_CHECK" "$out/fused.json" "$out/a.json" --rel "$DKF_REL" --all-complete
