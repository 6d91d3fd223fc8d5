// The coarse (two-level) correction of the implicit step's SSOR-PCG, as deflation (session 13;
// docs/deformation-models.md "Session 13"). Design note:
// - Why: a new contact is a local load whose answer is global (the whole tissue moves). SSOR's
//   sweeps move information a few vertices per iteration, so the CG needs several iterations to
//   carry it across the body (the probe's 9-10-iteration bursts, docs/interaction.md "Session 12").
//   A coarse space that holds the body's smooth motions solves that part directly.
// - Coarse space: the free vertices grouped into aggregates by geometric boxes of their rest
//   positions (about `aggregate_size` vertices each, from the mesh alone); Z holds each
//   aggregate's three rigid translations (Z_{i,(I,d)} = e_d where vertex i is in aggregate I).
//   E = Z^T A Z (the Galerkin matrix, 3 x aggregates square) is assembled from the sweeps' blocks
//   every step and factorised by dense Cholesky.
// - Combination: deflated CG (Saad, Yeung, Erhel, Guyomarc'h, SIAM J. Sci. Comput. 21, 2000) with
//   the SSOR preconditioner, not a multiplicative pre-sweep/coarse/post-sweep preconditioner: the
//   multiplicative form needs two more products with A per iteration (~3x an Eisenstat iteration),
//   deflation needs only sparse products with the precomputed A Z. The start is corrected so that
//   Z^T r = 0, and every search direction is made A-orthogonal to Z (p -= Z E^-1 (AZ)^T p); r then
//   stays orthogonal to Z and CG runs on the complement of the coarse space. In Eisenstat's form the
//   iteration carries p^ = (D + L^T) p beside p, so p^ is corrected by W = (D + L^T) Z (also sparse).
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <span>
#include <vector>

#include "sim/math_types.h"

namespace pliant {

/// The block system of the SSOR sweeps, A = D + L + L^T (corotational_fem.cpp, SsorSweeps): D_i the
/// 3x3 diagonal blocks, L_ji = s K'_ij^T for the stored upper blocks of K' (j > i). Fixed vertices'
/// rows and columns are not part of A (the vectors are zero there).
struct BlockSystemView {
  const double* blocks = nullptr;  ///< K' upper-triangle blocks, column-major 3x3 (row i's first is K'_ii)
  const int* cols = nullptr;       ///< block column (vertex) index
  const int* offsets = nullptr;    ///< row i: blocks [offsets[i], offsets[i + 1])
  const Mat3* D = nullptr;         ///< diagonal blocks of A
  const char* fixed = nullptr;     ///< 1 where a vertex is held
  double s = 0.0;                  ///< h (beta + h): the factor of K' in A
  size_t n = 0;                    ///< vertices
};

/// Aggregates, the Galerkin matrix and the deflation operators of the coarse correction.
class CoarseSpace {
 public:
  /// Groups the free vertices (fixed[i] == 0) into boxes of about aggregate_size rest positions;
  /// forgets any assembled operator. aggregate_size >= 1.
  void build_aggregates(std::span<const Vec3> rest, std::span<const char> fixed, int aggregate_size);
  /// True when the aggregates were built for this fixed set and aggregate size.
  bool built_for(std::span<const char> fixed, int aggregate_size) const;
  /// Aggregate of each vertex (-1: fixed).
  std::span<const int> aggregate_of() const { return aggregate_; }
  /// Number of aggregates.
  int aggregate_count() const { return aggregates_; }
  /// out_i = c_(aggregate of i) (the prolongation Z c; zero at fixed vertices); c has 3 per aggregate.
  void prolong(std::span<const double> c, std::span<Vec3> out) const;
  /// Assembles A Z, W = (D + L^T) Z and E = Z^T A Z from `sys` and factorises E; false (and the
  /// correction unusable) if E is not positive definite.
  bool assemble(const BlockSystemView& sys);
  /// The Galerkin matrix E = Z^T A Z of the last assemble.
  const Eigen::MatrixXd& galerkin_matrix() const { return galerkin_; }
  /// Corrects a start so the residual is orthogonal to Z: dv += Z l, r -= A Z l, E l = Z^T r.
  void correct_start(std::span<Vec3> dv, std::span<Vec3> r);
  /// Makes a direction A-orthogonal to Z: m = E^-1 (A Z)^T p, p -= Z m and p^ -= W m (so that
  /// p^ = (D + L^T) p still holds).
  void project_direction(std::span<Vec3> p, std::span<Vec3> p_hat);
  /// (A Z)^T y (3 per aggregate), from the assembled sparse A Z.
  void restrict_product(std::span<const Vec3> y, Eigen::VectorXd& out) const;

 private:
  /// Per-row lists of the aggregates a row of A Z touches, and each stored block's slots in them.
  void build_pattern(const BlockSystemView& sys);

  std::vector<int> aggregate_;      ///< per vertex, -1 where fixed
  std::vector<char> fixed_;         ///< the fixed set the aggregates were built for
  int aggregate_size_ = 0;
  int aggregates_ = 0;
  bool pattern_built_ = false;
  std::vector<int> row_offsets_;    ///< row i's slots: [row_offsets_[i], row_offsets_[i + 1])
  std::vector<int> slot_aggregate_;  ///< per slot, its aggregate
  std::vector<int> diagonal_slot_;  ///< per vertex, the slot of its own aggregate (-1: fixed)
  std::vector<int> upper_slot_;     ///< per stored block (i, j): slot of aggregate(j) in row i (-1: none)
  std::vector<int> lower_slot_;     ///< per stored block (i, j): slot of aggregate(i) in row j (-1: none)
  std::vector<Mat3> az_;            ///< per slot: (A Z)_(i, I), the sum of A_ij over j in I
  std::vector<Mat3> w_;             ///< per slot: ((D + L^T) Z)_(i, I)
  Eigen::MatrixXd galerkin_;
  Eigen::LLT<Eigen::MatrixXd> factor_;
  Eigen::VectorXd coarse_;          ///< scratch, 3 per aggregate
};

}  // namespace pliant
