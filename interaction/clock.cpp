#include "interaction/clock.h"

#include <time.h>

#include <cerrno>

namespace pliant {
namespace {

// CLOCK_MONOTONIC in nanoseconds: the clock clock_nanosleep can sleep on with an absolute deadline.
int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + static_cast<int64_t>(ts.tv_nsec);
}

}  // namespace

SteadyClock::SteadyClock(double spin_us)
    : epoch_ns_(monotonic_ns()), spin_ns_(static_cast<int64_t>(spin_us * 1e3)) {}

double SteadyClock::now() const { return 1e-9 * static_cast<double>(monotonic_ns() - epoch_ns_); }

void SteadyClock::sleep_until(double t) {
  const int64_t deadline = epoch_ns_ + static_cast<int64_t>(t * 1e9);
  // Sleep to an absolute deadline (a relative sleep computed from "now" is late by however long
  // the thread was preempted between reading the clock and going to sleep), spin_ns before t, then
  // spin: a wake-up from clock_nanosleep overshoots by tens of microseconds.
  const int64_t wake = deadline - spin_ns_;
  if (monotonic_ns() < wake) {
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(wake / 1'000'000'000);
    ts.tv_nsec = static_cast<long>(wake % 1'000'000'000);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
  }
  while (monotonic_ns() < deadline) {
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
