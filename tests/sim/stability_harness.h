// Stability at the extremes (issue 8, item 3): one small contact scene per case of the matrix,
// run for a fixed span, with three checks per step (docs/stability.md states the bounds and why):
//  1. finite: every step ends with report.all_finite; a faulted step (the world restores its last
//     good state) is handled by retrying it as two half steps, like SceneRunner does; a fault that
//     survives the retry fails the case.
//  2. energy: kinetic + elastic + gravitational (StepReport::energy) never exceeds the energy put in:
//     work_by_kinematic, plus what resolving an initial overlap injects (measured as the total
//     energy after the first step, plus sum k d^2 / 2 for the penalty springs of the first
//     contacts), plus a floor. The ratio E / budget must stay <= 1 + kEnergyTolerance.
//  3. overlap: the residual overlap after the response stays below kOverlapFraction of the thinnest
//     body's thickness over the second half of the run (the first half may still be resolving an
//     initial overlap or a fast instrument's first bite).
// Shared by stability_test.cpp (a few corners) and stability_long_test.cpp (the full matrix).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "sim/mesh/box_mesh.h"
#include "sim/mesh/mesh_quality.h"
#include "sim/world.h"

namespace pliant::stability {

/// Relative slack on the energy budget: implicit Euler and Rayleigh damping only remove energy,
/// so anything above the budget is injected; 10% leaves room for the work estimate, which uses the
/// instrument's displacement times the reaction at the end of the step (a rectangle rule).
inline constexpr double kEnergyTolerance = 0.10;
/// Energy floor as a fraction of the scene's gravitational scale sum(m g thickness), so that
/// round-off on a near-zero budget is not read as injection.
inline constexpr double kEnergyFloorFraction = 1e-3;
/// Residual overlap bound as a fraction of the thinnest body's thickness.
inline constexpr double kOverlapFraction = 0.25;

/// The held contact force fraction the matrix runs with: the library default (session 4: full
/// strength, docs/contact-surface.md "Held contact forces as the library default"; sessions 2-3
/// ran 0.8 while the default was 0). The matrix: 37/70 at 1.0, 36/70 at 0.8 on the same tree.
inline constexpr double kHeldForceFraction = ContactSettings{}.held_force_fraction;

/// What the upper body touches.
enum class Partner {
  block,       ///< a deformable upper block rests on a deformable lower block fixed at its base
  instrument,  ///< a kinematic box (the instrument) is pressed into the fixed lower block
};

/// One case of the matrix. Defaults are the nominal scene; each case changes one or two fields.
struct Case {
  std::string name;
  ContactMethod method = ContactMethod::contact_surface;
  Partner partner = Partner::block;
  double stiffness_ratio = 1.0;   ///< E_upper / E_lower
  double young_mean = 1e4;        ///< Pa, geometric mean of the two moduli
  double poisson = 0.3;
  double dt = 1e-3;               ///< s
  double speed = 0.1;             ///< m/s, instrument press speed (Partner::instrument)
  double press_depth = 0.01;      ///< m, instrument travel into the block
  double overlap_fraction = 0.0;  ///< initial overlap as a fraction of the upper body's thickness
  bool sliver = false;            ///< a sliver tet (min dihedral < 1 degree) at the upper body's contact face
  double upper_mass = 0.0;        ///< kg; zero means density 1000 kg/m^3
  double duration = 0.3;          ///< s simulated, clamped to [kMinSteps, kMaxSteps] steps
  bool finishing_projection = false;
  /// Contact surface: ContactSettings::held_force_fraction (session 2: 0.8 fixes F1; 0 is the paper).
  double held_force_fraction = kHeldForceFraction;
  std::FILE* trace = nullptr;     ///< when set, one line per step: energies, work, overlap
  /// Contact settings changed beyond the library defaults, for measuring a mechanism (none in the
  /// matrix, which runs the defaults).
  std::function<void(ContactSettings&)> contact_tweak;
};

/// gtest prints a parameter by its name.
inline void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

inline constexpr int kMinSteps = 100;
inline constexpr int kMaxSteps = 400;

/// What a case measured.
struct Outcome {
  bool finite = true;          ///< no step ended non-finite after its retry
  int handled_faults = 0;      ///< steps that faulted and succeeded as two half steps
  int steps = 0;
  double max_energy_ratio = 0.0;     ///< max over steps of E / budget
  double max_overlap = 0.0;          ///< m, max residual overlap over the whole run
  double max_overlap_late = 0.0;     ///< m, over the second half
  double overlap_bound = 0.0;        ///< m
  double min_dihedral_deg = 180.0;   ///< of the upper body's mesh
  double max_energy_excess = 0.0;    ///< max over steps of (E - budget without floor) / energy scale
  bool passed_through = false;       ///< the upper block ended below the lower block's centroid
  std::string message;               ///< first fault message, if any
  bool energy_ok() const { return max_energy_ratio <= 1.0 + kEnergyTolerance; }
  /// Bounded overlap; a block that fell through the other has none left, so that fails too.
  bool overlap_ok() const { return max_overlap_late <= overlap_bound && !passed_through; }
  bool passed() const { return finite && energy_ok() && overlap_ok(); }
};

inline constexpr double kUpperSize = 0.04;   ///< m, upper block edge (x, y)
inline constexpr double kUpperHeight = 0.02; ///< m
inline constexpr double kLowerSize = 0.08;   ///< m
inline constexpr double kLowerHeight = 0.04; ///< m

inline Material material(double young, double poisson, double density) {
  Material m;
  m.young_modulus = young;
  m.poisson_ratio = poisson;
  m.density = density;
  m.mass_damping = 1.0;
  m.stiffness_damping = 0.01;
  m.friction = 0.2;
  return m;
}

/// A box mesh with one bottom-face vertex moved towards the opposite face of one of its tets until
/// that tet is a sliver (min dihedral angle below 1 degree) while every tet keeps a positive volume.
inline TetMeshPtr make_sliver_box(const BoxMeshSpec& spec, double* min_dihedral_deg) {
  const TetMeshPtr box = make_box_mesh(spec);
  const double z_bottom = -0.5 * spec.size.z();
  for (int v : box->surface_vertices()) {
    const Vec3 p = box->rest_positions()[static_cast<size_t>(v)];
    if (std::abs(p.z() - z_bottom) > 1e-12) continue;
    for (int t : box->vertex_tets(v)) {
      const TetIndices& tet = box->tets()[static_cast<size_t>(t)];
      std::vector<Vec3> face;
      for (int k = 0; k < 4; ++k) {
        if (tet[k] != v) face.push_back(box->rest_positions()[static_cast<size_t>(tet[k])]);
      }
      const Vec3 n = (face[1] - face[0]).cross(face[2] - face[0]).normalized();
      const double h = (p - face[0]).dot(n);
      std::vector<Vec3> x = box->rest_positions();
      x[static_cast<size_t>(v)] = p - 0.995 * h * n;  // 0.5% of its height left
      bool positive = true;
      double min_ratio = 1.0;
      for (size_t e = 0; e < box->tets().size(); ++e) {
        const TetIndices& q = box->tets()[e];
        const double vol = signed_tet_volume(x[q[0]], x[q[1]], x[q[2]], x[q[3]]);
        const double rest = box->rest_volumes()[e];
        if (!(vol > 0.0)) positive = false;
        min_ratio = std::min(min_ratio, vol / rest);
      }
      if (!positive || min_ratio < 1e-3) continue;
      try {
        TetMeshPtr mesh = TetMesh::build(x, box->tets(), "sliver box");
        const MeshQuality q = compute_mesh_quality(*mesh);
        if (q.min_dihedral_deg < 1.0) {
          *min_dihedral_deg = q.min_dihedral_deg;
          return mesh;
        }
      } catch (const std::exception&) {
        continue;
      }
    }
  }
  return nullptr;
}

/// Vertices of `mesh` (rest positions) at height z.
inline std::vector<int> vertices_at_height(const TetMesh& mesh, double z) {
  std::vector<int> out;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    if (std::abs(mesh.rest_positions()[static_cast<size_t>(v)].z() - z) < 1e-9) out.push_back(v);
  }
  return out;
}

