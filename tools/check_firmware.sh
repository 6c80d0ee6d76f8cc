#!/usr/bin/env bash
# tools/check_firmware.sh - build the Cortex-M4F image (ports/cortex-m4) and
# check its footprint. For each variant (default: float double float-nochecks;
# float-nochecks is float with DKF_DEBUG_CHECKS=0, the lean configuration):
#   build     library + image with the arm-none-eabi toolchain, -Werror
#   no-heap   nm finds no allocator symbol (malloc, free, _sbrk, _malloc_r...)
#             in the ELF, and libdkf.a references none
#   stack     worst-case stack of dkf_kf_init/predict/update (GCC
#             -fstack-usage/-fcallgraph-info + tools/stack_usage.py) is
#             bounded (no recursion, no dynamic frame) and within
#             DKF_M4_STACK_BUDGET bytes (default 4096)
#   host-run  the image's filter code (demo.c), built for the host against a
#             host library of the same real type, reproduces the reference
#             (not for -nochecks: the checks do not change any number)
#   qemu      (with float) the node image dkf_m4_qemu.elf runs under
#             qemu-system-arm -M mps2-an386 (tools/m4_check.py): on every
#             tests/vectors/diffkf vector, kf and dkf, its output equals the
#             host float dkf-run's bit for bit; the double image's matches
#             the vectors (rel 1e-9); a refused model, an input cut short and
#             a failing filter make it exit 2, 2 and 3; then the instructions per
#             step, stack, flash and RAM of the DKF node and the KF
# and prints arm-none-eabi-size. Builds go to build/m4-<real>/ (reused); the
# host float dkf-run to build/m4-host-float (or DKF_M4_HOST_DKF_RUN: see below).
# The last line is "firmware: N passed, M failed"; exit status 1 if M > 0.
#
# usage: tools/check_firmware.sh [float] [double] [float-nochecks] [double-nochecks]
set -uo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
reals=("$@")
(( ${#reals[@]} )) || reals=(float double float-nochecks)
budget=${DKF_M4_STACK_BUDGET:-4096}
# The host float dkf-run the qemu check compares with: DKF_M4_HOST_DKF_RUN
# (tools/run_tests.sh passes its float configuration's, the same sources
# and options), else one built in build/m4-host-float.
host_dkf_run=${DKF_M4_HOST_DKF_RUN:-}
jobs=${DKF_JOBS:-2}
passed=0
failed=0

pass() { echo "PASS: $*"; passed=$((passed + 1)); }
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }

# Anything the allocator would bring in. newlib-nano names included.
heap_re='^(malloc|calloc|realloc|free|reallocf|memalign|aligned_alloc|posix_memalign|valloc|pvalloc|_malloc_r|_calloc_r|_realloc_r|_free_r|_memalign_r|_valloc_r|_pvalloc_r|_malloc_trim_r|_mallinfo_r|_sbrk|_sbrk_r|sbrk|__malloc_av_|__malloc_lock|__malloc_unlock|__malloc_sbrk_base|__malloc_top_pad|__malloc_max_sbrked_mem|__malloc_current_mallinfo|__nano_malloc|nano_malloc|nano_free|__malloc_free_list|__malloc_sbrk_start|alloca)$'

check_real() {
  local variant=$1
  local real=${variant%-nochecks}
  local checks=ON
  [[ $variant == *-nochecks ]] && checks=OFF
  if [[ $real != float && $real != double ]]; then
    fail "unknown firmware variant '$variant'"
    return
  fi
  local bdir=$ROOT/build/m4-$variant
  local hdir=$ROOT/build/m4-host-$real
  local elf=$bdir/dkf_m4.elf
  echo "== Cortex-M4F image, DKF_REAL=$real, debug checks $checks ($bdir)"

  if cmake -S ports/cortex-m4 -B "$bdir" -DDKF_REAL="$real" -DDKF_M4_DEBUG_CHECKS=$checks >"$bdir.configure.log" 2>&1 &&
     cmake --build "$bdir" -j"$jobs" >"$bdir.build.log" 2>&1; then
    pass "m4-$variant build (library + image, -Werror)"
  else
    cat "$bdir.configure.log" "$bdir.build.log" 2>/dev/null | tail -40
    fail "m4-$variant build"
    return
  fi

  local heap lib_heap
  heap=$(arm-none-eabi-nm "$elf" "$bdir/dkf_m4_qemu.elf" "$bdir/dkf_m4_live.elf" | awk '{print $NF}' |
         grep -E "$heap_re" || true)
  lib_heap=$(arm-none-eabi-nm -u "$bdir/dkf/libdkf.a" 2>/dev/null | awk '{print $NF}' |
             grep -E "$heap_re" || true)
  # shellcheck disable=SC2086 # the symbols, one word each
  heap_verdict "m4-$variant no heap symbols in dkf_m4.elf, dkf_m4_qemu.elf, dkf_m4_live.elf or libdkf.a" "m4-$variant" \
    $heap $lib_heap

  image_sizes "$elf" "$bdir/dkf_m4.map" "" " in the image"
  echo "-- libdkf.a objects (arm-none-eabi-size -t)"
  arm-none-eabi-size -t "$bdir/dkf/libdkf.a" | sed 's/^/  /'

  echo "-- worst-case stack (bytes; frame sizes in parentheses)"
  stack_verdict "m4-$variant filter" \
    "m4-$variant stack analysis (recursion, indirect call or dynamic frame)" '^dkf_kf_' \
    --elf "$elf" --skip dkf_m4_nerts.dir --skip dkf_m4_qemu.dir --skip dkf_m4_live.dir "$bdir" \
    dkf_kf_init dkf_kf_predict dkf_kf_update m4_demo_run Reset_Handler

  check_nerts_image "$variant" "$bdir"

  # The same demo.c on the host, against a host library of the same type
  # (the float build also has dkf-run, the reference of the qemu check).
  [[ $checks == ON ]] || return
  local ports=OFF targets=(dkf)
  [[ $real == float && -z $host_dkf_run ]] && ports=ON targets=(dkf dkf-run)
  if cmake -S . -B "$hdir" -DDKF_REAL="$real" -DDKF_BUILD_TESTS=OFF -DDKF_BUILD_PORTS=$ports \
       -DDKF_BUILD_BENCH=OFF >"$hdir.configure.log" 2>&1 &&
     cmake --build "$hdir" -j"$jobs" --target "${targets[@]}" >"$hdir.build.log" 2>&1 &&
     cc -std=c99 -Wall -Wextra -Wpedantic -Werror -O2 -DDKF_USE_FLOAT=$([[ $real == float ]] && echo 1 || echo 0) \
       -Iinclude -Iports/cortex-m4 ports/cortex-m4/demo.c ports/cortex-m4/host_main.c \
       "$hdir/libdkf.a" -lm -o "$hdir/m4_demo_host" 2>"$hdir.demo.log" &&
     "$hdir/m4_demo_host"; then
    pass "m4-$variant demo filter on the host matches the reference"
  else
    cat "$hdir.configure.log" "$hdir.build.log" "$hdir.demo.log" 2>/dev/null | tail -30
    fail "m4-$variant demo filter on the host"
  fi
  if cc -std=c99 -Wall -Wextra -Wpedantic -Werror -O2 -DDKF_USE_FLOAT=$([[ $real == float ]] && echo 1 || echo 0) \
       -Iinclude -Iports/cortex-m4 ports/cortex-m4/nerts_demo.c ports/cortex-m4/nerts_host_main.c \
       "$hdir/libdkf.a" -lm -o "$hdir/m4_nerts_host" 2>"$hdir.nerts.log" &&
     "$hdir/m4_nerts_host"; then
    pass "m4-$variant DNERTSIF node demo on the host converges (position < 0.5, omega < 1e-3)"
  else
    cat "$hdir.nerts.log" 2>/dev/null | tail -20
    fail "m4-$variant DNERTSIF node demo on the host"
  fi
}

# PASS $1 when no heap symbol was linked (the arguments after $2), else FAIL
# "$2 heap symbols linked: ...".
heap_verdict() {
  local ok=$1 bad=$2
  shift 2
  if (( $# == 0 )); then
    pass "$ok"
  else
    fail "$bad heap symbols linked: $*"
  fi
}

# The image $1's size and its bytes per input from its linker map $2; $3
# starts both headings, $4 ends the second's first words.
image_sizes() {
  echo "-- ${3}arm-none-eabi-size"
  arm-none-eabi-size "$1"
  echo "-- ${3}bytes per input${4} (from the linker map)"
  python3 tools/map_summary.py "$2"
}

# tools/stack_usage.py with the arguments after the third, indented: PASS
# or FAIL "$1 stack N B" against the budget, N the deepest of the calls
# matching $3; FAIL $2 when the analysis fails.
stack_verdict() {
  local what=$1 broken=$2 re=$3 out worst
  shift 3
  if out=$(python3 tools/stack_usage.py "$@" 2>&1); then
    echo "$out" | sed 's/^/  /'
    worst=$(echo "$out" | awk -v re="$re" '$1 ~ re { if ($2 > w) w = $2 } END { print w + 0 }')
    if (( worst > 0 && worst <= budget )); then
      pass "$what stack ${worst} B <= budget ${budget} B"
    else
      fail "$what stack ${worst} B (budget ${budget} B)"
    fi
  else
    echo "$out" | sed 's/^/  /'
    fail "$broken"
  fi
}

# The second image, one seed-001 DNERTSIF node (ports/cortex-m4/nerts_demo.c):
# no heap, its size, and the stack of the node's calls with the model's
# callbacks as the only targets of the library's indirect calls.
check_nerts_image() {
  local variant=$1 bdir=$2
  local elf=$bdir/dkf_m4_nerts.elf heap
  heap=$(arm-none-eabi-nm "$elf" | awk '{print $NF}' | grep -E "$heap_re" || true)
  # shellcheck disable=SC2086 # the symbols, one word each
  heap_verdict "m4-$variant DNERTSIF image: no heap symbols" "m4-$variant DNERTSIF image:" $heap
  image_sizes "$elf" "$bdir/dkf_m4_nerts.map" "DNERTSIF node image: " ""
  echo "-- DNERTSIF node image: worst-case stack (the model's f, h, y_diff as the indirect targets)"
  stack_verdict "m4-$variant DNERTSIF node" "m4-$variant DNERTSIF node stack analysis" \
    '^dkf_nerts_' --elf "$elf" --indirect ct_f,radar_h,wrap_diff \
    --skip CMakeFiles/dkf_m4.dir --skip dkf_m4_qemu.dir --skip dkf_m4_live.dir "$bdir" dkf_nerts_init dkf_nerts_step m4_nerts_run Reset_Handler
}

# The node image under QEMU (tools/m4_check.py): its PASS/FAIL lines count
# here. Needs the float variant (its image and the host float dkf-run);
# the double image joins when the double variant was built.
check_qemu() {
  local fimg=$ROOT/build/m4-float/dkf_m4_qemu.elf dimg=$ROOT/build/m4-double/dkf_m4_qemu.elf
  local dkf_run=${host_dkf_run:-$ROOT/build/m4-host-float/ports/linux/dkf-run} out line
  echo "== the node image on an emulated Cortex-M4F (qemu-system-arm -M mps2-an386)"
  if ! command -v qemu-system-arm >/dev/null 2>&1; then
    if [[ "$(id -u)" == 0 ]]; then
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        qemu-system-arm >/dev/null 2>&1 || true
    fi
    if ! command -v qemu-system-arm >/dev/null 2>&1; then
      echo "qemu-system-arm is missing; install it with:"
      echo "  sudo apt-get install -y --no-install-recommends qemu-system-arm"
      fail "qemu-system-arm missing"
      return
    fi
  fi
  if [[ ! -f $fimg || ! -x $dkf_run ]]; then
    fail "qemu check: $fimg or $dkf_run not built (see above)"
    return
  fi
  local args=(--dkf-run "$dkf_run" --float-image "$fimg")
  [[ " ${reals[*]} " == *" double "* && -f $dimg ]] && args+=(--double-image "$dimg")
  out=$(python3 tools/m4_check.py "${args[@]}" 2>&1)
  echo "$out"
  while IFS= read -r line; do
    case $line in
      PASS:*) passed=$((passed + 1)) ;;
      FAIL:*) failed=$((failed + 1)) ;;
    esac
  done <<<"$out"
  if ! grep -q '^PASS:' <<<"$out"; then fail "qemu check: tools/m4_check.py ran no check"; fi
}

echo "arm-none-eabi-gcc: $(arm-none-eabi-gcc --version | head -1)"
mkdir -p build
for r in "${reals[@]}"; do
  check_real "$r"
done
[[ " ${reals[*]} " == *" float "* ]] && check_qemu
echo "firmware: $passed passed, $failed failed"
(( failed == 0 ))
