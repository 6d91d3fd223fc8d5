#include "interaction/haptic_thread.h"

#include <cmath>

namespace pliant {

HapticThread::HapticThread(Clock& clock, const HapticForceModel& model, const HapticLimits& limits,
                           PositionFunction position, OutputFunction output)
    : clock_(clock),
      model_(model),
      limits_(limits),
      position_(std::move(position)),
      output_(std::move(output)),
      filter_(limits) {}

HapticThread::~HapticThread() { stop(); }

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
  const Vec3 x = position_ ? position_() : Vec3::Zero();
  // A non-finite device position or model gives a non-finite prediction: the filter zeroes it.
  const Vec3 desired = x.allFinite() ? model_.force_at(x) : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  Vec3 out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    out = filter_.filter(desired);
    ++stats_.ticks;
    stats_.faults = filter_.fault_count();
    stats_.limited = filter_.limited_count();
  }
  if (output_) output_(t, out);
  return out;
}

void HapticThread::loop() {
  const double period = 1.0 / limits_.rate_hz;
  const double origin = clock_.now();
  long slot = 0;
  while (!stop_requested_.load()) {
    const double scheduled = origin + static_cast<double>(slot) * period;
    clock_.sleep_until(scheduled);
    tick(clock_.now());
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

Vec3 HapticThread::last_force() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return filter_.last();
}

}  // namespace pliant