/// The two bodies of a case's scene and its energy scale.
struct Scene {
  BodyId lower, upper;
  Vec3 start = Vec3::Zero();  ///< m, the upper block's initial translation
  double scale = 0.0;         ///< J, sum over deformable bodies of m g (thickness)
  double min_dihedral_deg = 180.0;
  bool ok = true;             ///< false: the sliver mesh could not be built
};

/// The world settings of a case.
inline WorldSettings world_settings(const Case& c) {
  WorldSettings settings;
  settings.contact.method = c.method;
  settings.contact.finishing_projection = c.finishing_projection;
  settings.contact.held_force_fraction = c.held_force_fraction;
  if (c.contact_tweak) c.contact_tweak(settings.contact);
  return settings;
}

/// Adds the case's two bodies to `world`.
inline Scene build_scene(const Case& c, World& world) {
  Scene scene;

  const double e_upper = c.young_mean * std::sqrt(c.stiffness_ratio);
  const double e_lower = c.young_mean / std::sqrt(c.stiffness_ratio);

  // Lower block, fixed at its base, top face at z = 0.
  const TetMeshPtr lower_mesh = make_box_mesh({Vec3(kLowerSize, kLowerSize, kLowerHeight), 6, 6, 3});
  BodyDef lower{.name = "lower", .mesh = lower_mesh, .material = material(e_lower, c.poisson, 1000.0)};
  lower.pose.translation = Vec3(0, 0, -0.5 * kLowerHeight);
  lower.fixed_vertices = vertices_at_height(*lower_mesh, -0.5 * kLowerHeight);
  scene.lower = world.add_body(lower);

  // Upper body: a block (deformable or the kinematic instrument), bottom face at z = -overlap.
  const BoxMeshSpec upper_spec{Vec3(kUpperSize, kUpperSize, kUpperHeight), 4, 4, 2};
  TetMeshPtr upper_mesh;
  if (c.sliver) {
    upper_mesh = make_sliver_box(upper_spec, &scene.min_dihedral_deg);
    if (!upper_mesh) {
      scene.ok = false;
      return scene;
    }
  } else {
    upper_mesh = make_box_mesh(upper_spec);
    scene.min_dihedral_deg = compute_mesh_quality(*upper_mesh).min_dihedral_deg;
  }
  const double upper_volume = upper_mesh->total_rest_volume();
  const double density = c.upper_mass > 0.0 ? c.upper_mass / upper_volume : 1000.0;
  const double overlap = c.overlap_fraction * kUpperHeight;
  BodyDef upper{.name = "upper", .mesh = upper_mesh, .material = material(e_upper, c.poisson, density)};
  // Off-centre by a fraction of a cell so no vertex sits exactly on the lower block's vertices.
  scene.start = Vec3(0.0013, -0.0007, 0.5 * kUpperHeight - overlap);
  upper.pose.translation = scene.start;
  if (c.partner == Partner::instrument) upper.motion = BodyMotion::kinematic;
  scene.upper = world.add_body(upper);

  for (BodyId id : {scene.lower, scene.upper}) {
    const Body& b = world.body(id);
    if (b.is_kinematic()) continue;
    const Aabb box = b.mesh->rest_bounds();
    scene.scale += b.total_mass() * world.settings().gravity.norm() * (box.max - box.min).z();
  }
  return scene;
}

