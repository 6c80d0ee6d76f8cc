#!/usr/bin/env bash
# tools/run_fuzz.sh - builds every harness tests/fuzz/fuzz_<name>.c with
# clang's libFuzzer + ASan + UBSan in build/fuzz (DKF_FUZZ=ON, docs/guide/fuzzing.md)
# and runs each for a bounded time on its corpus tests/fuzz/corpus/<name>/.
#
# usage: tools/run_fuzz.sh [name...]      (default: every harness)
# env:   FUZZ_SECONDS=60   time per harness (libFuzzer -max_total_time)
#        FUZZ_MERGE=1      afterwards merge the inputs that add coverage into
#                          tests/fuzz/corpus/<name>/ (default: the committed
#                          corpus is only read; new inputs go to build/fuzz/work)
#        FUZZ_SEED=1       libFuzzer's -seed (fixed, as every randomised test here;
#                          0 lets libFuzzer pick one)
#        FUZZ_JOBS=1       harnesses run at the same time (each uses one core)
#        DKF_JOBS=2        build jobs;  CC=clang-14  the compiler
# One line per harness (PASS/FAIL, executions, coverage, the crash input if
# any), then "fuzz: N passed, M failed". A crash leaves its input in
# build/fuzz/artifacts/<name>/ and the run's log in build/fuzz/logs/<name>.log.
set -uo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BDIR=$ROOT/build/fuzz
SECONDS_EACH=${FUZZ_SECONDS:-60}
JOBS=${DKF_JOBS:-2}
FUZZ_JOBS_N=${FUZZ_JOBS:-1}
CC_FUZZ=${CC:-}
case "$(basename "${CC_FUZZ:-none}")" in
  clang*) ;;
  *) CC_FUZZ=$(command -v clang-14 || command -v clang || true) ;; # libFuzzer is clang's
esac
if [[ -z "$CC_FUZZ" ]]; then
  echo "run_fuzz: FAILED: no clang (tools/bootstrap.sh installs clang-14, libclang-rt-14-dev)"
  echo "fuzz: 0 passed, 1 failed"
  exit 1
fi

