// Floating-point exception traps for tests (glibc feenableexcept).
#pragma once

#include <cfenv>
#include <cstdlib>

namespace pliant::testing {

inline constexpr int kTrappedExceptions = FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW;

/// Turns on traps for invalid, divide-by-zero and overflow unless PLIANT_FP_TRAPS=0.
inline void enable_fp_traps() {
  const char* env = std::getenv("PLIANT_FP_TRAPS");
  if (env != nullptr && env[0] == '0') return;
  feclearexcept(FE_ALL_EXCEPT);
  feenableexcept(kTrappedExceptions);
}

/// Turns the traps off for a scope (tests that inject NaN on purpose), and restores them after.
class ScopedFpTrapsOff {
 public:
  ScopedFpTrapsOff() : previous_(fegetexcept()) { fedisableexcept(FE_ALL_EXCEPT); }
  ~ScopedFpTrapsOff() {
    feclearexcept(FE_ALL_EXCEPT);
    feenableexcept(previous_);
  }
  ScopedFpTrapsOff(const ScopedFpTrapsOff&) = delete;
  ScopedFpTrapsOff& operator=(const ScopedFpTrapsOff&) = delete;

 private:
  int previous_;
};

}  // namespace pliant::testing
