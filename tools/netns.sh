#!/usr/bin/env bash
# tools/netns.sh - private network namespaces for the LCM network tests and
# demos, so that multicast traffic cannot leave this machine even by mistake.
#
#   netns.sh check                 exit 0 if namespaces can be made here, else
#                                  print why and exit 77 (the ctest skip code)
#   netns.sh exec -- CMD [ARG...]  run CMD in a new, unnamed namespace
#                                  (unshare -n) that has only the loopback
#                                  device; it disappears when CMD exits
#   netns.sh create NAME           a named namespace (ip netns add) with the
#                                  same set-up, for several terminals:
#                                  ip netns exec NAME dkf-node --id 0 ...
#   netns.sh delete NAME           remove it
#
# Set-up inside: lo up with multicast on, and 239.0.0.0/8 routed to lo, so
# LCM's udpm://239.x.y.z...?ttl=0 works between processes in the namespace
# and there is no other interface to send anything to. Root only.
set -euo pipefail

prog=netns.sh
die() { echo "$prog: $*" >&2; exit 2; }

check() {
  if [[ $(id -u) != 0 ]]; then
    echo "$prog: SKIP: network namespaces need root (unshare -n / ip netns); run as root" >&2
    return 77
  fi
  command -v unshare >/dev/null || { echo "$prog: SKIP: unshare not found (util-linux)" >&2; return 77; }
  command -v ip >/dev/null || { echo "$prog: SKIP: ip not found (iproute2)" >&2; return 77; }
  if ! unshare -n true 2>/dev/null; then
    echo "$prog: SKIP: unshare -n is not permitted here" >&2
    return 77
  fi
}

# The set-up, run inside the namespace.
setup_lo() {
  ip link set lo up multicast on
  ip route add 239.0.0.0/8 dev lo
}

case "${1:-}" in
  check)
    check
    ;;
  exec)
    shift
    [[ ${1:-} == -- ]] && shift
    [[ $# -gt 0 ]] || die "exec: no command"
    check || exit $?
    # shellcheck disable=SC2016
    exec unshare -n bash -c 'ip link set lo up multicast on && ip route add 239.0.0.0/8 dev lo && exec "$@"' netns-exec "$@"
    ;;
  create)
    [[ -n ${2:-} ]] || die "create: no NAME"
    check || exit $?
    ip netns add "$2"
    ip netns exec "$2" bash -c "$(declare -f setup_lo); setup_lo"
    echo "$prog: namespace $2 ready: ip netns exec $2 COMMAND" >&2
    ;;
  delete)
    [[ -n ${2:-} ]] || die "delete: no NAME"
    ip netns delete "$2"
    ;;
  -h|--help|"")
    sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'
    [[ -n ${1:-} ]] || exit 2
    ;;
  *)
    die "$1: unknown command (check, exec, create, delete)"
    ;;
esac
