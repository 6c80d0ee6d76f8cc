# 64-bit ARM Linux (arm64) cross build, run under qemu-aarch64 user
# emulation: the target where the kernels' vector code (DKF__SIMD) is NEON.
#
#   cmake -S . -B build/qemu-arm64-double \
#         -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-aarch64-linux-gnu.cmake -DDKF_REAL=double
#   cmake --build build/qemu-arm64-double -j2 && ctest --test-dir build/qemu-arm64-double
#
# Needs gcc-aarch64-linux-gnu, libc6-dev-arm64-cross, qemu-user and
# libcmocka-dev:arm64 libjansson-dev:arm64 (tools/bootstrap.sh).
set(DKF_CROSS_TRIPLE aarch64-linux-gnu)
set(DKF_CROSS_PROCESSOR aarch64)
set(DKF_CROSS_QEMU qemu-aarch64)
include(${CMAKE_CURRENT_LIST_DIR}/cross-linux-qemu.cmake)
