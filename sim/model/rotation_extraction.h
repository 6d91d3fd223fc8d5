// Rotation of a deformation gradient by the iteration of Mueller, Bender, Chentanez & Macklin,
// "A Robust Method to Extract the Rotational Part of Deformations" (MIG 2016), eq. 9:
//   omega = sum_i r_i x a_i / (|sum_i r_i . a_i| + eps),   R <- exp(omega) R,
// with r_i, a_i the columns of R and F. It climbs tr(R^T F) over rotations, so it converges to the
// rotation U diag(1, 1, det(U V^T)) V^T of the SVD F = U S V^T: the polar rotation for det F > 0
// and the reflection-fixed one for inverted elements (the smallest singular value changes sign).
// For F = 0 (a collapsed element) omega is zero and R keeps its warm start. At convergence R^T F
// is symmetric, which is what makes the corotated force the exact gradient of the energy.
#pragma once

#include <Eigen/SVD>
#include <cmath>

#include "sim/math_types.h"

namespace pliant {

/// Refines q (warm start, unit) towards the rotation of F; stops when the update angle (rad) is
/// below `tolerance` or after `max_iterations`. Returns the iterations used.
inline int extract_rotation(const Mat3& F, Quat& q, int max_iterations = 30, double tolerance = 1e-13) {
  // The iteration climbs tr(R^T F) and stalls at its saddle points: a warm start facing away
  // from F (tr(R^T F) <= 0, e.g. identity against a body placed at 180 degrees) is replaced by
  // the rotation of the SVD, which the iteration then only polishes.
  if (q.toRotationMatrix().cwiseProduct(F).sum() <= 0.0 && F.allFinite()) {
    Eigen::JacobiSVD<Mat3> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 U = svd.matrixU();
    const Mat3 V = svd.matrixV();
    if ((U * V.transpose()).determinant() < 0.0) U.col(2) = -U.col(2);
    q = Quat(Mat3(U * V.transpose()));
    q.normalize();
  }
  int it = 0;
  for (; it < max_iterations; ++it) {
    const Mat3 R = q.toRotationMatrix();
    const Vec3 omega_num = R.col(0).cross(F.col(0)) + R.col(1).cross(F.col(1)) + R.col(2).cross(F.col(2));
    const double denom = std::abs(R.col(0).dot(F.col(0)) + R.col(1).dot(F.col(1)) + R.col(2).dot(F.col(2))) + 1e-9;
    Vec3 omega = omega_num / denom;
    if (!(omega.norm() >= tolerance)) break;  // converged (also stops on NaN input)
    bool newton_step = false;
    const Mat3 A = F * R.transpose();
    Mat3 H = -0.5 * (A + A.transpose());
    H.diagonal().array() += A.trace();
    // Positive definite by Sylvester's criterion (leading minors), then the adjugate solve.
    const double m1 = H(0, 0), m2 = H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0), det = H.determinant();
    const double floor = 1e-3 * denom;
    if (m1 > floor && m2 > floor * floor && det > floor * floor * floor) {
      Mat3 adj;
      adj(0, 0) = H(1, 1) * H(2, 2) - H(1, 2) * H(2, 1);
      adj(0, 1) = H(0, 2) * H(2, 1) - H(0, 1) * H(2, 2);
      adj(0, 2) = H(0, 1) * H(1, 2) - H(0, 2) * H(1, 1);
      adj(1, 1) = H(0, 0) * H(2, 2) - H(0, 2) * H(2, 0);
      adj(1, 2) = H(0, 2) * H(1, 0) - H(0, 0) * H(1, 2);
      adj(2, 2) = H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0);
      adj(1, 0) = adj(0, 1);  // H is symmetric
      adj(2, 0) = adj(0, 2);
      adj(2, 1) = adj(1, 2);
      const Vec3 step = adj * omega_num / det;
      if (step.squaredNorm() < 1.0) {
        omega = step;
        newton_step = true;
      }
    }
    const double angle = omega.norm();
    if (!(angle >= tolerance)) break;  // also stops on NaN input
    // Retraction without sin/cos: q <- normalize((1, omega/2) q), a rotation by 2 atan(|omega|/2)
    // = |omega| (1 + O(|omega|^2)) about omega, which keeps Newton's quadratic convergence.
    q = Quat(1.0, 0.5 * omega.x(), 0.5 * omega.y(), 0.5 * omega.z()) * q;
    q.normalize();
    // Newton converges quadratically: after a step of `angle` the error is O(angle^2).
    if (newton_step && angle * angle < tolerance) {
      ++it;
      break;
    }
  }
  return it;
}

}  // namespace pliant
