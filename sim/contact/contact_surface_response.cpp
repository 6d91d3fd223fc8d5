// Stage 4 (paper section 4.4) and the reporting around it. Per step:
//   1. build the deformation region and displacement vectors s (stage 3, deformation_region.cpp);
//   2. binary search: every searching vertex starts at x + s/2; after each local evaluation of
//      internal forces it moves by +-s/2^(k+1) (k = 1..n), backing off where its own pressure
//      exceeds the other body's (Eq. 2) and going further where it is lower. Immovable vertices
//      stay; a vertex facing an immovable one takes its whole displacement;
//   3. optional finishing projection (beyond the paper): Gauss-Seidel passes that put every
//      colliding vertex exactly into the plane of its displaced contact triangle, splitting each
//      correction between the two sides in the ratio the search found;
//   4. velocity update and Coulomb friction (stage 5, contact_velocity_update.cpp);
//   5. contact forces from the stage-5 impulses over dt (normal and friction): reactions on
//      kinematic bodies (the haptic force), per-pair forces; beside them each side's elastic
//      restoring force, residual overlap and pressure imbalance.
#include "sim/contact/contact_surface_response.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#include "sim/contact/derived_held_fraction.h"

namespace pliant {
namespace {

// Moves region vertices to x + lambda s.
void place_region(std::span<Body* const> bodies, std::vector<DisplacementVertex>& region) {
  for (const auto& v : region) {
    if (v.immovable) continue;
    bodies[static_cast<size_t>(v.body)]->positions[static_cast<size_t>(v.vertex)] =
        v.rest_of_step + v.fraction * v.displacement;
  }
}

// Internal forces at the region's movable vertices (local query), and the elastic restoring
// pressure along each vertex's own displacement direction. `search_only`: only the vertices the
// binary search reads (each group's leading search_count), else all.
// With `frozen_iterations` (n) > 0, a vertex that moved at most h / 2^(n+1) from where the model
// last linearised (h: its local edge length) is evaluated with the model's frozen-rotation query:
// its error relative to the force change grows like |s| / h (0.4 |s| / h measured on a
// pre-stressed beam, docs/deformation-models.md), so there it stays below the search's own
// resolution 1 / 2^(n+1), with a margin of about 2.5. The others get the exact query. The final
// evaluation passes n = 0 (always exact).
// With `rotation_tolerance` > 0 the exact pass reuses rotations extracted earlier where the
// element's F moved by at most that much (internal_forces_at_nearby_rotations; search only).
// Linearised search (session 6, ContactSettings::linearised_search): `linearisation` = start
// asks a linearised group's query exactly (no reused rotations, session 8) and records, after the
// queries, each linearised group's positions and search forces (x1, f(x1));
// = use evaluates such a group as f(x1) - K' (x - x1) (DeformationModel::stiffness_product_at)
// instead of asking the query; a model without K' falls back to the query. = final (session 7,
// ContactSettings::linearised_final_evaluation): the final evaluation of such a group takes
// f(x1) - K' (x - x1) at its search entries with the moves of all its entries (the projection and
// the secant step move the others too); the remaining entries ask the exact query.
enum class Linearisation { none, start, use, final };

// The linearised search's gate: every searching vertex of the group has |s| <= h / 2^(n+2). Its
// moves after the first evaluation (at most 7/16 |s|) then stay below h / 2^(n+3), a quarter of
// the frozen search's gate (h / 2^(n+1), where the frozen-rotation error, ~0.4 |d| / h of the force
// change, stays below the search's resolution): the margin covers K's rotation lag (<= 1e-3 rad
// plus the step's rotation since x_n). Measured (docs/contact-surface.md "Speed (session 6)"): at
// h / 2^(n+1) the matrix's dt 20 ms case ended 1.3% deeper (15.4 -> 15.6 mm), at h / 2^(n+2) not;
// three cubes respond ~5% slower (a few groups ask the query).
void gate_linearisation(DeformationRegion& region, int iterations, bool enabled) {
  const double resolution = std::ldexp(1.0, -(iterations + 2));
  const auto& vertices = region.vertices();
  for (auto& g : region.groups()) {
    g.linearised = enabled && g.search_count > 0;
    for (size_t i = 0; i < g.search_count && g.linearised; ++i) {
      const auto& v = vertices[static_cast<size_t>(g.region_indices[i])];
      const double limit = resolution * v.length;
      if (v.searching && !(v.displacement.squaredNorm() <= limit * limit)) g.linearised = false;
    }
  }
}

// f(x1) - K' (x - x1) over the group's search entries, with the moves of its first `moved`
// entries (>= search_count; the others stayed at x1); false if the model has no K' or refuses.
bool linearised_forces(const Body& body, DeformationRegion::BodyGroup& g, double strain_tolerance, size_t moved) {
  const size_t count = g.search_count;
  g.moves.resize(moved);
  g.stiffness_moves.resize(count);
  for (size_t i = 0; i < moved; ++i) {
    g.moves[i] = body.positions[static_cast<size_t>(g.vertices[i])] - g.start_positions[i];
  }
  const std::span<const int> movers(g.vertices.data(), moved), rows(g.vertices.data(), count);
  if (!body.model->stiffness_product_at(movers, g.moves, rows, g.stiffness_moves, strain_tolerance)) return false;
  for (size_t i = 0; i < count; ++i) g.forces[i] = g.start_forces[i] - g.stiffness_moves[i];
  return true;
}

// Threads (session 22): one body group per chunk. A group is one body: its queries run in that
// body's model with its own scratch, and write only the group and the pressures of its vertices.
void evaluate_pressures(TaskExecutor* executor, std::span<Body* const> bodies, DeformationRegion& region,
                        bool search_only, int frozen_iterations, double rotation_tolerance = 0.0,
                        Linearisation linearisation = Linearisation::none, double strain_tolerance = 0.0) {
  auto& vertices = region.vertices();
  const double resolution = std::ldexp(1.0, -(frozen_iterations + 1));
  // One body group: its queries in its body's model, its forces and its vertices' pressures.
  auto evaluate_group = [&](DeformationRegion::BodyGroup& g) {
    const size_t count = search_only ? g.search_count : g.vertices.size();
    if (count == 0) return;
    Body& body = *bodies[static_cast<size_t>(g.body)];
    size_t linear_count = 0;  // the leading entries taken from K' (the rest ask the query)
    if (linearisation == Linearisation::use && g.linearised &&
        linearised_forces(body, g, strain_tolerance, g.search_count)) {
      linear_count = count;
    } else if (linearisation == Linearisation::final && g.linearised &&
               linearised_forces(body, g, strain_tolerance, g.vertices.size())) {
      linear_count = g.search_count;
    }
    for (int pass = 0; pass < 2 && linear_count < count; ++pass) {  // frozen, then exact
      const bool frozen = pass == 0;
      if (frozen && frozen_iterations <= 0) continue;
      g.query_vertices.clear();
      g.query_entries.clear();
      if (frozen_iterations <= 0) {  // every remaining entry asks the exact query (session 15: no per-entry test)
        g.query_vertices.assign(g.vertices.begin() + static_cast<std::ptrdiff_t>(linear_count),
                                g.vertices.begin() + static_cast<std::ptrdiff_t>(count));
        g.query_entries.resize(count - linear_count);
        std::iota(g.query_entries.begin(), g.query_entries.end(), static_cast<int>(linear_count));
      } else {  // small displacements in the frozen pass, the others in the exact one
        for (size_t i = linear_count; i < count; ++i) {
          const auto& v = vertices[static_cast<size_t>(g.region_indices[i])];
          const double limit = resolution * v.length;
          const bool small = v.displacement.squaredNorm() <= limit * limit;
          if (small != frozen) continue;
          g.query_vertices.push_back(g.vertices[i]);
          g.query_entries.push_back(static_cast<int>(i));
        }
      }
      if (g.query_vertices.empty()) continue;
      g.query_forces.resize(g.query_vertices.size());
      if (frozen) {
        body.model->internal_forces_at_frozen_rotations(body.positions, g.query_vertices, g.query_forces);
      } else {  // tolerance 0 is the exact query
        // The linearisation point f(x1) is exact (session 8): every later iteration of the group
        // reuses it, so a reused rotation's error there would be carried through the whole search.
        const bool linearisation_point = linearisation == Linearisation::start && g.linearised;
        body.model->internal_forces_at_nearby_rotations(body.positions, g.query_vertices, g.query_forces,
                                                        linearisation_point ? 0.0 : rotation_tolerance);
      }
      for (size_t q = 0; q < g.query_entries.size(); ++q) {
        g.forces[static_cast<size_t>(g.query_entries[q])] = g.query_forces[q];
      }
    }
    if (linearisation == Linearisation::start && g.linearised) {
      // Positions of every entry (the final evaluation's moves), forces of the search entries.
      g.start_positions.resize(g.vertices.size());
      g.start_forces.assign(g.forces.begin(), g.forces.begin() + static_cast<std::ptrdiff_t>(g.search_count));
      for (size_t i = 0; i < g.vertices.size(); ++i) {
        g.start_positions[i] = body.positions[static_cast<size_t>(g.vertices[i])];
      }
    }
    for (size_t i = 0; i < count; ++i) {
      auto& v = vertices[static_cast<size_t>(g.region_indices[i])];
      const double len = v.displacement_length;
      const double along = len > 0.0 ? -g.forces[i].dot(v.displacement) / len : 0.0;
      v.pressure = v.area > 0.0 ? std::max(0.0, along) / v.area : 0.0;
    }
  };
  const std::span<DeformationRegion::BodyGroup> groups = region.groups();
  parallel_for_chunks(executor, groups.size(), 1, [&](size_t begin, size_t end) {
    for (size_t gi = begin; gi < end; ++gi) evaluate_group(groups[gi]);
  });
}

// Beyond the paper, opt-in (ContactSettings::cfl_limited_displacement; docs/stability.md, M1).
// Moving a surface vertex by the search's displacement while the rest of its body keeps its
// integrated positions dents one layer of cells; once the body's pressure wave would cross more
// than that layer in the step (CFL = c_p dt / h > 1, c_p = sqrt((lambda + 2 mu) / rho), h the
// vertex's local edge length) the dent stores about CFL^2 times the kinetic energy the velocity
// update removes. The vertex's share is scaled by 1 / CFL^2 (1 / CFL measured too: the drop test
// 12.7 -> 7.6x its kinetic energy; 1 / CFL^2: 2.8x, of which friction's positional move is most);
// the rest of the overlap stays and the held forces push it out through the implicit step.
void limit_to_contact_layer(std::span<Body* const> bodies, std::vector<DisplacementVertex>& region, double dt) {
  bool moved = false;
  for (auto& v : region) {
    if (v.immovable || !(v.length > 0.0)) continue;
    const Material& m = bodies[static_cast<size_t>(v.body)]->material;
    if (!(m.density > 0.0)) continue;
    const double cfl = m.pressure_wave_speed() * dt / v.length;
    if (cfl <= 1.0) continue;
    v.fraction /= cfl * cfl;
    moved = true;
  }
  if (moved) place_region(bodies, region);
}

// Eq. 2 with each partner's force over its own area: the barycentric-weighted mean pressure of
// the other body's vertices in v's comparison area.
double partner_pressure(const DeformationRegion& region, const DisplacementVertex& v) {
  double sum = 0.0, weights = 0.0;
  for (const auto& p : region.partners_of(v)) {
    sum += p.weight * region.vertices()[static_cast<size_t>(p.region_vertex)].pressure;
    weights += p.weight;
  }
  return weights > 0.0 ? sum / weights : 0.0;
}

// Signed penetration of contact c after the response: > 0 where the vertex is still below the
// plane of its (displaced) contact triangle.
double contact_overlap(std::span<Body* const> bodies, const VertexContact& c, Vec3* normal_out = nullptr,
                       Vec3* point_out = nullptr) {
  const Body& m = *bodies[static_cast<size_t>(c.body)];
  const Body& n = *bodies[static_cast<size_t>(c.penetrated_body)];
  const auto& tri = n.mesh->surface_triangles()[static_cast<size_t>(c.contact_triangle)];
  Vec3 p = Vec3::Zero();
  for (int k = 0; k < 3; ++k) p += c.contact_barycentric[k] * n.positions[static_cast<size_t>(tri[static_cast<size_t>(k)])];
  Vec3 normal = n.mesh->triangle_normal(n.positions, c.contact_triangle);
  if (normal.squaredNorm() == 0.0) normal = c.penetration_direction;
  if (normal_out != nullptr) *normal_out = normal;
  if (point_out != nullptr) *point_out = p;
  return (p - m.positions[static_cast<size_t>(c.vertex)]).dot(normal);
}

// Beyond the paper: Gauss-Seidel projection of every colliding vertex onto the plane of its
// displaced contact triangle. The correction is split with generalized inverse masses equal to
// the share each side took in the search (lambda for the vertex, 1 - lambda for the triangle), so
// the pressure split found by the binary search is kept; immovable vertices take nothing.
void finishing_projection(std::span<Body* const> bodies, std::span<const VertexContact> contacts,
                          const DeformationRegion& region, int passes) {
  const auto& vertices = region.vertices();
  for (int pass = 0; pass < passes; ++pass) {
    double worst = 0.0;
    for (size_t c = 0; c < contacts.size(); ++c) {
      Vec3 normal;
      const double overlap = contact_overlap(bodies, contacts[c], &normal);
      if (overlap <= 0.0) continue;
      worst = std::max(worst, overlap);
      const auto& xv = vertices[static_cast<size_t>(region.contact_vertex(c))];
      const double share_x = xv.immovable ? 0.0 : (xv.rigid_partner ? 1.0 : std::clamp(xv.fraction, 0.05, 0.95));
      const auto& tri = region.contact_triangle_vertices(c);
      const Vec3& b = contacts[c].contact_barycentric;
      double w_tri = 0.0;
      for (int k = 0; k < 3; ++k) {
        const auto& yv = vertices[static_cast<size_t>(tri[static_cast<size_t>(k)])];
        if (!yv.immovable) w_tri += b[k] * b[k] * (xv.immovable ? 1.0 : 1.0 - share_x);
      }
      const double denom = share_x + w_tri;
      if (denom <= 0.0) continue;
      const double step = overlap / denom;
      if (!xv.immovable) bodies[static_cast<size_t>(xv.body)]->positions[static_cast<size_t>(xv.vertex)] += share_x * step * normal;
      for (int k = 0; k < 3; ++k) {
        const auto& yv = vertices[static_cast<size_t>(tri[static_cast<size_t>(k)])];
        if (yv.immovable) continue;
        const double wy = xv.immovable ? 1.0 : 1.0 - share_x;
        bodies[static_cast<size_t>(yv.body)]->positions[static_cast<size_t>(yv.vertex)] -= wy * b[k] * step * normal;
      }
    }
    if (worst < 1e-12) break;  // m: round-off for tissue-sized bodies
  }
}

}  // namespace

void ContactSurfaceResponse::SearchSamples::add(double fraction, double difference) {
  previous = last;
  has_previous = has_last;
  last = {fraction, difference};
  has_last = true;
  if (difference > 0.0) {
    above = last;
    has_above = true;
  } else {
    below = last;
    has_below = true;
  }
}

// The pressure difference grows with the fraction (more displacement: more own pressure, less of
// the other's). Interpolate its zero between the closest samples of either sign (regula falsi),
// clamped to that bracket; if every sample had the same sign, extrapolate from the last two,
// clamped between the last sample and the end of [0, 1] it points to. With linear elasticity and
// one vertex per side this lands on the balance exactly, where bisection stops within
// 1/2^(n+1): at a stiffness ratio of 1e6 that floor leaves the stiff side 1/32 of the overlap.
double ContactSurfaceResponse::SearchSamples::refine(double bisection) const {
  auto zero_of = [](const Sample& a, const Sample& b) {
    return a.fraction - a.difference * (b.fraction - a.fraction) / (b.difference - a.difference);
  };
  if (has_above && has_below) {
    if (above.difference == below.difference) return bisection;
    const double lo = std::min(above.fraction, below.fraction), hi = std::max(above.fraction, below.fraction);
    return std::clamp(zero_of(below, above), lo, hi);
  }
  if (!has_previous || last.difference == previous.difference || last.fraction == previous.fraction) {
    return bisection;
  }
  const double estimate = zero_of(previous, last);
  return has_above ? std::clamp(estimate, 0.0, last.fraction) : std::clamp(estimate, last.fraction, 1.0);
}

void ContactSurfaceResponse::take_held_forces(const Body& body, std::span<Vec3> forces) {
  for (auto& h : held_) {
    if (h.body != &body) continue;
    if (h.pending && h.force.size() == forces.size()) {
      for (size_t v = 0; v < forces.size(); ++v) forces[v] += h.force[v];
      h.taken = true;
    } else {
      h.taken = false;  // nothing held since the last response: no held impulse this step
    }
    h.pending = false;
  }
}

// Copy assignment keeps the vectors' capacity: no allocation per step once they have grown.
void ContactSurfaceResponse::save_held_forces() {
  saved_held_ = held_;
  saved_held_contacts_ = held_contacts_;
  saved_held_normal_force_ = held_normal_force_;
}

void ContactSurfaceResponse::restore_held_forces() {
  held_ = saved_held_;
  held_contacts_ = saved_held_contacts_;
  held_normal_force_ = saved_held_normal_force_;
}

// Session 9 (docs/stability.md M10, ContactSettings::release_distant_held_contacts): a lingering
// held contact (detection no longer finds its vertex inside the partner) is otherwise released
// only by a separating normal velocity. A vertex that went through the partner moves on along the
// minus normal of the triangle it entered through, which reads as approach, so its held force (and
// the friction cone it opens) stayed for good: after the 1000 kg block passed through the 1e9 Pa
// block, stage 5 fed the lower block 2-5e4 J per step through 3-10 such contacts, 3-16 cells from
// their held points. A vertex farther from the point it is held against than one cell of the
// partner's mesh (the contact triangle's longest rest edge, which the wrecked partner's stretched
// triangles do not inflate) touches no part of that triangle.
namespace {
bool left_its_contact_triangle(std::span<Body* const> bodies, const VertexContact& contact) {
  const Body& m = *bodies[static_cast<size_t>(contact.body)];
  const Body& n = *bodies[static_cast<size_t>(contact.penetrated_body)];
  const auto& tri = n.mesh->surface_triangles()[static_cast<size_t>(contact.contact_triangle)];
  const auto& rest = n.mesh->rest_positions();
  Vec3 p = Vec3::Zero();
  std::array<Vec3, 3> y0;
  for (size_t k = 0; k < 3; ++k) {
    const auto y = static_cast<size_t>(tri[k]);
    p += contact.contact_barycentric[static_cast<Eigen::Index>(k)] * n.positions[y];
    y0[k] = rest[y];
  }
  const double cell_squared =
      std::max({(y0[1] - y0[0]).squaredNorm(), (y0[2] - y0[1]).squaredNorm(), (y0[0] - y0[2]).squaredNorm()});
  return (m.positions[static_cast<size_t>(contact.vertex)] - p).squaredNorm() > cell_squared;
}
}  // namespace

void ContactSurfaceResponse::gather_contacts(std::span<Body* const> bodies, std::span<const VertexContact> contacts,
                                             double dt, bool warm_start, bool release_distant) {
  all_contacts_.assign(contacts.begin(), contacts.end());
  held_impulses_.assign(contacts.size(), 0.0);
  lingering_begin_ = contacts.size();
  if (!warm_start) return;
  // A held force acted if its body is the same and at least one side was integrated this step.
  auto acted = [&](const VertexContact& c) {
    const auto m = static_cast<size_t>(c.body), n = static_cast<size_t>(c.penetrated_body);
    if (m >= held_.size() || n >= held_.size() || bodies[m] == nullptr || bodies[n] == nullptr) return false;
    if (held_[m].body != bodies[m] || held_[n].body != bodies[n]) return false;
    if (held_[m].contact.size() != bodies[m]->positions.size()) return false;
    return held_[m].taken || held_[n].taken;
  };
  held_used_.assign(held_contacts_.size(), 0);
  for (size_t c = 0; c < contacts.size(); ++c) {
    if (!acted(contacts[c])) continue;
    const int idx = held_[static_cast<size_t>(contacts[c].body)].contact[static_cast<size_t>(contacts[c].vertex)];
    if (idx < 0 || held_used_[static_cast<size_t>(idx)] != 0) continue;
    if (held_contacts_[static_cast<size_t>(idx)].penetrated_body != contacts[c].penetrated_body) continue;
    held_impulses_[c] = held_normal_force_[static_cast<size_t>(idx)] * dt;
    held_used_[static_cast<size_t>(idx)] = 1;
  }
  for (size_t idx = 0; idx < held_contacts_.size(); ++idx) {
    if (held_used_[idx] != 0 || !acted(held_contacts_[idx])) continue;
    // Released, not kept for this step's velocity update nor held again (M10).
    if (release_distant && left_its_contact_triangle(bodies, held_contacts_[idx])) continue;
    all_contacts_.push_back(held_contacts_[idx]);
    held_impulses_.push_back(held_normal_force_[idx] * dt);
  }
}

void ContactSurfaceResponse::derive_pair_held_fractions(std::span<Body* const> bodies, double dt,
                                                        double pair_fraction) {
  pair_held_.clear();
  auto movable = [&](int body) {
    const Body& b = *bodies[static_cast<size_t>(body)];
    return !b.is_kinematic() && !b.is_sleeping();
  };
  for (size_t c = 0; c < all_contacts_.size(); ++c) {
    if (impulses_[c].normal_magnitude <= 0.0) continue;
    const VertexContact& contact = all_contacts_[c];
    if (!movable(contact.body) || !movable(contact.penetrated_body)) continue;
    const int a = std::min(contact.body, contact.penetrated_body), b = std::max(contact.body, contact.penetrated_body);
    // The impulse pushes the colliding vertex's body away from the other: orient it on body_a.
    const Vec3 normal = contact.body == a ? Vec3(impulses_[c].normal) : Vec3(-impulses_[c].normal);
    auto it = std::find_if(pair_held_.begin(), pair_held_.end(),
                           [&](const PairHeldFraction& p) { return p.body_a == a && p.body_b == b; });
    if (it == pair_held_.end()) {
      pair_held_.push_back({a, b, normal, pair_fraction});
    } else {
      it->normal += normal;
    }
  }
  for (PairHeldFraction& p : pair_held_) {
    const double length = p.normal.norm();
    if (!(length > 0.0)) continue;
    const double omega = contact_mode_omega(*bodies[static_cast<size_t>(p.body_a)],
                                            *bodies[static_cast<size_t>(p.body_b)], p.normal / length);
    p.fraction = std::min(pair_fraction, held_fraction_for_contact_mode(omega * dt));
  }
}

double ContactSurfaceResponse::pair_held_fraction(int p, int q) const {
  const int a = std::min(p, q), b = std::max(p, q);
  for (const PairHeldFraction& pair : pair_held_) {
    if (pair.body_a == a && pair.body_b == b) return pair.fraction;
  }
  return 1.0;  // not reached: every held movable pair was derived
}

void ContactSurfaceResponse::hold_forces(std::span<Body* const> bodies, double dt, double fraction,
                                         double deformable_pair_fraction, bool derived_pairs,
                                         bool record_directions) {
  // Session 9 (docs/contact-surface.md "Resting churn, session 9"): between two movable deformable
  // bodies the one-step-late held force drives their contact mode (the resting churn); against an
  // immovable partner (kinematic, sleeping) the whole reaction stays held.
  const double pair_fraction = std::min(fraction, deformable_pair_fraction);
  auto movable = [&](int body) {
    const Body& b = *bodies[static_cast<size_t>(body)];
    return !b.is_kinematic() && !b.is_sleeping();
  };
  // Last step's entries back to zero (session 9): only the vertices its held contacts wrote (the
  // colliding vertex and its contact triangle; the release writes the same ones), not every
  // vertex of every body each step (17% of the probe's respond stage). A slot whose body changed
  // or that was never filled is cleared whole.
  held_.resize(bodies.size());
  auto kept = [&](size_t i) {  // slot i still holds body i's arrays (cleared entry by entry)
    const HeldForces& h = held_[i];
    return bodies[i] != nullptr && h.body == bodies[i] &&
           h.force.size() == static_cast<size_t>(bodies[i]->vertex_count()) && h.contact.size() == h.force.size();
  };
  for (const VertexContact& c : held_contacts_) {
    const auto m = static_cast<size_t>(c.body), n = static_cast<size_t>(c.penetrated_body);
    if (m < bodies.size() && kept(m)) {
      held_[m].force[static_cast<size_t>(c.vertex)] = Vec3::Zero();
      held_[m].contact[static_cast<size_t>(c.vertex)] = -1;
    }
    if (n < bodies.size() && kept(n)) {
      const auto& tri = bodies[n]->mesh->surface_triangles()[static_cast<size_t>(c.contact_triangle)];
      for (int k = 0; k < 3; ++k) held_[n].force[static_cast<size_t>(tri[static_cast<size_t>(k)])] = Vec3::Zero();
    }
  }
  for (size_t i = 0; i < bodies.size(); ++i) {
    HeldForces& h = held_[i];
    const bool same_body = kept(i);
    h.body = bodies[i];
    h.pending = false;
    h.taken = false;
    if (bodies[i] == nullptr || same_body) continue;
    const auto n = static_cast<size_t>(bodies[i]->vertex_count());
    h.force.assign(n, Vec3::Zero());
    h.contact.assign(n, -1);
  }
  held_contacts_.clear();
  held_normal_force_.clear();
  held_direction_.clear();
  // Internal force at each region vertex at the contact surface (the last local evaluation).
  // Session 10: with the derived strength each movable deformable pair holds at most the part of
  // its contact force that a trapezoidal step of its contact mode would (derived_held_fraction.h).
  if (derived_pairs) derive_pair_held_fractions(bodies, dt, pair_fraction);
  region_force_.assign(region_.vertices().size(), Vec3::Zero());
  for (const auto& g : region_.groups()) {
    for (size_t i = 0; i < g.vertices.size(); ++i) region_force_[static_cast<size_t>(g.region_indices[i])] = g.forces[i];
  }
  for (size_t c = 0; c < all_contacts_.size(); ++c) {
    if (impulses_[c].normal_magnitude <= 0.0) continue;
    const VertexContact& contact = all_contacts_[c];
    // Hold at most the elastic force with which the dent pushes back (the sustained part of the
    // contact force), not the inertial part of an impact: holding that overshoots.
    const bool pair = movable(contact.body) && movable(contact.penetrated_body);
    const double held_fraction =
        !pair ? fraction : (derived_pairs ? pair_held_fraction(contact.body, contact.penetrated_body) : pair_fraction);
    double magnitude = held_fraction * impulses_[c].normal_magnitude / dt;
    if (c < lingering_begin_) {
      const Vec3 normal = impulses_[c].normal / impulses_[c].normal_magnitude;
      const auto& vertices = region_.vertices();
      const auto x = static_cast<size_t>(region_.contact_vertex(c));
      // Each movable side's push-back along the normal; the held force is at most the smaller.
      double restoring = std::numeric_limits<double>::infinity();
      if (!vertices[x].immovable) restoring = std::max(0.0, -region_force_[x].dot(normal));
      const auto& tri = region_.contact_triangle_vertices(c);
      double triangle = 0.0;
      bool triangle_movable = false;
      for (int k = 0; k < 3; ++k) {
        const auto y = static_cast<size_t>(tri[static_cast<size_t>(k)]);
        if (vertices[y].immovable) continue;
        triangle_movable = true;
        triangle += contact.contact_barycentric[k] * std::max(0.0, region_force_[y].dot(normal));
      }
      if (triangle_movable) restoring = std::min(restoring, triangle);
      if (!std::isfinite(restoring)) restoring = 0.0;
      magnitude = std::min(magnitude, restoring);
    }
    if (!(magnitude > 0.0) || !std::isfinite(magnitude)) continue;  // nothing, or a faulty step's
    const Vec3 f = magnitude * impulses_[c].normal / impulses_[c].normal_magnitude;  // on the colliding vertex
    HeldForces& m = held_[static_cast<size_t>(contact.body)];
    HeldForces& n = held_[static_cast<size_t>(contact.penetrated_body)];
    int& slot = m.contact[static_cast<size_t>(contact.vertex)];
    if (slot >= 0) continue;  // a vertex with two contacts holds the first
    slot = static_cast<int>(held_contacts_.size());
    held_contacts_.push_back(contact);
    held_normal_force_.push_back(magnitude);
    if (record_directions) held_direction_.push_back(impulses_[c].normal / impulses_[c].normal_magnitude);
    m.force[static_cast<size_t>(contact.vertex)] += f;
    m.pending = true;
    const auto& tri = bodies[static_cast<size_t>(contact.penetrated_body)]
                          ->mesh->surface_triangles()[static_cast<size_t>(contact.contact_triangle)];
    for (int k = 0; k < 3; ++k) {
      n.force[static_cast<size_t>(tri[static_cast<size_t>(k)])] -= contact.contact_barycentric[k] * f;
    }
    n.pending = true;
  }
}

// Design note (session 7, docs/contact-surface.md "Resting churn"): the energy ledger of the
// two-block stack at dt 1 ms shows the held forces doing positive work on the blocks' centres of
// mass in the integration (the rigid bounce mode is pumped: a contact force delayed by one step at
// omega dt ~ 1), while their total work is negative (they hold the dents). Stage 5 of the next step
// would take back the held impulse a separating free body carries (the rigid take-back); releasing
// that part before the integration keeps it from pushing first. Only the rigid part is judged:
// centre-of-mass velocities (after stage 5) along the pair's total held force. A body with fixed
// vertices has no rigid modes; its pairs keep their held forces (a soft fixed-base partner's
// rebound is pushed by the held force legitimately: releasing there failed the energy ledger's
// stiffness-ratio-1e3 case and the CFL-limited ratio-1e6 case).
void ContactSurfaceResponse::release_separating_pairs(std::span<Body* const> bodies, double dt) {
  auto is_free = [](const Body& b) {
    if (b.is_kinematic() || b.is_sleeping()) return false;
    return std::none_of(b.fixed.begin(), b.fixed.end(), [](char f) { return f != 0; });
  };
  auto centre_velocity = [](const Body& b, double& mass) {  // m/s; mass in kg
    Vec3 momentum = Vec3::Zero();
    mass = 0.0;
    for (size_t v = 0; v < b.positions.size(); ++v) {
      momentum += b.masses[v] * b.velocities[v];
      mass += b.masses[v];
    }
    return Vec3(momentum / mass);
  };
  // The held contacts grouped by (body, penetrated body), each group in index order (a stable
  // sort), and the groups taken in the order of their first contact: the same sums in the same
  // order as a scan from each pair's first contact, in linear-logarithmic instead of quadratic time.
  pair_order_.resize(held_contacts_.size());
  std::iota(pair_order_.begin(), pair_order_.end(), size_t{0});
  auto pair_of = [&](size_t j) { return std::pair(held_contacts_[j].body, held_contacts_[j].penetrated_body); };
  std::stable_sort(pair_order_.begin(), pair_order_.end(), [&](size_t i, size_t j) { return pair_of(i) < pair_of(j); });
  pair_groups_.clear();
  for (size_t begin = 0, end = 0; begin < pair_order_.size(); begin = end) {
    for (end = begin + 1; end < pair_order_.size() && pair_of(pair_order_[end]) == pair_of(pair_order_[begin]); ++end) {}
    pair_groups_.push_back({begin, end});
  }
  std::sort(pair_groups_.begin(), pair_groups_.end(), [&](const std::pair<size_t, size_t>& g, const std::pair<size_t, size_t>& h) {
    return pair_order_[g.first] < pair_order_[h.first];
  });
  for (const auto& [begin, end] : pair_groups_) {
    const std::span<const size_t> group(pair_order_.data() + begin, end - begin);
    const auto [a, b] = pair_of(group.front());
    Vec3 force = Vec3::Zero();  // N, the pair's held force on a
    for (const size_t j : group) force += held_normal_force_[j] * held_direction_[j];
    const Body& body_a = *bodies[static_cast<size_t>(a)];
    const Body& body_b = *bodies[static_cast<size_t>(b)];
    const bool free_a = is_free(body_a), free_b = is_free(body_b);
    const bool rigid_a = free_a || body_a.is_kinematic() || body_a.is_sleeping();
    const bool rigid_b = free_b || body_b.is_kinematic() || body_b.is_sleeping();
    if (!(free_a || free_b) || !rigid_a || !rigid_b || force.squaredNorm() == 0.0) continue;
    double mass_a = 0.0, mass_b = 0.0;
    const Vec3 velocity_a = free_a ? centre_velocity(body_a, mass_a) : Vec3::Zero();
    const Vec3 velocity_b = free_b ? centre_velocity(body_b, mass_b) : Vec3::Zero();
    const double reduced = free_a && free_b ? mass_a * mass_b / (mass_a + mass_b) : (free_a ? mass_a : mass_b);
    const double separating = (velocity_a - velocity_b).dot(force.normalized());  // m/s
    if (separating <= 0.0) continue;
    const double scale = std::max(0.0, 1.0 - reduced * separating / (force.norm() * dt));
    const auto& triangles = body_b.mesh->surface_triangles();
    for (const size_t j : group) {
      const VertexContact& c = held_contacts_[j];
      // The part of this contact's held force released, on the vertex; its triangle gets it back.
      const Vec3 released = (1.0 - scale) * held_normal_force_[j] * held_direction_[j];
      held_[static_cast<size_t>(a)].force[static_cast<size_t>(c.vertex)] -= released;
      const auto& tri = triangles[static_cast<size_t>(c.contact_triangle)];
      for (int k = 0; k < 3; ++k) {
        held_[static_cast<size_t>(b)].force[static_cast<size_t>(tri[static_cast<size_t>(k)])] +=
            c.contact_barycentric[k] * released;
      }
      held_normal_force_[j] *= scale;
    }
  }
}

void ContactSurfaceResponse::respond(std::span<Body* const> bodies, std::span<const VertexContact> contacts,
                                     double dt, const ContactSettings& settings,
                                     StepReport& report) {
  // Stage 3: deformation region and displacement vectors.
  region_.build(bodies, contacts, settings.barycentric_weighting);
  auto& vertices = region_.vertices();

  // Stage 4: binary search on the pressure difference.
  place_region(bodies, vertices);
  const int iterations = std::max(0, settings.binary_search_iterations);
  // The search's samples are read only by the secant refinement (session 12: not kept without it).
  const bool keep_samples = settings.secant_refinement;
  if (keep_samples) samples_.assign(vertices.size(), SearchSamples{});
  // Without searching vertices (everything in contact faces an immovable body) no pressure is
  // read: the fractions below still step as before (a zero displacement only ever goes further).
  const bool search = region_.has_searching_vertices();
  // The linearised search replaces the later iterations' queries (not with the frozen search).
  const bool linearised = search && settings.linearised_search && !settings.frozen_rotation_search;
  gate_linearisation(region_, iterations, linearised);
  for (int k = 1; k <= iterations; ++k) {
    if (search) {
      const Linearisation linearisation =
          !linearised ? Linearisation::none : (k == 1 ? Linearisation::start : Linearisation::use);
      evaluate_pressures(executor_, bodies, region_, true, settings.frozen_rotation_search ? iterations : 0,
                         settings.search_rotation_tolerance, linearisation, settings.linearised_search_strain);
    }
    const double step = std::ldexp(1.0, -(k + 1));  // 1 / 2^(k+1)
    for (size_t i = 0; i < vertices.size(); ++i) {
      auto& v = vertices[i];
      if (v.immovable || v.rigid_partner) continue;
      const double difference = v.pressure - partner_pressure(region_, v);
      if (keep_samples) samples_[i].add(v.fraction, difference);
      v.fraction += difference > 0.0 ? -step : step;
    }
    if (search) place_region(bodies, vertices);
  }
  report.binary_search_iterations = iterations;
  if (settings.secant_refinement) {
    for (size_t i = 0; i < vertices.size(); ++i) {
      auto& v = vertices[i];
      if (!v.immovable && !v.rigid_partner) v.fraction = samples_[i].refine(v.fraction);
    }
    place_region(bodies, vertices);
  }

  if (settings.cfl_limited_displacement) limit_to_contact_layer(bodies, vertices, dt);

  if (observer) observer(ContactStage::search);
  if (settings.finishing_projection) {
    finishing_projection(bodies, contacts, region_, 32);
    if (observer) observer(ContactStage::projection);
  }

  // Forces at the final contact surface, exact by default (session 4: the frozen query's error is
  // multiplied by a stiff body's pre-stress, and these forces leave the stage as the held-force cap
  // and the reported elastic forces): pressure imbalance, held-force cap, each side's elastic force.
  // Session 7: without held forces these forces are only reported (imbalance, elastic pair forces),
  // and a linearised group's search entries take f(x1) - K' (x - x1) here too, under the search's
  // gates (ContactSettings::linearised_final_evaluation; false: exact, bit for bit). With held
  // forces they cap the next step's external force and stay exact: linearised there, the 1 mg
  // sliver case gained 4.85x the work put in (docs/contact-surface.md "Speed (session 7)").
  // Session 21: with held forces, linearised only under the tighter opt-in gate
  // (ContactSettings::held_linearised_final_strain; 0, the default: exact as before).
  const bool held = settings.held_force_fraction > 0.0;
  const double final_strain = held ? settings.held_linearised_final_strain : settings.linearised_search_strain;
  const bool linear_final = linearised && settings.linearised_final_evaluation && (!held || final_strain > 0.0);
  evaluate_pressures(executor_, bodies, region_, false, 0, 0.0, linear_final ? Linearisation::final : Linearisation::none,
                     final_strain);
  double imbalance_sum = 0.0;
  int imbalance_count = 0;
  for (const auto& v : vertices) {
    if (v.immovable || v.rigid_partner || v.partner_count == 0) continue;
    const double own = v.pressure, other = partner_pressure(region_, v);
    const double larger = std::max(own, other);
    if (larger <= 0.0) continue;
    const double imbalance = std::abs(own - other) / larger;
    imbalance_sum += imbalance;
    report.pressure_imbalance_max = std::max(report.pressure_imbalance_max, imbalance);
    ++imbalance_count;
  }
  report.pressure_imbalance_mean = imbalance_count > 0 ? imbalance_sum / imbalance_count : 0.0;

  // Stage 5: velocities and friction, with the held normal impulses (warm start).
  const bool warm_start = settings.held_force_fraction > 0.0;
  gather_contacts(bodies, contacts, dt, warm_start, settings.release_distant_held_contacts);
  friction_moves_.charge_returns = settings.limit_friction_move_charges_returns;
  friction_moves_.excuse_instrument_returns = settings.limit_friction_move_excuses_instrument_returns;
  friction_moves_.energy_flow = settings.limit_friction_move_energy_flow;
  apply_contact_velocity_update(bodies, all_contacts_, dt, settings.friction, held_impulses_, lingering_begin_,
                                impulses_, rigid_modes_, settings.limit_friction_move ? &friction_moves_ : nullptr,
                                settings.anchored_friction_compliance);
  // Friction moves the vertices it slows by h dv, tangentially to its own contact's plane but not
  // to a neighbouring contact's that shares a triangle vertex (a dent's slopes; lingering contacts):
  // with held forces the friction cone is the full load's and this left up to 0.1 mm of overlap on
  // the probe scene. The projection is the last thing that moves positions, so it runs again, but
  // only if friction moved a vertex (otherwise the overlap is the first projection's round-off).
  const bool friction_moved = std::any_of(impulses_.begin(), impulses_.end(),
                                          [](const ContactImpulse& i) { return i.friction.squaredNorm() > 0.0; });
  if (settings.finishing_projection && friction_moved) finishing_projection(bodies, contacts, region_, 32);
  if (warm_start) {
    hold_forces(bodies, dt, settings.held_force_fraction, settings.deformable_pair_held_force_fraction,
                settings.deformable_pair_held_force_derived, settings.held_force_release);
    if (settings.held_force_release) release_separating_pairs(bodies, dt);
  } else {
    held_.clear();
    held_contacts_.clear();
    held_normal_force_.clear();
  }
  if (observer) observer(ContactStage::velocity_update);

  // Contact forces are the stage-5 impulses over dt: equal and opposite on the two sides of each
  // contact, and exactly the weight for a body resting on a floor. Beside them, each side's own
  // elastic restoring force through its displaced surface measures the pressure balance.
  // A pair is found through its lower body's list (a few partners each), not by a search over all
  // pairs, once per contact and per partner of every region vertex: the fruit dish has 53 pairs
  // within its first 80 steps and more once piled (session 10, docs/contact-surface.md).
  // Each pair's sums take the same terms in the same order as before, and pairs_ is sorted below.
  for (const auto& pair : pairs_) pair_slots_[static_cast<size_t>(pair.body_a)].clear();
  pairs_.clear();  // no allocation once grown
  if (pair_slots_.size() < bodies.size()) pair_slots_.resize(bodies.size());
  auto pair_of = [&](int p, int q) -> PairContactForce& {
    const int a = std::min(p, q), b = std::max(p, q);
    auto& slots = pair_slots_[static_cast<size_t>(a)];
    for (const auto& [other, index] : slots) {
      if (other == b) return pairs_[static_cast<size_t>(index)];
    }
    slots.emplace_back(b, static_cast<int>(pairs_.size()));
    PairContactForce& pair = pairs_.emplace_back();
    pair.body_a = a;
    pair.body_b = b;
    return pair;
  };
  auto add_reaction = [&](int kinematic_body, const Vec3& point, const Vec3& f_on_kinematic) {
    for (auto& r : report.reactions) {
      if (r.body != kinematic_body) continue;
      const Body& k = *bodies[static_cast<size_t>(kinematic_body)];
      r.force += f_on_kinematic;
      r.torque += (point - k.pose.translation).cross(f_on_kinematic);
    }
  };
  for (size_t c = 0; c < all_contacts_.size(); ++c) {
    const auto& contact = all_contacts_[c];
    const Vec3 f = (impulses_[c].normal + impulses_[c].friction) / dt;  // on the colliding vertex
    if (c >= lingering_begin_ && f.squaredNorm() == 0.0) continue;
    report.total_contact_force += f.norm();
    PairContactForce& pair = pair_of(contact.body, contact.penetrated_body);
    if (c < lingering_begin_) pair.contacts++;
    (pair.body_a == contact.body ? pair.force_on_a : pair.force_on_b) += f;
    (pair.body_a == contact.body ? pair.force_on_b : pair.force_on_a) -= f;
    const Body& m = *bodies[static_cast<size_t>(contact.body)];
    const Body& n = *bodies[static_cast<size_t>(contact.penetrated_body)];
    if (m.is_kinematic()) add_reaction(contact.body, m.positions[static_cast<size_t>(contact.vertex)], f);
    if (n.is_kinematic()) add_reaction(contact.penetrated_body, contact.contact_point, -f);
  }
  for (const auto& g : region_.groups()) {
    for (size_t i = 0; i < g.vertices.size(); ++i) {
      const auto& v = vertices[static_cast<size_t>(g.region_indices[i])];
      const double len = v.displacement_length;
      if (len <= 0.0 || v.partner_count == 0) continue;
      const Vec3 dir = v.displacement / len;
      const Vec3 restoring = std::max(0.0, -g.forces[i].dot(dir)) * dir;  // pushes the other body away
      double weights = 0.0;
      for (const auto& p : region_.partners_of(v)) weights += p.weight;
      // Session 15: a vertex's partners are almost always on one body, so the pair found for the
      // last partner is taken again without pair_of's look-up (the same pair, the same sums).
      int last_other = -1;
      PairContactForce* last_pair = nullptr;
      for (const auto& p : region_.partners_of(v)) {
        const int other = vertices[static_cast<size_t>(p.region_vertex)].body;
        if (other != last_other) {
          last_pair = &pair_of(v.body, other);
          last_other = other;
        }
        PairContactForce& pair = *last_pair;
        // The elastic force of v's body acts on the other body, against its own displacement.
        (pair.body_a == other ? pair.elastic_on_a : pair.elastic_on_b) -= (p.weight / weights) * restoring;
      }
    }
  }
  std::sort(pairs_.begin(), pairs_.end(), [](const PairContactForce& p, const PairContactForce& q) {
    return p.body_a != q.body_a ? p.body_a < q.body_a : p.body_b < q.body_b;
  });
  report.pair_forces.insert(report.pair_forces.end(), pairs_.begin(), pairs_.end());
  for (size_t c = 0; c < contacts.size(); ++c) {
    report.max_residual_overlap = std::max(report.max_residual_overlap, contact_overlap(bodies, contacts[c]));
  }
}

}  // namespace pliant
