#include "interaction/haptic_thread.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>

#include <cmath>
#include <limits>

namespace pliant {

HapticThread::HapticThread(Clock& clock, const HapticForceModel& model, const HapticLimits& limits,
                           PositionFunction position, OutputFunction output)
    : HapticThread(clock, std::vector<Channel>{Channel{&model, std::move(position)}}, limits,
                   output ? ChannelOutputFunction([out = std::move(output)](double t, size_t, const Vec3& f) {
                     out(t, f);
                   })
                          : ChannelOutputFunction()) {}

HapticThread::HapticThread(Clock& clock, std::vector<Channel> channels, const HapticLimits& limits,
                           ChannelOutputFunction output)
    : clock_(clock),
      channels_(std::move(channels)),
      limits_(limits),
      output_(std::move(output)),
      filters_(channels_.size(), HapticOutputFilter(limits)) {}

HapticThread::~HapticThread() { stop(); }

void HapticThread::reserve_timing(long ticks) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto n = static_cast<size_t>(std::max(0L, ticks));
  lateness_.reserve(n);
  period_jitter_.reserve(n);
  tick_duration_.reserve(n);
}

void HapticThread::start() {
  if (running_.load()) return;
  stop_requested_ = false;
  running_ = true;
  thread_ = std::thread([this] { loop(); });
}

void HapticThread::stop() {
  stop_requested_ = true;
  if (thread_.joinable()) thread_.join();
  running_ = false;
}

Vec3 HapticThread::tick(double t) {
  Vec3 first = Vec3::Zero();
  for (size_t c = 0; c < channels_.size(); ++c) {
    const Channel& channel = channels_[c];
    const Vec3 x = channel.position ? channel.position() : Vec3::Zero();
    // A non-finite device position or model gives a non-finite prediction: the filter zeroes it.
    const Vec3 desired = x.allFinite() && channel.model != nullptr
                             ? channel.model->force_at(x)
                             : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    Vec3 out;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      out = filters_[c].filter(desired);
    }
    if (output_) output_(t, c, out);
    if (c == 0) first = out;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.ticks;
  stats_.faults = 0;
  stats_.limited = 0;
  for (const HapticOutputFilter& f : filters_) {
    stats_.faults += f.fault_count();
    stats_.limited += f.limited_count();
  }
  return first;
}

void HapticThread::loop() {
  // Timer slack of 1 ns (default 50 us) and, if asked and allowed, a real-time priority: both
  // only shorten the wake-up delay; nothing depends on them.
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  if (realtime_priority_requested_) {
    sched_param param{};
    param.sched_priority = 10;
    realtime_priority_granted_ = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
  }
  const double period = 1.0 / limits_.rate_hz;
  const double origin = clock_.now();
  long slot = 0;
  double previous_start = 0.0;
  long previous_slot = -2;  // no previous tick: slot 0 has no period
  while (!stop_requested_.load()) {
    const double scheduled = origin + static_cast<double>(slot) * period;
    clock_.sleep_until(scheduled);
    const double start = clock_.now();
    tick(start);
    const double end = clock_.now();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      lateness_.add(start - scheduled);
      tick_duration_.add(end - start);
      if (previous_slot == slot - 1) period_jitter_.add(std::abs(start - previous_start - period));
      if (end > scheduled + period) ++late_ticks_;
    }
    previous_start = start;
    previous_slot = slot;
    // Skip slots that passed while this tick ran (no bursts after a stall).
    const auto due = static_cast<long>(std::floor((clock_.now() - origin) / period));
    ++slot;
    if (due > slot) {
      std::lock_guard<std::mutex> lock(mutex_);
      stats_.skipped_ticks += due - slot;
      slot = due;
    }
  }
  running_ = false;
}

HapticStats HapticThread::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

HapticTiming HapticThread::timing() const {
  std::lock_guard<std::mutex> lock(mutex_);
  HapticTiming t;
  t.period = 1.0 / limits_.rate_hz;
  t.lateness = lateness_.summary();
  t.period_jitter = period_jitter_.summary();
  t.tick_duration = tick_duration_.summary();
  t.late_ticks = late_ticks_;
  t.skipped_ticks = stats_.skipped_ticks;
  t.deadline_misses = late_ticks_ + stats_.skipped_ticks;
  t.realtime_priority = realtime_priority_granted_.load();
  return t;
}

Vec3 HapticThread::last_force(size_t channel) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return channel < filters_.size() ? filters_[channel].last() : Vec3::Zero();
}

}  // namespace pliant
