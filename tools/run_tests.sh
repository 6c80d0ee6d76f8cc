#!/usr/bin/env bash
# tools/run_tests.sh - the test command: every build configuration dkf
# promises to support, configured, built and tested in build/<config>/
# (reused, so a second run is incremental).
#
#   double           DKF_REAL=double (Joseph form on), with the benchmarks'
#                    smoke test (bench/smoke.py: builds, runs, checksums);
#                    the only configuration that runs the tests labelled
#                    `once` (cmake/testing.cmake: the network processes in
#                    namespaces, the Python tools, the paper reproductions,
#                    the install and build consumers), which do not depend on
#                    the configuration; every other one runs `ctest -LE once`.
#                    Its network tests (-L net) run after the others, 4 at a
#                    time, reported as double:net
#   float            DKF_REAL=float (the Eigen peer at -O2 only)
#   python           the Python package (docs/guide/python.md): a venv in
#                    build/python/venv (reused), `pip install` of the tree into
#                    it (its CMake build in build/python/build, incremental;
#                    warnings are errors) and its pytest suite, python/tests;
#                    the venv's packages install in the background from the
#                    start, and the tests compare with double's and float's dkf-run
#   double-nojoseph  DKF_REAL=double, DKF_JOSEPH=OFF, built Release (-O3
#                    -DNDEBUG; the others RelWithDebInfo: -O2 without -g, ASan -Og -g)
#   double-asan      DKF_REAL=double, DKF_SANITIZE=ON (ASan + UBSan)
#   double-dim1024   DKF_REAL=double, DKF_MAX_DIM=1024: the host limit the
#                    demo and the 200-node centre are built with (decision 23)
#   clang            DKF_REAL=float, built by clang-14 with -Werror (our
#                    code), the port left out: Clang's warnings differ from
#                    GCC's (an unused static inline function in a .c file)
#   qemu-arm-float   armhf cross build, DKF_REAL=float, every test run under
#                    qemu-arm (cmake/toolchain-arm-linux-gnueabihf.cmake)
#   qemu-arm64-double  arm64 cross build, DKF_REAL=double, every test run
#                    under qemu-aarch64 (cmake/toolchain-aarch64-linux-gnu.cmake):
#                    the kernels' vector code as NEON
#   firmware         Cortex-M4F image, float and double: -Werror build, no
#                    heap symbols, sizes, worst-case stack; the node image under
#                    qemu-system-arm -M mps2-an386, bit for bit against the host
#                    float dkf-run on the diffkf vectors (check_firmware.sh)
#   fuzz             every tests/fuzz harness under clang libFuzzer + ASan +
#                    UBSan for FUZZ_SECONDS (here 6) each, two at a time
#                    (tools/run_fuzz.sh; the long run: docs/guide/fuzzing.md)
#   demo             the README's demo (tools/net_demo.sh) on the programs of
#                    double-dim1024 (the demo's DKF_MAX_DIM; its own build in
#                    build/demo when run alone): every network, 2 to 200 nodes,
#                    fused == central, and the graph, seed-001 and seed-002 networks
#
# usage: tools/run_tests.sh [config...]   every configuration (default), or those
#        tools/run_tests.sh --quick       the edit-compile-test loop: the double
#                    build without the benchmarks in build/quick and its unit
#                    tests (ctest -L unit: core and host, in process)
# env:   DKF_JOBS=2        parallel build/test jobs
#        DKF_KEEP_GOING=1  run the remaining configurations after a failure
#        DKF_SKIP_BOOTSTRAP=1  do not run tools/bootstrap.sh first
#        FUZZ_SECONDS=6    each fuzz harness's time in the fuzz configuration
# Builds use Ninja (from tools/bootstrap.sh; make if it is missing). The end
# is a table of each configuration's configure, build and test seconds.
# The last line is "N passed, M failed" summed over all configurations (a
# configuration that does not configure or build counts as 1 failed).
#
# Output: every long step keeps its whole output in a log under build/ and
# prints progress lines instead, "[config] what (elapsed s)": build
# percentages at most every 10 s, a running ctest count at most every 10 s
# and every failing test at once. On failure it prints the first distinct
# error (compiler diagnostics deduplicated across translation units; the
# failing tests with their first failing assertion), and the log's path.
set -uo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
JOBS=${DKF_JOBS:-2}
all_configs=(double float python double-nojoseph double-asan double-dim1024 clang fuzz qemu-arm-float qemu-arm64-double firmware
  demo)
