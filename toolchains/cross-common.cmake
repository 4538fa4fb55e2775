# Shared part of the areomap cross toolchains (aarch64-linux-gnu.cmake, powerpc-linux-gnu.cmake). The
# including file sets AREOMAP_TARGET_TRIPLET, AREOMAP_QEMU (the qemu-user emulator's name) and
# CMAKE_SYSTEM_PROCESSOR, and AREOMAP_QEMU_LD_PREFIX (the root qemu takes the target's dynamic loader and
# shared libraries from) before including this file.
#
# Libraries come from three places, searched in this order:
#   1. $AREOMAP_CROSS_ROOT/<triplet> (default /opt/areomap-cross): what setup-targets.sh unpacked or
#      cross-built there (LCM's arm64 runtime; CppUTest and libjpeg-turbo for powerpc);
#   2. Debian's multiarch folders /usr/lib/<triplet> (arm64 packages installed with apt);
#   3. the cross compiler's own /usr/<triplet> (libc, libstdc++).
# Host programs (lcm-gen) are found on the host. Tests run under qemu-user through
# CMAKE_CROSSCOMPILING_EMULATOR, with -L AREOMAP_QEMU_LD_PREFIX. The loader and libc must come from one
# place: the cross compiler's /usr/<triplet> holds an older glibc than the multiarch libc6:<arch>, and the
# loader of one with the libc of the other hangs in pthread_create.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_C_COMPILER ${AREOMAP_TARGET_TRIPLET}-gcc)
set(CMAKE_CXX_COMPILER ${AREOMAP_TARGET_TRIPLET}-g++)
set(CMAKE_LIBRARY_ARCHITECTURE ${AREOMAP_TARGET_TRIPLET})

if(DEFINED ENV{AREOMAP_CROSS_ROOT})
  set(AREOMAP_CROSS_ROOT "$ENV{AREOMAP_CROSS_ROOT}")
else()
  set(AREOMAP_CROSS_ROOT /opt/areomap-cross)
endif()
set(AREOMAP_TARGET_ROOT ${AREOMAP_CROSS_ROOT}/${AREOMAP_TARGET_TRIPLET})
# Both the prefix itself (libraries built from source install there) and its usr/ (unpacked .deb files).
list(PREPEND CMAKE_PREFIX_PATH ${AREOMAP_TARGET_ROOT} ${AREOMAP_TARGET_ROOT}/usr)
# No CMAKE_FIND_ROOT_PATH: Debian's multiarch layout keeps the target's libraries in /usr/lib/<triplet>,
# which CMAKE_LIBRARY_ARCHITECTURE selects; host libraries live in /usr/lib/x86_64-linux-gnu and are not
# searched. Programs are the host's.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)

# pkg-config (CppUTest) looks only at the target's .pc files.
set(_pc_dirs ${AREOMAP_TARGET_ROOT}/lib/pkgconfig
             ${AREOMAP_TARGET_ROOT}/usr/lib/${AREOMAP_TARGET_TRIPLET}/pkgconfig
             /usr/lib/${AREOMAP_TARGET_TRIPLET}/pkgconfig /usr/share/pkgconfig)
list(JOIN _pc_dirs ":" _pc_dirs)
set(ENV{PKG_CONFIG_LIBDIR} "${_pc_dirs}")
set(ENV{PKG_CONFIG_PATH} "")

# Run target executables (CTest, custom commands) under user-mode emulation.
find_program(AREOMAP_QEMU_EXECUTABLE ${AREOMAP_QEMU} NO_CMAKE_FIND_ROOT_PATH)
if(NOT AREOMAP_QEMU_EXECUTABLE)
  set(AREOMAP_QEMU_EXECUTABLE ${AREOMAP_QEMU})
  message(WARNING "${AREOMAP_QEMU} not found: tests cannot run (toolchains/setup-targets.sh installs it)")
endif()
set(CMAKE_CROSSCOMPILING_EMULATOR ${AREOMAP_QEMU_EXECUTABLE} -L ${AREOMAP_QEMU_LD_PREFIX})

# The rover side only: no OpenCV, GDAL or Ceres for the targets (the ground runs on the host).
set(AREOMAP_ROVER_ONLY ON CACHE BOOL "Build only the rover side (firmware_core, platform, msgs)")
