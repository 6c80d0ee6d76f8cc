# net_common.sh - the shell helpers of the network test scripts
# (ports/linux/net/tests/*.sh) and of the demos (tools/*_net_demo.sh), sourced:
# entering a private network namespace (tools/netns.sh), the background
# processes of a run, readiness waits, the logger, the load probe the
# deadlines derive from, and the demos' common options and set-up.

# ---- the namespace and the run's processes ------------------------------------------

# The multicast group of every test and demo: ttl=0, inside its own namespace.
URL='udpm://239.255.76.67:7667?ttl=0'

# in_netns SCRIPT ARGS...: outside a namespace made for this run, checks that
# one can be made ($DKF_NETNS check: exit 77, the ctest skip code, if not) and
# re-runs SCRIPT ARGS in it; inside, returns if the namespace has only the
# loopback device, else exits 1 (nothing is sent).
in_netns() {
  local script=$1; shift
  if [[ ${DKF_IN_NETNS:-0} != 1 ]]; then
    "$DKF_NETNS" check || exit $?
    DKF_IN_NETNS=1 exec "$DKF_NETNS" exec -- "$script" "$@"
  fi
  loopback_only FAIL || exit 1
}

# loopback_only WHO: 0 if this network namespace has no device but loopback,
# else says so as WHO and returns 1.
loopback_only() {
  if ip -o link | grep -qv ': lo:'; then
    echo "$1: the namespace has a non-loopback interface; not sending anything" >&2
    return 1
  fi
}

# needs_numpy WHY: exit 77 (skip) outside the namespace when $DKF_PYTHON has
# no numpy (WHY: what needs it).
needs_numpy() {
  [[ ${DKF_IN_NETNS:-0} == 1 ]] && return 0
  "$DKF_PYTHON" -c 'import numpy' 2>/dev/null || { echo "SKIP: numpy missing ($1)"; exit 77; }
}

# start_run DIR: DIR made empty; the run's background processes go into
# pids, and every one still there is killed (and waited for) on exit.
start_run() {
  rm -rf "$1" && mkdir -p "$1"
  pids=()
  trap kill_run EXIT
}
kill_run() {
  local p
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
}

# ---- waits ---------------------------------------------------------------------------

wait_file() { # FILE SECONDS: until FILE exists
  local i
  for ((i = 0; i < $2 * 100; ++i)); do [[ -e $1 ]] && return 0; sleep 0.01; done
  echo "FAIL: $1 did not appear within $2 s" >&2; return 1
}

start_logger() { # URL LOG: lcm-logger recording URL into LOG in the background; sets logger
  # A 4 MiB receive buffer (capped by net.core.rmem_max) and a higher priority
  # (we are root in the namespace): at load 8 on 2 cores a logger descheduled
  # for ~150 ms lost a few datagrams of every channel from the 208 KiB default
  # buffer, and the log checks then failed on a step the log did not hold.
  nice -n -10 "$DKF_LCM_LOGGER" --lcm-url="$1&recv_buf_size=4194304" -f -q --flush-interval=10 \
    "$2" & pids+=($!); logger=$!
}

wait_log_quiet() { # LOG [QUIET_MS]: until lcm-logger's LOG has stopped growing for
  # QUIET_MS (default 300; a loaded machine may hold the logger back longer:
  # callers derive it, probe_ms below), at most 60 s
  local i last=-1 still=0 size need=$(( (${2:-300} + 9) / 10 ))
  for ((i = 0; i < 6000 && still < need; ++i)); do
    size=$(stat -c %s "$1")
    if [[ $size == "$last" ]]; then ((++still)); else still=0 last=$size; fi
    sleep 0.01
  done
}

# probe_ms PROGRAM: the longest of 10 runs of `PROGRAM --help`, in ms. A
# start of one of our programs is a fixed piece of work, so its wall time
# measures how long this machine takes, now, to give a process the CPU: it
# grows with the load (measured on 2 cores: 9 ms quiet, 16-20 ms with two
# CPU-bound processes, 28-35 ms with six).
probe_ms() {
  local i t0 dt max=1
  for ((i = 0; i < 10; ++i)); do
    t0=$(date +%s%N)
    "$1" --help >/dev/null 2>&1
    dt=$(( ($(date +%s%N) - t0) / 1000000 ))
    (( dt > max )) && max=$dt
  done
  echo "$max"
}

# derived_ms PROGRAM FLOOR_MS FACTOR: a deadline for detecting a process that
# is absent (dead, never started, dropping its messages) that a process that
# is only slow never reaches: FACTOR x probe_ms PROGRAM, at least FLOOR_MS.
# Said on stdout's last line is the value; the reason goes to stderr.
derived_ms() {
  local p d
  p=$(probe_ms "$1")
  d=$(( $3 * p ))
  (( d < $2 )) && d=$2
  echo "deadline ${d} ms (${3} x ${p} ms, the slowest of 10 starts of $(basename "$1"); at least $2 ms)" >&2
  echo "$d"
}

# ---- the demos (tools/*_net_demo.sh) --------------------------------------------------

