# 64-bit ARM (Snapdragon-class rover and companion computers), little-endian, Debian's aarch64-linux-gnu
# cross compiler; tests run under qemu-aarch64. Set-up: toolchains/setup-targets.sh aarch64.
#   cmake --preset aarch64 && cmake --build --preset aarch64 && ctest --preset aarch64
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(AREOMAP_TARGET_TRIPLET aarch64-linux-gnu)
set(AREOMAP_QEMU qemu-aarch64)
# Run-time libraries: Debian's arm64 multiarch packages (libc6, libstdc++6, glib for LCM) in /lib/<triplet>.
set(AREOMAP_QEMU_LD_PREFIX /)
include(${CMAKE_CURRENT_LIST_DIR}/cross-common.cmake)
