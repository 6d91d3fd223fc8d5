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
#include <cstring>

#include "sim/math_types.h"

namespace pliant {

/// Iteration cap and tolerance (rad) of the corotational FEM's element rotations: the full pass and
/// the lazy local queries must extract the same rotation from the same F and warm start.
inline constexpr int kElementRotationIterations = 30;
inline constexpr double kElementRotationTolerance = 1e-11;  ///< makes R^T F symmetric to ~1e-11

/// The iteration's start: G = R^T F for the warm start q, or q and G from the SVD's rotation when
/// q faces away from F (shared by extract_rotation and extract_rotations_batch, bit for bit).
inline Mat3 rotation_iteration_start(const Mat3& F, Quat& q) {
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
  return G;
}

/// Refines q (warm start, unit) towards the rotation of F; stops when the update angle (rad) is
/// below `tolerance`, or after a Newton step of angle a with a^2 < tolerance (quadratic convergence:
/// the error left is O(a^2)), or after `max_iterations`. Returns the iterations used (updates made).
inline int extract_rotation(const Mat3& F, Quat& q, int max_iterations = 30, double tolerance = 1e-13) {
  Mat3 G = rotation_iteration_start(F, q);
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

/// Tets per call of extract_rotations_batch: one SIMD register of doubles (2 with SSE2, 4 with AVX;
/// four lanes in two SSE2 registers spill: 0.93 ms per probe pass against 0.52 for the scalar).
#ifdef __AVX__
inline constexpr int kRotationBatchLanes = 4;
#else
inline constexpr int kRotationBatchLanes = 2;
#endif

// Batched extraction (session 6, docs/deformation-models.md "Rotation, batched"). One tet's
// iteration is a dependent chain (G -> Hessian -> det -> division -> theta -> Q -> G) with a
// data-dependent exit, so the core waits on latency; two tets (four with AVX) in the lanes of GCC
// vector types, one SIMD register per value, run their chains in the instructions of one. Every lane performs exactly extract_rotation's operations
// in its order (Eigen's: the trace as a + (b + c), squared norms and the 3x3 product's k-sums
// left to right, the quaternion product as Eigen's SSE2 kernel groups it), selected per
// lane where the scalar branches: the result is the scalar's bit for bit (tested on random input;
// with FMA contraction, -march=native, both may round differently). A lane that stopped keeps its
// q, G and count; the batch runs until every lane stopped.
namespace rotation_batch_detail {
/// One SIMD register of L doubles (GCC vector type) and its lane mask (lane true: -1), with the lane
/// operations the templates below use: comparisons, selects, any lane set, a square root, and the
/// loads of q and F into lanes. Spelled out per L: GCC does not apply a vector_size that depends on
/// a template parameter. LaneTypes<8> lives in rotation_batch_avx512.cpp, its operations AVX-512
/// instructions (session 17: why they are functions there, not GCC's vector operators).
template <int L>
struct LaneTypes;
/// The lane operations lane by lane (the 2- and 4-lane batches').
template <int L, class LanesType, class MaskType>
struct LaneByLaneOperations {
  typedef LanesType Lanes;
  typedef MaskType Mask;
  /// True when some lane of m is set.
  static bool any(const Mask& m) {
    for (int l = 0; l < L; ++l) {
      if (m[l] != 0) return true;
    }
    return false;
  }
  /// a < b and a <= b per lane (all bits set where true).
  static Mask less(const Lanes& a, const Lanes& b) { return a < b; }
  static Mask less_equal(const Lanes& a, const Lanes& b) { return a <= b; }
  /// m ? a : b per lane.
  static Lanes select(const Mask& m, const Lanes& a, const Lanes& b) { return m ? a : b; }
  /// Lane l of qx, qy, qz, qw = the coefficients of q[l].
  static void load_quaternions(const Quat* q, Lanes& qx, Lanes& qy, Lanes& qz, Lanes& qw) {
    double x[L], y[L], z[L], w[L];
    for (int l = 0; l < L; ++l) x[l] = q[l].x(), y[l] = q[l].y(), z[l] = q[l].z(), w[l] = q[l].w();
    std::memcpy(&qx, x, sizeof(qx));
    std::memcpy(&qy, y, sizeof(qy));
    std::memcpy(&qz, z, sizeof(qz));
    std::memcpy(&qw, w, sizeof(qw));
  }
  /// Lane l of Fl[i][j] = F[l](i, j).
  static void load_matrices(const Mat3* F, Lanes (&Fl)[3][3]) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        double values[L];
        for (int l = 0; l < L; ++l) values[l] = F[l](i, j);
        std::memcpy(&Fl[i][j], values, sizeof(Lanes));
      }
    }
  }
  /// s = sqrt(n) in the lanes where n > 0, 1 elsewhere (correctly rounded: the scalar's bits).
  static void square_root_where_positive(const Lanes& n, Lanes& s) {
    double values[L];
    for (int l = 0; l < L; ++l) values[l] = n[l] > 0.0 ? std::sqrt(n[l]) : 1.0;
    std::memcpy(&s, values, sizeof(s));
  }
};
typedef double Lanes2 __attribute__((vector_size(16)));
typedef long Mask2 __attribute__((vector_size(16)));
typedef double Lanes4 __attribute__((vector_size(32)));
typedef long Mask4 __attribute__((vector_size(32)));
template <>
struct LaneTypes<2> : LaneByLaneOperations<2, Lanes2, Mask2> {};
template <>
struct LaneTypes<4> : LaneByLaneOperations<4, Lanes4, Mask4> {};
static_assert(sizeof(long) == sizeof(double), "masks as wide as the lanes");
template <int L, class Mask>
inline bool any(const Mask& m) {
  return LaneTypes<L>::any(m);
}