/// Runs one case and measures it.
inline Outcome run_case(const Case& c) {
  Outcome out;
  const WorldSettings settings = world_settings(c);
  World world(settings);
  const Scene scene = build_scene(c, world);
  out.min_dihedral_deg = scene.min_dihedral_deg;
  if (!scene.ok) {
    out.finite = false;
    out.message = "could not build a sliver mesh";
    return out;
  }
  const BodyId lower_id = scene.lower, upper_id = scene.upper;
  const Vec3 start = scene.start;
  const double scale = scene.scale;

  const int steps = std::clamp(static_cast<int>(std::lround(c.duration / c.dt)), kMinSteps, kMaxSteps);
  out.steps = steps;
  out.overlap_bound = kOverlapFraction * std::min(kUpperHeight, kLowerHeight);

  // Energy floor: a small fraction of the gravitational scale of the deformable bodies.
  const double floor = kEnergyFloorFraction * scale;

  double injected = 0.0;
  const double press_time = c.press_depth / c.speed;
  for (int i = 0; i < steps; ++i) {
    auto command = [&](double t) {
      if (c.partner != Partner::instrument) return;
      Pose pose;
      pose.translation = start - Vec3(0, 0, c.speed * std::min(t, press_time));
      world.set_kinematic_pose(upper_id, pose);
    };
    const double t0 = world.time();
    command(t0 + c.dt);
    StepReport r = world.step(c.dt);
    if (r.fault != StepFault::none) {
      if (out.message.empty()) out.message = r.fault_message;
      command(t0 + 0.5 * c.dt);
      r = world.step(0.5 * c.dt);
      if (r.fault == StepFault::none) {
        command(t0 + c.dt);
        r = world.step(0.5 * c.dt);
      }
      if (r.fault != StepFault::none || !r.all_finite) {
        out.finite = false;
        out.message = r.fault_message;
        return out;
      }
      ++out.handled_faults;
    }
    if (!r.all_finite) {
      out.finite = false;
      return out;
    }
    if (i == 0) {
      // What resolving the initial overlap injects: the energy after the first step, plus the
      // penalty springs' potential k d^2 / 2 at the first contacts (not part of StepReport energy).
      injected = std::max(0.0, r.energy.total() - r.energy.work_by_kinematic);
      if (c.method == ContactMethod::penalty) {
        for (const VertexContact& vc : world.contacts()) {
          injected += 0.5 * settings.contact.penalty_stiffness * vc.penetration_depth * vc.penetration_depth;
        }
      }
    }
    if (c.trace != nullptr) {
      std::fprintf(c.trace, "%d t=%.4g KE=%.4g EL=%.4g GR=%.4g W=%.4g tot=%.4g ovl=%.3g pen=%.3g nc=%d\n", i, r.time,
                   r.energy.kinetic, r.energy.elastic, r.energy.gravitational, r.energy.work_by_kinematic,
                   r.energy.total(), r.max_residual_overlap, r.max_penetration_before, r.colliding_vertices);
    }
    const double budget = injected + std::max(0.0, r.energy.work_by_kinematic) + floor;
    out.max_energy_ratio = std::max(out.max_energy_ratio, r.energy.total() / budget);
    out.max_energy_excess = std::max(out.max_energy_excess, (r.energy.total() - (budget - floor)) / scale);
    out.max_overlap = std::max(out.max_overlap, r.max_residual_overlap);
    if (i >= steps / 2) out.max_overlap_late = std::max(out.max_overlap_late, r.max_residual_overlap);
  }
  if (c.partner == Partner::block) {
    auto mean_z = [&](BodyId id) {
      double z = 0.0;
      for (const Vec3& p : world.body(id).positions) z += p.z();
      return z / world.body(id).vertex_count();
    };
    out.passed_through = mean_z(upper_id) < mean_z(lower_id);
  }
  return out;
}

