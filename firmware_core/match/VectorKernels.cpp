#include "firmware_core/match/VectorKernels.hpp"

namespace areomap {
namespace {
bool g_match_avx2_allowed = true;
}  // namespace

bool matchUsesAvx2() {
#if AREOMAP_MATCH_AVX2_KERNELS
  static const bool has_avx2 = __builtin_cpu_supports("avx2") != 0;
  return g_match_avx2_allowed && has_avx2;
#else
  return false;
#endif
}

void allowMatchAvx2(bool allowed) {
  g_match_avx2_allowed = allowed;
}

}  // namespace areomap