/// extract_rotation's start and Newton iteration for L tets in lanes, from F's entries Fl[i][j]
/// (lane l = tet l; F_of_lane(l) the same F as a matrix, read by a lane that takes the SVD start)
/// and the warm starts warm_starts[l] (a lane taking the SVD start writes its start into q[l]; q may
/// be warm_starts; session 17: the pass's kernel reads the warm starts from one array and writes
/// another, without a copy first): leaves each lane's unnormalised
/// quaternion in qx, qy, qz, qw and its update count in count (session 14: shared by
/// extract_rotations_lanes and the exact query's kernel, which computes F in the lanes itself).
template <int L, class FOfLane>
inline void iterate_rotation_lanes(const typename LaneTypes<L>::Lanes (&Fl)[3][3], FOfLane F_of_lane,
                                   const Quat* warm_starts, Quat* q, int max_iterations, double tolerance, typename LaneTypes<L>::Lanes& qx,
                                   typename LaneTypes<L>::Lanes& qy, typename LaneTypes<L>::Lanes& qz,
                                   typename LaneTypes<L>::Lanes& qw, typename LaneTypes<L>::Lanes& count) {
  using Lanes = typename LaneTypes<L>::Lanes;
  using Mask = typename LaneTypes<L>::Mask;
  Lanes G[3][3];  // G(i, j) per lane
  LaneTypes<L>::load_quaternions(warm_starts, qx, qy, qz, qw);
  // rotation_iteration_start in the lanes: R = q.toRotationMatrix() (Eigen's expressions), G = R^T F.
  {
    const Lanes tx = 2.0 * qx, ty = 2.0 * qy, tz = 2.0 * qz;
    const Lanes twx = tx * qw, twy = ty * qw, twz = tz * qw;
    const Lanes txx = tx * qx, txy = ty * qx, txz = tz * qx;
    const Lanes tyy = ty * qy, tyz = tz * qy, tzz = tz * qz;
    const Lanes R[3][3] = {{1.0 - (tyy + tzz), txy - twz, txz + twy},
                           {txy + twz, 1.0 - (txx + tzz), tyz - twx},
                           {txz - twy, tyz + twx, 1.0 - (txx + tyy)}};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) G[i][j] = (R[0][i] * Fl[0][j] + R[1][i] * Fl[1][j]) + R[2][i] * Fl[2][j];
    }
  }
  // Comparisons and selects through LaneTypes<L> (GCC's vector operators for 2 and 4 lanes; for 8,
  // functions compiled for AVX-512 and inlined into the 8-lane kernel, see LaneTypes<8>).
  using Ops = LaneTypes<L>;
  const Lanes zero = {}, one = zero + 1.0;
  const Mask all_lanes = Ops::less(zero, one), no_lanes = {};
  // A warm start facing away (the SVD start) is rare: that lane runs the scalar start again (the
  // lanes' trace is the scalar's a + (b + c), so the same lanes are found).
  const Mask facing_away = Ops::less_equal(G[0][0] + (G[1][1] + G[2][2]), zero);
  if (any<L>(facing_away)) {
    for (int l = 0; l < L; ++l) {
      if (facing_away[l] == 0 || !F_of_lane(l).allFinite()) continue;
      q[l] = warm_starts[l];  // (the same quaternion where the caller passes q twice)
      const Mat3 start = rotation_iteration_start(F_of_lane(l), q[l]);
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) G[i][j][l] = start(i, j);
      }
      qx[l] = q[l].x();
      qy[l] = q[l].y();
      qz[l] = q[l].z();
      qw[l] = q[l].w();
    }
  }
  const double tolerance_sq = tolerance * tolerance;
  const Lanes tolerance_sq_lanes = zero + tolerance_sq;
  Mask active = all_lanes;
  count = zero;
  for (int it = 0; it < max_iterations; ++it) {  // (every lane active at it = 0; the break below after)
    const Lanes g0 = G[2][1] - G[1][2], g1 = G[0][2] - G[2][0], g2 = G[1][0] - G[0][1];
    const Lanes tr = G[0][0] + (G[1][1] + G[2][2]);  // Eigen's unrolled trace: a + (b + c)
    const Lanes denom = Ops::select(Ops::less(tr, zero), -tr, tr) + 1e-9;
    const Lanes h00 = tr - G[0][0], h11 = tr - G[1][1], h22 = tr - G[2][2];
    const Lanes h01 = -0.5 * (G[0][1] + G[1][0]), h02 = -0.5 * (G[0][2] + G[2][0]), h12 = -0.5 * (G[1][2] + G[2][1]);
    const Lanes c00 = h11 * h22 - h12 * h12, c01 = h02 * h12 - h01 * h22, c02 = h01 * h12 - h02 * h11;
    const Lanes m2 = h00 * h11 - h01 * h01, det = (h00 * c00 + h01 * c01) + h02 * c02;
    const Lanes floor = 1e-3 * denom;
    const Mask positive_definite = Ops::less(floor, h00) & Ops::less(floor * floor, m2) &
                                   Ops::less(floor * floor * floor, det);
    const Lanes c11 = h00 * h22 - h02 * h02, c12 = h02 * h01 - h00 * h12;
    // Lanes the scalar would not compute something for get harmless inputs (0, or 1 for a
    // divisor) instead: with FP traps on, the batch must not overflow where the scalar does not.
    const Lanes inv_det = 1.0 / Ops::select(positive_definite, det, one);
    const Lanes p0 = Ops::select(positive_definite, g0, zero), p1 = Ops::select(positive_definite, g1, zero),
                p2 = Ops::select(positive_definite, g2, zero);
    const Lanes n0 = inv_det * ((c00 * p0 + c01 * p1) + c02 * p2);
    const Lanes n1 = inv_det * ((c01 * p0 + c11 * p1) + c12 * p2);
    const Lanes n2 = inv_det * ((c02 * p0 + c12 * p1) + m2 * p2);
    const Mask newton_step = positive_definite & Ops::less((n0 * n0 + n1 * n1) + n2 * n2, one);
    const Lanes t0 = Ops::select(newton_step, n0, g0 / denom), t1 = Ops::select(newton_step, n1, g1 / denom),
                t2 = Ops::select(newton_step, n2, g2 / denom);
    const Lanes angle_sq = (t0 * t0 + t1 * t1) + t2 * t2;
    // the scalar's converged break where angle_sq < tolerance_sq or NaN
    const Mask moves = active & Ops::less_equal(tolerance_sq_lanes, angle_sq);
    // q <- q * (u0, u1, u2, w), grouped as Eigen's SSE2 quaternion product (lanes that stay: by
    // (0, 0, 0, 2), discarded).
    const Lanes u0 = Ops::select(moves, t0, zero), u1 = Ops::select(moves, t1, zero), u2 = Ops::select(moves, t2, zero);
    const Lanes w = 2.0 + 0.5 * Ops::select(moves, angle_sq, zero);
    const Lanes nx = (qw * u0 + qy * u2) - (qz * u1 - qx * w);
    const Lanes ny = (qw * u1 + qy * w) + (qz * u0 - qx * u2);
    const Lanes nz = (qw * u2 - qy * u0) + (qz * w + qx * u1);
    const Lanes nw = (qw * w - qy * u1) - (qz * u2 + qx * u0);
    qx = Ops::select(moves, nx, qx);
    qy = Ops::select(moves, ny, qy);
    qz = Ops::select(moves, nz, qz);
    qw = Ops::select(moves, nw, qw);
    count = Ops::select(moves, count + 1.0, count);
    const Mask at_cap = it + 1 == max_iterations ? all_lanes : no_lanes;
    const Lanes newton_angle_sq = Ops::select(newton_step, angle_sq, zero);  // < 1 where the scalar squares it
    const Mask last = (newton_step & Ops::less(newton_angle_sq * newton_angle_sq, tolerance_sq_lanes)) | at_cap;
    active = moves & ~last;
    if (!any<L>(active)) break;
    // G <- n^2 Q^T G (extract_rotation's update) for the lanes that go on; the others by Q = 4 I
    // (u = 0, w = 2), discarded.
    const Lanes v0 = Ops::select(active, u0, zero), v1 = Ops::select(active, u1, zero),
                v2 = Ops::select(active, u2, zero);
    const Lanes wq = Ops::select(active, w, zero + 2.0), aq = Ops::select(active, angle_sq, zero);
    const Lanes d = wq * wq - aq;
    const Lanes Q[3][3] = {{d + 2.0 * v0 * v0, 2.0 * (v0 * v1 - wq * v2), 2.0 * (v0 * v2 + wq * v1)},
                           {2.0 * (v1 * v0 + wq * v2), d + 2.0 * v1 * v1, 2.0 * (v1 * v2 - wq * v0)},
                           {2.0 * (v2 * v0 - wq * v1), 2.0 * (v2 * v1 + wq * v0), d + 2.0 * v2 * v2}};
    Lanes next[3][3];
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) next[i][j] = (Q[0][i] * G[0][j] + Q[1][i] * G[1][j]) + Q[2][i] * G[2][j];
    }
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) G[i][j] = Ops::select(active, next[i][j], G[i][j]);
    }
  }
}

