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

wait_log_quiet() { # LOG: until lcm-logger's LOG has stopped growing for 0.3 s (at most 10 s)
  local i last=-1 still=0 size
  for ((i = 0; i < 1000 && still < 30; ++i)); do
    size=$(stat -c %s "$1")
    if [[ $size == "$last" ]]; then ((++still)); else still=0 last=$size; fi
    sleep 0.01
  done
}
