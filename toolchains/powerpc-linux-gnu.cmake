# 32-bit big-endian PowerPC tuned for the 750 family (the RAD750 of MSL and Perseverance): -mcpu=750, hard
# float (the 750 has an FPU; Debian's powerpc-linux-gnu ABI is hard-float). Tests run under qemu-ppc, which
# must be >= 8.1 (bookworm's 7.2 crashes in glibc's math functions for 32-bit PowerPC).
# Set-up: toolchains/setup-targets.sh powerpc.
#   cmake --preset powerpc && cmake --build --preset powerpc && ctest --preset powerpc
set(CMAKE_SYSTEM_PROCESSOR powerpc)
set(AREOMAP_TARGET_TRIPLET powerpc-linux-gnu)
set(AREOMAP_QEMU qemu-ppc)
# Run-time libraries: the cross compiler's own (libc6-powerpc-cross, libstdc++6-powerpc-cross); every other
# library of this target is static.
set(AREOMAP_QEMU_LD_PREFIX /usr/powerpc-linux-gnu)
include(${CMAKE_CURRENT_LIST_DIR}/cross-common.cmake)

set(CMAKE_C_FLAGS_INIT "-mcpu=750 -mhard-float")
set(CMAKE_CXX_FLAGS_INIT "-mcpu=750 -mhard-float")
# 32-bit PowerPC has no 64-bit atomic instructions: std::atomic<uint64_t> (the heap counter) calls libatomic.
set(CMAKE_C_STANDARD_LIBRARIES "-latomic" CACHE STRING "Libraries linked into every C executable")
set(CMAKE_CXX_STANDARD_LIBRARIES "-latomic" CACHE STRING "Libraries linked into every C++ executable")
# Debian does not build LCM for powerpc (a ports architecture without glib here): the messages' generated
# code needs only LCM's headers (lcm_coretypes.h, copied by setup-targets.sh); the LCM transport (udpm,
# file://) is left out of this target (cmake/AreomapDependencies.cmake, platform/posix).
set(AREOMAP_WITH_LCM_RUNTIME OFF CACHE BOOL "Link LCM's runtime library (udpm/file transports)")