configs=()
for a in "$@"; do
  case $a in
    --quick) configs+=(quick) ;;
    -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"; exit 0 ;;
    -*) echo "run_tests: $a: unknown option (see --help)" >&2; exit 2 ;;
    *) configs+=("$a") ;;
  esac
done
(( ${#configs[@]} )) || configs=("${all_configs[@]}")

# The configurations' CMake arguments (shell words: eval'd). The test builds
# are RelWithDebInfo's -O2 without its -g (NOG): debug information changes
# no test and was a quarter to a third of the compile time; ASan + UBSan at
# -Og -g (optimised for debugging: src/kf.c compiles in 21 s, 57 s at -O2;
# the configuration in 96 s instead of 148), -g for the reports' line
# numbers. --quick keeps -g, for a debugger.
NOG="-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O2 -DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2"
declare -A cfg_args=(
  [quick]="-DDKF_REAL=double -DDKF_JOSEPH=ON -DDKF_SANITIZE=OFF -DDKF_BUILD_BENCH=OFF"
  [double]="-DDKF_REAL=double -DDKF_JOSEPH=ON -DDKF_SANITIZE=OFF -DDKF_BUILD_BENCH=ON $NOG"
  [float]="-DDKF_REAL=float -DDKF_JOSEPH=ON -DDKF_SANITIZE=OFF -DDKF_BUILD_BENCH=ON -DDKF_BENCH_EIGEN=O2 $NOG"
  [double-nojoseph]="-DDKF_REAL=double -DDKF_JOSEPH=OFF -DDKF_SANITIZE=OFF -DCMAKE_BUILD_TYPE=Release"
  [double-asan]="-DDKF_REAL=double -DDKF_JOSEPH=ON -DDKF_SANITIZE=ON '-DCMAKE_C_FLAGS_RELWITHDEBINFO=-Og -g' '-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-Og -g'"
  [double-dim1024]="-DDKF_REAL=double -DDKF_JOSEPH=ON -DDKF_SANITIZE=OFF -DDKF_MAX_DIM=1024 $NOG"
  [clang]="-DCMAKE_C_COMPILER=clang-14 -DDKF_REAL=float -DDKF_JOSEPH=ON -DDKF_SANITIZE=OFF -DDKF_BUILD_PORTS=OFF $NOG"
  [qemu-arm-float]="-DDKF_REAL=float -DDKF_JOSEPH=ON -DCMAKE_TOOLCHAIN_FILE=$ROOT/cmake/toolchain-arm-linux-gnueabihf.cmake -DDKF_BUILD_PORTS=OFF $NOG"
  [qemu-arm64-double]="-DDKF_REAL=double -DDKF_JOSEPH=ON -DCMAKE_TOOLCHAIN_FILE=$ROOT/cmake/toolchain-aarch64-linux-gnu.cmake -DDKF_BUILD_PORTS=OFF $NOG"
)
# What ctest runs in each configuration (cmake/testing.cmake's labels).
declare -A cfg_ctest=([quick]="-L unit" [double]="")
ctest_args() { echo "${cfg_ctest[$1]--LE once}"; }
GEN=()
command -v ninja >/dev/null && GEN=(-G Ninja)
for c in "${configs[@]}"; do
  if [[ -z "${cfg_args[$c]+x}" && ! "$c" =~ ^(firmware|fuzz|demo|python)$ ]]; then
    echo "run_tests: unknown configuration '$c' (known: ${all_configs[*]})" >&2
    exit 2
  fi
done

if [[ "${DKF_SKIP_BOOTSTRAP:-0}" != 1 ]]; then
  boot_start=$SECONDS
  if ! tools/bootstrap.sh; then
    echo "run_tests: FAILED: tools/bootstrap.sh could not provide the build dependencies" >&2
    exit 1
  fi
  # the dependencies' minutes on a bare machine, apart from the test command's own
  echo "[bootstrap] dependencies ready ($((SECONDS - boot_start)) s, not in the times below)"
fi

total_pass=0
total_fail=0
summary=()
stop=0

# times+=("config configure build test"): seconds of each part (- if none)
times=()
t_configure=- t_build=- t_test=-
record() { # config passed failed note
  summary+=("$(printf '%-16s %6s %6s  %s' "$1" "$2" "$3" "$4")")
  times+=("$(printf '%-18s %9s %6s %6s %6s' "$1" "$t_configure" "$t_build" "$t_test" \
             $((SECONDS - step_t0)))")
  t_configure=- t_build=- t_test=-
  total_pass=$((total_pass + $2))
  total_fail=$((total_fail + $3))
  if (( $3 > 0 )) && [[ "${DKF_KEEP_GOING:-0}" != 1 ]]; then stop=1; fi
}

# ---- output machinery ----------------------------------------------------------
# Progress lines and first distinct errors; every step's full output stays in
# its log. say LABEL TEXT prints "[LABEL] TEXT (s since the step began)";
# say, next_line and progress_build are tools/progress.sh's.
. tools/progress.sh

# progress_ctest LABEL LOG < ctest output: all of it to LOG; each failing
# test at once, "[LABEL] ctest 12/85 ..." at most every 10 s and at the end.
progress_ctest() {
  local label=$1 log=$2 line n=0 total=? name res bad=0 t=$SECONDS rc _partial=''
  local re='^ *([0-9]+)/([0-9]+) Test +#[0-9]+: ([^ ]+) [ .]*(Passed|\*\*\*[A-Za-z ]*[A-Za-z]|Exception: [A-Za-z ]*[A-Za-z]) +[0-9.]+ sec'
  : >"$log"
  while :; do
    next_line; rc=$?
    if (( rc == 2 )); then
      (( SECONDS - t >= 30 )) && { say "$label" "ctest $n/$total done, $bad failed, still running"; t=$SECONDS; }
      continue
    fi
    (( rc == 0 )) || break
    printf '%s\n' "$line" >>"$log"
    [[ $line =~ $re ]] || continue
    n=${BASH_REMATCH[1]} total=${BASH_REMATCH[2]} name=${BASH_REMATCH[3]} res=${BASH_REMATCH[4]}
    if [[ $res == '***Not Run' ]]; then
      bad=$((bad + 1)) # a cascade (a setup fixture failed, or no executable): summed up at the end
    elif [[ $res != Passed ]]; then
      bad=$((bad + 1)); say "$label" "ctest $n/$total FAILED: $name (${res#\*\*\*})"
    elif (( SECONDS - t >= 10 || n == total )); then
      say "$label" "ctest $n/$total done, $bad failed"; t=$SECONDS
    fi
  done
}

# first_build_errors LABEL LOG: the first distinct compiler/linker error
# with the lines that explain it, then the other distinct diagnostics, one
# line each (the same header diagnostic from 40 translation units is one).
first_build_errors() {
  local label=$1 log=$2
  awk -v label="$label" -v logf="$log" '
    function diag(s) {
      return s ~ /(^|: )(fatal error|error|warning): / || s ~ /undefined reference to|multiple definition of/
    }
    diag($0) && $0 !~ /^(g?make|collect2|ninja)/ {
      if (!($0 in idx)) { idx[$0] = ++nd; d[nd] = $0; iserr[nd] = ($0 !~ /: warning: /) }
      cap = 0
      if (!first && iserr[idx[$0]]) { first = idx[$0]; cap = 1 }
      next
    }
    cap && ctx < 6 && $0 !~ /^(g?make|ninja|In file included|  +from |\[ *[0-9]+%\])/ { c[++ctx] = $0; next }
    { cap = 0 }
    END {
      if (!nd) exit 1
      if (!first) first = 1
      ne = 0; for (i = 1; i <= nd; ++i) ne += iserr[i]
      printf "[%s] first error (%d distinct errors, %d distinct warnings; full log %s):\n", label, ne, nd - ne, logf
      print "  " d[first]
      for (i = 1; i <= ctx; ++i) print "  " c[i]
      shown = 0
      for (i = 1; i <= nd && shown < 8; ++i) if (i != first) {
        if (!shown) printf "[%s] the other distinct diagnostics:\n", label
        print "  " d[i]; ++shown
      }
      if (nd - 1 > shown) printf "  ... and %d more\n", nd - 1 - shown
    }' "$log" || { echo "[$label] no compiler diagnostic found; the log ends:"; tail -15 "$log"; }
}

# build_warnings LABEL LOG: after a build that succeeded, one line if it
# printed warnings (third-party code without -Werror: bench/CMakeLists.txt).
build_warnings() {
  local n
  n=$(grep -E ': warning: ' "$2" | sort -u | wc -l)
  (( n > 0 )) && echo "[$1] build: $n distinct compiler warnings (code built without -Werror), first: $(grep -E -m1 ': warning: ' "$2")"
  return 0
}

# first_test_failures LABEL BDIR NAME...: each failing test's first failing
# assertion, from ctest's own per-test record (Testing/Temporary/LastTest.log).
first_test_failures() {
  local label=$1 rec=$2/Testing/Temporary/LastTest.log
  shift 2
  (( $# )) || return 0
  [[ -f $rec ]] || { echo "[$label] failed: $* (no $rec)"; return 0; }
  awk -v label="$label" -v names=" $* " '
    /^[0-9]+\/[0-9]+ Test: / { name = $3; out = 0; next }
    /^Output:$/ { getline; out = (index(names, " " name " ") > 0); nl = 0; got = 0; next }
    /^<end of output>$/ {
      if (out) {
        printf "[%s] FAILED %s:\n", label, name
        if (got) for (i = 1; i <= got; ++i) print "  " g[i]
        else for (i = (nl > 4 ? nl - 3 : 1); i <= nl; ++i) print "  " last[i % 4]
      }
      out = 0; next
    }
    out {
      ++nl; last[nl % 4] = $0
      if (!got && $0 ~ /(ERROR|FAIL|[Ff]ailure|[Ff]ailed|[Aa]ssert|MISMATCH|[Mm]ismatch|Traceback|[Ee]rror[: ]|runtime error|Sanitizer)/ &&
          $0 !~ /(^|[^0-9])0 (tests? |checks? )?failed/) { g[++got] = $0; more = 1; next }
      if (more) { more = 0; if ($0 ~ /(LINE|[Ee]rror|FAIL)/) g[++got] = $0 }
    }' "$rec"
}

# A build directory made by another generator (make before Ninja) cannot be
# reused: its cache goes, the objects are rebuilt.
forget_other_generator() {
  local cache=$1/CMakeCache.txt want=${GEN[1]:-Unix Makefiles}
  [[ -f $cache ]] || return 0
  grep -qx "CMAKE_GENERATOR:INTERNAL=$want" "$cache" && return 0
  rm -rf "$cache" "$1/CMakeFiles"
}

run_ctest_config() {
  local cfg=$1 bdir=$ROOT/build/$1 t
  mkdir -p "$bdir"
  forget_other_generator "$bdir"
  step_t0=$SECONDS
  say "$cfg" "configure ($bdir)"
  local cargs
  eval "cargs=(${cfg_args[$cfg]})"
  if ! cmake -S "$ROOT" -B "$bdir" "${GEN[@]}" "${cargs[@]}" >"$bdir/run_tests.configure.log" 2>&1; then
    if grep -q 'CMake Error' "$bdir/run_tests.configure.log"; then
      grep -m1 -A8 'CMake Error' "$bdir/run_tests.configure.log"
    else
      tail -15 "$bdir/run_tests.configure.log"
    fi
    echo "run_tests: FAILED: $cfg does not configure (log: $bdir/run_tests.configure.log)"
    record "$cfg" 0 1 "configure failed"
    return
  fi
  t_configure=$((SECONDS - step_t0)) t=$SECONDS
  say "$cfg" "build"
  cmake --build "$bdir" -j"$JOBS" 2>&1 | progress_build "$cfg" "$bdir/run_tests.build.log"
  if (( PIPESTATUS[0] != 0 )); then
    first_build_errors "$cfg" "$bdir/run_tests.build.log"
    echo "run_tests: FAILED: $cfg does not build (log: $bdir/run_tests.build.log)"
    record "$cfg" 0 1 "build failed"
    return
  fi
  t_build=$((SECONDS - t)) t=$SECONDS
  say "$cfg" "build done"
  build_warnings "$cfg" "$bdir/run_tests.build.log"
  local log=$bdir/run_tests.ctest.log rc args
  args=$(ctest_args "$cfg")
  [[ $cfg == double ]] && args="-LE net"
  say "$cfg" "ctest $args"
  # shellcheck disable=SC2086  # the label arguments are meant to split
  ctest --test-dir "$bdir" --output-on-failure -j"$JOBS" $args 2>&1 |
    progress_ctest "$cfg" "$log"
  rc=${PIPESTATUS[0]}
  t_test=$((SECONDS - t))
  ctest_verdict "$cfg" "$bdir" "$log" "$rc"
  [[ $cfg == double ]] && run_net "$bdir"
}

# The network tests of double (ctest -L net: processes in namespaces), 4 at a
# time: they mostly wait (29 tests: 40 s at -j4, 62 s at -j2, about 30 s of
# CPU), and they hold on a loaded machine (docs/guide/build.md, "Tests on a busy
# machine"). Recorded as the configuration double:net.
run_net() {
  local bdir=$1 log=$1/run_tests.net.log rc t=$SECONDS
  step_t0=$SECONDS
  say double:net "ctest -L net -j4"
  ctest --test-dir "$bdir" --output-on-failure -j4 -L net 2>&1 | progress_ctest double:net "$log"
  rc=${PIPESTATUS[0]}
  t_test=$((SECONDS - t))
  ctest_verdict double:net "$bdir" "$log" "$rc"
}

# ctest_verdict CONFIG BDIR LOG RC: passed/failed from a ctest log; the
# failures' first assertions; record.
ctest_verdict() {
  local cfg=$1 bdir=$2 log=$3 rc=$4
  local line total failed
  line=$(grep -E '^[0-9]+% tests passed, [0-9]+ tests? failed out of [0-9]+' "$log" | tail -1)
  if [[ -z "$line" ]]; then
    tail -15 "$log"
    echo "run_tests: FAILED: $cfg ran no test (log: $log)"
    record "$cfg" 0 1 "no tests found"
    return
  fi
  failed=$(echo "$line" | sed -E 's/.*, ([0-9]+) tests? failed out of ([0-9]+).*/\1/')
  total=$(echo "$line" | sed -E 's/.*, ([0-9]+) tests? failed out of ([0-9]+).*/\2/')
  if (( rc != 0 && failed == 0 )); then failed=1; fi
  say "$cfg" "$line"
  if (( failed > 0 )); then
    # ctest's closing list: "\t  5 - test_kf (Failed)". The first 5 that
    # ran get their first failing assertion; the rest are named; tests that
    # did not run (their setup fixture failed) are counted.
    local ran notrun
    ran=$(sed -n -E 's/^[[:space:]]+[0-9]+ - ([^ ]+) \((Failed|Timeout|SEGFAULT|Exception|[A-Za-z ]*)\)$/\1 \2/p' "$log" |
          awk '$2 != "Not" { print $1 }')
    notrun=$(grep -cE '^[[:space:]]+[0-9]+ - [^ ]+ \(Not Run\)$' "$log")
    # shellcheck disable=SC2086  # one name per word
    first_test_failures "$cfg" "$bdir" $(echo $ran | tr ' ' '\n' | head -5)
    (( $(echo $ran | wc -w) > 5 )) && echo "[$cfg] also failed: $(echo $ran | tr ' ' '\n' | tail -n +6 | tr '\n' ' ')"
    (( notrun > 0 )) && echo "[$cfg] $notrun test(s) not run (a setup test they need failed, or no executable)"
    echo "run_tests: FAILED: $failed test(s) of $cfg (log: $log)"
  fi
  record "$cfg" $((total - failed)) "$failed" ""
}

# The counts of the last "NAME: P passed, F failed" line of log $2 into the
# caller's p and f (f at least 1 when the script's exit status $3 was not 0);
# returns 1 when the log has no such line (the script did not finish).
passed_failed() {
  local line
  line=$(grep -E "^$1: [0-9]+ passed, [0-9]+ failed\$" "$2" | tail -1)
  [[ -n $line ]] || return 1
  p=$(echo "$line" | sed -E "s/$1: ([0-9]+) passed, ([0-9]+) failed/\\1/")
  f=$(echo "$line" | sed -E "s/$1: ([0-9]+) passed, ([0-9]+) failed/\\2/")
  if (( $3 != 0 && f == 0 )); then f=1; fi
  return 0
}

run_firmware() {
  step_t0=$SECONDS
  say firmware "Cortex-M4F image (tools/check_firmware.sh)"
  local log=$ROOT/build/run_tests.firmware.log line p f
  mkdir -p "$ROOT/build"
  # Progress: its section headers and every PASS/FAIL line; the sizes and
  # stack tables stay in the log.
  # The float configuration's dkf-run, when it ran here, is the qemu check's
  # reference (the same sources and options; no third host build)
  local ref=()
  [[ " ${configs[*]} " == *" float "* && -x $ROOT/build/float/ports/linux/dkf-run ]] &&
    ref=(DKF_M4_HOST_DKF_RUN="$ROOT/build/float/ports/linux/dkf-run")
  env "${ref[@]}" DKF_JOBS=$JOBS tools/check_firmware.sh 2>&1 | tee "$log" |
    while IFS= read -r line; do
      [[ $line =~ ^(==|PASS:|FAIL:) ]] && say firmware "$line"
    done
  if ! passed_failed firmware "$log" "${PIPESTATUS[0]}"; then
    first_build_errors firmware "$log"
    echo "run_tests: FAILED: firmware check did not finish (log: $log)"
    record firmware 0 1 "check aborted"
    return
  fi
  (( f > 0 )) && echo "run_tests: FAILED: $f firmware check(s) (see FAIL: lines above; log: $log)"
  record firmware "$p" "$f" "checks, not ctest"
}

run_fuzz() {
  step_t0=$SECONDS
  say fuzz "libFuzzer harnesses (tools/run_fuzz.sh)"
  local log=$ROOT/build/run_tests.fuzz.log line p f
  mkdir -p "$ROOT/build"
  # Progress: the build header, one line per harness and the first line of
  # each failure; libFuzzer's own output stays in build/fuzz/logs/.
  DKF_JOBS=$JOBS FUZZ_SECONDS=${FUZZ_SECONDS:-6} FUZZ_JOBS=$JOBS tools/run_fuzz.sh 2>&1 |
    tee "$log" |
    while IFS= read -r line; do say fuzz "$line"; done
  if ! passed_failed fuzz "$log" "${PIPESTATUS[0]}"; then
    echo "run_tests: FAILED: fuzz run did not finish (log: $log)"
    record fuzz 0 1 "run aborted"
    return
  fi
  (( f > 0 )) && echo "run_tests: FAILED: $f fuzz harness(es) (see FAIL lines above; log: $log)"
  record fuzz "$p" "$f" "harnesses, not ctest"
}

# The Python package: venv (reused), pip install of the tree, pytest. Each
# step bounded by `timeout`; pytest's "N passed, M failed" is the count.
# The venv and its packages (downloads, mostly): started in the background
# at the beginning of the run, so that run_python finds them ready. Its
# status: 0 ready, 1 no venv, 2 a package did not install.
python_env() {
  local bdir=$ROOT/build/python venv=$ROOT/build/python/venv oracle what
  local deps=(scikit-build-core nanobind numpy pytest)
  mkdir -p "$bdir"
  if [[ ! -x $venv/bin/python ]] && ! python3 -m venv "$venv" >"$bdir/run_tests.venv.log" 2>&1; then
    rm -rf "$venv"
    echo "run_tests: FAILED: python3 -m venv did not work (log: $bdir/run_tests.venv.log); run:"
    echo "  sudo apt-get install -y python3-venv"
    return 1
  fi
  if ! "$venv/bin/python" -c 'import scikit_build_core, nanobind, numpy, pytest' 2>/dev/null &&
     ! timeout 600 "$venv/bin/pip" install -q --disable-pip-version-check "${deps[@]}" \
         >"$bdir/run_tests.deps.log" 2>&1; then
    tail -5 "$bdir/run_tests.deps.log"
    echo "run_tests: FAILED: python: the venv's packages did not install (log: $bdir/run_tests.deps.log)"
    return 2
  fi
  # FilterPy and Stone Soup are test oracles only, numba the optional
  # dependency of dkf.jit_model: without one its tests are skipped, and say
  # so; pytest-xdist runs the tests two at a time (without it, one)
  for oracle in filterpy stonesoup numba xdist; do
    if ! "$venv/bin/python" -c "import $oracle" 2>/dev/null &&
       ! timeout 300 "$venv/bin/pip" install -q --disable-pip-version-check "${oracle/xdist/pytest-xdist}" \
         >>"$bdir/run_tests.deps.log" 2>&1; then
      if [[ $oracle == xdist ]]; then what="pytest runs one test at a time"; else what="its tests are skipped"; fi
      echo "[python] $oracle did not install (log: $bdir/run_tests.deps.log): $what"
    fi
  done
  return 0
}

run_python() {
  step_t0=$SECONDS
  local bdir=$ROOT/build/python venv=$ROOT/build/python/venv rc line p f t
  if [[ -n ${python_env_pid:-} ]]; then
    say python "the venv and its packages (prepared since the start of the run)"
    wait "$python_env_pid"
    rc=$?
    cat "$bdir/run_tests.env.out"
  else
    say python "the venv and its packages ($venv)"
    python_env
    rc=$?
  fi
  case $rc in
    0) ;;
    1) record python 0 1 "no venv"; return ;;
    *) record python 0 1 "pip install failed"; return ;;
  esac
  t=$SECONDS
  say python "pip install . (build in $bdir/build)"
  timeout 1200 "$venv/bin/pip" install -v --no-build-isolation --disable-pip-version-check \
    -C build-dir="$bdir/build" -C cmake.define.DKF_PY_WERROR=ON "$ROOT" 2>&1 |
    sed -u 's/^ *//' | progress_build python "$bdir/run_tests.build.log"
  if (( PIPESTATUS[0] != 0 )); then
    first_build_errors python "$bdir/run_tests.build.log"
    echo "run_tests: FAILED: python: pip install . did not build (log: $bdir/run_tests.build.log)"
    record python 0 1 "build failed"
    return
  fi
  t_build=$((SECONDS - t)) t=$SECONDS
  local two=()
  "$venv/bin/python" -c 'import xdist' 2>/dev/null && two=(-n 2)
  say python "pytest python/tests ${two[*]}"
  # test_scenario.py compares dkf.run_scenario with the double build's dkf-run (DKF_RUN),
  # dkf.float32.run_scenario with the float build's (DKF_RUN_FLOAT)
  (cd "$ROOT/python/tests" && { [[ ! -x $ROOT/build/double/ports/linux/dkf-run ]] ||
    export DKF_RUN=$ROOT/build/double/ports/linux/dkf-run; } &&
    { [[ ! -x $ROOT/build/float/ports/linux/dkf-run ]] ||
    export DKF_RUN_FLOAT=$ROOT/build/float/ports/linux/dkf-run; } && timeout 600 "$venv/bin/python" -m pytest -p no:cacheprovider -q -rs "${two[@]}") \
    >"$bdir/run_tests.pytest.log" 2>&1
  rc=$?
  t_test=$((SECONDS - t))
  line=$(grep -E '^=* ?[0-9]+ (passed|failed)' "$bdir/run_tests.pytest.log" | tail -1)
  p=$(echo "$line" | sed -nE 's/.*\b([0-9]+) passed.*/\1/p')
  f=$(echo "$line" | sed -nE 's/.*\b([0-9]+) failed.*/\1/p')
  p=${p:-0} f=${f:-0}
  if (( rc != 0 && f == 0 )); then f=1; fi
  say python "pytest: ${line:-no result line}"
  if (( f > 0 )); then
    grep -E '^(FAILED|ERROR) ' "$bdir/run_tests.pytest.log" | head -5
    echo "run_tests: FAILED: python: pytest exited $rc (log: $bdir/run_tests.pytest.log)"
  fi
  grep -E '^SKIPPED' "$bdir/run_tests.pytest.log" | head -3
  record python "$p" "$f" "pytest, not ctest"
}

run_demo() {
  step_t0=$SECONDS
  # double-dim1024 is the demo's build (double, DKF_MAX_DIM = 1024) when this
  # run made it; alone, the demo builds its own
  local dim=$ROOT/build/double-dim1024 args=(--build-dir "$ROOT/build/demo")
  [[ -x $dim/ports/linux/net/dkf-net-local && -x $dim/ports/linux/net/dkf-tw-node ]] &&
    args=(--build-dir "$dim" --no-build)
  say demo "the README's demo (tools/net_demo.sh ${args[*]})"
  local log=$ROOT/build/run_tests.demo.log rc
  mkdir -p "$ROOT/build"
  # Progress: its "==" headers and result rows; the whole output in the log.
  tools/net_demo.sh "${args[@]}" 2>&1 | tee "$log" |
    while IFS= read -r line; do
      [[ $line =~ ^==|\ ok|FAIL ]] && say demo "$line"
    done
  rc=${PIPESTATUS[0]}
  if (( rc != 0 )); then
    echo "run_tests: FAILED: tools/net_demo.sh exited $rc (log: $log)"
    record demo 0 1 "net_demo.sh, not ctest"
  else
    record demo 1 0 "net_demo.sh, not ctest"
  fi
}

start=$SECONDS
if [[ " ${configs[*]} " == *" python "* ]]; then
  mkdir -p "$ROOT/build/python"
  python_env >"$ROOT/build/python/run_tests.env.out" 2>&1 &
  python_env_pid=$!
fi
for c in "${configs[@]}"; do
  if (( stop )); then
    summary+=("$(printf '%-16s %6s %6s  %s' "$c" - - "not run (earlier failure; DKF_KEEP_GOING=1 runs all)")")
    continue
  fi
  case $c in
    firmware) run_firmware ;;
    fuzz) run_fuzz ;;
    demo) run_demo ;;
    python) run_python ;;
    *) run_ctest_config "$c" ;;
  esac
done

echo
echo "==== time (s; configure, build and test of the ctest configurations)"
printf '%-18s %9s %6s %6s %6s\n' config configure build test total
printf '%s\n' "${times[@]}"
echo "==== summary ($((SECONDS - start)) s)"
printf '%-16s %6s %6s\n' config passed failed
printf '%s\n' "${summary[@]}"
echo "${total_pass} passed, ${total_fail} failed"
(( total_fail == 0 && stop == 0 ))
