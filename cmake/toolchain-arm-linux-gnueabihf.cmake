# 32-bit ARM Linux (armhf) cross build, run under qemu-arm user emulation.
#
#   cmake -S . -B build/qemu-arm-float \
#         -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-arm-linux-gnueabihf.cmake -DDKF_REAL=float
#   cmake --build build/qemu-arm-float -j2 && ctest --test-dir build/qemu-arm-float
#
# Needs gcc-arm-linux-gnueabihf, libc6-dev-armhf-cross, qemu-user and
# libcmocka-dev:armhf libjansson-dev:armhf (tools/bootstrap.sh).
set(DKF_CROSS_TRIPLE arm-linux-gnueabihf)
set(DKF_CROSS_PROCESSOR arm)
set(DKF_CROSS_QEMU qemu-arm)
include(${CMAKE_CURRENT_LIST_DIR}/cross-linux-qemu.cmake)
