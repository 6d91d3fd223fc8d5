// HapticForceModel (issue 6, item 6; DESIGN.md): the local linear contact model that lets the
// haptic force run at 1 kHz when a physics step cannot.
//
//   F(x) = F0 - K (x - x0)
//
// F0 is the force the tissue exerted on the instrument at the last physics step, x0 the
// instrument position then, and K a 3x3 local stiffness (N/m), symmetric positive semi-definite,
// so the predicted force never pushes the instrument further in. K is estimated from successive
// physics steps by least squares over a short window of secant pairs (s_i = x_i - x_{i-1},
// y_i = -(F_i - F_{i-1})): K = argmin sum |K s_i - y_i|^2 = Y S^T (S S^T)^+, restricted to the
// excited subspace on both sides (P K P, P the projector onto span{s_i}), symmetrised and
// projected onto the PSD cone (negative eigenvalues set to zero). Directions the window has not
// excited get no stiffness, so nothing is invented; with all three excited a linear symmetric
// environment is recovered exactly (tested).
// Choices where the sources are silent (docs/interaction.md):
//   - pairs where either force is zero (onset or loss of contact) are not used: contact onset is
//     not linear;
//   - out of contact (F0 = 0) the model predicts zero: it does not anticipate a contact;
//   - the prediction never reverses F0's direction (if F . F0 < 0 it is zero): a model that was
//     linearised while pushing must not pull.
// Thread-safe: the physics thread calls update(), the haptic thread calls force_at(). The fit runs
// under the writer's own lock; the lock the haptic thread takes guards only the published model's
// copy, so a physics thread descheduled mid-fit (a loaded machine) cannot hold a haptic tick.
#pragma once

#include <deque>
#include <mutex>

#include "sim/math_types.h"

namespace pliant {

/// A snapshot of the model (what force_at uses).
struct LinearContactModel {
  Vec3 x0 = Vec3::Zero();  ///< m, instrument position at the last physics step
  Vec3 f0 = Vec3::Zero();  ///< N, force on the instrument then
  Mat3 k = Mat3::Zero();   ///< N/m, symmetric PSD
  double time = 0.0;       ///< s, simulated time of the last physics step
  bool valid = false;      ///< false until the first update
};

class HapticForceModel {
 public:
  /// `window` secant pairs are kept for the least-squares fit.
  explicit HapticForceModel(int window = 6);

  /// Refreshes the model after a physics step: instrument position x (m), force f (N) at time t (s).
  /// Non-finite inputs are ignored (the model keeps its last good state) and counted.
  void update(double t, const Vec3& x, const Vec3& f);
  /// Predicted force (N) at instrument position x: F0 - K (x - x0), per the rules above.
  Vec3 force_at(const Vec3& x) const;
  /// Copy of the current model.
  LinearContactModel snapshot() const;
  /// Inputs rejected as non-finite.
  long rejected_updates() const;
  /// Forgets everything.
  void reset();

  /// The fit itself, exposed for tests: K from secant pairs, symmetric PSD.
  static Mat3 fit_stiffness(const std::deque<std::pair<Vec3, Vec3>>& pairs);
  /// Symmetric part of m with negative eigenvalues set to zero.
  static Mat3 nearest_psd(const Mat3& m);

 private:
  mutable std::mutex mutex_;                 ///< guards model_ (the haptic thread's read)
  LinearContactModel model_;                 ///< the published model
  mutable std::mutex writer_mutex_;          ///< guards what only update() and reset() work on
  LinearContactModel latest_;                ///< the writer's copy of the model
  std::deque<std::pair<Vec3, Vec3>> pairs_;  ///< (s, y)
  int window_;
  long rejected_ = 0;
};

/// Predicts with a snapshot (same rules as HapticForceModel::force_at).
Vec3 predict_force(const LinearContactModel& m, const Vec3& x);

}  // namespace pliant
