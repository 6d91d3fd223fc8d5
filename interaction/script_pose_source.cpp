// Evaluates tool-script segments. Each segment maps its local time tau in [0, D] to a command by
// a quintic ease (zero velocity and acceleration at both ends), except "press until force", which
// follows a velocity profile: smoothstep ramp up to `speed`, cruise, smoothstep ramp down. The
// ramp down starts at the first of: the sample at which the measured force reached the target,
// the planned time at which stopping lands exactly on max_depth, or D - ramp (at rest by D). The
// planned triggers are analytic, so they do not depend on how often the source is sampled.
#include "interaction/script_pose_source.h"

#include <algorithm>
#include <cmath>

#include "interaction/easing.h"

namespace pliant {
namespace {

// Ramp time actually used: at most half the segment.
double effective_ramp(const ScriptKeyframe& k, double duration) { return std::min(k.ramp, 0.5 * duration); }

// Distance and speed of the ramp-up/cruise profile at tau (speed V, ramp R).
void cruise_profile(double tau, double v, double r, double& distance, double& speed) {
  if (r <= 0.0) {
    distance = 0.0;
    speed = 0.0;
    return;
  }
  if (tau <= r) {
    distance = v * r * smoothstep_integral(tau / r);
    speed = v * smoothstep(tau / r);
  } else {
    distance = 0.5 * v * r + v * (tau - r);
    speed = v;
  }
}

// Time at which starting to decelerate stops exactly at max_depth.
double depth_trigger_time(double max_depth, double v, double r) {
  if (r <= 0.0) return 0.0;
  if (max_depth >= v * r) return max_depth / v;
  // On the ramp: distance + speed r / 2 = v r (1.5 u^2 - 0.5 u^4), monotone in u on [0, 1].
  const double target = max_depth / (v * r);
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 60; ++i) {
    const double u = 0.5 * (lo + hi);
    (1.5 * u * u - 0.5 * u * u * u * u < target ? lo : hi) = u;
  }
  return 0.5 * (lo + hi) * r;
}

}  // namespace

ScriptPoseSource::ScriptPoseSource(const ToolScript& script, std::string instrument, const InstrumentCommand& initial)
    : instrument_(std::move(instrument)),
      keyframes_(script.for_instrument(instrument_)),
      segment_start_(initial),
      last_(initial) {}

void ScriptPoseSource::begin_segment(size_t) { press_ = PressState{}; }

double ScriptPoseSource::press_distance(const ScriptKeyframe& k, double tau, double duration,
                                        const InstrumentFeedback* fb) {
  const double r = effective_ramp(k, duration);
  const double planned = std::min(duration - r, depth_trigger_time(k.max_depth, k.speed, r));
  // The measured force may start the ramp down earlier than planned (only at a sample).
  if (fb != nullptr && press_.phase == 0 && tau < planned && -fb->force.dot(k.axis) >= k.force) {
    press_.phase = 1;
    press_.decel_start = tau;
    cruise_profile(tau, k.speed, r, press_.decel_distance0, press_.decel_speed0);
    force_reached_time_ = segment_start_time_ + tau;
  }
  if (press_.phase == 0 && tau >= planned) {
    press_.phase = 1;
    press_.decel_start = planned;
    cruise_profile(planned, k.speed, r, press_.decel_distance0, press_.decel_speed0);
  }
  if (press_.phase == 0) {
    double d = 0.0, v = 0.0;
    cruise_profile(tau, k.speed, r, d, v);
    return d;
  }
  if (r <= 0.0) return press_.decel_distance0;
  const double u = std::min((tau - press_.decel_start) / r, 1.0);
  return press_.decel_distance0 + press_.decel_speed0 * r * (u - smoothstep_integral(u));
}

InstrumentCommand ScriptPoseSource::evaluate(size_t index, double t, const InstrumentFeedback* fb) {
  const ScriptKeyframe& k = keyframes_[index];
  const InstrumentCommand& a = segment_start_;
  const double duration = k.time - segment_start_time_;
  const double tau = std::clamp(t - segment_start_time_, 0.0, std::max(duration, 0.0));
  const bool at_end = tau >= duration;  // exact end values at the keyframe
  const double u = duration > 0.0 ? tau / duration : 1.0;
  const double e = quintic_ease(u);
  if (tau <= 0.0 && duration > 0.0) return a;

  InstrumentCommand c = a;
  switch (k.op) {
    case ScriptOp::move:
      c.pose.translation = at_end ? k.position : Vec3(a.pose.translation + e * (k.position - a.pose.translation));
      if (k.has_orientation) c.pose.rotation = at_end ? k.orientation : a.pose.rotation.slerp(e, k.orientation);
      break;
    case ScriptOp::press_depth: {
      const Vec3 target = a.pose.translation + k.depth * k.axis;
      c.pose.translation = at_end ? target : Vec3(a.pose.translation + e * k.depth * k.axis);
      break;
    }
    case ScriptOp::press_force:
      c.pose.translation = a.pose.translation + press_distance(k, tau, duration, fb) * k.axis;
      break;
    case ScriptOp::hold:
      break;
    case ScriptOp::slide: {
      // Legs from the start through every path point; time shared by length; each leg eased.
      std::vector<Vec3> points{a.pose.translation};
      points.insert(points.end(), k.path.begin(), k.path.end());
      double total = 0.0;
      for (size_t i = 1; i < points.size(); ++i) total += (points[i] - points[i - 1]).norm();
      if (at_end) {
        c.pose.translation = k.path.back();
        break;
      }
      if (total <= 0.0) break;
      double covered = 0.0;
      for (size_t i = 1; i < points.size(); ++i) {
        const double leg = (points[i] - points[i - 1]).norm();
        const double u0 = covered / total, u1 = (covered + leg) / total;
        covered += leg;
        if (leg <= 0.0) continue;
        if (u <= u1 || i + 1 == points.size()) {
          const double s = quintic_ease((u - u0) / (u1 - u0));
          c.pose.translation = points[i - 1] + s * (points[i] - points[i - 1]);
          break;
        }
      }
      break;
    }
    case ScriptOp::rotate:
      c.pose.rotation = (Quat(Eigen::AngleAxisd((at_end ? 1.0 : e) * k.angle, k.axis)) * a.pose.rotation).normalized();
      break;
    case ScriptOp::jaws:
      c.jaw_opening = at_end ? k.jaw_opening : a.jaw_opening + e * (k.jaw_opening - a.jaw_opening);
      break;
  }
  return c;
}

InstrumentCommand ScriptPoseSource::sample(double t, const InstrumentFeedback& fb) {
  t = std::max(t, last_t_);
  last_t_ = t;
  // Close every segment that ended by t; the next starts where it actually ended.
  while (segment_ < keyframes_.size() && t >= keyframes_[segment_].time) {
    const InstrumentCommand end = evaluate(segment_, keyframes_[segment_].time, nullptr);
    segment_start_ = end;
    segment_start_time_ = keyframes_[segment_].time;
    ++segment_;
    begin_segment(segment_);
  }
  last_ = segment_ < keyframes_.size() ? evaluate(segment_, t, &fb) : segment_start_;
  return last_;
}

bool ScriptPoseSource::finished(double t) const {
  return keyframes_.empty() || t >= keyframes_.back().time;
}

}  // namespace pliant
