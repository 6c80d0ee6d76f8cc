# 32-bit ARM Linux (armhf) cross build, run under qemu-arm user emulation.
#
#   cmake -S . -B build/qemu-arm-float \
#         -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-arm-linux-gnueabihf.cmake -DDKF_REAL=float
#   cmake --build build/qemu-arm-float -j2 && ctest --test-dir build/qemu-arm-float
#
# Target libraries (cmocka, jansson) come from Debian multiarch
# (libcmocka-dev:armhf libjansson-dev:armhf, see tools/bootstrap.sh), which
# the Debian cross gcc finds in /usr/lib/arm-linux-gnueabihf by itself.
# ctest runs every test through CMAKE_CROSSCOMPILING_EMULATOR.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(DKF_ARMHF_TRIPLE arm-linux-gnueabihf)

find_program(CMAKE_C_COMPILER ${DKF_ARMHF_TRIPLE}-gcc REQUIRED)
find_program(CMAKE_CXX_COMPILER ${DKF_ARMHF_TRIPLE}-g++)

# qemu-arm loads the dynamic loader and libc from the cross libc
# (libc6-armhf-cross); other libraries fall through to the multiarch dirs.
find_program(DKF_QEMU_ARM qemu-arm REQUIRED)
set(CMAKE_CROSSCOMPILING_EMULATOR "${DKF_QEMU_ARM};-L;/usr/${DKF_ARMHF_TRIPLE}")

# pkg-config must describe the target, not the host: look only at the armhf
# multiarch .pc files (plus arch-independent ones).
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/${DKF_ARMHF_TRIPLE}/pkgconfig:/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

set(CMAKE_FIND_ROOT_PATH /usr/${DKF_ARMHF_TRIPLE})
set(CMAKE_LIBRARY_ARCHITECTURE ${DKF_ARMHF_TRIPLE})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
