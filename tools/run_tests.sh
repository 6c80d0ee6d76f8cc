#!/usr/bin/env bash
# tools/run_tests.sh - the test command: every build configuration dkf
# promises to support, configured, built and tested in build/<config>/
# (reused, so a second run is incremental).
#
#   double           DKF_REAL=double (Joseph form on), with the benchmarks'
#                    smoke test (bench/smoke.py: builds, runs, checksums)
#   float            DKF_REAL=float
#   double-nojoseph  DKF_REAL=double, DKF_JOSEPH=OFF
#   double-asan      DKF_REAL=double, DKF_SANITIZE=ON (ASan + UBSan)
#   qemu-arm-float   armhf cross build, DKF_REAL=float, every test run under
#                    qemu-arm (cmake/toolchain-arm-linux-gnueabihf.cmake)
#   firmware         Cortex-M4F image, float and double: -Werror build, no
#                    heap symbols, sizes, worst-case stack (check_firmware.sh)
#   fuzz             every tests/fuzz harness under clang libFuzzer + ASan +
#                    UBSan for FUZZ_SECONDS (60) each (tools/run_fuzz.sh)
# Every ctest configuration includes `install_consumer` (install + a
# separate find_package(dkf) project, tests/consumer/).
#
# usage: tools/run_tests.sh [config...]      (default: all, in that order)
# env:   DKF_JOBS=2        parallel build/test jobs
#        DKF_KEEP_GOING=1  run the remaining configurations after a failure
#        DKF_SKIP_BOOTSTRAP=1  do not run tools/bootstrap.sh first
# The last line is "N passed, M failed" summed over all configurations (a
# configuration that does not configure or build counts as 1 failed).
set -uo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
JOBS=${DKF_JOBS:-2}
all_configs=(double float double-nojoseph double-asan fuzz qemu-arm-float firmware)
configs=("$@")
(( ${#configs[@]} )) || configs=("${all_configs[@]}")

declare -A cfg_args=(
  [double]="-DDKF_REAL=double -DDKF_JOSEPH=ON -DDKF_SANITIZE=OFF -DDKF_BUILD_BENCH=ON"
  [float]="-DDKF_REAL=float -DDKF_JOSEPH=ON -DDKF_SANITIZE=OFF -DDKF_BUILD_BENCH=ON"
  [double-nojoseph]="-DDKF_REAL=double -DDKF_JOSEPH=OFF -DDKF_SANITIZE=OFF"
  [double-asan]="-DDKF_REAL=double -DDKF_JOSEPH=ON -DDKF_SANITIZE=ON"
  [qemu-arm-float]="-DDKF_REAL=float -DDKF_JOSEPH=ON -DCMAKE_TOOLCHAIN_FILE=$ROOT/cmake/toolchain-arm-linux-gnueabihf.cmake -DDKF_BUILD_PORTS=OFF"
)
for c in "${configs[@]}"; do
  if [[ -z "${cfg_args[$c]+x}" && "$c" != firmware && "$c" != fuzz ]]; then
    echo "run_tests: unknown configuration '$c' (known: ${all_configs[*]})" >&2
    exit 2
  fi
done

if [[ "${DKF_SKIP_BOOTSTRAP:-0}" != 1 ]]; then
  if ! tools/bootstrap.sh; then
    echo "run_tests: FAILED: tools/bootstrap.sh could not provide the build dependencies" >&2
    exit 1
  fi
fi

total_pass=0
total_fail=0
summary=()
stop=0

record() { # config passed failed note
  summary+=("$(printf '%-16s %6s %6s  %s' "$1" "$2" "$3" "$4")")
  total_pass=$((total_pass + $2))
  total_fail=$((total_fail + $3))
  if (( $3 > 0 )) && [[ "${DKF_KEEP_GOING:-0}" != 1 ]]; then stop=1; fi
}

run_ctest_config() {
  local cfg=$1 bdir=$ROOT/build/$1
  mkdir -p "$bdir"
  echo "==== $cfg: configure ($bdir)"
  # shellcheck disable=SC2086  # the arguments are meant to split
  if ! cmake -S "$ROOT" -B "$bdir" ${cfg_args[$cfg]} >"$bdir/run_tests.configure.log" 2>&1; then
    tail -40 "$bdir/run_tests.configure.log"
    echo "run_tests: FAILED: $cfg does not configure (log: $bdir/run_tests.configure.log)"
    record "$cfg" 0 1 "configure failed"
    return
  fi
  echo "==== $cfg: build"
  if ! cmake --build "$bdir" -j"$JOBS" >"$bdir/run_tests.build.log" 2>&1; then
    grep -E 'error|warning' "$bdir/run_tests.build.log" | head -40
    tail -20 "$bdir/run_tests.build.log"
    echo "run_tests: FAILED: $cfg does not build (log: $bdir/run_tests.build.log)"
    record "$cfg" 0 1 "build failed"
    return
  fi
  echo "==== $cfg: ctest"
  local out rc
  out=$(ctest --test-dir "$bdir" --output-on-failure -j"$JOBS" 2>&1)
  rc=$?
  echo "$out"
  local line total failed
  line=$(echo "$out" | grep -E '^[0-9]+% tests passed, [0-9]+ tests? failed out of [0-9]+' | tail -1)
  if [[ -z "$line" ]]; then
    echo "run_tests: FAILED: $cfg ran no test"
    record "$cfg" 0 1 "no tests found"
    return
  fi
  failed=$(echo "$line" | sed -E 's/.*, ([0-9]+) tests? failed out of ([0-9]+).*/\1/')
  total=$(echo "$line" | sed -E 's/.*, ([0-9]+) tests? failed out of ([0-9]+).*/\2/')
  if (( rc != 0 && failed == 0 )); then failed=1; fi
  if (( failed > 0 )); then
    echo "run_tests: FAILED: $failed test(s) of $cfg (see the output above)"
  fi
  record "$cfg" $((total - failed)) "$failed" ""
}

run_firmware() {
  echo "==== firmware: Cortex-M4F image (tools/check_firmware.sh)"
  local out rc line p f
  out=$(DKF_JOBS=$JOBS tools/check_firmware.sh 2>&1)
  rc=$?
  echo "$out"
  line=$(echo "$out" | grep -E '^firmware: [0-9]+ passed, [0-9]+ failed$' | tail -1)
  if [[ -z "$line" ]]; then
    echo "run_tests: FAILED: firmware check did not finish"
    record firmware 0 1 "check aborted"
    return
  fi
  p=$(echo "$line" | sed -E 's/firmware: ([0-9]+) passed, ([0-9]+) failed/\1/')
  f=$(echo "$line" | sed -E 's/firmware: ([0-9]+) passed, ([0-9]+) failed/\2/')
  if (( rc != 0 && f == 0 )); then f=1; fi
  (( f > 0 )) && echo "run_tests: FAILED: $f firmware check(s) (see FAIL: lines above)"
  record firmware "$p" "$f" "checks, not ctest"
}

run_fuzz() {
  echo "==== fuzz: libFuzzer harnesses (tools/run_fuzz.sh)"
  local out rc line p f
  out=$(DKF_JOBS=$JOBS tools/run_fuzz.sh 2>&1)
  rc=$?
  echo "$out"
  line=$(echo "$out" | grep -E '^fuzz: [0-9]+ passed, [0-9]+ failed$' | tail -1)
  if [[ -z "$line" ]]; then
    echo "run_tests: FAILED: fuzz run did not finish"
    record fuzz 0 1 "run aborted"
    return
  fi
  p=$(echo "$line" | sed -E 's/fuzz: ([0-9]+) passed, ([0-9]+) failed/\1/')
  f=$(echo "$line" | sed -E 's/fuzz: ([0-9]+) passed, ([0-9]+) failed/\2/')
  if (( rc != 0 && f == 0 )); then f=1; fi
  (( f > 0 )) && echo "run_tests: FAILED: $f fuzz harness(es) (see FAIL lines above)"
  record fuzz "$p" "$f" "harnesses, not ctest"
}

start=$SECONDS
for c in "${configs[@]}"; do
  if (( stop )); then
    summary+=("$(printf '%-16s %6s %6s  %s' "$c" - - "not run (earlier failure; DKF_KEEP_GOING=1 runs all)")")
    continue
  fi
  if [[ $c == firmware ]]; then run_firmware; elif [[ $c == fuzz ]]; then run_fuzz; else run_ctest_config "$c"; fi
done

echo
echo "==== summary ($((SECONDS - start)) s)"
printf '%-16s %6s %6s\n' config passed failed
printf '%s\n' "${summary[@]}"
echo "${total_pass} passed, ${total_fail} failed"
(( total_fail == 0 && stop == 0 ))
