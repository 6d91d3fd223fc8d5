// Properties both deformation models must have, each against an honest reference: forces equal the
// negative energy gradient (central finite differences), the local query equals the global rows,
// rigid motions cost nothing, a free body keeps its momentum, extremes stay finite, bad settings
// are rejected, and World + model make a column under gravity sag by rho g L^2 / (2E).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "sim/input_error.h"
#include "sim/mesh/box_mesh.h"
#include "sim/model/deformation_model.h"
#include "sim/world.h"

namespace pliant {
namespace {

Material soft_material(double E = 1e4, double nu = 0.3) {
  Material m;
  m.young_modulus = E;
  m.poisson_ratio = nu;
  m.density = 1000.0;
  m.mass_damping = 0.0;
  m.stiffness_damping = 0.0;
  return m;
}

ModelSettings settings_for(ModelKind kind) {
  ModelSettings s;
  if (kind == ModelKind::teschner_explicit) s.area_stiffness = 0.5;  // exercise the area term too
  return s;
}

// Rest positions moved by a random field of amplitude `amplitude` (m).
std::vector<Vec3> perturbed(const TetMesh& mesh, double amplitude, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3> x = mesh.rest_positions();
  for (auto& p : x) p += amplitude * Vec3(u(rng), u(rng), u(rng));
  return x;
}

double norm(const std::vector<Vec3>& f) {
  double s = 0.0;
  for (const auto& v : f) s += v.squaredNorm();
  return std::sqrt(s);
}

Vec3 linear_momentum(std::span<const Vec3> v, std::span<const double> m) {
  Vec3 p = Vec3::Zero();
  for (size_t i = 0; i < v.size(); ++i) p += m[i] * v[i];
  return p;
}

Vec3 angular_momentum(std::span<const Vec3> x, std::span<const Vec3> v, std::span<const double> m) {
  Vec3 l = Vec3::Zero();
  for (size_t i = 0; i < v.size(); ++i) l += m[i] * x[i].cross(v[i]);
  return l;
}

class ModelProperties : public ::testing::TestWithParam<ModelKind> {};

TEST_P(ModelProperties, ForcesAreMinusEnergyGradientByCentralDifferences) {
  const auto mesh = make_box_mesh({Vec3(0.1, 0.08, 0.06), 2, 2, 2});
  const Material material = soft_material();
  auto model = make_deformation_model(GetParam(), mesh, material, settings_for(GetParam()));
  for (unsigned seed : {1u, 2u, 3u}) {
    std::vector<Vec3> x = perturbed(*mesh, 0.012, seed);
    // Also rotate the whole configuration so the rotations are far from identity.
    const Mat3 Q = Eigen::AngleAxisd(0.7 + seed, Vec3(1, 2, 3).normalized()).toRotationMatrix();
    for (auto& p : x) p = Q * p;
    std::vector<Vec3> f(x.size());
    model->internal_forces(x, f);
    std::vector<Vec3> fd(x.size());
    const double eps = 1e-7;
    for (size_t i = 0; i < x.size(); ++i) {
      for (int k = 0; k < 3; ++k) {
        const double saved = x[i][k];
        x[i][k] = saved + eps;
        const double ep = model->elastic_energy(x);
        x[i][k] = saved - eps;
        const double em = model->elastic_energy(x);
        x[i][k] = saved;
        fd[i][k] = -(ep - em) / (2.0 * eps);
      }
    }
    std::vector<Vec3> diff(x.size());
    for (size_t i = 0; i < x.size(); ++i) diff[i] = f[i] - fd[i];
    ASSERT_GT(norm(f), 1e-3) << "deformation too small to test";
    EXPECT_LT(norm(diff) / norm(f), 1e-5) << "seed " << seed;

    // The local query returns exactly the rows of the global evaluation.
    const std::vector<int> vertices = {0, 4, 13, 17, 26};
    std::vector<Vec3> local(vertices.size());
    model->internal_forces_at(x, vertices, local);
    for (size_t k = 0; k < vertices.size(); ++k) {
      EXPECT_LT((local[k] - f[static_cast<size_t>(vertices[k])]).norm(), 1e-9 * norm(f)) << "vertex " << vertices[k];
    }
  }
}

TEST_P(ModelProperties, RigidMotionOfRestShapeHasNoForceOrEnergy) {
  const auto mesh = make_box_mesh({Vec3(0.1, 0.08, 0.06), 2, 2, 2});
  const Material material = soft_material();
  auto model = make_deformation_model(GetParam(), mesh, material, settings_for(GetParam()));
  // Reference scale: the force of a 1% random deformation.
  std::vector<Vec3> f(static_cast<size_t>(mesh->vertex_count()));
  model->internal_forces(perturbed(*mesh, 0.001, 7), f);
  const double scale = norm(f);
  // pi: an identity warm start faces away from F (the saddle of tr(R^T F); the SVD restart).
  for (double angle : {0.3, 2.0, 3.1, std::numbers::pi}) {
    const Mat3 Q = Eigen::AngleAxisd(angle, Vec3(-1, 0.5, 2).normalized()).toRotationMatrix();
    std::vector<Vec3> x = mesh->rest_positions();
    for (auto& p : x) p = Q * p + Vec3(0.3, -2.0, 1.5);
    model->internal_forces(x, f);
    EXPECT_LT(norm(f), 1e-10 * scale) << "angle " << angle;
    EXPECT_LT(model->elastic_energy(x), 1e-20) << "angle " << angle;
  }
}

struct MomentumDrift {
  double linear = 0.0;   ///< |P1 - P0| / |P0|
  double angular = 0.0;  ///< |L1 - L0| / |L0|
};

// A free, spinning, deformed body without gravity or damping, run for `duration` (s) at step dt.
MomentumDrift free_body_drift(ModelKind kind, double dt, double duration, double amplitude = 0.005) {
  const auto mesh = make_box_mesh({Vec3(0.1, 0.08, 0.06), 3, 2, 2});
  const Material material = soft_material();
  ModelSettings settings = settings_for(kind);
  settings.accuracy.max_solver_iterations = 2000;
  settings.accuracy.solver_tolerance = 1e-13;
  auto model = make_deformation_model(kind, mesh, material, settings);
  const auto n = static_cast<size_t>(mesh->vertex_count());
  std::vector<Vec3> x = perturbed(*mesh, amplitude, 11);
  std::vector<Vec3> v(n);
  const Vec3 omega(1.0, -2.0, 0.5), v0(0.1, 0.2, -0.3);
  for (size_t i = 0; i < n; ++i) v[i] = v0 + omega.cross(x[i]);
  const std::vector<double> masses = mesh->lumped_masses(material.density);
  const std::vector<char> fixed(n, 0);
  const std::vector<Vec3> external(n, Vec3::Zero());
  const Vec3 p0 = linear_momentum(v, masses);
  const Vec3 l0 = angular_momentum(x, v, masses);
  const int steps = static_cast<int>(std::lround(duration / dt));
  for (int step = 0; step < steps; ++step) model->advance(x, v, {masses, fixed, external, dt});
  return {(linear_momentum(v, masses) - p0).norm() / p0.norm(),
          (angular_momentum(x, v, masses) - l0).norm() / l0.norm()};
}

TEST_P(ModelProperties, FreeBodyKeepsMomentum) {
  if (GetParam() == ModelKind::teschner_explicit) {
    // Central forces and symplectic Euler: both momenta to round-off.
    const MomentumDrift d = free_body_drift(GetParam(), 1e-3, 0.05);
    EXPECT_LT(d.linear, 1e-12);
    EXPECT_LT(d.angular, 1e-12);
  } else {
    // Linear momentum: exact up to the CG residual. Angular: the elastic forces are torque-free, but
    // the frozen K' = R K R^T of the implicit term is not once the element is deformed (Mueller &
    // Gross drop dR/dx), so the torque is O(h * deformation): tiny for a rigidly spinning body,
    // bounded for a deformed one (about 3% strain here). Measured: 1.2e-7 rigid, 1.4e-3 deformed.
    const MomentumDrift rigid = free_body_drift(GetParam(), 1e-3, 0.05, 0.0);
    const MomentumDrift deformed = free_body_drift(GetParam(), 1e-3, 0.05, 0.001);
    EXPECT_LT(rigid.linear, 1e-10);
    EXPECT_LT(deformed.linear, 1e-10);
    EXPECT_LT(rigid.angular, 1e-5);
    EXPECT_LT(deformed.angular, 1e-2);
  }
}

// A box with its base fixed under gravity must stay finite and bounded.
void run_extreme(ModelKind kind, Vec3 size, const Material& material, double dt, int steps) {
  const auto mesh = make_box_mesh({size, 3, 3, 3});
  auto model = make_deformation_model(kind, mesh, material, {});
  const auto n = static_cast<size_t>(mesh->vertex_count());
  std::vector<Vec3> x = mesh->rest_positions(), v(n, Vec3::Zero());
  const std::vector<double> masses = mesh->lumped_masses(material.density);
  std::vector<char> fixed(n, 0);
  std::vector<Vec3> external(n);
  for (size_t i = 0; i < n; ++i) {
    fixed[i] = x[i].z() < -0.5 * size.z() + 1e-12 ? 1 : 0;
    external[i] = masses[i] * Vec3(0, 0, -9.81);
  }
  for (int s = 0; s < steps; ++s) model->advance(x, v, {masses, fixed, external, dt});
  for (size_t i = 0; i < n; ++i) {
    ASSERT_TRUE(x[i].allFinite() && v[i].allFinite());
    EXPECT_LT((x[i] - mesh->rest_positions()[i]).norm(), size.norm()) << "vertex " << i;
    if (fixed[i]) {
      EXPECT_EQ(x[i], mesh->rest_positions()[i]);
      EXPECT_EQ(v[i], Vec3::Zero());
    }
  }
  EXPECT_TRUE(std::isfinite(model->elastic_energy(x)));
}

TEST_P(ModelProperties, NearlyIncompressibleStaysFinite) {
  Material m = soft_material(1e4, 0.499);
  m.stiffness_damping = 0.01;
  run_extreme(GetParam(), Vec3(0.1, 0.1, 0.1), m, 1e-2, 20);
}

TEST_P(ModelProperties, OneMilligramBodyStaysFinite) {
  Material m = soft_material(5e3, 0.45);
  m.stiffness_damping = 0.01;
  run_extreme(GetParam(), Vec3(1e-3, 1e-3, 1e-3), m, 1e-3, 20);  // 1e-9 m^3 * 1000 kg/m^3 = 1 mg
}

TEST_P(ModelProperties, OneTonneBodyStaysFinite) {
  Material m = soft_material(1e6, 0.45);
  m.stiffness_damping = 0.01;
  run_extreme(GetParam(), Vec3(1.0, 1.0, 1.0), m, 1e-2, 20);  // 1 m^3 * 1000 kg/m^3
}

TEST_P(ModelProperties, RejectsBadSettings) {
  const auto mesh = make_box_mesh({});
  ModelSettings s;
  s.accuracy.max_solver_iterations = 0;
  EXPECT_THROW(make_deformation_model(GetParam(), mesh, soft_material(), s), InputError);
  s = {};
  s.distance_stiffness = -1.0;
  try {
    make_deformation_model(GetParam(), mesh, soft_material(), s);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::bad_value);
    EXPECT_NE(std::string(e.what()).find("distance_stiffness"), std::string::npos);
  }
}

// World + model: a column (nu = 0) on a fixed base under its own weight shortens by
// rho g L^2 / (2 E) at the top, and comes to rest.
TEST_P(ModelProperties, WorldColumnUnderGravitySagsAndComesToRest) {
  WorldSettings ws;
  ws.contact.method = ContactMethod::none;
  World world(ws);
  BodyDef def;
  def.name = "column";
  const double L = 0.2;
  def.mesh = make_box_mesh({Vec3(0.05, 0.05, L), 2, 2, 8});
  def.material = soft_material(2e5, 0.0);
  def.material.mass_damping = 20.0;  // heavy damping: reach the static state quickly
  def.model = GetParam();
  for (int i = 0; i < def.mesh->vertex_count(); ++i) {
    if (def.mesh->rest_positions()[static_cast<size_t>(i)].z() < -0.5 * L + 1e-12) def.fixed_vertices.push_back(i);
  }
  const BodyId id = world.add_body(def);
  for (int s = 0; s < 400; ++s) ASSERT_EQ(world.step(5e-3).fault, StepFault::none);
  const Body& body = world.body(id);
  double top_shift = 0.0;
  int top = 0;
  for (int i = 0; i < body.vertex_count(); ++i) {
    if (def.mesh->rest_positions()[static_cast<size_t>(i)].z() > 0.5 * L - 1e-12) {
      top_shift += body.positions[static_cast<size_t>(i)].z() - def.mesh->rest_positions()[static_cast<size_t>(i)].z();
      ++top;
    }
  }
  top_shift /= top;
  const double expected = -def.material.density * 9.81 * L * L / (2.0 * def.material.young_modulus);
  if (GetParam() == ModelKind::corotational_fem) {
    EXPECT_NEAR(top_shift, expected, 0.05 * std::abs(expected));
  } else {
    // The Teschner constraint network is stiffer than E at nu = 0 (docs/deformation-models.md:
    // the derived springs give an effective modulus of about 1.3 E on an isotropic mesh; 0.69 of the
    // FEM sag measured on this one).
    EXPECT_GT(top_shift / expected, 0.5);
    EXPECT_LT(top_shift / expected, 1.0);
  }
  EXPECT_LT(world.last_report().energy.kinetic, 1e-6 * def.material.density * 9.81 * L * 0.05 * 0.05 * L);
}

INSTANTIATE_TEST_SUITE_P(BothModels, ModelProperties,
                         ::testing::Values(ModelKind::corotational_fem, ModelKind::teschner_explicit),
                         [](const auto& info) { return std::string(to_string(info.param)); });

}  // namespace
}  // namespace pliant
