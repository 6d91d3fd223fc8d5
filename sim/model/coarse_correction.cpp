#include "sim/model/coarse_correction.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace pliant {

// Boxes of equal size over the free vertices' bounding box, as near cubes as the extents allow,
// their number chosen so that a box holds about aggregate_size vertices; empty boxes are dropped.
void CoarseSpace::build_aggregates(std::span<const Vec3> rest, std::span<const char> fixed, int aggregate_size) {
  assert(aggregate_size >= 1 && rest.size() == fixed.size());
  const size_t n = rest.size();
  fixed_.assign(fixed.begin(), fixed.end());
  aggregate_size_ = aggregate_size;
  pattern_built_ = false;
  Aabb box;
  size_t free_count = 0;
  for (size_t i = 0; i < n; ++i) {
    if (fixed[i] != 0) continue;
    box.extend(rest[i]);
    ++free_count;
  }
  aggregate_.assign(n, -1);
  aggregates_ = 0;
  if (free_count == 0) return;
  const double wanted = std::max(1.0, std::round(static_cast<double>(free_count) / aggregate_size));
  // Cell side c with prod(extent_k / c) = wanted over the axes that have an extent.
  const Vec3 extent = box.extent();
  double volume = 1.0;
  int axes = 0;
  for (int k = 0; k < 3; ++k) {
    if (extent[k] > 0.0) {
      volume *= extent[k];
      ++axes;
    }
  }
  std::array<int, 3> cells{1, 1, 1};
  if (axes > 0) {
    const double side = std::pow(volume / wanted, 1.0 / axes);
    for (int k = 0; k < 3; ++k) {
      if (extent[k] > 0.0) cells[k] = std::max(1, static_cast<int>(std::lround(extent[k] / side)));
    }
  }
  const auto cell_of = [&](const Vec3& p) {
    int index = 0;
    for (int k = 2; k >= 0; --k) {
      int c = extent[k] > 0.0 ? static_cast<int>((p[k] - box.min[k]) / extent[k] * cells[k]) : 0;
      c = std::clamp(c, 0, cells[k] - 1);
      index = index * cells[k] + c;
    }
    return index;
  };
  std::vector<int> id(static_cast<size_t>(cells[0]) * cells[1] * cells[2], -1);
  for (size_t i = 0; i < n; ++i) {
    if (fixed[i] != 0) continue;
    int& a = id[static_cast<size_t>(cell_of(rest[i]))];
    if (a < 0) a = aggregates_++;
    aggregate_[i] = a;
  }
}

bool CoarseSpace::built_for(std::span<const char> fixed, int aggregate_size) const {
  return aggregate_size == aggregate_size_ && fixed.size() == fixed_.size() &&
         std::equal(fixed.begin(), fixed.end(), fixed_.begin());
}

void CoarseSpace::prolong(std::span<const double> c, std::span<Vec3> out) const {
  for (size_t i = 0; i < out.size(); ++i) {
    const int a = aggregate_[i];
    out[i] = a < 0 ? Vec3::Zero() : Vec3(c[3 * a], c[3 * a + 1], c[3 * a + 2]);
  }
}

void CoarseSpace::build_pattern(const BlockSystemView& sys) {
  const size_t n = sys.n;
  const auto total_blocks = static_cast<size_t>(sys.offsets[n]);
  // Row i of A Z touches its own aggregate and those of its free neighbours (either triangle).
  std::vector<std::vector<int>> touched(n);
  for (size_t i = 0; i < n; ++i) {
    if (aggregate_[i] < 0) continue;
    touched[i].push_back(aggregate_[i]);
    for (auto b = static_cast<size_t>(sys.offsets[i]) + 1; b < static_cast<size_t>(sys.offsets[i + 1]); ++b) {
      const auto j = static_cast<size_t>(sys.cols[b]);
      if (aggregate_[j] < 0) continue;
      touched[i].push_back(aggregate_[j]);
      touched[j].push_back(aggregate_[i]);
    }
  }
  row_offsets_.assign(n + 1, 0);
  slot_aggregate_.clear();
  for (size_t i = 0; i < n; ++i) {
    auto& t = touched[i];
    std::sort(t.begin(), t.end());
    t.erase(std::unique(t.begin(), t.end()), t.end());
    slot_aggregate_.insert(slot_aggregate_.end(), t.begin(), t.end());
    row_offsets_[i + 1] = static_cast<int>(slot_aggregate_.size());
  }
  const auto slot = [&](size_t row, int aggregate) {
    const auto first = slot_aggregate_.begin() + row_offsets_[row], last = slot_aggregate_.begin() + row_offsets_[row + 1];
    return static_cast<int>(std::lower_bound(first, last, aggregate) - slot_aggregate_.begin());
  };
  diagonal_slot_.assign(n, -1);
  upper_slot_.assign(total_blocks, -1);
  lower_slot_.assign(total_blocks, -1);
  for (size_t i = 0; i < n; ++i) {
    if (aggregate_[i] < 0) continue;
    diagonal_slot_[i] = slot(i, aggregate_[i]);
    for (auto b = static_cast<size_t>(sys.offsets[i]) + 1; b < static_cast<size_t>(sys.offsets[i + 1]); ++b) {
      const auto j = static_cast<size_t>(sys.cols[b]);
      if (aggregate_[j] < 0) continue;
      upper_slot_[b] = slot(i, aggregate_[j]);
      lower_slot_[b] = slot(j, aggregate_[i]);
    }
  }
  az_.assign(slot_aggregate_.size(), Mat3::Zero());
  w_.assign(slot_aggregate_.size(), Mat3::Zero());
  pattern_built_ = true;
}

