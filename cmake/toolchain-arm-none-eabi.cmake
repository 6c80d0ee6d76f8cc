# Cortex-M4F bare-metal toolchain (GNU Arm Embedded, newlib).
#
#   cmake -S . -B build/m4 -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-arm-none-eabi.cmake \
#         -DDKF_REAL=float
#
# The M4F FPU is single precision only (fpv4-sp-d16), so firmware wants
# DKF_REAL=float; double still compiles (soft-float double routines).
# CMAKE_SYSTEM_NAME Generic makes the top-level project build the library
# only (no tests, no Linux port).
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

set(DKF_ARM_TRIPLE arm-none-eabi CACHE STRING "Prefix of the bare-metal GNU tools")
find_program(CMAKE_C_COMPILER ${DKF_ARM_TRIPLE}-gcc REQUIRED)
find_program(CMAKE_CXX_COMPILER ${DKF_ARM_TRIPLE}-g++)
find_program(CMAKE_ASM_COMPILER ${DKF_ARM_TRIPLE}-gcc REQUIRED)
find_program(CMAKE_AR ${DKF_ARM_TRIPLE}-ar REQUIRED)
find_program(CMAKE_RANLIB ${DKF_ARM_TRIPLE}-ranlib REQUIRED)
find_program(CMAKE_OBJCOPY ${DKF_ARM_TRIPLE}-objcopy)
find_program(CMAKE_SIZE ${DKF_ARM_TRIPLE}-size)
find_program(CMAKE_NM ${DKF_ARM_TRIPLE}-nm)

# No OS to run a test executable on: try_compile builds a static library.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(DKF_M4_CPU_FLAGS "-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16")
# -ffunction-sections/-fdata-sections let the firmware link drop unused code
# with --gc-sections; newlib-nano keeps libc small.
set(CMAKE_C_FLAGS_INIT "${DKF_M4_CPU_FLAGS} -ffunction-sections -fdata-sections --specs=nano.specs")
set(CMAKE_CXX_FLAGS_INIT "${CMAKE_C_FLAGS_INIT}")
set(CMAKE_ASM_FLAGS_INIT "${DKF_M4_CPU_FLAGS}")
# nano.specs is already in the compile flags, which CMake also passes when
# linking (a second --specs=nano.specs is an error).
set(CMAKE_EXE_LINKER_FLAGS_INIT "-Wl,--gc-sections --specs=nosys.specs")

# Size-optimised in every build type (firmware builds care about flash).
# Cache entries, not *_INIT: CMake appends its own -O2/-O3 to *_INIT values,
# and the last -O wins.
set(CMAKE_C_FLAGS_RELEASE "-Os -DNDEBUG" CACHE STRING "")
set(CMAKE_C_FLAGS_RELWITHDEBINFO "-Os -g -DNDEBUG" CACHE STRING "")
set(CMAKE_C_FLAGS_MINSIZEREL "-Os -DNDEBUG" CACHE STRING "")
set(CMAKE_C_FLAGS_DEBUG "-Os -g" CACHE STRING "")

# Libraries and headers come from the toolchain, programs from the host.
# The root is newlib's directory (it holds lib/libm.a), asked of the
# compiler so that other installs of the GNU Arm toolchain work too; the
# top-level find_library(m) needs it to link libm.
execute_process(COMMAND ${CMAKE_C_COMPILER} -print-file-name=libc.a
  OUTPUT_VARIABLE _dkf_newlib_libc OUTPUT_STRIP_TRAILING_WHITESPACE)
get_filename_component(_dkf_newlib_root "${_dkf_newlib_libc}/../.." ABSOLUTE)
set(CMAKE_FIND_ROOT_PATH "${_dkf_newlib_root}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
