// A 4-wide view of a binary bounding volume hierarchy for box queries: the fan query's traversal
// (session 10, issue #4).
//
// Design note. SurfaceBvh's fan query visits every leaf whose box, and every ancestor's box, meets
// the fan's box, one binary node at a time: one hard-to-predict "does the box meet" branch per
// node (docs/penetration-depth.md, session 9: the traversal was 0.75 M instructions and 10 k
// mispredictions per call at 10k tets). Here every inner node of the binary tree is collapsed with
// its inner children into one node of up to four children (its grandchildren, or a child that is
// a leaf), whose boxes are stored as structure of arrays and tested against the query by one AVX
// comparison per bound; the children that meet are pushed without branches. The children's boxes
// are the binary nodes' boxes (copied after every fit), and a binary node's box contains its
// descendants', so a child whose box meets the query has ancestors whose boxes meet it too: the
// leaves found are exactly the binary traversal's, and children are pushed so that they are
// popped in the binary depth-first order (left subtree first). The same closed comparisons
// (false for NaN) decide, so the list of leaves is the binary traversal's, in its order, bit for
// bit. Needs AVX (available()); SurfaceBvh uses it only with the AVX segment-packet kernel, and
// its scalar fan query keeps the binary traversal.
//
// Float boxes, exact decisions (session 14). The boxes a query reads are floats rounded outward
// (min down, max up): a node is 128 B, two cache lines instead of four, which at 100k tets is what
// the traversal misses on. One 8-lane float comparison per bound gives two masks: "may meet"
// (outward float box against the query rounded outward: true whenever the double boxes meet) and
// "surely meets" (the same float box against the query shrunk past its own rounding: true only
// when the double boxes meet). A child that may but not surely meet (a face within a float ulp of
// the query's, e.g. a point query on the surface) is re-tested on its double box (exact_, read
// only then). So every child pushed is one the double test pushes: the same leaves, same order.
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "sim/math_types.h"

namespace pliant {

class QuadBoxTree {
 public:
  /// Collapses a binary tree in SurfaceBvh's layout: nodes[i].box, and for an inner node
  /// (count == 0) the left child i + 1 and the right child nodes[i].first; a leaf has count > 0.
  template <class BinaryNodes>
  void build(const BinaryNodes& nodes);
  /// Copies the binary nodes' current boxes (after a fit of the same tree).
  template <class BinaryNodes>
  void refresh_boxes(const BinaryNodes& nodes);

  /// Binary-node indices of the leaves whose box (and every ancestor's box) meets `query`, in the
  /// binary tree's depth-first order (left first); returns their number. `out` holds leaf_count().
  /// Only where available().
  int leaves_meeting(const Aabb& query, int* out) const;
  /// True when this CPU runs leaves_meeting (AVX).
  static bool available();
  /// Number of leaves of the binary tree (the size `out` of leaves_meeting needs).
  int leaf_count() const { return leaf_count_; }

  /// Four closed boxes (min[axis][k], max[axis][k]) against `query` by the float test with its
  /// exact re-test, as leaves_meeting decides a node's children; bit k set iff box k meets query
  /// by the double comparisons (every box used). For tests. Only where available().
  static int children_meeting(const double (&min)[3][4], const double (&max)[3][4], const Aabb& query);
  /// Largest float <= d (-inf below -FLT_MAX; NaN stays NaN).
  static float float_below(double d) {
    const float f = static_cast<float>(d);
    return static_cast<double>(f) > d ? float_step_down(f) : f;
  }
  /// Smallest float >= d (+inf above FLT_MAX; NaN stays NaN).
  static float float_above(double d) {
    const float f = static_cast<float>(d);
    return static_cast<double>(f) < d ? float_step_up(f) : f;
  }
  /// The next float below f (f not NaN, not -inf): std::nextafter's value without its library call.
  static float float_step_down(float f) {
    const auto b = std::bit_cast<std::uint32_t>(f);
    if (f == 0.0f) return std::bit_cast<float>(std::uint32_t{0x80000001u});  // -denorm_min
    return std::bit_cast<float>((b >> 31) != 0 ? b + 1 : b - 1);
  }
  /// The next float above f (f not NaN, not +inf).
  static float float_step_up(float f) {
    const auto b = std::bit_cast<std::uint32_t>(f);
    if (f == 0.0f) return std::bit_cast<float>(std::uint32_t{1u});  // denorm_min
    return std::bit_cast<float>((b >> 31) != 0 ? b - 1 : b + 1);
  }

