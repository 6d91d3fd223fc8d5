// Cohen-Sutherland out-codes of a body's vertices against a set of up to 64 boxes at once, for the
// spatial hash's pass 2 (session 16, issues #4 and #8).
//
// Design note. In a pile every body's bounds are covered by the union of its partners' bounds, so
// one box per penetrated body culls nothing (session 11). What a tet of body b can contain is a
// partner's inserted vertex inside b's bounds: per partner, the box of those vertices (for two
// touching fruits, the box of the lens where they overlap) is a small part of b. A tet whose box
// meets none of these boxes needs no look-up. Each vertex gets six bit planes, one per side of a box
// (x below min, x above max, y below, ...), bit k for box k; a tet misses box k exactly when its four
// corners share a side bit of k (its box lies beyond that side), so the tet misses every box when the
// OR over the six sides of the AND over the four corners holds every box's bit. This is the closed
// box-overlap test of Aabb::overlaps, decided from the corners without building the tet's box; a
// coordinate that is not a number sets no bit on its axis (a corner with none keeps its tet). Boxes
// beyond the 64th are merged into the 64th (a coarser box: still exact, only rejects less).
// Session 17: with up to 8 boxes (the probe's one partner, a pair of bodies, most of a pile's fruits)
// a vertex's six side bytes fit one 64-bit word, so a tet's test is three ANDs and a fold of the
// bytes instead of 24 loads and ANDs; the same decision, bit for bit.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "sim/math_types.h"

namespace pliant {

/// Per-vertex side bits against a set of boxes; rejects the tets whose box meets none of them.
class BoxSetOutcodes {
 public:
  /// Most boxes kept apart (one bit each); later ones are merged into the last.
  static constexpr int max_boxes = 64;
  /// Up to this many boxes, a vertex's codes are one word (a byte per side).
  static constexpr int narrow_boxes = 8;

  /// Forgets the boxes (the codes are stale until assign_codes).
  void clear_boxes();
  /// Adds a (non-empty) box; beyond max_boxes it is merged into the last one.
  void add_box(const Aabb& box);
  /// Boxes held (at most max_boxes).
  int box_count() const { return static_cast<int>(boxes_.size()); }
  /// The side bits of every point against the boxes held.
  void assign_codes(std::span<const Vec3> points);
  /// Whether the box of the tet with corners `tet` (indices into the coded points) meets none of the
  /// boxes (closed: a shared face, edge or corner is a meeting).
  bool misses_every_box(const TetIndices& tet) const {
    if (narrow_) {
      // Byte s of a word is side s; the AND keeps the sides all four corners share, the fold ORs
      // the six bytes into the lowest.
      std::uint64_t shared = narrow_codes_[static_cast<size_t>(tet[0])] & narrow_codes_[static_cast<size_t>(tet[1])] &
                             narrow_codes_[static_cast<size_t>(tet[2])] & narrow_codes_[static_cast<size_t>(tet[3])];
      shared |= shared >> 32;
      shared |= shared >> 16;
      shared |= shared >> 8;
      return (shared & 0xffu) == every_box_;
    }
    const Sides& a = codes_[static_cast<size_t>(tet[0])];
    const Sides& b = codes_[static_cast<size_t>(tet[1])];
    const Sides& c = codes_[static_cast<size_t>(tet[2])];
    const Sides& d = codes_[static_cast<size_t>(tet[3])];
    std::uint64_t missed = 0;
    for (size_t s = 0; s < 6; ++s) missed |= a[s] & b[s] & c[s] & d[s];
    return missed == every_box_;
  }
  /// The first tet of tets[first, end) whose box meets some box held (tets.size() if none):
  /// misses_every_box over the range in one loop (session 18: the per-tet call cost the probe's
  /// detection ~38 instructions per tissue tet, 0.17 M per step; the same decisions).
  size_t first_tet_meeting_a_box(std::span<const TetIndices> tets, size_t first) const {
    const size_t end = tets.size();
    if (narrow_ && every_box_ == 1) {
      // One box: only bit 0 of each side byte is ever set, so the fold equals every_box_ exactly
      // when some bit of the AND is set.
      const std::uint64_t* codes = narrow_codes_.data();
      for (size_t t = first; t < end; ++t) {
        const TetIndices& tet = tets[t];
        const std::uint64_t shared = codes[static_cast<size_t>(tet[0])] & codes[static_cast<size_t>(tet[1])] &
                                     codes[static_cast<size_t>(tet[2])] & codes[static_cast<size_t>(tet[3])];
        if (shared == 0) return t;
      }
      return end;
    }
    for (size_t t = first; t < end; ++t) {
      if (!misses_every_box(tets[t])) return t;
    }
    return end;
  }

 private:
  /// Per side (x < min, x > max, y < min, y > max, z < min, z > max): bit k for box k.
  using Sides = std::array<std::uint64_t, 6>;
  std::vector<Aabb> boxes_;
  std::vector<Sides> codes_;        ///< per point of the last assign_codes (more than narrow_boxes boxes)
  std::vector<std::uint64_t> narrow_codes_;  ///< per point, byte s = side s (at most narrow_boxes boxes)
  bool narrow_ = false;             ///< the last assign_codes wrote narrow_codes_
  std::uint64_t every_box_ = 0;     ///< bit k set for each box held
};

}  // namespace pliant
