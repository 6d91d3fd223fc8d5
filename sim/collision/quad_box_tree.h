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
#pragma once

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

 private:
  /// Up to four children; child[k] >= 0 is a QuadBoxTree node, ~child[k] a binary leaf.
  struct Node {
    alignas(32) double min[3][4];  ///< children's boxes; empty slots min +inf
    alignas(32) double max[3][4];  ///< empty slots max -inf
    int child[4] = {0, 0, 0, 0};
    int source[4] = {-1, -1, -1, -1};  ///< binary node of each child (-1: empty slot)
    int valid = 0;                     ///< bit k: slot k is used
  };
  static constexpr int kMaxStack = 256;

  /// Appends a node whose children are the binary nodes `slots` (inner ones collapsed in turn).
  template <class BinaryNodes>
  int add_node(const BinaryNodes& nodes, const int* slots, int used);
  int leaves_meeting_avx(const Aabb& query, int* out) const;

  std::vector<Node> nodes_;  ///< node 0 has one child, the binary root (so its box is tested too)
  int leaf_count_ = 0;
};

template <class BinaryNodes>
int QuadBoxTree::add_node(const BinaryNodes& nodes, const int* slots, int used) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
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
    node.source[k] = b;
    node.valid |= 1 << k;
  }
  return index;
}

template <class BinaryNodes>
void QuadBoxTree::build(const BinaryNodes& nodes) {
  nodes_.clear();
  leaf_count_ = 0;
  for (const auto& n : nodes) leaf_count_ += n.count > 0 ? 1 : 0;
  if (nodes.empty()) return;
  const int root = 0;
  add_node(nodes, &root, 1);
  refresh_boxes(nodes);
}

template <class BinaryNodes>
void QuadBoxTree::refresh_boxes(const BinaryNodes& nodes) {
  for (Node& node : nodes_) {
    for (int k = 0; k < 4; ++k) {
      const Aabb box = node.source[k] >= 0 ? nodes[static_cast<size_t>(node.source[k])].box : Aabb{};
      for (int a = 0; a < 3; ++a) {
        node.min[a][k] = box.min[a];
        node.max[a][k] = box.max[a];
      }
    }
  }
}

}  // namespace pliant
