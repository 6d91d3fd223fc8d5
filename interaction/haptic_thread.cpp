#include "interaction/haptic_thread.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>

#include <algorithm>
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

void HapticThread::set_thread_count(int threads) { thread_count_ = std::clamp(threads, 1, kMaxHapticThreads); }

void HapticThread::start() {
  if (running_.load()) return;
  stop_requested_ = false;
  running_ = true;
  realtime_priority_granted_ = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ticks_by_thread_.assign(static_cast<size_t>(thread_count_), 0);
  }
  origin_ = clock_.now();
  last_slot_ = -1;
  for (int i = 0; i < thread_count_; ++i) threads_.emplace_back([this, i] { loop(i); });
}

void HapticThread::stop() {
  stop_requested_ = true;
  for (std::thread& t : threads_) {
    if (t.joinable()) t.join();
  }
  threads_.clear();
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

namespace {

// Pins the calling thread to the index-th CPU the process may run on (wrapping around); false if
// there is only one such CPU or the kernel refuses.
bool pin_to_cpu(int index) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof allowed, &allowed) != 0) return false;
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (CPU_ISSET(c, &allowed)) cpus.push_back(c);
  }
  if (cpus.size() < 2) return false;
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(cpus[static_cast<size_t>(index) % cpus.size()], &one);
  return pthread_setaffinity_np(pthread_self(), sizeof one, &one) == 0;
}

}  // namespace

void HapticThread::loop(int index) {
  // Timer slack of 1 ns (default 50 us), if asked and allowed a real-time priority, and with
  // several threads a CPU each: all only shorten or spread the wake-up delay; nothing depends on them.
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  if (thread_count_ > 1) pin_to_cpu(index);
  if (realtime_priority_requested_) {
    sched_param param{};
    param.sched_priority = 10;
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0) ++realtime_priority_granted_;
  }
  const double period = 1.0 / limits_.rate_hz;
  long slot = 0;
  while (!stop_requested_.load()) {
    const double scheduled = origin_ + static_cast<double>(slot) * period;
    clock_.sleep_until(scheduled);
    claim_and_tick(index, slot, scheduled);
    // The next slot, or, if this thread was stalled past it, the latest slot already due (the
    // slots in between are dropped, not sent in a burst; claim_and_tick counts them).
    const auto due = static_cast<long>(std::floor((clock_.now() - origin_) / period));
    slot = std::max(slot + 1, due);
  }
}

void HapticThread::claim_and_tick(int index, long slot, double scheduled) {
  std::lock_guard<std::mutex> claim(claim_mutex_);
  if (slot <= last_slot_) return;  // another thread was awake first
  const double start = clock_.now();
  tick(start);
  const double end = clock_.now();
  const double period = 1.0 / limits_.rate_hz;
  std::lock_guard<std::mutex> lock(mutex_);
  lateness_.add(start - scheduled);
  tick_duration_.add(end - start);
  // Pairs across skipped slots are not periods (they are misses).
  if (last_slot_ >= 0 && last_slot_ == slot - 1) period_jitter_.add(std::abs(start - last_start_ - period));
  if (end > scheduled + period) ++late_ticks_;
  stats_.skipped_ticks += slot - last_slot_ - 1;  // the first claim is slot 0
  ++ticks_by_thread_[static_cast<size_t>(index)];
  last_slot_ = slot;
  last_start_ = start;
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
  t.realtime_priority = realtime_priority_granted_.load() == thread_count_;
  t.ticks_by_thread = ticks_by_thread_;
  return t;
}

Vec3 HapticThread::last_force(size_t channel) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return channel < filters_.size() ? filters_[channel].last() : Vec3::Zero();
}

}  // namespace pliant
