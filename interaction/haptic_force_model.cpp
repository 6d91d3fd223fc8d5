#include "interaction/haptic_force_model.h"

#include <Eigen/Eigenvalues>

namespace pliant {

HapticForceModel::HapticForceModel(int window) : window_(std::max(window, 1)) {}

Mat3 HapticForceModel::nearest_psd(const Mat3& m) {
  const Mat3 sym = 0.5 * (m + m.transpose());
  Eigen::SelfAdjointEigenSolver<Mat3> eig(sym);
  const Vec3 lambda = eig.eigenvalues().cwiseMax(0.0);
  return eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
}

Mat3 HapticForceModel::fit_stiffness(const std::deque<std::pair<Vec3, Vec3>>& pairs) {
  // Least squares K s_i ~ y_i: K = (sum y s^T) (sum s s^T)^+, the pseudo-inverse limited to the
  // directions the steps excited (eigenvalues above 1e-10 of the largest).
  Mat3 sst = Mat3::Zero(), yst = Mat3::Zero();
  for (const auto& [s, y] : pairs) {
    sst += s * s.transpose();
    yst += y * s.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Mat3> eig(sst);
  const Vec3 lambda = eig.eigenvalues();
  const double largest = lambda.maxCoeff();
  if (!(largest > 0.0)) return Mat3::Zero();
  Vec3 inverse = Vec3::Zero(), excited = Vec3::Zero();
  for (int i = 0; i < 3; ++i) {
    if (lambda[i] > 1e-10 * largest) {
      inverse[i] = 1.0 / lambda[i];
      excited[i] = 1.0;
    }
  }
  const Mat3 pinv = eig.eigenvectors() * inverse.asDiagonal() * eig.eigenvectors().transpose();
  // Restricted to the excited subspace (projector P) on both sides, so the symmetric part keeps
  // the secant exactly there and says nothing about directions without data.
  const Mat3 p = eig.eigenvectors() * excited.asDiagonal() * eig.eigenvectors().transpose();
  return nearest_psd(p * (yst * pinv) * p);
}

void HapticForceModel::update(double t, const Vec3& x, const Vec3& f) {
  std::lock_guard<std::mutex> writer(writer_mutex_);
  if (!x.allFinite() || !f.allFinite() || !std::isfinite(t)) {
    ++rejected_;
    return;
  }
  if (latest_.valid) {
    const Vec3 s = x - latest_.x0;
    const Vec3 y = -(f - latest_.f0);
    // Only steps in contact on both ends, and steps that moved, say something about stiffness.
    const bool in_contact = f.squaredNorm() > 0.0 && latest_.f0.squaredNorm() > 0.0;
    if (!in_contact) pairs_.clear();
    if (in_contact && s.squaredNorm() > 0.0) {
      pairs_.emplace_back(s, y);
      while (static_cast<int>(pairs_.size()) > window_) pairs_.pop_front();
      latest_.k = fit_stiffness(pairs_);
    }
  }
  latest_.x0 = x;
  latest_.f0 = f;
  latest_.time = t;
  latest_.valid = true;
  std::lock_guard<std::mutex> lock(mutex_);
  model_ = latest_;
}

Vec3 predict_force(const LinearContactModel& m, const Vec3& x) {
  if (!m.valid || m.f0.squaredNorm() == 0.0) return Vec3::Zero();
  const Vec3 f = m.f0 - m.k * (x - m.x0);
  // A model linearised while pushing must not pull.
  if (f.dot(m.f0) < 0.0) return Vec3::Zero();
  return f;
}

Vec3 HapticForceModel::force_at(const Vec3& x) const { return predict_force(snapshot(), x); }

LinearContactModel HapticForceModel::snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return model_;
}

long HapticForceModel::rejected_updates() const {
  std::lock_guard<std::mutex> writer(writer_mutex_);
  return rejected_;
}

void HapticForceModel::reset() {
  std::lock_guard<std::mutex> writer(writer_mutex_);
  latest_ = LinearContactModel{};
  pairs_.clear();
  std::lock_guard<std::mutex> lock(mutex_);
  model_ = latest_;
}

}  // namespace pliant