bool CoarseSpace::assemble(const BlockSystemView& sys) {
  assert(sys.n == aggregate_.size());
  if (aggregates_ == 0) return false;
  if (!pattern_built_) build_pattern(sys);
  std::fill(az_.begin(), az_.end(), Mat3::Zero());
  std::fill(w_.begin(), w_.end(), Mat3::Zero());
  // (A Z)_(i, I) = sum over j in I of A_ij; W takes D and the upper blocks only.
  for (size_t i = 0; i < sys.n; ++i) {
    if (aggregate_[i] < 0) continue;
    const auto d = static_cast<size_t>(diagonal_slot_[i]);
    az_[d] += sys.D[i];
    w_[d] += sys.D[i];
    for (auto b = static_cast<size_t>(sys.offsets[i]) + 1; b < static_cast<size_t>(sys.offsets[i + 1]); ++b) {
      if (upper_slot_[b] < 0) continue;
      const Mat3 block = sys.s * Eigen::Map<const Mat3>(sys.blocks + 9 * b);
      az_[static_cast<size_t>(upper_slot_[b])] += block;
      w_[static_cast<size_t>(upper_slot_[b])] += block;
      az_[static_cast<size_t>(lower_slot_[b])] += block.transpose();
    }
  }
  // E_(I, J) = sum over i in I of (A Z)_(i, J).
  const int m = 3 * aggregates_;
  galerkin_.setZero(m, m);
  for (size_t i = 0; i < sys.n; ++i) {
    const int a = aggregate_[i];
    if (a < 0) continue;
    for (int k = row_offsets_[i]; k < row_offsets_[i + 1]; ++k) {
      galerkin_.block<3, 3>(3 * a, 3 * slot_aggregate_[static_cast<size_t>(k)]) += az_[static_cast<size_t>(k)];
    }
  }
  // Symmetric in exact arithmetic; the two triangles differ by round-off only (in place: no
  // temporary, no allocation per step).
  for (int r = 0; r < m; ++r) {
    for (int c = r + 1; c < m; ++c) galerkin_(r, c) = galerkin_(c, r) = 0.5 * (galerkin_(r, c) + galerkin_(c, r));
  }
  factor_.compute(galerkin_);
  coarse_.resize(m);
  return factor_.info() == Eigen::Success;
}

void CoarseSpace::restrict_product(std::span<const Vec3> y, Eigen::VectorXd& out) const {
  out.setZero(3 * aggregates_);
  for (size_t i = 0; i < y.size(); ++i) {
    for (int k = row_offsets_[i]; k < row_offsets_[i + 1]; ++k) {
      out.segment<3>(3 * slot_aggregate_[static_cast<size_t>(k)]) += az_[static_cast<size_t>(k)].transpose() * y[i];
    }
  }
}

void CoarseSpace::correct_start(std::span<Vec3> dv, std::span<Vec3> r) {
  coarse_.setZero(3 * aggregates_);
  for (size_t i = 0; i < r.size(); ++i) {
    if (aggregate_[i] >= 0) coarse_.segment<3>(3 * aggregate_[i]) += r[i];
  }
  factor_.solveInPlace(coarse_);
  for (size_t i = 0; i < r.size(); ++i) {
    if (aggregate_[i] < 0) continue;
    dv[i] += coarse_.segment<3>(3 * aggregate_[i]);
    for (int k = row_offsets_[i]; k < row_offsets_[i + 1]; ++k) {
      r[i] -= az_[static_cast<size_t>(k)] * coarse_.segment<3>(3 * slot_aggregate_[static_cast<size_t>(k)]);
    }
  }
}

void CoarseSpace::project_direction(std::span<Vec3> p, std::span<Vec3> p_hat) {
  restrict_product(p, coarse_);
  factor_.solveInPlace(coarse_);
  for (size_t i = 0; i < p.size(); ++i) {
    if (aggregate_[i] < 0) continue;
    p[i] -= coarse_.segment<3>(3 * aggregate_[i]);
    Vec3 correction = Vec3::Zero();
    for (int k = row_offsets_[i]; k < row_offsets_[i + 1]; ++k) {
      correction += w_[static_cast<size_t>(k)] * coarse_.segment<3>(3 * slot_aggregate_[static_cast<size_t>(k)]);
    }
    p_hat[i] -= correction;
  }
}

}  // namespace pliant
