#include "sim/collision/box_set_outcodes.h"

namespace pliant {

void BoxSetOutcodes::clear_boxes() {
  boxes_.clear();
  every_box_ = 0;
}

void BoxSetOutcodes::add_box(const Aabb& box) {
  if (boxes_.size() < static_cast<size_t>(max_boxes)) {
    every_box_ |= std::uint64_t{1} << boxes_.size();
    boxes_.push_back(box);
    return;
  }
  boxes_.back().extend(box.min);
  boxes_.back().extend(box.max);
}

void BoxSetOutcodes::assign_codes(std::span<const Vec3> points) {
  narrow_ = boxes_.size() <= static_cast<size_t>(narrow_boxes);
  if (narrow_) {
    if (narrow_codes_.size() < points.size()) narrow_codes_.resize(points.size());
    if (boxes_.size() == 1) {
      // One box (the probe's partner; session 18): its bounds in locals, the six comparisons of the
      // loop below for k = 0 in its order, the same bits (~57 -> ~20 instructions per point).
      const Vec3 lo = boxes_[0].min, hi = boxes_[0].max;
      std::uint64_t* codes = narrow_codes_.data();
      for (size_t v = 0; v < points.size(); ++v) {
        const Vec3& x = points[v];
        std::uint64_t sides = 0;
        for (int axis = 0; axis < 3; ++axis) {
          sides |= static_cast<std::uint64_t>(x[axis] < lo[axis]) << (16 * axis);
          sides |= static_cast<std::uint64_t>(x[axis] > hi[axis]) << (16 * axis + 8);
        }
        codes[v] = sides;
      }
      return;
    }
    for (size_t v = 0; v < points.size(); ++v) {
      const Vec3& x = points[v];
      std::uint64_t sides = 0;
      for (size_t k = 0; k < boxes_.size(); ++k) {
        const Aabb& box = boxes_[k];
        for (int axis = 0; axis < 3; ++axis) {
          // Comparisons with a NaN are false: a NaN coordinate sets no bit on its axis.
          sides |= static_cast<std::uint64_t>(x[axis] < box.min[axis]) << (16 * axis + k);
          sides |= static_cast<std::uint64_t>(x[axis] > box.max[axis]) << (16 * axis + 8 + k);
        }
      }
      narrow_codes_[v] = sides;
    }
    return;
  }
  if (codes_.size() < points.size()) codes_.resize(points.size());
  for (size_t v = 0; v < points.size(); ++v) {
    const Vec3& x = points[v];
    Sides sides{};
    for (size_t k = 0; k < boxes_.size(); ++k) {
      const Aabb& box = boxes_[k];
      const std::uint64_t bit = std::uint64_t{1} << k;
      for (int axis = 0; axis < 3; ++axis) {
        // Comparisons with a NaN are false: a NaN coordinate sets no bit on its axis.
        sides[static_cast<size_t>(2 * axis)] |= x[axis] < box.min[axis] ? bit : 0;
        sides[static_cast<size_t>(2 * axis + 1)] |= x[axis] > box.max[axis] ? bit : 0;
      }
    }
    codes_[v] = sides;
  }
}

}  // namespace pliant