# demo_options NAME HELP_LAST BUILD ARGS...: here and root (the demo's folder
# and the repository), the defaults build=$root/build/BUILD, do_build=1,
# inproc=0, then the options of every demo: --build-dir DIR into build,
# --no-build (do_build=0), --steps T into steps, --in-process (inproc=1),
# --nodes N into nodes (a demo that has set nodes), -h/--help (the script's
# lines 2..HELP_LAST), and --inner: the arguments after it into inner (the
# processes inside the namespace). Anything else: exit 2.
demo_options() {
  local name=$1 help_last=$2
  here=$(cd "$(dirname "$0")" && pwd)
  root=$(dirname "$here")
  build=$root/build/$3 do_build=1 inproc=0
  shift 3
  inner=()
  while [[ $# -gt 0 ]]; do
    case $1 in
      --build-dir) build=$(realpath -m "$2"); shift 2 ;;
      --no-build) do_build=0; shift ;;
      --steps) steps=$2; shift 2 ;;
      --nodes) [[ -v nodes ]] || break; nodes=$2; shift 2 ;;
      --in-process) inproc=1; shift ;;
      --inner) shift; inner=("$@"); return 0 ;;
      -h|--help) sed -n "2,${help_last}p" "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
      *) break ;;
    esac
  done
  [[ $# -eq 0 ]] || { echo "$name: $1: unknown option (see --help)" >&2; exit 2; }
}

# demo_build DIR TARGET...: configures DIR from the demo's root and builds
# the targets (unless --no-build).
demo_build() {
  local dir=$1; shift
  (( do_build )) || return 0
  echo "== building $* in $dir"
  cmake -S "$root" -B "$dir" >/dev/null
  cmake --build "$dir" -j2 --target "$@" >/dev/null
}

# demo_require NAME PROGRAM...: exit 2 unless every PROGRAM is executable.
demo_require() {
  local name=$1 p; shift
  for p in "$@"; do
    [[ -x $p ]] || { echo "$name: $p missing (build first, or --build-dir)" >&2; exit 2; }
  done
}

# demo_tw_programs NAME: dkf-tw-node, dkf-run, dkf-keygen built in $build
# (demo_build) and checked (demo_require), into node, run, keygen.
demo_tw_programs() {
  demo_build "$build" dkf-tw-node dkf-run dkf-keygen
  node=$build/ports/linux/net/dkf-tw-node
  run=$build/ports/linux/dkf-run
  keygen=$build/ports/linux/net/dkf-keygen
  demo_require "$1" "$node" "$run" "$keygen"
}

# run_tw_nodes N DIR NODE SCN KEYS ARGS...: N NODE (dkf-tw-node) processes,
# ids 0..N-1, with ARGS on scenario SCN over $URL (keys KEYS), each writing
# DIR/node<i>.json and .log; waits for all, the wall time into DIR/wall_s.
# 1 if any failed.
run_tw_nodes() {
  local n=$1 dir=$2 node=$3 scn=$4 keys=$5 t0 i p rc=0
  shift 5
  t0=$(date +%s.%N)
  for ((i = 0; i < n; ++i)); do
    "$node" --url "$URL" --id $i "$@" --timeout 300 --quiet --key-dir "$keys" \
      --output "$dir/node$i.json" "$scn" 2>"$dir/node$i.log" & pids+=($!)
  done
  for p in "${pids[@]}"; do wait "$p" || rc=1; done
  wall_since "$t0" "$dir/wall_s"
  pids=()
  return $rc
}

# demo_mode NAME UNIT FALLBACK OUTDIR: mode=udpm, or mode=inproc with
# --in-process or where the demo's $here/netns.sh cannot make a private
# network namespace (said: one process per UNIT needs one; running
# FALLBACK only).
demo_mode() {
  local name=$1 pad
  pad=$(printf '%*s' $((${#name} + 2)) '')
  mode=udpm
  if (( inproc )); then
    mode=inproc
  elif ! "$here/netns.sh" check 2>"$4/netns.err"; then
    echo "$name: $(sed 's/^netns.sh: //' "$4/netns.err")"
    echo "$name: one process per $2 needs a private network namespace (root),"
    echo "${pad}so that nothing can leave this machine; running $3 only."
    mode=inproc
  fi
}

# demo_auth_exit RC: exits with RC, or 1 when the processes ran (mode udpm)
# and tools/auth_summary.py finds a datagram rejected in $out/proc*/node*.json
# (every process authenticated with a key per edge: nothing may be rejected).
demo_auth_exit() {
  local rc=$1
  if [[ $mode == udpm ]]; then
    python3 "$here/auth_summary.py" --what "a key per edge of the graph" "$out"/proc*/node*.json || rc=1
  fi
  exit "$rc"
}

# wall_since T0 FILE: the seconds since T0 (date +%s.%N) into FILE.
wall_since() { echo "$(date +%s.%N) - $1" | bc > "$2"; }

# demo_timed WALL CMD...: runs CMD and writes its wall time in seconds to WALL.
demo_timed() {
  local wall=$1 t0
  shift
  t0=$(date +%s.%N)
  "$@"
  wall_since "$t0" "$wall"
}

# demo_processes NAME VAR FAILED ARGS...: the demo again inside a private
# network namespace (tools/netns.sh) as VAR=1 "$0" --inner ARGS..., where it
# runs its processes; "NAME: FAILED" if one of them failed.
demo_processes() {
  local name=$1 var=$2 failed=$3
  shift 3
  env "$var=1" "$root/tools/netns.sh" exec -- "$0" --inner "$@" || echo "$name: $failed"
}
