// Which bodies' bounds overlap: the body-level broad phase in front of the spatial hash (session 17,
// issue #4).
//
// Design note. The spatial hash asks, per body, for the bodies whose bounds overlap its own (pass 1:
// where a vertex can be inside a partner; pass 2: whose vertices can be inside its tets). Asked of
// every other body, that is B^2 box tests per detect: at 521 bodies (200k tets) about a tenth of the
// hash's instructions, and the part that made detection super-linear in the number of bodies.
// Here the boxes go into a uniform grid whose cell is the median of the boxes' largest extents, so
// a typical box covers at most 2 x 2 x 2 cells; the grid is a sorted list of (cell, box) entries (no
// hash table to size or clear), and two boxes are compared only when they share a cell. A pair is
// reported in one cell only, the one holding the lowest corner of the two boxes' intersection
// (both boxes cover it, because the cell coordinate is monotone). Boxes covering more than
// kMaxCellsPerBox cells (a dish under many fruits, a stretched or non-finite box) are compared with
// every box instead; few boxes (up to kBruteForceBoxes) are compared pair by pair. The result is
// exactly the pairs that Aabb::overlaps accepts, each body's list in ascending order (tested against
// the all-pairs loop).
#pragma once

#include <span>
#include <vector>

#include "sim/math_types.h"

namespace pliant {

class BoundsOverlap {
 public:
  /// Box counts up to this are compared pair by pair (the grid's sort costs more than it saves).
  static constexpr int kBruteForceBoxes = 32;
  /// A box covering more cells than this is compared with every box instead of entering the grid.
  static constexpr double kMaxCellsPerBox = 64.0;

  /// Finds every pair i != j of boxes with include[i], include[j], neither empty, that overlap
  /// (closed: Aabb::overlaps). boxes and include have one entry per body.
  void compute(std::span<const Aabb> boxes, std::span<const char> include);

  /// The bodies whose boxes overlap body i's, ascending (i itself is never listed).
  std::span<const int> overlapping(int i) const {
    const auto k = static_cast<size_t>(i);
    return {partners_.data() + offsets_[k], static_cast<size_t>(offsets_[k + 1] - offsets_[k])};
  }

  /// Box pairs compared by the last compute (for tests and benchmarks).
  long long pairs_tested() const { return pairs_tested_; }

 private:
  struct CellEntry {
    int cell[3];
    int box;
  };
  struct Pair {
    int a;
    int b;
  };

  std::vector<int> participating_;  ///< included, non-empty boxes
  std::vector<int> large_;          ///< participating boxes compared with all others
  std::vector<CellEntry> entries_;  ///< (cell, box) of every grid box, sorted by cell
  std::vector<double> extents_;     ///< scratch: largest extent per participating box
  std::vector<Pair> pairs_;         ///< both orders of every overlapping pair
  std::vector<int> offsets_;        ///< per body: its partners are partners_[offsets_[i], offsets_[i + 1])
  std::vector<int> partners_;
  long long pairs_tested_ = 0;

  void add_pair(int a, int b) {
    pairs_.push_back(Pair{a, b});
    pairs_.push_back(Pair{b, a});
  }
};

}  // namespace pliant
