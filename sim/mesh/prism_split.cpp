#include "sim/mesh/prism_split.h"

#include <algorithm>
#include <utility>

namespace pliant {

void orient_tet_positively(TetIndices& tet, const std::vector<Vec3>& x) {
  const double v = signed_tet_volume(x[static_cast<size_t>(tet[0])], x[static_cast<size_t>(tet[1])],
                                     x[static_cast<size_t>(tet[2])], x[static_cast<size_t>(tet[3])]);
  if (v < 0.0) std::swap(tet[2], tet[3]);
}

void split_prism(const std::array<int, 6>& v, const std::vector<Vec3>& x, std::vector<TetIndices>& tets) {
  // Relabel so the smallest global index sits at local vertex 0 (a rotation, or a reflection that
  // swaps bottom and top), keeping "local i + 3 above local i".
  constexpr int kRelabel[6][6] = {{0, 1, 2, 3, 4, 5}, {1, 2, 0, 4, 5, 3}, {2, 0, 1, 5, 3, 4},
                                  {3, 5, 4, 0, 2, 1}, {4, 3, 5, 1, 0, 2}, {5, 4, 3, 2, 1, 0}};
  const auto m = static_cast<size_t>(std::min_element(v.begin(), v.end()) - v.begin());
  int p[6];
  for (size_t k = 0; k < 6; ++k) p[k] = v[static_cast<size_t>(kRelabel[m][k])];
  // The quad (1, 2, 5, 4) opposite vertex 0 takes the diagonal through its smallest index.
  TetIndices t[3];
  if (std::min(p[1], p[5]) < std::min(p[2], p[4])) {
    t[0] = {p[0], p[1], p[2], p[5]};
    t[1] = {p[0], p[1], p[5], p[4]};
    t[2] = {p[0], p[4], p[5], p[3]};
  } else {
    t[0] = {p[0], p[1], p[2], p[4]};
    t[1] = {p[0], p[4], p[2], p[5]};
    t[2] = {p[0], p[4], p[5], p[3]};
  }
  for (auto& tet : t) {
    orient_tet_positively(tet, x);
    tets.push_back(tet);
  }
}

}  // namespace pliant
