#!/usr/bin/env bash
# tools/bootstrap.sh - install what building and testing dkf needs (Debian).
#
# Idempotent and silent when everything is present: it asks dpkg-query which
# packages are missing and only then touches apt (one `apt-get update`, one
# `apt-get install`). As root it installs; otherwise it prints the exact
# command to run and exits 1.
#
#   DKF_BOOTSTRAP_NO_ARMHF=1  skip the armhf and arm64 multiarch packages (the
#                             qemu-arm and qemu-arm64 tests)
#   DKF_BOOTSTRAP_NO_PYTHON=1 skip the python3 numpy/matplotlib check
set -euo pipefail

# Host toolchain, unit-test deps, cross compilers, qemu, bench deps, fuzzing.
pkgs=(
  cmake make ninja-build gcc g++ pkg-config binutils
  libcmocka-dev libjansson-dev libmuparser-dev  # muparser: expression models (ports/linux/nlm/nlm_expr.c)
  gcc-arm-none-eabi libnewlib-arm-none-eabi binutils-arm-none-eabi
  gcc-arm-linux-gnueabihf libc6-dev-armhf-cross
  gcc-aarch64-linux-gnu libc6-dev-arm64-cross
  qemu-user
  qemu-system-arm  # the node image on an emulated Cortex-M4F (tools/m4_run.sh, mps2-an386)
  libeigen3-dev liblcm-dev liblcm-bin libglib2.0-dev valgrind libsodium-dev  # libsodium: node-message MACs (ports/linux/net/transport/auth.c)
  clang-14 libclang-rt-14-dev  # libFuzzer + sanitizer runtimes (tools/run_fuzz.sh)
  python3 python3-pip python3-venv  # python3-venv: the Python package's tests (run_tests.sh python)
  iproute2 nftables  # the emulated several-host network test (ports/linux/net/tests/lan_net.sh)
)
# Target (armhf, arm64) builds of the unit-test libraries, via Debian multiarch.
foreign_archs=(armhf arm64)
foreign_pkgs=(libcmocka-dev:armhf libjansson-dev:armhf libcmocka-dev:arm64 libjansson-dev:arm64)

want_armhf=1
[[ "${DKF_BOOTSTRAP_NO_ARMHF:-0}" == 1 ]] && want_armhf=0

native_arch="$(dpkg --print-architecture)"
# True if package $1 ("name" = native or arch-all, or "name:arch") is installed.
# dpkg-query prints one line per installed architecture of a Multi-Arch:
# same package, so look for the line of the architecture we want.
is_installed() {
  local name="${1%%:*}" arch="${1#*:}"
  [[ "$arch" == "$1" ]] && arch=""
  local a st
  while read -r a st; do
    [[ "$st" == installed ]] || continue
    if [[ -n "$arch" ]]; then
      [[ "$a" == "$arch" ]] && return 0
    elif [[ "$a" == "$native_arch" || "$a" == all ]]; then
      return 0
    fi
  done < <(dpkg-query -W -f='${Architecture} ${db:Status-Status}\n' "$name" 2>/dev/null || true)
  return 1
}

apt_updated=0
apt_update() {
  (( apt_updated )) && return 0
  apt_updated=1
  # A partial index failure (a mirror mid-sync) is not fatal: install decides.
  apt-get update -qq >/dev/null || echo "bootstrap: apt-get update reported errors; trying anyway" >&2
}

missing=()
for p in "${pkgs[@]}"; do
  is_installed "$p" || missing+=("$p")
done
new_archs=()
if (( want_armhf )); then
  for a in "${foreign_archs[@]}"; do
    dpkg --print-foreign-architectures | grep -qx "$a" || new_archs+=("$a")
  done
  for p in "${foreign_pkgs[@]}"; do
    is_installed "$p" || missing+=("$p")
  done
fi

if (( ${#missing[@]} )); then
  if [[ "$(id -u)" != 0 ]]; then
    echo "bootstrap: missing Debian packages: ${missing[*]}" >&2
    echo "bootstrap: run as root, or:" >&2
    for a in "${new_archs[@]}"; do echo "  sudo dpkg --add-architecture $a" >&2; done
    echo "  sudo apt-get update && sudo apt-get install -y --no-install-recommends ${missing[*]}" >&2
    exit 1
  fi
  echo "bootstrap: installing ${missing[*]}" >&2
  for a in "${new_archs[@]}"; do dpkg --add-architecture "$a"; done
  export DEBIAN_FRONTEND=noninteractive
  apt_update
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# Python for the analysis, Monte-Carlo and monitoring tools (numpy,
# matplotlib; PyPI `lcm` for the LCM monitors; mpmath for the 60-digit references of
# tools/make_stress_vectors.py). Their smoke tests need them.
py_missing=()
if [[ "${DKF_BOOTSTRAP_NO_PYTHON:-0}" != 1 ]]; then
  for mod in numpy matplotlib lcm mpmath; do
    python3 -c "import $mod" >/dev/null 2>&1 || py_missing+=("$mod")
  done
fi
if (( ${#py_missing[@]} )); then
  stdlib="$(python3 -c 'import sysconfig; print(sysconfig.get_path("stdlib"))')"
  managed=0
  [[ -e "$stdlib/EXTERNALLY-MANAGED" ]] && managed=1
  if [[ "$(id -u)" != 0 ]]; then
    echo "bootstrap: python3 lacks: ${py_missing[*]}; run:" >&2
    if (( managed )); then
      echo "  sudo apt-get install -y python3-numpy python3-matplotlib python3-mpmath && sudo python3 -m pip install --break-system-packages lcm" >&2
    else
      echo "  python3 -m pip install ${py_missing[*]}" >&2
    fi
    exit 1
  fi
  echo "bootstrap: installing python modules ${py_missing[*]}" >&2
  pip_mods=()
  for mod in "${py_missing[@]}"; do
    if (( managed )) && [[ "$mod" != lcm ]]; then
      # Debian's own python3 refuses pip (PEP 668): use its packages.
      apt_update
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        "python3-$mod" >/dev/null
    else
      pip_mods+=("$mod")
    fi
  done
  if (( ${#pip_mods[@]} )); then
    extra=()
    (( managed )) && extra=(--break-system-packages) # lcm is on PyPI only
    PIP_ROOT_USER_ACTION=ignore python3 -m pip install --quiet --disable-pip-version-check \
      "${extra[@]}" "${pip_mods[@]}"
  fi
fi
exit 0