/// Eigen's (SSE2) Quaternion::normalize in lanes: n = (x^2 + z^2) + (y^2 + w^2), each coefficient
/// divided by sqrt(n) where n > 0 (sqrt and division are correctly rounded, so the same bits).
template <int L>
inline void normalise_quaternion_lanes(typename LaneTypes<L>::Lanes& qx, typename LaneTypes<L>::Lanes& qy,
                                       typename LaneTypes<L>::Lanes& qz, typename LaneTypes<L>::Lanes& qw) {
  using Lanes = typename LaneTypes<L>::Lanes;
  using Ops = LaneTypes<L>;
  const Lanes n = (qx * qx + qz * qz) + (qy * qy + qw * qw), zero = {};
  const typename Ops::Mask positive = Ops::less(zero, n);
  Lanes s;  // sqrt(n) where n > 0 (1 elsewhere, unused)
  Ops::square_root_where_positive(n, s);
  qx = Ops::select(positive, qx / s, qx);
  qy = Ops::select(positive, qy / s, qy);
  qz = Ops::select(positive, qz / s, qz);
  qw = Ops::select(positive, qw / s, qw);
}

/// Rl[i][j] = R(i, j) of q.toRotationMatrix() per lane (Eigen's expressions) for a unit q.
template <int L>
inline void rotation_matrix_lanes(const typename LaneTypes<L>::Lanes& qx, const typename LaneTypes<L>::Lanes& qy,
                                  const typename LaneTypes<L>::Lanes& qz, const typename LaneTypes<L>::Lanes& qw,
                                  typename LaneTypes<L>::Lanes (&Rl)[3][3]) {
  using Lanes = typename LaneTypes<L>::Lanes;
  const Lanes tx = 2.0 * qx, ty = 2.0 * qy, tz = 2.0 * qz;
  const Lanes twx = tx * qw, twy = ty * qw, twz = tz * qw;
  const Lanes txx = tx * qx, txy = ty * qx, txz = tz * qx;
  const Lanes tyy = ty * qy, tyz = tz * qy, tzz = tz * qz;
  Rl[0][0] = 1.0 - (tyy + tzz), Rl[0][1] = txy - twz, Rl[0][2] = txz + twy;
  Rl[1][0] = txy + twz, Rl[1][1] = 1.0 - (txx + tzz), Rl[1][2] = tyz - twx;
  Rl[2][0] = txz - twy, Rl[2][1] = tyz + twx, Rl[2][2] = 1.0 - (txx + tyy);
}
}  // namespace rotation_batch_detail

