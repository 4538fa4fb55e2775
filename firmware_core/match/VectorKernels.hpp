// Which vector width the matcher's correlation kernels run at (EpipolarSearch.cpp, WarpedSearch.cpp). Each
// kernel is written once over a GCC/Clang vector type and compiled twice: at the baseline width (four
// floats / two doubles: SSE2 on x86-64, NEON, or plain code on a 750 PowerPC) and, on x86-64 only, eight
// floats / four doubles in a function built for AVX2 and called only where the processor has it. The
// lanes are independent and every build has -ffp-contract=off, so both give the same result bit for bit
// (the curve search sums integers exactly in float; the warped search repeats nccWarpedAt's double
// operations per lane); the tests compare them.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__)
#define AREOMAP_MATCH_AVX2_KERNELS 1
#else
#define AREOMAP_MATCH_AVX2_KERNELS 0
#endif

namespace areomap {

// True when the AVX2 kernels run: compiled in, the processor has AVX2, and not switched off.
bool matchUsesAvx2();
// Tests: false runs the baseline kernels everywhere (to compare them with the AVX2 ones).
void allowMatchAvx2(bool allowed);

}  // namespace areomap
