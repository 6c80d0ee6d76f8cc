#!/usr/bin/env bash
# bench/build_bench.sh TYPE [FORM] - configures and builds the benchmark
# build directory of one real type (double or float) and one covariance
# update (FORM joseph: DKF_JOSEPH=ON, the default; short: DKF_JOSEPH=OFF),
# used by run_bench.sh and callgrind.sh so both measure the very same
# binaries. Prints its path.
#
# The library and bench_kf: Release with -O2 -DNDEBUG ("without special
# flags": no -march, no -ffast-math, default config.h, so argument checks
# stay on). -g only adds debug info for callgrind's annotations; GCC's code
# generation does not depend on it. The Eigen executables get their own
# flags (bench/CMakeLists.txt): -O2 and -O3, baseline ISA.
#   BENCH_BUILD_PREFIX  directories are <prefix>-<type>-<form> (default <repo>/build-bench)
#   BENCH_NATIVE=1      also build bench_kf_eigen_O3native (-O3 -march=native):
#                       by hand only, never the test command or callgrind.sh
set -euo pipefail
t="${1:?usage: build_bench.sh double|float [joseph|short]}"
form="${2:-joseph}"
case "$form" in
  joseph) joseph=ON ;;
  short) joseph=OFF ;;
  *) echo "build_bench.sh: form must be joseph or short, not '$form'" >&2; exit 2 ;;
esac
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
b="${BENCH_BUILD_PREFIX:-$root/build-bench}-$t-$form"
maxdim="${BENCH_MAX_DIM:-48}"
[[ "$maxdim" != 48 ]] && b="$b-dim$maxdim"
targets=(bench_kf bench_kf_ref bench_kf_eigen_O2 bench_kf_eigen_O3 bench_uif bench_nerts bench_wfusion bench_fc)
native=OFF
if [[ "${BENCH_NATIVE:-0}" == 1 ]]; then
  native=ON
  targets+=(bench_kf_eigen_O3native)
fi
cmake -S "$root" -B "$b" -DDKF_REAL="$t" -DDKF_JOSEPH="$joseph" -DDKF_MAX_DIM="$maxdim" \
  -DDKF_BUILD_BENCH=ON -DDKF_BENCH_NATIVE="$native" -DDKF_BUILD_TESTS=OFF -DDKF_BUILD_PORTS=OFF \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_FLAGS_RELEASE="-O2 -g -DNDEBUG" >/dev/null
cmake --build "$b" -j2 --target "${targets[@]}" >/dev/null
echo "$b"
