#include "sim/model/teschner_explicit.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pliant {

namespace {

/// dV/dp for the four corners of tet (a, b, c, d), V = (b-a).((c-a)x(d-a))/6.
inline std::array<Vec3, 4> volume_gradient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  std::array<Vec3, 4> g;
  g[1] = (c - a).cross(d - a) / 6.0;
  g[2] = (d - a).cross(b - a) / 6.0;
  g[3] = (b - a).cross(c - a) / 6.0;
  g[0] = -(g[1] + g[2] + g[3]);
  return g;
}

/// dA/dp for the corners of triangle (a, b, c); false if the triangle is degenerate (no gradient).
inline bool area_gradient(const Vec3& a, const Vec3& b, const Vec3& c, double& area, std::array<Vec3, 3>& g) {
  const Vec3 N = (b - a).cross(c - a);
  const double norm = N.norm();
  area = 0.5 * norm;
  if (!(norm > 0.0)) return false;
  const Vec3 n = N / norm;
  g[1] = 0.5 * (c - a).cross(n);
  g[2] = 0.5 * n.cross(b - a);
  g[0] = -(g[1] + g[2]);
  return true;
}

}  // namespace

TeschnerExplicit::TeschnerExplicit(TetMeshPtr mesh, const Material& material, const ModelSettings& settings)
    : mesh_(std::move(mesh)), accuracy_(settings.accuracy), alpha_(material.mass_damping) {
  const auto& X = mesh_->rest_positions();
  const auto& tets = mesh_->tets();
  const auto& edges = mesh_->edges();
  const auto n = static_cast<size_t>(mesh_->vertex_count());
  const double mu = material.lame_mu();
  const double lambda = material.lame_lambda();

  // Volume each edge stands for: a sixth of every tet around it.
  vertex_edge_offsets_.assign(n + 1, 0);
  for (const Edge& e : edges) {
    vertex_edge_offsets_[static_cast<size_t>(e.a) + 1]++;
    vertex_edge_offsets_[static_cast<size_t>(e.b) + 1]++;
  }
  for (size_t i = 0; i < n; ++i) vertex_edge_offsets_[i + 1] += vertex_edge_offsets_[i];
  vertex_edges_.assign(static_cast<size_t>(vertex_edge_offsets_[n]), 0);
  {
    std::vector<int> fill(vertex_edge_offsets_.begin(), vertex_edge_offsets_.end() - 1);
    for (size_t k = 0; k < edges.size(); ++k) {
      vertex_edges_[static_cast<size_t>(fill[static_cast<size_t>(edges[k].a)]++)] = static_cast<int>(k);
      vertex_edges_[static_cast<size_t>(fill[static_cast<size_t>(edges[k].b)]++)] = static_cast<int>(k);
    }
  }
  std::vector<double> edge_volume(edges.size(), 0.0);
  for (size_t t = 0; t < tets.size(); ++t) {
    for (size_t i = 0; i < 4; ++i) {
      for (size_t j = i + 1; j < 4; ++j) {
        const int a = std::min(tets[t][i], tets[t][j]);
        const int b = std::max(tets[t][i], tets[t][j]);
        const auto row = std::span<const int>(vertex_edges_).subspan(
            static_cast<size_t>(vertex_edge_offsets_[static_cast<size_t>(a)]),
            static_cast<size_t>(vertex_edge_offsets_[static_cast<size_t>(a) + 1] -
                                vertex_edge_offsets_[static_cast<size_t>(a)]));
        for (int k : row) {
          if (edges[static_cast<size_t>(k)].b == b && edges[static_cast<size_t>(k)].a == a) {
            edge_volume[static_cast<size_t>(k)] += mesh_->rest_volumes()[t] / 6.0;
          }
        }
      }
    }
  }

  // Stiffnesses. Derived (docs/deformation-models.md): an isotropic network of edge springs with
  // k = 15 mu V_edge has shear modulus mu and lambda = mu (Cauchy solid); the volume term adds the
  // rest of lambda, k_V = max(lambda - mu, mu / 2) V0. The area term is off unless set.
  derived_damping_ = !(settings.distance_damping > 0.0);
  edge_rest_length_.resize(edges.size());
  edge_stiffness_.resize(edges.size());
  edge_damping_.resize(edges.size());
  for (size_t k = 0; k < edges.size(); ++k) {
    edge_rest_length_[k] = (X[static_cast<size_t>(edges[k].b)] - X[static_cast<size_t>(edges[k].a)]).norm();
    edge_stiffness_[k] = settings.distance_stiffness > 0.0 ? settings.distance_stiffness : 15.0 * mu * edge_volume[k];
    edge_damping_[k] = settings.distance_damping > 0.0 ? settings.distance_damping
                                                       : material.stiffness_damping * edge_stiffness_[k];
    if (edge_stiffness_[k] > 0.0) max_damping_ratio_ = std::max(max_damping_ratio_, edge_damping_[k] / edge_stiffness_[k]);
  }
  tet_stiffness_.resize(tets.size());
  for (size_t t = 0; t < tets.size(); ++t) {
    tet_stiffness_[t] = settings.volume_stiffness > 0.0 ? settings.volume_stiffness
                                                        : std::max(lambda - mu, 0.5 * mu) * mesh_->rest_volumes()[t];
  }
  const auto nf = static_cast<size_t>(mesh_->surface_triangle_count());
  triangle_rest_area_.resize(nf);
  triangle_stiffness_.assign(nf, std::max(settings.area_stiffness, 0.0));
  for (size_t f = 0; f < nf; ++f) triangle_rest_area_[f] = mesh_->triangle_area(X, static_cast<int>(f));

  // Gershgorin bound on the constraint stiffness per vertex, from the rest gradients.
  frequency_bound_.assign(n, 0.0);
  for (size_t k = 0; k < edges.size(); ++k) {
    const double s = 2.0 * edge_stiffness_[k] / (edge_rest_length_[k] * edge_rest_length_[k]);
    frequency_bound_[static_cast<size_t>(edges[k].a)] += s;
    frequency_bound_[static_cast<size_t>(edges[k].b)] += s;
  }
  for (size_t t = 0; t < tets.size(); ++t) {
    const auto& tet = tets[t];
    const auto g = volume_gradient(X[static_cast<size_t>(tet[0])], X[static_cast<size_t>(tet[1])],
                                   X[static_cast<size_t>(tet[2])], X[static_cast<size_t>(tet[3])]);
    const double V0 = mesh_->rest_volumes()[t];
    double sum = 0.0;
    for (const auto& gi : g) sum += gi.norm() / V0;
    for (size_t i = 0; i < 4; ++i) frequency_bound_[static_cast<size_t>(tet[i])] += tet_stiffness_[t] * g[i].norm() / V0 * sum;
  }
  for (size_t f = 0; f < nf; ++f) {
    if (!(triangle_stiffness_[f] > 0.0)) continue;
    const auto& tri = mesh_->surface_triangles()[f];
    double area = 0.0;
    std::array<Vec3, 3> g;
    if (!area_gradient(X[static_cast<size_t>(tri[0])], X[static_cast<size_t>(tri[1])], X[static_cast<size_t>(tri[2])], area, g)) continue;
    const double A0 = triangle_rest_area_[f];
    double sum = 0.0;
    for (const auto& gi : g) sum += gi.norm() / A0;
    for (size_t i = 0; i < 3; ++i) frequency_bound_[static_cast<size_t>(tri[i])] += triangle_stiffness_[f] * g[i].norm() / A0 * sum;
  }
  accel_.assign(n, Vec3::Zero());
}

