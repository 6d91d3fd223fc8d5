// Rotation of a deformation gradient by the iteration of Mueller, Bender, Chentanez & Macklin,
// "A Robust Method to Extract the Rotational Part of Deformations" (MIG 2016), eq. 9:
//   omega = sum_i r_i x a_i / (|sum_i r_i . a_i| + eps),   R <- exp(omega) R,
// with r_i, a_i the columns of R and F. It climbs tr(R^T F) over rotations, so it converges to the
// rotation U diag(1, 1, det(U V^T)) V^T of the SVD F = U S V^T: the polar rotation for det F > 0
// and the reflection-fixed one for inverted elements (the smallest singular value changes sign).
// At convergence R^T F is symmetric, which is what makes the corotated force the exact gradient of
// the energy.
//
// Design note (session 2, for speed; docs/deformation-models.md "Rotation"):
// - The iteration runs in the frame of the current estimate: with G = R^T F and R <- R Q, the
//   gradient of tr(Q^T G) at Q = I is g = axial(G - G^T) = (G21 - G12, G02 - G20, G10 - G01) and
//   its Hessian in the rotation vector is tr(G) I - sym(G); both are read off G without products.
//   G is carried along (G <- Q^T G) instead of being rebuilt from R and F at every iteration.
// - Newton step theta = (tr(G) I - sym(G))^-1 g when that Hessian is positive definite (Sylvester
//   test, adjugate solve), the paper's step g / (|tr G| + eps) otherwise (inverted, far away).
// - Retraction by the unnormalised quaternion (2 + |theta|^2 / 2, theta): a rotation by
//   atan(|theta|) (1 + O(|theta|^4)) about theta. For a pure rotation error phi the Newton step is
//   tan(phi), so this retraction lands on the solution to O(phi^5); what remains after one step
//   comes from the strain. No sqrt: the iteration is latency-bound, one division per iteration.
// - The quaternion is normalised once at the end (the products only scale it), and G is carried
//   unnormalised (every test and step below is invariant to a positive scale of G).
#pragma once

#include <Eigen/SVD>
#include <cmath>

#include "sim/math_types.h"

namespace pliant {

/// Iteration cap and tolerance (rad) of the corotational FEM's element rotations: the full pass and
/// the lazy local queries must extract the same rotation from the same F and warm start.
inline constexpr int kElementRotationIterations = 30;
inline constexpr double kElementRotationTolerance = 1e-11;  ///< makes R^T F symmetric to ~1e-11

/// Refines q (warm start, unit) towards the rotation of F; stops when the update angle (rad) is
/// below `tolerance`, or after a Newton step of angle a with a^2 < tolerance (quadratic convergence:
/// the error left is O(a^2)), or after `max_iterations`. Returns the iterations used (updates made).
inline int extract_rotation(const Mat3& F, Quat& q, int max_iterations = 30, double tolerance = 1e-13) {
  Mat3 G = q.toRotationMatrix().transpose() * F;  // F seen from the warm start
  // The iteration climbs tr(R^T F) and stalls at its saddle points: a warm start facing away
  // from F (tr(R^T F) <= 0, e.g. identity against a body placed at 180 degrees) is replaced by
  // the rotation of the SVD, which the iteration then only polishes.
  if (G.trace() <= 0.0 && F.allFinite()) {
    Eigen::JacobiSVD<Mat3> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 U = svd.matrixU();
    const Mat3 V = svd.matrixV();
    if ((U * V.transpose()).determinant() < 0.0) U.col(2) = -U.col(2);
    const Mat3 R = U * V.transpose();
    q = Quat(R);
    q.normalize();
    G = R.transpose() * F;
  }
  const double tolerance_sq = tolerance * tolerance;
  int it = 0;
  for (; it < max_iterations; ++it) {
    const Vec3 g(G(2, 1) - G(1, 2), G(0, 2) - G(2, 0), G(1, 0) - G(0, 1));
    const double tr = G.trace();
    const double denom = std::abs(tr) + 1e-9;
    // Hessian H = tr(G) I - sym(G), symmetric.
    const double h00 = tr - G(0, 0), h11 = tr - G(1, 1), h22 = tr - G(2, 2);
    const double h01 = -0.5 * (G(0, 1) + G(1, 0)), h02 = -0.5 * (G(0, 2) + G(2, 0)),
                 h12 = -0.5 * (G(1, 2) + G(2, 1));
    const double c00 = h11 * h22 - h12 * h12, c01 = h02 * h12 - h01 * h22, c02 = h01 * h12 - h02 * h11;
    const double m2 = h00 * h11 - h01 * h01, det = h00 * c00 + h01 * c01 + h02 * c02;
    const double floor = 1e-3 * denom;
    Vec3 theta;
    bool newton_step = false;
    // Positive definite by Sylvester's criterion (leading minors), then the adjugate solve.
    if (h00 > floor && m2 > floor * floor && det > floor * floor * floor) {
      const double c11 = h00 * h22 - h02 * h02, c12 = h02 * h01 - h00 * h12;
      const double inv_det = 1.0 / det;
      theta = inv_det * Vec3(c00 * g.x() + c01 * g.y() + c02 * g.z(), c01 * g.x() + c11 * g.y() + c12 * g.z(),
                             c02 * g.x() + c12 * g.y() + m2 * g.z());
      newton_step = theta.squaredNorm() < 1.0;
    }
    if (!newton_step) theta = g / denom;
    const double angle_sq = theta.squaredNorm();
    if (!(angle_sq >= tolerance_sq)) break;  // converged (also stops on NaN input)
    // Q = rotation of the quaternion (w, theta), w = 2 + |theta|^2 / 2 = 1 + sqrt(1 + |theta|^2) +
    // O(|theta|^4): by atan(|theta|) (1 + O(|theta|^4)) about theta.
    const double w = 2.0 + 0.5 * angle_sq;
    const Quat dq(w, theta.x(), theta.y(), theta.z());
    q = q * dq;
    // Newton converges quadratically: after a step of angle a the error is O(a^2).
    if ((newton_step && angle_sq * angle_sq < tolerance_sq) || it + 1 == max_iterations) {
      ++it;  // (no G update after the last one)
      break;
    }
    // G <- n^2 Q^T G with n^2 Q = (w^2 - |v|^2) I + 2 v v^T + 2 w [v]x, v = theta: the Newton
    // step, the Sylvester test (floors scale with |tr G|) and the paper's step are invariant to the
    // scale of G, so the division by n^2 = w^2 + |v|^2 is left out (G grows by ~4 per iteration).
    Mat3 Q;
    const double d = w * w - angle_sq, s2 = 2.0;
    Q << d + s2 * theta.x() * theta.x(), s2 * (theta.x() * theta.y() - w * theta.z()),
        s2 * (theta.x() * theta.z() + w * theta.y()),  //
        s2 * (theta.y() * theta.x() + w * theta.z()), d + s2 * theta.y() * theta.y(),
        s2 * (theta.y() * theta.z() - w * theta.x()),  //
        s2 * (theta.z() * theta.x() - w * theta.y()), s2 * (theta.z() * theta.y() + w * theta.x()),
        d + s2 * theta.z() * theta.z();
    G = (Q.transpose() * G).eval();
  }
  q.normalize();
  return it;
}

}  // namespace pliant
