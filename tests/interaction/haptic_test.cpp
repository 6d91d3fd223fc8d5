// Haptic output: the local linear contact model predicts a linear spring environment exactly,
// K stays symmetric PSD, the device force is clamped, rate-limited and never NaN.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "interaction/haptic_thread.h"
#include "support/fp_traps.h"

namespace pliant {
namespace {

// A linear spring environment: force on the instrument F(x) = -K (x - x_s), K SPD (N/m).
struct Spring {
  Mat3 k;
  Vec3 rest;
  Vec3 force(const Vec3& x) const { return -k * (x - rest); }
};

Spring make_spring() {
  Mat3 a;
  a << 3.0, 0.5, -0.2,  //
      0.5, 2.0, 0.3,    //
      -0.2, 0.3, 1.0;
  return Spring{200.0 * a, Vec3(0.0, 0.0, 0.01)};
}

TEST(HapticForceModel, PredictsALinearSpringFromSuccessivePhysicsSteps) {
  const Spring env = make_spring();
  HapticForceModel model;
  // Physics steps moving in three independent directions, always in contact.
  const std::vector<Vec3> path = {Vec3(0, 0, 0), Vec3(1e-4, 0, -2e-4), Vec3(1e-4, 2e-4, -3e-4),
                                  Vec3(-1e-4, 2e-4, -5e-4), Vec3(0, 1e-4, -6e-4)};
  double t = 0.0;
  for (const Vec3& x : path) model.update(t += 1e-2, x, env.force(x));
  const LinearContactModel m = model.snapshot();
  EXPECT_NEAR((m.k - env.k).norm() / env.k.norm(), 0.0, 1e-9);
  EXPECT_NEAR((m.k - m.k.transpose()).norm(), 0.0, 1e-12 * env.k.norm());
  // F0 + K dx equals the spring at positions the physics has not visited.
  for (const Vec3& dx : {Vec3(1e-4, 0, 0), Vec3(0, -2e-4, 1e-4), Vec3(-3e-4, 1e-4, -1e-4)}) {
    const Vec3 x = path.back() + dx;
    EXPECT_NEAR((model.force_at(x) - env.force(x)).norm(), 0.0, 1e-9 * env.force(x).norm());
  }
}

TEST(HapticForceModel, UnexcitedDirectionsGetNoStiffness) {
  const Spring env = make_spring();
  HapticForceModel model;
  for (int i = 0; i < 4; ++i) {
    const Vec3 x(0, 0, -1e-4 * i);  // pressing straight down only
    model.update(i * 1e-2, x, env.force(x));
  }
  const Mat3 k = model.snapshot().k;
  // Along z the secant is exact: k_zz = e_z . K e_z.
  EXPECT_NEAR(k(2, 2), env.k(2, 2), 1e-9 * env.k(2, 2));
  // PSD: every eigenvalue >= 0.
  Eigen::SelfAdjointEigenSolver<Mat3> eig(k);
  EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-9 * env.k.norm());
}

TEST(HapticForceModel, NearestPsdDropsNegativeEigenvaluesOnly) {
  const Mat3 q = Quat(Eigen::AngleAxisd(0.4, Vec3(1, 2, 3).normalized())).toRotationMatrix();
  const Mat3 m = q * Vec3(3.0, -1.0, 2.0).asDiagonal() * q.transpose();
  const Mat3 expected = q * Vec3(3.0, 0.0, 2.0).asDiagonal() * q.transpose();
  EXPECT_NEAR((HapticForceModel::nearest_psd(m) - expected).norm(), 0.0, 1e-12);
}

TEST(HapticForceModel, OutOfContactPredictsZeroAndNeverPulls) {
  HapticForceModel model;
  EXPECT_EQ(model.force_at(Vec3::Zero()), Vec3::Zero());  // no update yet
  const Spring env = make_spring();
  for (int i = 0; i < 4; ++i) {
    const Vec3 x(0, 0, -1e-4 * i);
    model.update(i * 1e-2, x, env.force(x));
  }
  // Withdrawing far beyond the contact: the linear model would pull; the prediction is zero.
  const Vec3 far_out = Vec3(0, 0, 0.05);
  EXPECT_LT((env.force(Vec3(0, 0, -3e-4)) - env.k * (far_out - Vec3(0, 0, -3e-4))).dot(env.force(Vec3(0, 0, -3e-4))), 0.0);
  EXPECT_EQ(model.force_at(far_out), Vec3::Zero());
  // Contact lost at the physics step: zero until contact comes back.
  model.update(1.0, Vec3(0, 0, 0.02), Vec3::Zero());
  EXPECT_EQ(model.force_at(Vec3(0, 0, 0.0)), Vec3::Zero());
}

TEST(HapticForceModel, NonFiniteUpdatesAreRejected) {
  testing::ScopedFpTrapsOff traps_off;
  HapticForceModel model;
  model.update(0.0, Vec3(0, 0, 0), Vec3(0, 0, 1));
  model.update(0.01, Vec3(0, 0, std::nan("")), Vec3(0, 0, 2));
  EXPECT_EQ(model.rejected_updates(), 1);
  EXPECT_EQ(model.snapshot().f0, Vec3(0, 0, 1));
  EXPECT_TRUE(model.force_at(Vec3::Zero()).allFinite());
}

TEST(HapticOutputFilter, ClampAndRateLimitHold) {
  HapticLimits limits;
  limits.max_force = 3.0;
  limits.max_delta = 0.25;
  HapticOutputFilter filter(limits);
  Vec3 previous = Vec3::Zero();
  const Vec3 desired = Vec3(30.0, -40.0, 0.0);  // 50 N, far above the clamp
  int ticks_to_reach = 0;
  for (int i = 0; i < 40; ++i) {
    const Vec3 out = filter.filter(desired);
    EXPECT_LE(out.norm(), limits.max_force * (1 + 1e-12));
    EXPECT_LE((out - previous).norm(), limits.max_delta * (1 + 1e-12));
    if (ticks_to_reach == 0 && (out - desired.normalized() * 3.0).norm() < 1e-12) ticks_to_reach = i + 1;
    previous = out;
  }
  EXPECT_EQ(ticks_to_reach, 12);  // 3 N at 0.25 N per tick
  // Direction preserved by the clamp.
  EXPECT_NEAR(previous.normalized().dot(desired.normalized()), 1.0, 1e-12);
  // A step down is rate-limited too.
  EXPECT_NEAR((filter.filter(Vec3::Zero()) - previous).norm(), limits.max_delta, 1e-12);
}

TEST(HapticOutputFilter, NanGivesZeroAndAFault) {
  testing::ScopedFpTrapsOff traps_off;
  HapticLimits limits;
  HapticOutputFilter filter(limits);
  for (int i = 0; i < 10; ++i) filter.filter(Vec3(0, 0, 5));
  EXPECT_GT(filter.last().norm(), 0.0);
  const Vec3 out = filter.filter(Vec3(0, std::nan(""), 1));
  EXPECT_EQ(out, Vec3::Zero());
  EXPECT_TRUE(filter.fault());
  EXPECT_EQ(filter.fault_count(), 1);
  const Vec3 inf_out = filter.filter(Vec3(std::numeric_limits<double>::infinity(), 0, 0));
  EXPECT_EQ(inf_out, Vec3::Zero());
  EXPECT_EQ(filter.fault_count(), 2);
  // Recovers from zero, rate-limited.
  const Vec3 next = filter.filter(Vec3(0, 0, 5));
  EXPECT_FALSE(filter.fault());
  EXPECT_NEAR(next.norm(), limits.max_delta, 1e-12);
}

TEST(HapticThread, TicksFollowTheDeviceThroughTheModel) {
  const Spring env = make_spring();
  HapticForceModel model;
  for (int i = 0; i < 4; ++i) {
    const Vec3 x(1e-4 * (i == 1), 1e-4 * (i == 2), -1e-4 * i);
    model.update(i * 1e-2, x, env.force(x));
  }
  HapticLimits limits;
  limits.max_force = 100.0;
  limits.max_delta = 100.0;  // no limiting: the output is the model
  Vec3 device = Vec3(0, 0, -3.5e-4);
  std::vector<std::pair<double, Vec3>> sent;
  VirtualClock clock;
  HapticThread haptics(clock, model, limits, [&] { return device; },
                       [&](double t, const Vec3& f) { sent.emplace_back(t, f); });
  const Vec3 f = haptics.tick(0.001);
  EXPECT_NEAR((f - env.force(device)).norm(), 0.0, 1e-9 * env.force(device).norm());
  ASSERT_EQ(sent.size(), 1u);
  EXPECT_EQ(sent[0].second, f);
  {
    testing::ScopedFpTrapsOff traps_off;
    device = Vec3(std::nan(""), 0, 0);
    EXPECT_EQ(haptics.tick(0.002), Vec3::Zero());
  }
  EXPECT_EQ(haptics.stats().faults, 1);
  EXPECT_EQ(haptics.stats().ticks, 2);
}

TEST(HapticThread, RunsOnItsOwnThreadAndStops) {
  const Spring env = make_spring();
  HapticForceModel model;
  SteadyClock clock;
  HapticLimits limits;
  limits.max_force = 2.0;
  std::atomic<long> bad{0};
  std::atomic<double> last_t{-1.0};
  HapticThread haptics(clock, model, limits, [] { return Vec3(0, 0, -2e-4); },
                       [&](double t, const Vec3& f) {
                         if (!f.allFinite() || f.norm() > 2.0 + 1e-12 || t < last_t.load()) ++bad;
                         last_t = t;
                       });
  haptics.start();
  // The physics thread refreshes the model meanwhile.
  for (int i = 0; i < 20; ++i) {
    const Vec3 x(0, 0, -1e-5 * i);
    model.update(i * 1e-3, x, env.force(x));
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  haptics.stop();
  EXPECT_FALSE(haptics.running());
  const long ticks = haptics.stats().ticks;
  EXPECT_GT(ticks, 0);
  EXPECT_EQ(bad.load(), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(haptics.stats().ticks, ticks);  // stopped means stopped
}

// Two threads wake for every slot: each slot is sent once (the first awake claims it), in order,
// and every send is counted against the thread that made it. Timing-free: a slow host only lowers
// the counts, never breaks the bounds.
TEST(HapticThread, SeveralThreadsSendEachSlotOnceAndInOrder) {
  HapticForceModel model;
  SteadyClock clock;
  HapticLimits limits;
  limits.rate_hz = 2000.0;
  std::mutex mutex;
  std::vector<double> sent;
  sent.reserve(4096);
  HapticThread haptics(clock, model, limits, [] { return Vec3::Zero(); },
                       [&](double t, const Vec3&) {
                         std::lock_guard<std::mutex> lock(mutex);
                         sent.push_back(t);
                       });
  haptics.set_thread_count(2);
  const double t_start = clock.now();
  haptics.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  haptics.stop();
  const double t_stop = clock.now();
  const HapticTiming timing = haptics.timing();
  const HapticStats stats = haptics.stats();
  ASSERT_EQ(timing.ticks_by_thread.size(), 2u);
  EXPECT_EQ(timing.ticks_by_thread[0] + timing.ticks_by_thread[1], stats.ticks);
  ASSERT_EQ(static_cast<long>(sent.size()), stats.ticks);
  ASSERT_GT(stats.ticks, 0);
  for (size_t i = 1; i < sent.size(); ++i) EXPECT_LT(sent[i - 1], sent[i]) << "send " << i;
  // Slots sent plus slots dropped cannot exceed the slots that came due while running; a slot
  // sent by both threads would be sent twice (about twice as many sends).
  const double slots_due = (t_stop - t_start) * limits.rate_hz + 1.0;
  EXPECT_LE(static_cast<double>(stats.ticks), slots_due);
  EXPECT_GE(stats.skipped_ticks, 0);
  EXPECT_LE(static_cast<double>(stats.ticks + stats.skipped_ticks), slots_due);
}

}  // namespace
}  // namespace pliant