 private:
  /// Up to four children; child[k] >= 0 is a QuadBoxTree node, ~child[k] a binary leaf.
  /// What a traversal reads: 128 B, two cache lines.
  struct Node {
    alignas(64) float min[3][4];  ///< children's boxes rounded down; empty slots +inf
    float max[3][4];              ///< rounded up; empty slots -inf
    int child[4] = {0, 0, 0, 0};
    int valid = 0;  ///< bit k: slot k is used
  };
  /// The children's double boxes, read only when the float test is not conclusive.
  struct ExactBoxes {
    alignas(32) double min[3][4];  ///< empty slots +inf
    double max[3][4];              ///< empty slots -inf
  };
  static constexpr int kMaxStack = 256;

  /// Appends a node whose children are the binary nodes `slots` (inner ones collapsed in turn).
  template <class BinaryNodes>
  int add_node(const BinaryNodes& nodes, const int* slots, int used);
  int leaves_meeting_avx(const Aabb& query, int* out) const;

  std::vector<Node> nodes_;  ///< node 0 has one child, the binary root (so its box is tested too)
  std::vector<ExactBoxes> exact_;             ///< per node
  std::vector<std::array<int, 4>> sources_;  ///< per node: binary node of each child (-1: empty slot)
  int leaf_count_ = 0;
};

template <class BinaryNodes>
int QuadBoxTree::add_node(const BinaryNodes& nodes, const int* slots, int used) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  exact_.emplace_back();
  sources_.push_back({-1, -1, -1, -1});
  for (int k = 0; k < used; ++k) {
    const int b = slots[k];
    const auto& binary = nodes[static_cast<size_t>(b)];
    int child = ~b;  // a leaf
    if (binary.count == 0) {
      // An inner node's children, each replaced by its own two children unless it is a leaf.
      int grand[4];
      int n = 0;
      for (const int c : {b + 1, binary.first}) {
        if (nodes[static_cast<size_t>(c)].count > 0) {
          grand[n++] = c;
        } else {
          grand[n++] = c + 1;
          grand[n++] = nodes[static_cast<size_t>(c)].first;
        }
      }
      child = add_node(nodes, grand, n);
    }
    Node& node = nodes_[static_cast<size_t>(index)];  // add_node may have moved the vector
    node.child[k] = child;
    node.valid |= 1 << k;
    sources_[static_cast<size_t>(index)][static_cast<size_t>(k)] = b;
  }
  return index;
}

template <class BinaryNodes>
void QuadBoxTree::build(const BinaryNodes& nodes) {
  nodes_.clear();
  exact_.clear();
  sources_.clear();
  leaf_count_ = 0;
  for (const auto& n : nodes) leaf_count_ += n.count > 0 ? 1 : 0;
  if (nodes.empty()) return;
  const int root = 0;
  add_node(nodes, &root, 1);
  refresh_boxes(nodes);
}

template <class BinaryNodes>
void QuadBoxTree::refresh_boxes(const BinaryNodes& nodes) {
  for (size_t i = 0; i < nodes_.size(); ++i) {
    Node& node = nodes_[i];
    ExactBoxes& exact = exact_[i];
    for (int k = 0; k < 4; ++k) {
      const int source = sources_[i][static_cast<size_t>(k)];
      const Aabb box = source >= 0 ? nodes[static_cast<size_t>(source)].box : Aabb{};
      for (int a = 0; a < 3; ++a) {
        exact.min[a][k] = box.min[a];
        exact.max[a][k] = box.max[a];
        node.min[a][k] = float_below(box.min[a]);
        node.max[a][k] = float_above(box.max[a]);
      }
    }
  }
}

}  // namespace pliant