void TeschnerExplicit::forces(std::span<const Vec3> x, const Vec3* vel, std::span<Vec3> f) const {
  std::fill(f.begin(), f.end(), Vec3::Zero());
  const auto& edges = mesh_->edges();
  for (size_t k = 0; k < edges.size(); ++k) {
    const auto a = static_cast<size_t>(edges[k].a), b = static_cast<size_t>(edges[k].b);
    const Vec3 d = x[b] - x[a];
    const double len = d.norm();
    if (!(len > 0.0)) continue;  // coincident ends: no direction, no force
    const double D0 = edge_rest_length_[k];
    const Vec3 grad = d / (len * D0);  // dC/dx_b
    double s = -edge_stiffness_[k] * (len - D0) / D0;
    if (vel != nullptr) s -= damping_scale_ * edge_damping_[k] * grad.dot(vel[b] - vel[a]);
    f[b] += s * grad;
    f[a] -= s * grad;
  }
  const auto& tets = mesh_->tets();
  for (size_t t = 0; t < tets.size(); ++t) {
    const auto& tet = tets[t];
    const Vec3 &p0 = x[static_cast<size_t>(tet[0])], &p1 = x[static_cast<size_t>(tet[1])],
               &p2 = x[static_cast<size_t>(tet[2])], &p3 = x[static_cast<size_t>(tet[3])];
    const double V0 = mesh_->rest_volumes()[t];
    const double C = (signed_tet_volume(p0, p1, p2, p3) - V0) / V0;
    const auto g = volume_gradient(p0, p1, p2, p3);
    const double s = -tet_stiffness_[t] * C / V0;
    for (size_t i = 0; i < 4; ++i) f[static_cast<size_t>(tet[i])] += s * g[i];
  }
  const auto& tris = mesh_->surface_triangles();
  for (size_t t = 0; t < tris.size(); ++t) {
    if (!(triangle_stiffness_[t] > 0.0)) continue;
    const auto& tri = tris[t];
    double area = 0.0;
    std::array<Vec3, 3> g;
    if (!area_gradient(x[static_cast<size_t>(tri[0])], x[static_cast<size_t>(tri[1])], x[static_cast<size_t>(tri[2])], area, g)) continue;
    const double A0 = triangle_rest_area_[t];
    const double s = -triangle_stiffness_[t] * (area - A0) / (A0 * A0);
    for (size_t i = 0; i < 3; ++i) f[static_cast<size_t>(tri[i])] += s * g[i];
  }
}