/// extract_rotation for L tets at once (F[l], warm starts q[l], or warm_starts[l] where given, the
/// results into q[l]), bit for bit the scalar's result per lane; iterations[l] (optional) receives each lane's count, and rotation_matrices[l] (optional) the rotation
/// matrix q[l].toRotationMatrix(), bit for bit. L = 4 wants AVX registers (see
/// extract_rotations_batch_avx2 in sim/model/rotation_batch_avx2.h for the run-time choice).
template <int L>
inline void extract_rotations_lanes(const Mat3* F, Quat* q, int max_iterations, double tolerance,
                                    int* iterations = nullptr, Mat3* rotation_matrices = nullptr,
                                    const Quat* warm_starts = nullptr) {
  using Lanes = typename rotation_batch_detail::LaneTypes<L>::Lanes;
  Lanes Fl[3][3];  // F(i, j) per lane
  rotation_batch_detail::LaneTypes<L>::load_matrices(F, Fl);
  Lanes qx, qy, qz, qw, count;
  // The warm starts from their own array where given (session 18: the 4-lane pass of an energy query
  // no longer copies them into q first), else from q.
  rotation_batch_detail::iterate_rotation_lanes<L>(Fl, [&](int l) -> const Mat3& { return F[l]; },
                                                   warm_starts != nullptr ? warm_starts : q, q, max_iterations,
                                                   tolerance, qx, qy, qz, qw, count);
  if (L >= 4 || rotation_matrices != nullptr) {
    // Session 13: the normalisation in the lanes (the per-lane normalisation was ~23 instructions
    // per tet), and for the local queries' stress the rotation matrix too (its own
    // toRotationMatrix per tet was ~30).
    rotation_batch_detail::normalise_quaternion_lanes<L>(qx, qy, qz, qw);
    const auto rotation_entries = [&](Lanes (&Rl)[3][3]) {
      rotation_batch_detail::rotation_matrix_lanes<L>(qx, qy, qz, qw, Rl);
    };
    if constexpr (L == 4) {
      // Out of the lanes by 4x4 transposes: q's coefficients (x, y, z, w) and R's column-major
      // entries 0-3 and 4-7 are one 32-byte store per tet (lane by lane: ~4x the instructions).
      using Index = typename rotation_batch_detail::LaneTypes<L>::Mask;
      const auto transpose_store = [](const Lanes& a, const Lanes& b, const Lanes& c, const Lanes& d, auto out_of_lane) {
        const Index low = {0, 4, 2, 6}, high = {1, 5, 3, 7}, front = {0, 1, 4, 5}, back = {2, 3, 6, 7};
        const Lanes t0 = __builtin_shuffle(a, b, low), t1 = __builtin_shuffle(a, b, high);
        const Lanes t2 = __builtin_shuffle(c, d, low), t3 = __builtin_shuffle(c, d, high);
        const Lanes r0 = __builtin_shuffle(t0, t2, front), r1 = __builtin_shuffle(t1, t3, front);
        const Lanes r2 = __builtin_shuffle(t0, t2, back), r3 = __builtin_shuffle(t1, t3, back);
        std::memcpy(out_of_lane(0), &r0, sizeof(Lanes));  // spelled out: a loop over an array of
        std::memcpy(out_of_lane(1), &r1, sizeof(Lanes));  // the four went through the stack
        std::memcpy(out_of_lane(2), &r2, sizeof(Lanes));
        std::memcpy(out_of_lane(3), &r3, sizeof(Lanes));
      };
      transpose_store(qx, qy, qz, qw, [&](int l) { return q[l].coeffs().data(); });
      if (rotation_matrices != nullptr) {
        Lanes Rl[3][3];
        rotation_entries(Rl);
        transpose_store(Rl[0][0], Rl[1][0], Rl[2][0], Rl[0][1], [&](int l) { return rotation_matrices[l].data(); });
        transpose_store(Rl[1][1], Rl[2][1], Rl[0][2], Rl[1][2], [&](int l) { return rotation_matrices[l].data() + 4; });
        double last_entries[L];  // R(2, 2) of each lane, one vector store and four scalar copies
        std::memcpy(last_entries, &Rl[2][2], sizeof(Lanes));
        for (int l = 0; l < L; ++l) rotation_matrices[l](2, 2) = last_entries[l];
      }
    } else if constexpr (L == 8) {
      // Session 17: q out of the lanes by permutes, one 64-byte store per two quaternions
      // (LaneTypes<8>, rotation_batch_avx512.cpp); R (the local queries', not asked for here) lane by lane.
      rotation_batch_detail::LaneTypes<L>::store_quaternions(qx, qy, qz, qw, q);
      if (rotation_matrices != nullptr) {
        Lanes Rl[3][3];
        rotation_entries(Rl);
        for (int l = 0; l < L; ++l) {
          for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) rotation_matrices[l](i, j) = Rl[i][j][l];
          }
        }
      }
    } else {
      Lanes Rl[3][3];
      rotation_entries(Rl);
      for (int l = 0; l < L; ++l) {
        q[l] = Quat(qw[l], qx[l], qy[l], qz[l]);
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) rotation_matrices[l](i, j) = Rl[i][j][l];
        }
      }
    }
    for (int l = 0; l < L && iterations != nullptr; ++l) iterations[l] = static_cast<int>(count[l]);
    return;
  }
  for (int l = 0; l < L; ++l) {
    q[l] = Quat(qw[l], qx[l], qy[l], qz[l]);
    q[l].normalize();
    if (iterations != nullptr) iterations[l] = static_cast<int>(count[l]);
  }
}

/// extract_rotation for kRotationBatchLanes tets at once (F[l], warm starts q[l]), bit for bit the
/// scalar's result per lane; iterations[l] (optional) receives each lane's count.
inline void extract_rotations_batch(const Mat3* F, Quat* q, int max_iterations, double tolerance,
                                    int* iterations = nullptr) {
  extract_rotations_lanes<kRotationBatchLanes>(F, q, max_iterations, tolerance, iterations);
}

}  // namespace pliant
