#!/usr/bin/env bash
# lan_cli.sh OUTDIR KEYGEN_ARGS SCENARIO PROGRAM [ARGS...] - the --lan and
# --insecure options of one network program (docs/guide/network.md, "Several
# hosts"), with no socket opened: every run that is accepted uses memq://,
# the one udpm:// URL is one the program must refuse before opening anything.
#
#   --lan without --key-dir                 refused (exit 2), one line saying why
#   --lan --insecure                        accepted, "UNAUTHENTICATED on the LAN"
#                                           on stderr (exit 4: --timeout)
#   --lan --key-dir KEYS                    accepted, nothing said of authentication
#   a URL saying ttl=0 twice, with --lan    refused (exit 2): "ttl=0 exactly once"
#                                           (--lan checks the URL as without it;
#                                           every other ttl: test_net_url.c)
#   --insecure without --lan                refused (exit 2)
#   --lan --insecure --key-dir KEYS         refused (exit 2)
#   --clock-offset-ms out of range          refused (exit 2)
#
# KEYGEN_ARGS: dkf-keygen's arguments before DIR and NODES ("" or "--edges")
# and NODES, e.g. "2" or "--edges 6". Environment: DKF_KEYGEN, DKF_NETNS.
# Every program runs in a network namespace of its own with only the loopback
# device (net_common.sh's in_netns), so a URL accepted by mistake reaches
# nothing; exit 77 (skip) where one cannot be made (not root).
set -uo pipefail
. "$(dirname "$0")/net_common.sh"
in_netns "$0" "$@"
out=$1 keygen_args=$2 scn=$3
shift 3
prog=("$@")
name=$(basename "$1")
rm -rf "$out" && mkdir -p "$out"
read -r -a kg <<<"$keygen_args"
"$DKF_KEYGEN" "${kg[@]:0:${#kg[@]}-1}" "$out/keys" "${kg[-1]}" || { echo "FAIL: dkf-keygen"; exit 1; }
fails=0 n=0

# expect TAG RC PATTERN OPTIONS...: PROGRAM OPTIONS SCENARIO exits RC and its
# stderr has PATTERN (fixed string; "" = none of "UNAUTHENTICATED")
expect() {
  local tag=$1 want=$2 pat=$3 rc
  shift 3
  ((++n))
  "${prog[@]}" "$@" "$scn" >"$out/$tag.out" 2>"$out/$tag.err"
  rc=$?
  if [[ $rc != "$want" ]]; then
    echo "FAIL: $name $*: exit $rc, want $want"; cat "$out/$tag.err"; ((++fails)); return
  fi
  if [[ -n $pat ]] && ! grep -qF -- "$pat" "$out/$tag.err"; then
    echo "FAIL: $name $*: stderr lacks '$pat':"; cat "$out/$tag.err"; ((++fails)); return
  fi
  if [[ -z $pat ]] && grep -q UNAUTHENTICATED "$out/$tag.err"; then
    echo "FAIL: $name $*: says it is unauthenticated:"; cat "$out/$tag.err"; ((++fails)); return
  fi
  if [[ $want == 2 && $(wc -l <"$out/$tag.err") != 1 ]]; then
    echo "FAIL: $name $*: the refusal is not one line:"; cat "$out/$tag.err"; ((++fails)); return
  fi
  echo "ok: $name $* -> exit $rc${pat:+, '$pat'}"
}

T=(--timeout 0.3)
expect lan-nokeys 2 "--lan without --key-dir: refused" --url memq:// --lan
expect lan-insecure 4 "UNAUTHENTICATED on the LAN (--insecure)" --url memq:// --lan --insecure "${T[@]}"
expect lan-keys 4 "" --url memq:// --lan --key-dir "$out/keys" "${T[@]}"
expect ttl-twice-lan 2 "ttl=0 exactly once" --url 'udpm://239.255.76.67:7667?ttl=0&ttl=0' --lan \
  --insecure
expect insecure-nolan 2 "--insecure: only with --lan" --url memq:// --insecure
expect insecure-keys 2 "--insecure and --key-dir: give one" --url memq:// --lan --insecure \
  --key-dir "$out/keys"
expect clock-bad 2 "--clock-offset-ms 1e10: expected a number" --url memq:// --clock-offset-ms 1e10
if (( fails )); then echo "FAIL: $fails of $n"; exit 1; fi
echo "PASS: $name: $n of $n"
