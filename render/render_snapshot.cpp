#include "render/render_snapshot.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <limits>

#include "sim/body.h"
#include "sim/world.h"

namespace pliant {
namespace {

constexpr double kNegligibleForce = 1e-9;  ///< N

std::string format(const char* fmt, double a) {
  std::array<char, 96> buffer{};
  std::snprintf(buffer.data(), buffer.size(), fmt, a);
  return buffer.data();
}

std::vector<double> compute_field(const Body& body, ScalarField field) {
  std::vector<double> values(body.positions.size(), 0.0);
  if (field == ScalarField::displacement && !body.is_kinematic()) {
    const auto& rest = body.mesh->rest_positions();
    for (size_t i = 0; i < values.size(); ++i) values[i] = (body.positions[i] - body.pose.apply(rest[i])).norm();
  } else if (field == ScalarField::speed) {
    for (size_t i = 0; i < values.size(); ++i) values[i] = body.velocities[i].norm();
  }
  return values;
}

}  // namespace

Rgba8 default_body_colour(int deformable_index, bool kinematic) {
  if (kinematic) return {165, 175, 190, 255};
  static constexpr std::array<Rgba8, 4> kTissue = {
      Rgba8{222, 132, 120, 255}, Rgba8{214, 178, 120, 255}, Rgba8{150, 186, 140, 255},
      Rgba8{150, 160, 214, 255}};
  return kTissue[static_cast<size_t>(deformable_index) % kTissue.size()];
}

bool RenderSnapshot::has_scalar_field() const {
  return std::any_of(bodies.begin(), bodies.end(), [](const BodySnapshot& b) { return !b.scalar_field.empty(); });
}

Aabb RenderSnapshot::bounds() const {
  Aabb box;
  for (const auto& body : bodies) {
    for (const Vec3& x : body.positions) box.extend(x);
  }
  for (const auto& arrow : arrows) {
    box.extend(arrow.origin);
    box.extend(arrow.origin + arrow.vector);
  }
  return box;
}

RenderSnapshot take_snapshot(const World& world, const SnapshotOptions& options) {
  RenderSnapshot snap;
  snap.time = world.time();
  snap.step = world.step_count();

  // Bodies: positions, colour, optional field.
  int deformable_index = 0;
  double field_lo = std::numeric_limits<double>::infinity();
  double field_hi = -std::numeric_limits<double>::infinity();
  for (const Body* body : world.bodies()) {
    if (body == nullptr) continue;
    BodySnapshot b;
    b.name = body->name;
    b.mesh = body->mesh;
    b.positions = body->positions;
    b.kinematic = body->is_kinematic();
    b.colour = default_body_colour(deformable_index, b.kinematic);
    if (!b.kinematic) ++deformable_index;
    for (const auto& [name, colour] : options.body_colours) {
      if (name == b.name) b.colour = colour;
    }
    if (options.field != ScalarField::none && !(options.field == ScalarField::displacement && b.kinematic)) {
      b.scalar_field = compute_field(*body, options.field);
      for (double v : b.scalar_field) {
        field_lo = std::min(field_lo, v);
        field_hi = std::max(field_hi, v);
      }
    }
    snap.bodies.push_back(std::move(b));
  }
  if (options.field != ScalarField::none) {
    snap.field_name = options.field == ScalarField::displacement ? "displacement (m)" : "speed (m/s)";
    if (options.field_range) {
      snap.field_min = options.field_range->first;
      snap.field_max = options.field_range->second;
    } else if (field_lo <= field_hi) {
      snap.field_min = field_lo;
      snap.field_max = field_hi;
    }
  }

  // Contacts of the last step.
  const auto& contacts = world.contacts();
  if (options.contact_points) {
    snap.contact_points.reserve(contacts.size());
    for (const auto& c : contacts) snap.contact_points.push_back(c.contact_point);
  }

  // Arrows: the reaction on every kinematic body, drawn from the mean contact point on it.
  std::vector<ForceArrow> reaction_arrows;
  std::vector<double> reaction_newtons;
  const auto& reactions = world.last_report().reactions;
  if (options.reaction_arrows) {
    for (const auto& r : reactions) {
      const double magnitude = r.force.norm();
      // Below a nanonewton the force is numerical noise; an auto-scaled arrow would magnify it.
      if (!(magnitude > kNegligibleForce) || r.body < 0 || static_cast<size_t>(r.body) >= world.bodies().size()) continue;
      const Body* body = world.bodies()[static_cast<size_t>(r.body)];
      if (body == nullptr) continue;
      Vec3 origin = Vec3::Zero();
      int count = 0;
      for (const auto& c : contacts) {
        if (c.body == r.body || c.penetrated_body == r.body) {
          origin += c.contact_point;
          ++count;
        }
      }
      origin = count > 0 ? Vec3(origin / static_cast<double>(count)) : body->pose.translation;
      reaction_arrows.push_back({origin, r.force, Rgba8{255, 220, 40, 255}});
      reaction_newtons.push_back(magnitude);
    }
  }
  double scale = options.force_scale;
  if (scale <= 0.0 && !reaction_newtons.empty()) {
    const double largest = *std::max_element(reaction_newtons.begin(), reaction_newtons.end());
    const Aabb box = snap.bounds();
    scale = box.empty() ? 0.0 : 0.25 * box.extent().norm() / largest;
  }
  for (auto& arrow : reaction_arrows) {
    arrow.vector *= scale;
    snap.arrows.push_back(arrow);
  }
  if (options.depth_vectors) {
    for (const auto& c : contacts) {
      const Body* body = world.bodies()[static_cast<size_t>(c.body)];
      if (body == nullptr) continue;
      snap.arrows.push_back({body->positions[static_cast<size_t>(c.vertex)], c.depth_vector(), Rgba8{60, 200, 255, 255}});
    }
  }

  // Text.
  if (options.overlay_text) {
    snap.overlay_lines.push_back(format("t %.4f s", snap.time) + "  step " + std::to_string(snap.step));
    for (const auto& r : reactions) {
      const Body* body = r.body >= 0 && static_cast<size_t>(r.body) < world.bodies().size()
                             ? world.bodies()[static_cast<size_t>(r.body)]
                             : nullptr;
      const std::string name = body != nullptr && !body->name.empty() ? body->name : "body " + std::to_string(r.body);
      snap.overlay_lines.push_back(name + format(" F %.3f N", r.force.norm()));
    }
    if (options.step_ms) snap.overlay_lines.push_back(format("step %.2f ms", *options.step_ms));
  }
  for (const auto& line : options.extra_lines) snap.overlay_lines.push_back(line);
  return snap;
}

}  // namespace pliant
