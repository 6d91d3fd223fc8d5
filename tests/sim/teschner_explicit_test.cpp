// Teschner et al. 2004 explicit model against references: the stable-step estimate is conservative
// but not wasteful compared with the true highest frequency (power iteration on M^-1 K, K by finite
// differences of the forces), substeps are reported, energy stays bounded without damping, and
// inverted elements recover through the signed volume term.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sim/mesh/box_mesh.h"
#include "sim/model/teschner_explicit.h"

namespace pliant {
namespace {

Material material(double E, double nu, double alpha = 0.0, double beta = 0.0) {
  Material m;
  m.young_modulus = E;
  m.poisson_ratio = nu;
  m.density = 1000.0;
  m.mass_damping = alpha;
  m.stiffness_damping = beta;
  return m;
}

// Largest eigenvalue of M^-1 K at rest (rad^2/s^2), K p from central differences of the forces.
double highest_frequency_squared(TeschnerExplicit& model, const TetMesh& mesh, std::span<const double> masses) {
  const auto n = static_cast<size_t>(mesh.vertex_count());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3> p(n), xp(n), xm(n), fp(n), fm(n);
  for (auto& v : p) v = Vec3(u(rng), u(rng), u(rng));
  const double e = 1e-7 * mesh.mean_edge_length();
  double lambda = 0.0;
  for (int it = 0; it < 400; ++it) {
    double pn = 0.0;
    for (const auto& v : p) pn += v.squaredNorm();
    pn = std::sqrt(pn);
    for (size_t i = 0; i < n; ++i) {
      p[i] /= pn;
      xp[i] = mesh.rest_positions()[i] + e * p[i];
      xm[i] = mesh.rest_positions()[i] - e * p[i];
    }
    model.internal_forces(xp, fp);
    model.internal_forces(xm, fm);
    double rayleigh = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const Vec3 Kp = -(fp[i] - fm[i]) / (2.0 * e);
      rayleigh += p[i].dot(Kp / masses[i]);
      p[i] = Kp / masses[i];
    }
    lambda = rayleigh;
  }
  return lambda;
}

TEST(TeschnerExplicit, StableStepIsConservativeAgainstTrueHighestFrequency) {
  for (double nu : {0.2, 0.45}) {
    const auto mesh = make_box_mesh({Vec3(0.1, 0.1, 0.1), 3, 3, 3});
    TeschnerExplicit model(mesh, material(1e4, nu), {});
    const std::vector<double> masses = mesh->lumped_masses(1000.0);
    const double omega = std::sqrt(highest_frequency_squared(model, *mesh, masses));
    const double limit = 2.0 / omega;  // symplectic Euler, undamped
    const double h = model.stable_time_step(masses);
    EXPECT_LT(h, TeschnerExplicit::kStabilitySafety * limit * 1.0001) << "nu " << nu;
    EXPECT_GT(h, 0.1 * limit) << "nu " << nu << ": estimate needlessly small";
  }
}

double total_energy(TeschnerExplicit& model, std::span<const Vec3> x, std::span<const Vec3> v,
                    std::span<const double> masses) {
  double kinetic = 0.0;
  for (size_t i = 0; i < x.size(); ++i) kinetic += 0.5 * masses[i] * v[i].squaredNorm();
  return kinetic + model.elastic_energy(x);
}

TEST(TeschnerExplicit, SubstepsAndBoundedEnergyWithoutDamping) {
  const auto mesh = make_box_mesh({Vec3(0.2, 0.1, 0.1), 4, 2, 2});
  const Material m = material(1e4, 0.3);
  TeschnerExplicit model(mesh, m, {});
  const auto n = static_cast<size_t>(mesh->vertex_count());
  const std::vector<double> masses = mesh->lumped_masses(m.density);
  const std::vector<char> fixed(n, 0);
  const std::vector<Vec3> ext(n, Vec3::Zero());
  std::vector<Vec3> x = mesh->rest_positions(), v(n);
  for (size_t i = 0; i < n; ++i) {
    const double a = 1.0 * x[i].x();
    x[i] = Vec3(1.1 * x[i].x(), std::cos(a) * x[i].y() - std::sin(a) * x[i].z(), std::sin(a) * x[i].y() + std::cos(a) * x[i].z());
    v[i] = Vec3(0.0, 0.0, 3.0).cross(x[i]);
  }
  const double dt = 1e-2;
  const double h = model.stable_time_step(masses);
  ASSERT_LT(h, dt);
  const double initial = total_energy(model, x, v, masses);
  double lowest = initial, highest = initial;
  for (int step = 0; step < 100; ++step) {
    const IntegrationResult r = model.advance(x, v, {masses, fixed, ext, dt});
    ASSERT_EQ(r.substeps, static_cast<int>(std::ceil(dt / h)));
    const double energy = total_energy(model, x, v, masses);
    lowest = std::min(lowest, energy);
    highest = std::max(highest, energy);
  }
  // Symplectic Euler conserves a nearby energy: no drift up (instability), no numerical dissipation.
  EXPECT_LT(highest, 1.1 * initial);
  EXPECT_GT(lowest, 0.9 * initial);
}

TEST(TeschnerExplicit, InvertedElementsRecoverThroughSignedVolume) {
  for (double squash : {-1.0, -0.3}) {
    const bool single = squash == -1.0;
    const auto mesh = single ? TetMesh::build({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}, {{0, 1, 2, 3}})
                             : make_box_mesh({Vec3(0.1, 0.1, 0.1), 2, 2, 2});
    const Material m = material(1e4, 0.3, 5.0, 0.01);
    TeschnerExplicit model(mesh, m, {});
    const auto n = static_cast<size_t>(mesh->vertex_count());
    std::vector<Vec3> x = mesh->rest_positions(), v(n, Vec3::Zero());
    for (auto& p : x) p.z() *= squash;
    const std::vector<double> masses = mesh->lumped_masses(m.density);
    const std::vector<char> fixed(n, 0);
    const std::vector<Vec3> ext(n, Vec3::Zero());
    for (int step = 0; step < 300; ++step) model.advance(x, v, {masses, fixed, ext, 1e-2});
    for (int t = 0; t < mesh->tet_count(); ++t) {
      const auto& tet = mesh->tets()[static_cast<size_t>(t)];
      const double V = signed_tet_volume(x[static_cast<size_t>(tet[0])], x[static_cast<size_t>(tet[1])],
                                         x[static_cast<size_t>(tet[2])], x[static_cast<size_t>(tet[3])]);
      EXPECT_NEAR(V, mesh->rest_volumes()[static_cast<size_t>(t)], 1e-3 * mesh->rest_volumes()[static_cast<size_t>(t)])
          << "squash " << squash << " tet " << t;
    }
  }
}

TEST(TeschnerExplicit, GivenStiffnessesAreThePapersConstants) {
  // A single tet: stretching edge 0-1 by 10% with the others kept costs k_d C^2 / 2 for that edge
  // plus the volume term, both from the settings as given.
  const auto mesh = TetMesh::build({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}, {{0, 1, 2, 3}});
  ModelSettings s;
  s.distance_stiffness = 2.0;
  s.volume_stiffness = 3.0;
  TeschnerExplicit model(mesh, material(1e4, 0.3), s);
  std::vector<Vec3> x = mesh->rest_positions();
  x[1].x() = 1.1;
  const double edge = [&] {
    double e = 0.0;
    for (auto [a, b] : {std::pair{1, 2}, std::pair{1, 3}}) {
      const double D0 = (mesh->rest_positions()[static_cast<size_t>(a)] - mesh->rest_positions()[static_cast<size_t>(b)]).norm();
      const double C = ((x[static_cast<size_t>(a)] - x[static_cast<size_t>(b)]).norm() - D0) / D0;
      e += 0.5 * s.distance_stiffness * C * C;
    }
    return e + 0.5 * s.distance_stiffness * 0.1 * 0.1;
  }();
  const double volume = 0.5 * s.volume_stiffness * 0.1 * 0.1;  // V grows by 10%
  EXPECT_NEAR(model.elastic_energy(x), edge + volume, 1e-14);
}

}  // namespace
}  // namespace pliant