Vec3 TeschnerExplicit::vertex_force(std::span<const Vec3> x, const Vec3* vel, int v) const {
  Vec3 f = Vec3::Zero();
  const auto vs = static_cast<size_t>(v);
  const auto& edges = mesh_->edges();
  for (int e = vertex_edge_offsets_[vs]; e < vertex_edge_offsets_[vs + 1]; ++e) {
    const auto k = static_cast<size_t>(vertex_edges_[static_cast<size_t>(e)]);
    const auto o = static_cast<size_t>(edges[k].a == v ? edges[k].b : edges[k].a);
    const Vec3 d = x[vs] - x[o];
    const double len = d.norm();
    if (!(len > 0.0)) continue;
    const double D0 = edge_rest_length_[k];
    const Vec3 grad = d / (len * D0);  // dC/dx_v
    double s = -edge_stiffness_[k] * (len - D0) / D0;
    if (vel != nullptr) s -= damping_scale_ * edge_damping_[k] * grad.dot(vel[vs] - vel[o]);
    f += s * grad;
  }
  for (int t : mesh_->vertex_tets(v)) {
    const auto& tet = mesh_->tets()[static_cast<size_t>(t)];
    const Vec3 &p0 = x[static_cast<size_t>(tet[0])], &p1 = x[static_cast<size_t>(tet[1])],
               &p2 = x[static_cast<size_t>(tet[2])], &p3 = x[static_cast<size_t>(tet[3])];
    const double V0 = mesh_->rest_volumes()[static_cast<size_t>(t)];
    const double C = (signed_tet_volume(p0, p1, p2, p3) - V0) / V0;
    const auto g = volume_gradient(p0, p1, p2, p3);
    for (size_t i = 0; i < 4; ++i) {
      if (tet[i] == v) f += -tet_stiffness_[static_cast<size_t>(t)] * C / V0 * g[i];
    }
  }
  for (int t : mesh_->vertex_surface_triangles(v)) {
    const auto ts = static_cast<size_t>(t);
    if (!(triangle_stiffness_[ts] > 0.0)) continue;
    const auto& tri = mesh_->surface_triangles()[ts];
    double area = 0.0;
    std::array<Vec3, 3> g;
    if (!area_gradient(x[static_cast<size_t>(tri[0])], x[static_cast<size_t>(tri[1])], x[static_cast<size_t>(tri[2])], area, g)) continue;
    const double A0 = triangle_rest_area_[ts];
    for (size_t i = 0; i < 3; ++i) {
      if (tri[i] == v) f += -triangle_stiffness_[ts] * (area - A0) / (A0 * A0) * g[i];
    }
  }
  return f;
}

void TeschnerExplicit::internal_forces(std::span<const Vec3> x, std::span<Vec3> f) { forces(x, nullptr, f); }

