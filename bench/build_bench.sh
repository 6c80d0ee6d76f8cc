#!/usr/bin/env bash
# bench/build_bench.sh TYPE - configures and builds the benchmark build
# directory of one real type (double or float), used by run_bench.sh and
# callgrind.sh so both measure the very same binaries. Prints its path.
#
# The library and bench_kf: Release with -O2 -DNDEBUG ("without special
# flags": no -march, no -ffast-math, default config.h, so argument checks
# stay on). -g only adds debug info for callgrind's annotations; GCC's code
# generation does not depend on it. The Eigen executables get their own flags (bench/CMakeLists.txt).
#   BENCH_BUILD_PREFIX  directories are <prefix>-<type> (default <repo>/build-bench)
#   BENCH_JOSEPH        ON/OFF, passed as -DDKF_JOSEPH (default ON)
set -euo pipefail
t="${1:?usage: build_bench.sh double|float}"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
b="${BENCH_BUILD_PREFIX:-$root/build-bench}-$t"
cmake -S "$root" -B "$b" -DDKF_REAL="$t" -DDKF_JOSEPH="${BENCH_JOSEPH:-ON}" \
  -DDKF_BUILD_BENCH=ON -DDKF_BUILD_TESTS=OFF -DDKF_BUILD_PORTS=OFF \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_FLAGS_RELEASE="-O2 -g -DNDEBUG" >/dev/null
cmake --build "$b" -j2 --target bench_kf bench_kf_eigen_O2 bench_kf_eigen_O3native bench_uif >/dev/null
echo "$b"
