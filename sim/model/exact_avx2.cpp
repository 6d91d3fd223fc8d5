#include "sim/model/exact_avx2.h"

namespace pliant {

bool exact_avx2_kernels_available() {
#if defined(PLIANT_EXACT_AVX2_KERNELS)
  static const bool available = __builtin_cpu_supports("avx2");
  return available;
#else
  return false;
#endif
}

}  // namespace pliant
