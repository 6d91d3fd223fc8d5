// Callgrind's client requests for `pliant bench --callgrind-timed`: instrumentation starts at the
// first timed step and stops after the last, so `valgrind --tool=callgrind --instr-atstart=no`
// counts the timed steps alone and runs the warm-up at near-native speed (a piled fruit dish needs
// ~500 warm-up steps: at callgrind's full slow-down that does not fit a sitting). The requests are
// a few no-op instructions outside valgrind; without valgrind's header they are nothing at all.
#pragma once

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define PLIANT_HAS_CALLGRIND_REQUESTS 1
#else
#define PLIANT_HAS_CALLGRIND_REQUESTS 0
#endif

namespace pliant {

/// Whether this build can toggle callgrind's instrumentation (valgrind's header was found).
inline constexpr bool callgrind_requests_available = PLIANT_HAS_CALLGRIND_REQUESTS != 0;

/// Starts callgrind's instrumentation (no-op outside callgrind).
inline void start_callgrind_instrumentation() {
#if PLIANT_HAS_CALLGRIND_REQUESTS
  CALLGRIND_START_INSTRUMENTATION;
#endif
}

/// Stops callgrind's instrumentation (no-op outside callgrind).
inline void stop_callgrind_instrumentation() {
#if PLIANT_HAS_CALLGRIND_REQUESTS
  CALLGRIND_STOP_INSTRUMENTATION;
#endif
}

}  // namespace pliant
