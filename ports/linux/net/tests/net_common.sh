# net_common.sh - shell helpers of the network test scripts (sourced).

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