void TeschnerExplicit::internal_forces_at(std::span<const Vec3> x, std::span<const int> vertices,
                                          std::span<Vec3> f) {
  for (size_t k = 0; k < vertices.size(); ++k) f[k] = vertex_force(x, nullptr, vertices[k]);
}

double TeschnerExplicit::elastic_energy(std::span<const Vec3> x) {
  double energy = 0.0;
  const auto& edges = mesh_->edges();
  for (size_t k = 0; k < edges.size(); ++k) {
    const double len = (x[static_cast<size_t>(edges[k].b)] - x[static_cast<size_t>(edges[k].a)]).norm();
    const double C = (len - edge_rest_length_[k]) / edge_rest_length_[k];
    energy += 0.5 * edge_stiffness_[k] * C * C;
  }
  const auto& tets = mesh_->tets();
  for (size_t t = 0; t < tets.size(); ++t) {
    const auto& tet = tets[t];
    const double V0 = mesh_->rest_volumes()[t];
    const double C = (signed_tet_volume(x[static_cast<size_t>(tet[0])], x[static_cast<size_t>(tet[1])],
                                        x[static_cast<size_t>(tet[2])], x[static_cast<size_t>(tet[3])]) - V0) / V0;
    energy += 0.5 * tet_stiffness_[t] * C * C;
  }
  const auto nf = triangle_stiffness_.size();
  for (size_t t = 0; t < nf; ++t) {
    if (!(triangle_stiffness_[t] > 0.0)) continue;
    const double C = (mesh_->triangle_area(x, static_cast<int>(t)) - triangle_rest_area_[t]) / triangle_rest_area_[t];
    energy += 0.5 * triangle_stiffness_[t] * C * C;
  }
  return energy;
}

double TeschnerExplicit::stable_time_step(std::span<const double> masses) const {
  double omega2 = 0.0;
  for (size_t i = 0; i < frequency_bound_.size(); ++i) {
    if (masses[i] > 0.0) omega2 = std::max(omega2, frequency_bound_[i] / masses[i]);
  }
  if (!(omega2 > 0.0)) return std::numeric_limits<double>::infinity();
  const double omega = std::sqrt(omega2);
  // Symplectic Euler with damping ratio zeta is stable for h < 2/omega (sqrt(1 + zeta^2) - zeta).
  const double zeta = 0.5 * (omega * max_damping_ratio_ * damping_scale_for(omega) + alpha_ / omega);
  return kStabilitySafety * 2.0 / omega * (std::sqrt(1.0 + zeta * zeta) - zeta);
}

double TeschnerExplicit::damping_scale_for(double omega) const {
  // Derived (Rayleigh) damping beyond critical on the highest mode only costs substeps: cap it there.
  if (!derived_damping_ || !(omega * max_damping_ratio_ > 2.0)) return 1.0;
  return 2.0 / (omega * max_damping_ratio_);
}

IntegrationResult TeschnerExplicit::advance(std::span<Vec3> x, std::span<Vec3> v, const IntegrationInput& in) {
  IntegrationResult result;
  double omega2 = 0.0;
  for (size_t i = 0; i < frequency_bound_.size(); ++i) {
    if (in.masses[i] > 0.0) omega2 = std::max(omega2, frequency_bound_[i] / in.masses[i]);
  }
  damping_scale_ = damping_scale_for(std::sqrt(omega2));
  const double h_stable = stable_time_step(in.masses);
  const double ratio = in.dt / h_stable;
  const int substeps = ratio <= 1.0 ? 1 : static_cast<int>(std::min(std::ceil(ratio), double(kMaxSubsteps)));
  const double h = in.dt / substeps;
  const size_t n = x.size();
  for (int s = 0; s < substeps; ++s) {
    forces(x, v.data(), accel_);
    // Symplectic Euler (= position Verlet with x_prev = x - h v): v+ = v + h a, x+ = x + h v+.
    for (size_t i = 0; i < n; ++i) {
      if (in.fixed[i] != 0 || !(in.masses[i] > 0.0)) {
        v[i].setZero();
        continue;
      }
      v[i] += h * ((accel_[i] + in.external_forces[i]) / in.masses[i] - alpha_ * v[i]);
      x[i] += h * v[i];
    }
  }
  result.substeps = substeps;
  return result;
}

}  // namespace pliant
