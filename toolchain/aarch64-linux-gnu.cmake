# CMake toolchain file: cross-build monomesh for the boards (aarch64, Raspberry Pi 4/5 class)
# with Debian's cross gcc (crossbuild-essential-arm64) against an arm64 sysroot made by
# toolchain/make-sysroot.sh, and run the tests under qemu-aarch64-static.
#
#   cmake --preset cross-aarch64            (or -DCMAKE_TOOLCHAIN_FILE=toolchain/aarch64-linux-gnu.cmake)
#   cmake --build --preset cross-aarch64
#   ctest --preset cross-aarch64            (the unit tests, each under qemu: see docs/cross.md)
#
# Cache variables:
#   MM_SYSROOT       the arm64 sysroot (default: $MM_SYSROOT, else ~/.cache/monomesh/sysroot-arm64,
#                    where make-sysroot.sh puts it)
#   MM_AARCH64_CPU   the board's CPU: cortex-a72 (Pi 4, the default) or cortex-a76 (Pi 5).
#                    Gives -mcpu=<cpu> (never -march=native: the build machine is not the board)
#                    and the CPU qemu emulates, so tests never run instructions the board lacks.
#                    (qemu's default CPU "max" has SVE/SVE2, which no Pi has.)
#   MM_QEMU          the emulator (default: qemu-aarch64-static from qemu-user-static)

set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(MM_TRIPLET aarch64-linux-gnu)

# --- sysroot ---------------------------------------------------------------------------------
if(DEFINED ENV{MM_SYSROOT} AND NOT "$ENV{MM_SYSROOT}" STREQUAL "")
  set(_mm_default_sysroot "$ENV{MM_SYSROOT}")
elseif(DEFINED ENV{XDG_CACHE_HOME} AND NOT "$ENV{XDG_CACHE_HOME}" STREQUAL "")
  set(_mm_default_sysroot "$ENV{XDG_CACHE_HOME}/monomesh/sysroot-arm64")
else()
  set(_mm_default_sysroot "$ENV{HOME}/.cache/monomesh/sysroot-arm64")
endif()
set(MM_SYSROOT "${_mm_default_sysroot}" CACHE PATH "arm64 sysroot (toolchain/make-sysroot.sh)")
if(NOT EXISTS "${MM_SYSROOT}/usr/include/${MM_TRIPLET}")
  message(FATAL_ERROR "No arm64 sysroot at ${MM_SYSROOT}: run toolchain/make-sysroot.sh "
                      "(after scripts/install-deps.sh cross), or set MM_SYSROOT")
endif()
set(CMAKE_SYSROOT "${MM_SYSROOT}")
# try_compile projects re-read this file without the cache: hand them the choices made here.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES MM_SYSROOT MM_AARCH64_CPU)

# --- compilers -------------------------------------------------------------------------------
set(CMAKE_C_COMPILER ${MM_TRIPLET}-gcc)
set(CMAKE_CXX_COMPILER ${MM_TRIPLET}-g++)

# --- CPU flags per target --------------------------------------------------------------------
set(MM_AARCH64_CPU cortex-a72 CACHE STRING "Board CPU: cortex-a72 (Raspberry Pi 4) or cortex-a76 (Raspberry Pi 5)")
set_property(CACHE MM_AARCH64_CPU PROPERTY STRINGS cortex-a72 cortex-a76)
if(NOT MM_AARCH64_CPU MATCHES "^(cortex-a72|cortex-a76)$")
  message(FATAL_ERROR "MM_AARCH64_CPU=${MM_AARCH64_CPU}: expected cortex-a72 (Pi 4) or cortex-a76 (Pi 5)")
endif()
# *_FLAGS_INIT: the project's and the user's flags are appended after these.
set(CMAKE_C_FLAGS_INIT "-mcpu=${MM_AARCH64_CPU}")
set(CMAKE_CXX_FLAGS_INIT "-mcpu=${MM_AARCH64_CPU}")

# --- where find_* look: libraries, headers and packages only in the sysroot; programs on the host
set(CMAKE_FIND_ROOT_PATH "${CMAKE_SYSROOT}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
# Debian's multiarch library folder inside the sysroot.
set(CMAKE_LIBRARY_ARCHITECTURE ${MM_TRIPLET})

# --- pkg-config: the host's pkg-config, reading only the sysroot's .pc files -----------------
set(ENV{PKG_CONFIG_DIR} "")
set(ENV{PKG_CONFIG_PATH} "")
set(ENV{PKG_CONFIG_LIBDIR}
  "${CMAKE_SYSROOT}/usr/lib/${MM_TRIPLET}/pkgconfig:${CMAKE_SYSROOT}/usr/lib/pkgconfig:${CMAKE_SYSROOT}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${CMAKE_SYSROOT}")

# --- tests run on the emulated board -----------------------------------------------------------
# ctest runs every test executable through this; -L makes qemu load the dynamic linker and the
# shared libraries from the sysroot (other paths, e.g. the source tree's data, are the host's).
find_program(MM_QEMU qemu-aarch64-static DOC "qemu user-mode emulator for aarch64")
if(NOT MM_QEMU)
  message(FATAL_ERROR "qemu-aarch64-static not found: scripts/install-deps.sh cross")
endif()
set(CMAKE_CROSSCOMPILING_EMULATOR "${MM_QEMU};-cpu;${MM_AARCH64_CPU};-L;${CMAKE_SYSROOT}")
