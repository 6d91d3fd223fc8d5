#include "interaction/clock.h"

#include <time.h>

#include <thread>

namespace pliant {

SteadyClock::SteadyClock() : epoch_(std::chrono::steady_clock::now()) {}

double SteadyClock::now() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - epoch_).count();
}

void SteadyClock::sleep_until(double t) {
  const auto deadline = epoch_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                     std::chrono::duration<double>(t));
  // Sleep most of the way, then spin the last ~100 us: OS sleeps overshoot by tens of microseconds.
  const auto spin = std::chrono::microseconds(100);
  if (std::chrono::steady_clock::now() + spin < deadline) std::this_thread::sleep_until(deadline - spin);
  while (std::chrono::steady_clock::now() < deadline) {
  }
}

double ThreadCpuClock::now() const {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

void ThreadCpuClock::sleep_until(double t) {
  while (now() < t) {
  }
}

}  // namespace pliant
