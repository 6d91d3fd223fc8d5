#include "sim/collision/bounds_overlap.h"

#include <algorithm>
#include <cmath>

#include "sim/collision/cell_coordinate.h"

namespace pliant {
namespace {

bool same_cell(const int* a, const int* b) { return a[0] == b[0] && a[1] == b[1] && a[2] == b[2]; }

}  // namespace

void BoundsOverlap::compute(std::span<const Aabb> boxes, std::span<const char> include) {
  const size_t n = boxes.size();
  participating_.clear();
  large_.clear();
  entries_.clear();
  pairs_.clear();
  pairs_tested_ = 0;
  for (size_t i = 0; i < n; ++i) {
    if (include[i] && !boxes[i].empty()) participating_.push_back(static_cast<int>(i));
  }
  auto test = [&](int a, int b) {
    ++pairs_tested_;
    if (boxes[static_cast<size_t>(a)].overlaps(boxes[static_cast<size_t>(b)])) add_pair(a, b);
  };

  // Cell size: the median of the boxes' largest extents.
  double h = 0.0;
  if (participating_.size() > static_cast<size_t>(kBruteForceBoxes)) {
    extents_.clear();
    for (int i : participating_) extents_.push_back(boxes[static_cast<size_t>(i)].extent().maxCoeff());
    const auto middle = extents_.begin() + static_cast<std::ptrdiff_t>(extents_.size() / 2);
    std::nth_element(extents_.begin(), middle, extents_.end());
    h = *middle;
  }
  if (!(h > 0.0) || !std::isfinite(h)) {
    // Few boxes, or no usable cell size (most boxes are points): every pair.
    for (size_t p = 0; p < participating_.size(); ++p) {
      for (size_t q = p + 1; q < participating_.size(); ++q) test(participating_[p], participating_[q]);
    }
  } else {
    const double inv_h = 1.0 / h;
    for (int i : participating_) {
      const Aabb& box = boxes[static_cast<size_t>(i)];
      int lo[3], hi[3];
      double cells = 1.0;
      for (int k = 0; k < 3; ++k) {
        lo[k] = cell_coordinate(box.min[k], inv_h);
        hi[k] = cell_coordinate(box.max[k], inv_h);
        cells *= static_cast<double>(hi[k]) - lo[k] + 1.0;
      }
      if (!(cells <= kMaxCellsPerBox)) {
        large_.push_back(i);
        continue;
      }
      for (int x = lo[0]; x <= hi[0]; ++x) {
        for (int y = lo[1]; y <= hi[1]; ++y) {
          for (int z = lo[2]; z <= hi[2]; ++z) entries_.push_back(CellEntry{{x, y, z}, i});
        }
      }
    }
    std::sort(entries_.begin(), entries_.end(), [](const CellEntry& a, const CellEntry& b) {
      if (a.cell[0] != b.cell[0]) return a.cell[0] < b.cell[0];
      if (a.cell[1] != b.cell[1]) return a.cell[1] < b.cell[1];
      if (a.cell[2] != b.cell[2]) return a.cell[2] < b.cell[2];
      return a.box < b.box;
    });
    // Pairs sharing a cell, each reported in the cell of the lowest corner of their intersection.
    for (size_t begin = 0; begin < entries_.size();) {
      size_t end = begin + 1;
      while (end < entries_.size() && same_cell(entries_[end].cell, entries_[begin].cell)) ++end;
      for (size_t p = begin; p < end; ++p) {
        const Aabb& a = boxes[static_cast<size_t>(entries_[p].box)];
        for (size_t q = p + 1; q < end; ++q) {
          const Aabb& b = boxes[static_cast<size_t>(entries_[q].box)];
          ++pairs_tested_;
          if (!a.overlaps(b)) continue;
          const Vec3 corner = a.min.cwiseMax(b.min);
          const int home[3] = {cell_coordinate(corner.x(), inv_h), cell_coordinate(corner.y(), inv_h),
                               cell_coordinate(corner.z(), inv_h)};
          if (same_cell(home, entries_[begin].cell)) add_pair(entries_[p].box, entries_[q].box);
        }
      }
      begin = end;
    }
    // Large boxes against every participating box (a pair of two large boxes once).
    for (size_t g = 0; g < large_.size(); ++g) {
      for (int j : participating_) {
        if (j == large_[g]) continue;
        const bool j_large = std::binary_search(large_.begin(), large_.end(), j);
        if (j_large && j < large_[g]) continue;
        test(large_[g], j);
      }
    }
  }

  // Per body, its partners in ascending order.
  std::sort(pairs_.begin(), pairs_.end(), [](const Pair& p, const Pair& q) { return p.a != q.a ? p.a < q.a : p.b < q.b; });
  offsets_.assign(n + 1, 0);
  partners_.resize(pairs_.size());
  for (const Pair& p : pairs_) ++offsets_[static_cast<size_t>(p.a) + 1];
  for (size_t i = 0; i < n; ++i) offsets_[i + 1] += offsets_[i];
  for (size_t k = 0; k < pairs_.size(); ++k) partners_[k] = pairs_[k].b;
}

}  // namespace pliant