names=("$@")
if (( ${#names[@]} == 0 )); then
  for src in tests/fuzz/fuzz_*.c; do
    n=$(basename "$src" .c)
    names+=("${n#fuzz_}")
  done
fi

mkdir -p "$BDIR/logs"
echo "==== fuzz: configure + build ($BDIR, $CC_FUZZ)"
# -O1 -g, the level libFuzzer and the sanitizers are usually built at: the
# build takes a third less time than at -O2 (src/kf.c under ASan: 30 s, 57 s)
if ! CC=$CC_FUZZ cmake -S "$ROOT" -B "$BDIR" -DDKF_FUZZ=ON -DDKF_BUILD_TESTS=OFF \
     -DDKF_REAL=double -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -g" \
     "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g" >"$BDIR/logs/configure.log" 2>&1; then
  tail -30 "$BDIR/logs/configure.log"
  echo "run_fuzz: FAILED: build/fuzz does not configure (log: $BDIR/logs/configure.log)"
  echo "fuzz: 0 passed, 1 failed"
  exit 1
fi
if ! cmake --build "$BDIR" -j"$JOBS" --target dkf_fuzzers >"$BDIR/logs/build.log" 2>&1; then
  grep -E 'error' "$BDIR/logs/build.log" | sort -u | head -20
  echo "run_fuzz: FAILED: the harnesses do not build (log: $BDIR/logs/build.log)"
  echo "fuzz: 0 passed, 1 failed"
  exit 1
fi

# fuzz_one NAME: runs one harness; its verdict line (and a failure's details)
# into $BDIR/logs/NAME.verdict, whose first word is PASS or FAIL.
fuzz_one() {
  local n=$1 bin=$BDIR/fuzz/fuzz_$1 corpus=$ROOT/tests/fuzz/corpus/$1 work=$BDIR/work/$1
  local art=$BDIR/artifacts/$1 log=$BDIR/logs/$1.log out=$BDIR/logs/$1.verdict
  local rc execs cov crash dict=()
  if [[ ! -x "$bin" ]]; then
    printf 'fuzz: %-24s FAIL  not built (register it in tests/fuzz/CMakeLists.txt)\n' "$n" >"$out"
    return
  fi
  if [[ ! -d "$corpus" ]] || [[ -z "$(ls -A "$corpus" 2>/dev/null)" ]]; then
    printf 'fuzz: %-24s FAIL  no seed corpus in tests/fuzz/corpus/%s/\n' "$n" "$n" >"$out"
    return
  fi
  mkdir -p "$work" "$art"
  [[ -f tests/fuzz/$n.dict ]] && dict=(-dict="$ROOT/tests/fuzz/$n.dict")
  # New inputs go to the first directory (work); the committed corpus is read.
  "$bin" -seed="${FUZZ_SEED:-1}" -max_total_time="$SECONDS_EACH" -timeout=25 -rss_limit_mb=2048 \
    -print_final_stats=1 "${dict[@]}" -artifact_prefix="$art/" "$work" "$corpus" >"$log" 2>&1
  rc=$?
  execs=$(grep -E '^stat::number_of_executed_units:' "$log" | awk '{print $2}' | tail -1)
  cov=$(grep -E '^#[0-9]+' "$log" | grep -oE 'cov: [0-9]+' | tail -1)
  crash=$(grep -oE "Test unit written to [^ ]+" "$log" | tail -1 | sed 's/Test unit written to //')
  if (( rc == 0 )); then
    printf 'fuzz: %-24s PASS  %s s, %s executions, %s\n' "$n" "$SECONDS_EACH" "${execs:-?}" \
      "${cov:-cov: ?}" >"$out"
  else
    {
      printf 'fuzz: %-24s FAIL  exit %s, input %s (log %s)\n' "$n" "$rc" "${crash:-none}" "$log"
      grep -m1 -E 'ERROR: |runtime error|property broken|deadly signal' "$log" | sed 's/^/      /'
      # the input itself, so a failure on another machine can be replayed here
      # (echo ... | base64 -d > crash; build/fuzz/fuzz/fuzz_<name> crash)
      if [[ -n "$crash" && -f "$crash" ]] && (( $(stat -c %s "$crash") <= 4096 )); then
        echo "      input (base64): $(base64 -w0 "$crash")"
      fi
    } >"$out"
  fi
  if [[ "${FUZZ_MERGE:-0}" == 1 ]] && (( rc == 0 )); then
    "$bin" -merge=1 "$corpus" "$work" >"$BDIR/logs/$n.merge.log" 2>&1 ||
      echo "run_fuzz: $n: merge failed (log $BDIR/logs/$n.merge.log)" >>"$out"
    echo "fuzz: $n: corpus now $(ls "$corpus" | wc -l) files (tests/fuzz/corpus/$n/)" >>"$out"
  fi
}

# FUZZ_JOBS harnesses at a time (each is one process on one core); their
# lines in the order of the names.
pass=0
fail=0
report() { # NAME: prints its verdict, counts it
  [[ -s $BDIR/logs/$1.verdict ]] ||
    printf 'fuzz: %-24s FAIL  no verdict (the run script stopped)\n' "$1" >"$BDIR/logs/$1.verdict"
  cat "$BDIR/logs/$1.verdict"
  if [[ $(awk 'NR == 1 { print $3 }' "$BDIR/logs/$1.verdict") == PASS ]]; then
    pass=$((pass + 1))
  else
    fail=$((fail + 1))
  fi
}
for ((i = 0; i < ${#names[@]}; i += FUZZ_JOBS_N)); do
  batch=("${names[@]:i:FUZZ_JOBS_N}")
  pids=()
  for n in "${batch[@]}"; do rm -f "$BDIR/logs/$n.verdict"; fuzz_one "$n" & pids+=($!); done
  wait "${pids[@]}"
  for n in "${batch[@]}"; do report "$n"; done
done
echo "fuzz: ${pass} passed, ${fail} failed"
(( fail == 0 ))
