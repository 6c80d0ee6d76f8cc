#!/usr/bin/env bash
# tools/m4_run.sh - run a scenario on the dkf node image under an emulated
# Cortex-M4F (qemu-system-arm -M mps2-an386, semihosting) and write its
# estimates in dkf-run's output layout (docs/reference/scenario-format.md,
# "Outputs"):
#
#   tools/m4_run.sh --filter dkf --output OUT.json SCENARIO.json
#   tools/m4_run.sh --real double --filter kf --stats STATS.json SCENARIO.json
#
# The image is build/m4-<real>/dkf_m4_qemu.elf (ports/cortex-m4, built here
# if missing; --image ELF to give another). Every other option goes to
# tools/m4_run.py (--output, --stats, --run, --keep DIR, --quiet; its
# --help). Exit status: the image's (0 ok, 2 input refused, 3 a filter call
# failed, 4 output not written), 2 for a bad option or scenario, 1 if
# qemu-system-arm or the image is missing.
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
real=float
image=
args=()
while (( $# )); do
  case $1 in
    --real) real=${2:-}; shift 2 ;;
    --real=*) real=${1#--real=}; shift ;;
    --image) image=${2:-}; shift 2 ;;
    --image=*) image=${1#--image=}; shift ;;
    -h|--help)
      awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"
      python3 "$ROOT/tools/m4_run.py" --help
      exit 0 ;;
    *) args+=("$1"); shift ;;
  esac
done
if [[ $real != float && $real != double ]]; then
  echo "m4_run: --real $real: expected float or double" >&2
  exit 2
fi
if ! command -v qemu-system-arm >/dev/null 2>&1; then
  echo "m4_run: qemu-system-arm is missing; install it with:" >&2
  echo "  sudo apt-get install -y --no-install-recommends qemu-system-arm" >&2
  exit 1
fi
if [[ -z $image ]]; then
  bdir=$ROOT/build/m4-$real
  image=$bdir/dkf_m4_qemu.elf
  if [[ ! -f $image ]]; then
    echo "m4_run: building $image" >&2
    if ! { cmake -S "$ROOT/ports/cortex-m4" -B "$bdir" -DDKF_REAL="$real" >/dev/null &&
           cmake --build "$bdir" -j"${DKF_JOBS:-2}" --target dkf_m4_qemu >/dev/null; }; then
      echo "m4_run: could not build $image" >&2
      exit 1
    fi
  fi
fi
if [[ ! -f $image ]]; then
  echo "m4_run: $image: no such image" >&2
  exit 1
fi
exec python3 "$ROOT/tools/m4_run.py" --image "$image" --real "$real" "${args[@]}"