/// One table row of docs/stability.md.
inline std::string table_row(const Case& c, const Outcome& o) {
  char buf[768];
  std::snprintf(buf, sizeof buf, "| %s | %s | %s | %.3g (excess %.2g) | %.3g mm (late %.3g mm) | %s%s%s%s%s |",
                c.name.c_str(), to_string(c.method), o.finite ? "yes" : "NO", o.max_energy_ratio,
                std::max(0.0, o.max_energy_excess), o.max_overlap * 1e3, o.max_overlap_late * 1e3,
                o.passed() ? "pass" : "FAIL", o.passed_through ? ", passed through" : "",
                o.handled_faults > 0 ? (", " + std::to_string(o.handled_faults) + " handled faults").c_str() : "",
                c.sliver ? (", min dihedral " + std::to_string(o.min_dihedral_deg) + " deg").c_str() : "",
                o.message.empty() ? "" : (", " + o.message).c_str());
  return buf;
}

/// Runs a case and expects all three checks to pass, printing its table row.
inline void expect_stable(const Case& c) {
  const Outcome o = run_case(c);
  std::printf("%s\n", table_row(c, o).c_str());
  EXPECT_TRUE(o.finite) << c.name << ": " << o.message;
  EXPECT_LE(o.max_energy_ratio, 1.0 + kEnergyTolerance) << c.name << ": energy exceeds the work put in";
  EXPECT_LE(o.max_overlap_late, o.overlap_bound) << c.name << ": residual overlap unbounded";
  EXPECT_FALSE(o.passed_through) << c.name << ": the upper block passed through the lower one";
  if (c.sliver) {
    EXPECT_LT(o.min_dihedral_deg, 1.0) << c.name;
  }
}

}  // namespace pliant::stability
