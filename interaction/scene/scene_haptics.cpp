#include "interaction/scene/scene_haptics.h"

#include <algorithm>
#include <iomanip>
#include <sstream>

namespace pliant {

void DeviceTrack::push(double t, const Vec3& x, const Vec3& torque) {
  std::lock_guard<std::mutex> lock(mutex_);
  t0_ = t1_;
  x0_ = x1_;
  t1_ = t;
  x1_ = x;
  torque_ = torque;
  pushes_ = std::min(pushes_ + 1, 2);
}

Vec3 DeviceTrack::position_at(double t) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (pushes_ < 2 || !(t1_ > t0_)) return x1_;
  // Fraction of the last interval elapsed since the last push, in [0, 1].
  const double ahead = std::clamp((t - t1_) / (t1_ - t0_), 0.0, 1.0);
  return x1_ + ahead * (x1_ - x0_);
}

Vec3 DeviceTrack::torque() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return torque_;
}

SceneHaptics::SceneHaptics(Clock& clock, const SceneRunner& runner, const HapticSettings& settings,
                           double expected_seconds, bool realtime_priority)
    : clock_(clock) {
  const HapticLimits& limits = settings.limits;
  const size_t n = runner.instance().instruments.size();
  std::vector<HapticThread::Channel> channels;
  for (size_t i = 0; i < n; ++i) {
    models_.push_back(std::make_unique<HapticForceModel>());
    tracks_.push_back(std::make_unique<DeviceTrack>());
    tracks_.back()->push(clock.now(), runner.readings()[i].position, runner.readings()[i].torque);
    DeviceTrack* track = tracks_.back().get();
    channels.push_back({models_.back().get(), [this, track] { return track->position_at(clock_.now()); }});
  }
  const long ticks = static_cast<long>(std::max(0.0, expected_seconds) * limits.rate_hz * 1.1) + 16;
  records_.reserve(static_cast<size_t>(ticks) * n);
  thread_ = std::make_unique<HapticThread>(clock, std::move(channels), limits,
                                           [this](double t, size_t c, const Vec3& f) {
                                             const Vec3 torque = tracks_[c]->torque();
                                             std::lock_guard<std::mutex> lock(records_mutex_);
                                             records_.push_back({t, c, f, torque});
                                           });
  thread_->set_realtime_priority(realtime_priority);
  thread_->set_thread_count(settings.threads);
  thread_->reserve_timing(ticks);
}

SceneHaptics::~SceneHaptics() { stop(); }

void SceneHaptics::refresh(const SceneRunner& runner, double now) {
  for (size_t i = 0; i < models_.size(); ++i) {
    const InstrumentReading& r = runner.readings()[i];
    models_[i]->update(runner.time(), r.position, r.force);
    tracks_[i]->push(now, r.position, r.torque);
  }
}

void SceneHaptics::start() { thread_->start(); }
void SceneHaptics::stop() { thread_->stop(); }
void SceneHaptics::tick(double t) { thread_->tick(t); }

std::vector<HapticRecord> SceneHaptics::records() const {
  std::lock_guard<std::mutex> lock(records_mutex_);
  return records_;
}

std::string haptic_forces_csv(const std::vector<HapticRecord>& records, const std::vector<std::string>& names) {
  std::ostringstream s;
  s << "time,instrument,fx,fy,fz,tx,ty,tz\n" << std::setprecision(17);
  for (const HapticRecord& r : records) {
    s << r.time << ',' << (r.instrument < names.size() ? names[r.instrument] : std::to_string(r.instrument)) << ','
      << r.force.x() << ',' << r.force.y() << ',' << r.force.z() << ',' << r.torque.x() << ',' << r.torque.y()
      << ',' << r.torque.z() << '\n';
  }
  return s.str();
}

}  // namespace pliant
