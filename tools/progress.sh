# tools/progress.sh - progress lines for long builds, sourced by
# tools/run_tests.sh and tools/net_demo.sh (bash).
#
#   . tools/progress.sh
#   cmake --build DIR 2>&1 | progress_build LABEL LOG
#
# say LABEL TEXT prints "[LABEL] TEXT (s since step_t0)"; set step_t0=$SECONDS
# where a step begins. Safe under `set -e` (a read that times out is a status
# here, not a failure).
step_t0=$SECONDS
say() { printf '[%s] %s (%d s)\n' "$1" "$2" $((SECONDS - step_t0)); }

# next_line: the next line of stdin into $line, waiting at most 10 s.
# Returns 0 with a line, 1 at the end of the input, 2 when 10 s passed
# without a whole line (then the progress functions print a heartbeat, so a
# long compile or test never leaves the terminal silent for long).
next_line() {
  local got rc
  IFS= read -r -t 10 got && rc=0 || rc=$?
  if (( rc > 128 )); then _partial+=$got; return 2; fi
  line=$_partial$got; _partial=''
  (( rc == 0 )) || [[ -n $line ]] || return 1
  return 0
}

# progress_build LABEL LOG < output: all of it to LOG, "[LABEL] build 37%"
# (make's percentages, or ninja's [37/120]) at most every 10 s.
progress_build() {
  local label=$1 log=$2 line pct=0 last=-1 t=$((SECONDS - 10)) rc _partial=''
  : >"$log"
  while :; do
    next_line && rc=0 || rc=$?
    if (( rc == 2 )); then
      (( SECONDS - t >= 30 )) && { say "$label" "build $pct%, still compiling"; t=$SECONDS; }
      continue
    fi
    (( rc == 0 )) || break
    printf '%s\n' "$line" >>"$log"
    if [[ $line =~ ^\[\ *([0-9]+)%\] ]]; then pct=${BASH_REMATCH[1]}
    elif [[ $line =~ ^\[([0-9]+)/([0-9]+)\] ]]; then pct=$((100 * BASH_REMATCH[1] / BASH_REMATCH[2]))
    else continue; fi
    if (( pct != last && SECONDS - t >= 10 )); then
      say "$label" "build $pct%"; last=$pct; t=$SECONDS
    fi
  done
}

