# Shared part of the Linux cross toolchains whose tests run under qemu user
# emulation (toolchain-arm-linux-gnueabihf.cmake, toolchain-aarch64-linux-gnu.cmake).
# The including file sets DKF_CROSS_TRIPLE (the Debian cross gcc's prefix and
# multiarch directory), DKF_CROSS_PROCESSOR and DKF_CROSS_QEMU.
#
# Target libraries (cmocka, jansson) come from Debian multiarch
# (libcmocka-dev:<arch> libjansson-dev:<arch>, see tools/bootstrap.sh), which
# the Debian cross gcc finds in /usr/lib/<triple> by itself. ctest runs every
# test through CMAKE_CROSSCOMPILING_EMULATOR.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR ${DKF_CROSS_PROCESSOR})

find_program(CMAKE_C_COMPILER ${DKF_CROSS_TRIPLE}-gcc REQUIRED)
find_program(CMAKE_CXX_COMPILER ${DKF_CROSS_TRIPLE}-g++)

# qemu loads the dynamic loader and libc from the cross libc
# (libc6-<arch>-cross); other libraries fall through to the multiarch dirs.
find_program(DKF_QEMU_PROGRAM ${DKF_CROSS_QEMU} REQUIRED)
set(CMAKE_CROSSCOMPILING_EMULATOR "${DKF_QEMU_PROGRAM};-L;/usr/${DKF_CROSS_TRIPLE}")

# pkg-config must describe the target, not the host: look only at the
# target's multiarch .pc files (plus arch-independent ones).
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/${DKF_CROSS_TRIPLE}/pkgconfig:/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

set(CMAKE_FIND_ROOT_PATH /usr/${DKF_CROSS_TRIPLE})
set(CMAKE_LIBRARY_ARCHITECTURE ${DKF_CROSS_TRIPLE})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
