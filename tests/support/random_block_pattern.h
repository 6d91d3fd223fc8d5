// Random upper-triangle 3x3-block sparsity patterns and block entries for the tests of the block
// kernels (the stiffness products, the SSOR sweeps): the layout of CorotationalFem's K' rows, drawn
// at random.
#pragma once

#include <cstddef>
#include <random>
#include <vector>

namespace pliant {

/// Compressed block rows: row i's blocks are cols[offsets[i]] .. cols[offsets[i + 1] - 1], the
/// diagonal block first, then columns j > i ascending.
struct UpperBlockPattern {
  std::vector<int> offsets{0};
  std::vector<int> cols;
};

/// n rows; each column j > i joins row i when pick(rng) < 5 (one draw per pair, rows ascending, so a
/// test's later draws follow the same sequence as before this helper): some rows have no upper
/// block, the last row never.
template <class Rng>
UpperBlockPattern random_upper_block_pattern(size_t n, Rng& rng, std::uniform_int_distribution<int>& pick) {
  UpperBlockPattern p;
  for (size_t i = 0; i < n; ++i) {
    p.cols.push_back(static_cast<int>(i));
    for (size_t j = i + 1; j < n; ++j) {
      if (pick(rng) < 5) p.cols.push_back(static_cast<int>(j));
    }
    p.offsets.push_back(static_cast<int>(p.cols.size()));
  }
  return p;
}

/// A block entry for the kernels' bit-for-bit tests, by one draw of pick (0..15): +0, -0, big u,
/// small u or u (u uniform on [-1, 1), one more draw): exact zeros of both signs and mixed magnitudes.
template <class Rng>
double random_block_entry(Rng& rng, std::uniform_int_distribution<int>& pick, std::uniform_real_distribution<double>& unit,
                          double big, double small) {
  switch (pick(rng)) {
    case 0: return 0.0;
    case 1: return -0.0;
    case 2: return big * unit(rng);
    case 3: return small * unit(rng);
    default: return unit(rng);
  }
}

}  // namespace pliant
