#include "sim/model/corotational_fem.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/model/rotation_extraction.h"

namespace pliant {

namespace {

constexpr int kRotationIterations = 30;
constexpr double kRotationTolerance = 1e-11;  ///< rad; makes R^T F symmetric to ~1e-11

// Scatters the columns of H (forces on local vertices 1..3) and their negated sum (vertex 0).
inline void scatter_tet(const TetIndices& tet, const Mat3& H, std::span<Vec3> f) {
  f[static_cast<size_t>(tet[0])] -= H.col(0) + H.col(1) + H.col(2);
  for (int j = 0; j < 3; ++j) f[static_cast<size_t>(tet[static_cast<size_t>(j + 1)])] += H.col(j);
}

inline double dot(std::span<const Vec3> a, std::span<const Vec3> b) {
  double s = 0.0;
  for (size_t i = 0; i < a.size(); ++i) s += a[i].dot(b[i]);
  return s;
}

}  // namespace

CorotationalFem::CorotationalFem(TetMeshPtr mesh, const Material& material, const ModelSettings& settings,
                                 StiffnessProduct product)
    : mesh_(std::move(mesh)),
      mu_(material.lame_mu()),
      lambda_(material.lame_lambda()),
      alpha_(material.mass_damping),
      beta_(material.stiffness_damping),
      accuracy_(settings.accuracy),
      product_(product) {
  const auto& X = mesh_->rest_positions();
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  rest_shape_inverse_.resize(nt);
  volume_ = mesh_->rest_volumes();
  rotations_.assign(nt, Quat::Identity());
  rotated_gradients_.resize(nt);
  for (size_t t = 0; t < nt; ++t) {
    const auto& tet = mesh_->tets()[t];
    Mat3 Dm;
    for (int j = 0; j < 3; ++j) {
      Dm.col(j) = X[static_cast<size_t>(tet[static_cast<size_t>(j + 1)])] - X[static_cast<size_t>(tet[0])];
    }
    rest_shape_inverse_[t] = Dm.inverse();  // the mesh guarantees positive volume
    rotated_gradients_[t] = rest_shape_inverse_[t].transpose();
  }
  const auto n = static_cast<size_t>(mesh_->vertex_count());
  for (auto* s : {&forces_, &rhs_, &dv_, &r_, &z_, &p_, &q_, &kv_}) s->assign(n, Vec3::Zero());
  preconditioner_.assign(n, Mat3::Zero());

  if (product_ == StiffnessProduct::assembled) {
    // CSR of 3x3 blocks: each vertex row holds itself and its edge neighbours, ascending.
    block_row_offsets_.assign(n + 1, 0);
    for (size_t v = 0; v < n; ++v) {
      auto nb = mesh_->vertex_neighbors(static_cast<int>(v));
      block_row_offsets_[v + 1] = block_row_offsets_[v] + static_cast<int>(nb.size()) + 1;
      std::vector<int> row(nb.begin(), nb.end());
      row.push_back(static_cast<int>(v));
      std::sort(row.begin(), row.end());
      block_cols_.insert(block_cols_.end(), row.begin(), row.end());
    }
    blocks_.assign(block_cols_.size(), Mat3::Zero());
    tet_blocks_.resize(nt);
    for (size_t t = 0; t < nt; ++t) {
      const auto& tet = mesh_->tets()[t];
      for (size_t i = 0; i < 4; ++i) {
        const auto b = block_cols_.begin() + block_row_offsets_[static_cast<size_t>(tet[i])];
        const auto e = block_cols_.begin() + block_row_offsets_[static_cast<size_t>(tet[i]) + 1];
        for (size_t j = 0; j < 4; ++j) {
          tet_blocks_[t][i * 4 + j] = static_cast<int>(std::lower_bound(b, e, tet[j]) - block_cols_.begin());
        }
      }
    }
  }
}

Mat3 CorotationalFem::deformation_gradient(std::span<const Vec3> x, int tet_index) const {
  const auto t = static_cast<size_t>(tet_index);
  const auto& tet = mesh_->tets()[t];
  const Vec3& x0 = x[static_cast<size_t>(tet[0])];
  Mat3 Ds;
  Ds.col(0) = x[static_cast<size_t>(tet[1])] - x0;
  Ds.col(1) = x[static_cast<size_t>(tet[2])] - x0;
  Ds.col(2) = x[static_cast<size_t>(tet[3])] - x0;
  return Ds * rest_shape_inverse_[t];
}

// P = 2 mu (F - R) + lambda tr(R^T F - I) R: the gradient of the corotated energy density.
Mat3 CorotationalFem::first_piola(const Mat3& F, const Mat3& R) const {
  const double trace = (R.transpose() * F).trace() - 3.0;
  return 2.0 * mu_ * (F - R) + lambda_ * trace * R;
}

void CorotationalFem::update_rotations(std::span<const Vec3> x) {
  stiffness_assembled_ = false;
  std::fill(forces_.begin(), forces_.end(), Vec3::Zero());
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  for (size_t t = 0; t < nt; ++t) {
    const Mat3 F = deformation_gradient(x, static_cast<int>(t));
    extract_rotation(F, rotations_[t], kRotationIterations, kRotationTolerance);
    const Mat3 R = rotations_[t].toRotationMatrix();
    const Mat3 DmInvT = rest_shape_inverse_[t].transpose();
    rotated_gradients_[t] = R * DmInvT;
    scatter_tet(mesh_->tets()[t], -volume_[t] * first_piola(F, R) * DmInvT, forces_);
  }
}

void CorotationalFem::internal_forces(std::span<const Vec3> x, std::span<Vec3> f) {
  update_rotations(x);
  std::copy(forces_.begin(), forces_.end(), f.begin());
}

void CorotationalFem::internal_forces_at(std::span<const Vec3> x, std::span<const int> vertices,
                                         std::span<Vec3> f) {
  for (size_t k = 0; k < vertices.size(); ++k) {
    const int v = vertices[k];
    Vec3 sum = Vec3::Zero();
    for (int t : mesh_->vertex_tets(v)) {
      const auto ts = static_cast<size_t>(t);
      const Mat3 F = deformation_gradient(x, t);
      Quat q = rotations_[ts];  // warm start; the stored rotation is left as it is
      extract_rotation(F, q, kRotationIterations, kRotationTolerance);
      const Mat3 H = -volume_[ts] * first_piola(F, q.toRotationMatrix()) * rest_shape_inverse_[ts].transpose();
      const auto& tet = mesh_->tets()[ts];
      if (tet[0] == v) {
        sum -= H.col(0) + H.col(1) + H.col(2);
      } else {
        for (int j = 0; j < 3; ++j) {
          if (tet[static_cast<size_t>(j + 1)] == v) sum += H.col(j);
        }
      }
    }
    f[k] = sum;
  }
}

double CorotationalFem::elastic_energy(std::span<const Vec3> x) {
  double energy = 0.0;
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  for (size_t t = 0; t < nt; ++t) {
    const Mat3 F = deformation_gradient(x, static_cast<int>(t));
    Quat q = rotations_[t];
    extract_rotation(F, q, kRotationIterations, kRotationTolerance);
    const Mat3 R = q.toRotationMatrix();
    const double trace = (R.transpose() * F).trace() - 3.0;
    energy += volume_[t] * (mu_ * (F - R).squaredNorm() + 0.5 * lambda_ * trace * trace);
  }
  return energy;
}

void CorotationalFem::apply_stiffness(std::span<const Vec3> p, std::span<Vec3> y) const {
  std::fill(y.begin(), y.end(), Vec3::Zero());
  if (stiffness_assembled_) {
    const size_t n = y.size();
    for (size_t i = 0; i < n; ++i) {
      Vec3 sum = Vec3::Zero();
      for (int b = block_row_offsets_[i]; b < block_row_offsets_[i + 1]; ++b) {
        sum.noalias() += blocks_[static_cast<size_t>(b)] * p[static_cast<size_t>(block_cols_[static_cast<size_t>(b)])];
      }
      y[i] = sum;
    }
    return;
  }
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  for (size_t t = 0; t < nt; ++t) {
    const auto& tet = mesh_->tets()[t];
    const Vec3& p0 = p[static_cast<size_t>(tet[0])];
    Mat3 Dp;
    Dp.col(0) = p[static_cast<size_t>(tet[1])] - p0;
    Dp.col(1) = p[static_cast<size_t>(tet[2])] - p0;
    Dp.col(2) = p[static_cast<size_t>(tet[3])] - p0;
    const Mat3& Rg = rotated_gradients_[t];
    const Mat3 A = Dp * Rg.transpose();
    Mat3 S = mu_ * (A + A.transpose());
    S.diagonal().array() += lambda_ * A.trace();
    scatter_tet(tet, volume_[t] * S * Rg, y);
  }
}

void CorotationalFem::assemble_stiffness() {
  std::fill(blocks_.begin(), blocks_.end(), Mat3::Zero());
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  for (size_t t = 0; t < nt; ++t) {
    const Mat3& Rg = rotated_gradients_[t];
    std::array<Vec3, 4> r;
    r[1] = Rg.col(0);
    r[2] = Rg.col(1);
    r[3] = Rg.col(2);
    r[0] = -(r[1] + r[2] + r[3]);
    const double V = volume_[t];
    // R K_ij R^T = V (mu (r_i . r_j) I + mu r_j r_i^T + lambda r_i r_j^T); K_ji = K_ij^T.
    const double Vmu = V * mu_, Vlambda = V * lambda_;
    for (size_t i = 0; i < 4; ++i) {
      for (size_t j = i; j < 4; ++j) {
        Mat3 K = Vmu * r[j] * r[i].transpose() + Vlambda * r[i] * r[j].transpose();
        K.diagonal().array() += Vmu * r[i].dot(r[j]);
        blocks_[static_cast<size_t>(tet_blocks_[t][i * 4 + j])] += K;
        if (j != i) blocks_[static_cast<size_t>(tet_blocks_[t][j * 4 + i])] += K.transpose();
      }
    }
  }
  stiffness_assembled_ = true;
}

void CorotationalFem::multiply_system(std::span<const Vec3> p, std::span<Vec3> y, double mass_scale,
                                      double stiffness_scale, std::span<const double> masses,
                                      std::span<const char> fixed) const {
  apply_stiffness(p, y);
  for (size_t i = 0; i < y.size(); ++i) {
    y[i] = fixed[i] != 0 ? Vec3::Zero() : Vec3(mass_scale * masses[i] * p[i] + stiffness_scale * y[i]);
  }
}

IntegrationResult CorotationalFem::advance(std::span<Vec3> x, std::span<Vec3> v, const IntegrationInput& in) {
  IntegrationResult result;
  const double h = in.dt;
  const size_t n = x.size();
  const double mass_scale = 1.0 + h * alpha_;        // M + h alpha M
  const double stiffness_scale = h * (beta_ + h);    // h beta K' + h^2 K'

  // Linearise at x_n: rotations, elastic forces f(x), rotated shape gradients for K'.
  update_rotations(x);
  if (product_ == StiffnessProduct::assembled) assemble_stiffness();

  // Right-hand side h (f + f_ext - alpha M v) - h (beta + h) K' v, zero at fixed vertices.
  apply_stiffness(v, kv_);
  for (size_t i = 0; i < n; ++i) {
    rhs_[i] = in.fixed[i] != 0 ? Vec3::Zero()
                               : Vec3(h * (forces_[i] + in.external_forces[i] - alpha_ * in.masses[i] * v[i]) -
                                      stiffness_scale * kv_[i]);
  }

  // Block-Jacobi preconditioner: inverse 3x3 diagonal blocks of the system matrix.
  for (size_t i = 0; i < n; ++i) preconditioner_[i] = Mat3::Identity() * (mass_scale * in.masses[i]);
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  if (product_ == StiffnessProduct::assembled) {
    for (size_t i = 0; i < n; ++i) {
      const auto b = std::lower_bound(block_cols_.begin() + block_row_offsets_[i],
                                      block_cols_.begin() + block_row_offsets_[i + 1], static_cast<int>(i));
      preconditioner_[i] += stiffness_scale * blocks_[static_cast<size_t>(b - block_cols_.begin())];
    }
  }
  for (size_t t = 0; t < nt && product_ == StiffnessProduct::matrix_free; ++t) {
    const Mat3& Rg = rotated_gradients_[t];
    const auto& tet = mesh_->tets()[t];
    const double c = stiffness_scale * volume_[t];
    for (size_t i = 0; i < 4; ++i) {
      const Vec3 r = i == 0 ? Vec3(-(Rg.col(0) + Rg.col(1) + Rg.col(2))) : Vec3(Rg.col(static_cast<int>(i) - 1));
      Mat3& B = preconditioner_[static_cast<size_t>(tet[i])];
      B.noalias() += c * (mu_ + lambda_) * r * r.transpose();
      B.diagonal().array() += c * mu_ * r.squaredNorm();
    }
  }
  for (size_t i = 0; i < n; ++i) {
    const double det = preconditioner_[i].determinant();
    preconditioner_[i] = (in.fixed[i] != 0 || !(det > 0.0)) ? Mat3::Zero() : Mat3(preconditioner_[i].inverse());
  }

  // Preconditioned conjugate gradients on (M + h D + h^2 K') dv = rhs, warm-started from the last dv.
  for (size_t i = 0; i < n; ++i) {
    if (in.fixed[i] != 0 || !dv_[i].allFinite()) dv_[i].setZero();
  }
  const double rhs_norm = std::sqrt(dot(rhs_, rhs_));
  if (!std::isfinite(rhs_norm)) {
    // Non-finite input (e.g. a NaN applied force): NaN comparisons would skip the CG loop and
    // silently reuse the warm start, so make the result non-finite and let World::step report the
    // fault and restore the state. The next step resets the non-finite warm start to zero.
    std::fill(dv_.begin(), dv_.end(), Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
    result.converged = false;
    result.solver_residual = std::numeric_limits<double>::quiet_NaN();
  } else if (rhs_norm == 0.0) {
    std::fill(dv_.begin(), dv_.end(), Vec3::Zero());
  } else {
    multiply_system(dv_, q_, mass_scale, stiffness_scale, in.masses, in.fixed);
    for (size_t i = 0; i < n; ++i) r_[i] = rhs_[i] - q_[i];
    double residual = std::sqrt(dot(r_, r_)) / rhs_norm;
    if (residual > 1.0) {
      // The warm start is worse than zero (e.g. after a contact edit): start from zero instead.
      std::fill(dv_.begin(), dv_.end(), Vec3::Zero());
      std::copy(rhs_.begin(), rhs_.end(), r_.begin());
      residual = 1.0;
    }
    for (size_t i = 0; i < n; ++i) p_[i] = z_[i] = preconditioner_[i] * r_[i];
    double rz = dot(r_, z_);
    int it = 0;
    while (residual > accuracy_.solver_tolerance && it < accuracy_.max_solver_iterations) {
      multiply_system(p_, q_, mass_scale, stiffness_scale, in.masses, in.fixed);
      const double pq = dot(p_, q_);
      if (!(pq > 0.0) || !(rz > 0.0)) break;
      const double a = rz / pq;
      for (size_t i = 0; i < n; ++i) {
        dv_[i] += a * p_[i];
        r_[i] -= a * q_[i];
      }
      ++it;
      residual = std::sqrt(dot(r_, r_)) / rhs_norm;
      if (residual <= accuracy_.solver_tolerance) break;
      for (size_t i = 0; i < n; ++i) z_[i] = preconditioner_[i] * r_[i];
      const double rz_next = dot(r_, z_);
      const double b = rz_next / rz;
      rz = rz_next;
      for (size_t i = 0; i < n; ++i) p_[i] = z_[i] + b * p_[i];
    }
    result.solver_iterations = it;
    result.solver_residual = residual;
    result.converged = residual <= accuracy_.solver_tolerance;
  }

  // v+ = v + dv, x+ = x + h v+; fixed vertices stay exactly put.
  for (size_t i = 0; i < n; ++i) {
    if (in.fixed[i] != 0) {
      v[i].setZero();
      continue;
    }
    v[i] += dv_[i];
    x[i] += h * v[i];
  }
  return result;
}

}  // namespace pliant
