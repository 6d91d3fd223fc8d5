#include "sim/model/corotational_fem.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#if defined(__SSE2__)
#include <emmintrin.h>
#include <xmmintrin.h>
#endif

#include "sim/model/diagonal_block_kernels.h"
#include "sim/model/exact_sweep_kernels.h"
#include "sim/model/fused_ssor_kernels.h"
#include "sim/model/preconditioned_cg.h"
#include "sim/model/rotation_batch_avx2.h"
#include "sim/model/rotation_batch_avx512.h"
#include "sim/model/rotation_extraction.h"
#include "sim/model/stiffness_row_kernels.h"
#include "sim/model/tet_gradient_kernels.h"
#include "sim/parallel/task_executor.h"

namespace pliant {

namespace {

/// A query whose positions differ from the cached state in more than 1/kIncrementalFraction of
/// the vertices re-evaluates every tet instead of the tets around the changed vertices.
constexpr size_t kIncrementalFraction = 16;


// Scatters the columns of H (forces on local vertices 1..3) and their negated sum (vertex 0).
inline void scatter_tet(const TetIndices& tet, const Mat3& H, std::span<Vec3> f) {
  f[static_cast<size_t>(tet[0])] -= H.col(0) + H.col(1) + H.col(2);
  for (int j = 0; j < 3; ++j) f[static_cast<size_t>(tet[static_cast<size_t>(j + 1)])] += H.col(j);
}

/// The most tets in one batch of the evaluation pass (evaluation_pass_lanes()).
constexpr size_t kMaxPassLanes = std::max({kRotationBatchLanesAvx512, kRotationBatchLanesAvx2, kRotationBatchLanes});

/// tet_gradient_kernels_available(), asked once (the callers test it per batch of tets).
inline bool tet_kernels_on_this_cpu() {
  static const bool available = tet_gradient_kernels_available();
  return available;
}

/// diagonal_block_kernels_available(), asked once.
inline bool diagonal_kernels_on_this_cpu() {
  static const bool available = diagonal_block_kernels_available();
  return available;
}

inline double dot(std::span<const Vec3> a, std::span<const Vec3> b) {
  double s = 0.0;
  for (size_t i = 0; i < a.size(); ++i) s += a[i].dot(b[i]);
  return s;
}

inline bool same_bits(const Vec3& a, const Vec3& b) { return std::memcmp(a.data(), b.data(), sizeof(double) * 3) == 0; }

/// Local index (0..3) of vertex v in tet, or -1.
inline int local_index(const TetIndices& tet, int v) {
  for (int j = 0; j < 4; ++j) {
    if (tet[static_cast<size_t>(j)] == v) return j;
  }
  return -1;
}

/// The system's diagonal blocks of rows [0, count): P holds D_i on entry and D_i^-1 on return
/// (zero where the row is fixed or det D_i <= 0); diagonal gets D_i (the identity where fixed).
/// Returns SSOR's test: every unfixed D_i has det > 0 and positive leading minors. Four rows per
/// call in lanes where `kernels` and the CPU has them (the scalar's bits).
inline bool invert_diagonal_rows(Mat3* P, const char* fixed, size_t count, bool kernels, Mat3* diagonal) {
  if (kernels && diagonal_kernels_on_this_cpu()) return invert_diagonal_blocks_avx2(P, fixed, count, diagonal, P);
  bool pass = true;
  for (size_t i = 0; i < count; ++i) {
    const Mat3 Di = P[i];
    const double det = Di.determinant();
    const bool is_fixed = fixed[i] != 0;
    pass = pass && (is_fixed || (det > 0.0 && Di(0, 0) > 0.0 && Di(0, 0) * Di(1, 1) > Di(0, 1) * Di(1, 0)));
    diagonal[i] = is_fixed ? Mat3::Identity() : Di;
    P[i] = (is_fixed || !(det > 0.0)) ? Mat3::Zero() : Mat3(Di.inverse());
  }
  return pass;
}

inline bool same_double_bits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

}  // namespace

CorotationalFem::CorotationalFem(TetMeshPtr mesh, const Material& material, const ModelSettings& settings,
                                 StiffnessProduct product)
    : mesh_(std::move(mesh)),
      mu_(material.lame_mu()),
      lambda_(material.lame_lambda()),
      alpha_(material.mass_damping),
      beta_(material.stiffness_damping),
      accuracy_(settings.accuracy),
      product_(product),
      stiffness_rotation_tolerance_(settings.stiffness_rotation_tolerance),
      fused_sweeps_(settings.fused_sweeps && fused_sweeps_available()),
      vector_kernels_(stiffness_row_kernels_available() && rotation_batch_avx2_available()),
      avx512_lanes_(rotation_batch_avx512_available()),
      coarse_aggregate_size_(settings.coarse_aggregate_size) {
  const auto& X = mesh_->rest_positions();
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  rest_shape_inverse_.resize(nt);
  volume_ = mesh_->rest_volumes();
  rotations_.assign(nt, Quat::Identity());
  rotated_gradients_.resize(nt);
  tet_energy_.assign(nt, 0.0);
  tet_stamp_.assign(nt, 0);
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
  for (auto* s : {&forces_, &rhs_, &dv_, &r_, &z_, &p_, &q_, &kv_, &sweep_rows_}) s->assign(n, Vec3::Zero());
  preconditioner_.assign(n, Mat3::Zero());
  diagonal_system_blocks_.assign(n, Mat3::Identity());
  dv_previous_.assign(n, Vec3::Zero());
  state_x_.assign(n, Vec3::Zero());
  changed_vertices_.reserve(n / kIncrementalFraction + 1);

  // The corners of the tets around each vertex, ascending by tet (the mesh's vertex_tets order):
  // the assembly's rows and the local queries' per-vertex sums (session 9: for any product).
  corner_offsets_.assign(n + 1, 0);
  corners_.reserve(nt * 4);
  for (size_t v = 0; v < n; ++v) {
    for (int t : mesh_->vertex_tets(static_cast<int>(v))) {
      corners_.push_back({t, local_index(mesh_->tets()[static_cast<size_t>(t)], static_cast<int>(v))});
    }
    corner_offsets_[v + 1] = static_cast<int>(corners_.size());
  }

  if (product_ == StiffnessProduct::assembled) {
    // CSR of 3x3 blocks, upper triangle (session 3): row i holds K_ii first, then K_ij for its edge
    // neighbours j > i, ascending; K_ji = K_ij^T is applied from row i. Half the blocks of full
    // rows: the product streams half the memory and the assembly computes 10 blocks per tet, not 16.
    block_row_offsets_.assign(n + 1, 0);
    diagonal_blocks_.resize(n);
    for (size_t v = 0; v < n; ++v) {
      std::vector<int> row{static_cast<int>(v)};
      for (int j : mesh_->vertex_neighbors(static_cast<int>(v))) {
        if (j > static_cast<int>(v)) row.push_back(j);
      }
      std::sort(row.begin() + 1, row.end());
      diagonal_blocks_[v] = block_row_offsets_[v];
      block_row_offsets_[v + 1] = block_row_offsets_[v] + static_cast<int>(row.size());
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
          tet_blocks_[t][i * 4 + j] =
              tet[j] < tet[i] ? -1 : static_cast<int>(std::find(b, e, tet[j]) - block_cols_.begin());
        }
      }
    }
    tet_block_lists_.resize(kTetBlockListSize * nt);
    tet_block_lists(tet_blocks_.data()->data(), nt, tet_block_lists_.data());
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
  const double trace = R.cwiseProduct(F).sum() - 3.0;
  return 2.0 * mu_ * (F - R) + lambda_ * trace * R;
}

Mat3 CorotationalFem::element_forces(size_t t, const Mat3& F, const Mat3& R) const {
  return -volume_[t] * first_piola(F, R) * rest_shape_inverse_[t].transpose();
}

namespace {

/// The rotated shape gradients r_0..r_3 of a tet (columns of R Dm^-T; r_0 = -(r_1 + r_2 + r_3)),
/// as plain triples (r[a][k], component k of r_a).
struct RotatedGradients {
  double r[4][3];
  explicit RotatedGradients(const Mat3& Rg) {
    const double* g = Rg.data();  // column-major: column j = r_{j+1}
    for (int k = 0; k < 3; ++k) {
      r[1][k] = g[k];
      r[2][k] = g[3 + k];
      r[3][k] = g[6 + k];
      r[0][k] = -(g[k] + g[3 + k] + g[6 + k]);
    }
  }
};

/// Adds the block R K_ab R^T = V (mu (r_a . r_b) I + mu r_b r_a^T + lambda r_a r_b^T) to the
/// column-major 3x3 block B, with Vmu = V mu and Vlambda = V lambda (signed). One expression for
/// every caller, so a block taken out is the value that was added. Plain scalars through restrict
/// pointers (session 4): with Eigen types GCC reloaded r_a from memory for every entry (it cannot
/// rule out that B aliases it) and spilled through the stack.
inline void add_stiffness_block(const double* __restrict ra, const double* __restrict rb, double Vmu, double Vlambda,
                                double* __restrict B) {
  const double u0 = Vmu * rb[0], u1 = Vmu * rb[1], u2 = Vmu * rb[2];
  const double w0 = Vlambda * ra[0], w1 = Vlambda * ra[1], w2 = Vlambda * ra[2];
  const double a0 = ra[0], a1 = ra[1], a2 = ra[2], b0 = rb[0], b1 = rb[1], b2 = rb[2];
  const double d = Vmu * (a0 * b0 + a1 * b1 + a2 * b2);
  B[0] += u0 * a0 + w0 * b0 + d;
  B[1] += u1 * a0 + w1 * b0;
  B[2] += u2 * a0 + w2 * b0;
  B[3] += u0 * a1 + w0 * b1;
  B[4] += u1 * a1 + w1 * b1 + d;
  B[5] += u2 * a1 + w2 * b1;
  B[6] += u0 * a2 + w0 * b2;
  B[7] += u1 * a2 + w1 * b2;
  B[8] += u2 * a2 + w2 * b2 + d;
}

/// The diagonal block R K_aa R^T = V ((mu + lambda) r_a r_a^T + mu |r_a|^2 I) (add_stiffness_block
/// with b = a, symmetric: its six distinct entries computed once, 24 flops instead of 50).
inline void add_diagonal_stiffness_block(const double* __restrict ra, double Vmu, double Vlambda,
                                         double* __restrict B) {
  const double a0 = ra[0], a1 = ra[1], a2 = ra[2];
  const double k = Vmu + Vlambda, d = Vmu * (a0 * a0 + a1 * a1 + a2 * a2);
  const double k0 = k * a0, k1 = k * a1, k2 = k * a2;
  const double b01 = k0 * a1, b02 = k0 * a2, b12 = k1 * a2;
  B[0] += k0 * a0 + d;
  B[1] += b01;
  B[2] += b02;
  B[3] += b01;
  B[4] += k1 * a1 + d;
  B[5] += b12;
  B[6] += b02;
  B[7] += b12;
  B[8] += k2 * a2 + d;
}

/// Adds the block (a, b) of a tet: the diagonal form for a = b. Every caller adds and takes out
/// blocks through this function, so a block taken out is the value that was added.
inline void add_tet_block(const RotatedGradients& g, size_t a, size_t b, double Vmu, double Vlambda, double* B) {
  if (a == b) {
    add_diagonal_stiffness_block(g.r[a], Vmu, Vlambda, B);
  } else {
    add_stiffness_block(g.r[a], g.r[b], Vmu, Vlambda, B);
  }
}

}  // namespace

void CorotationalFem::assemble_tet(size_t t, const Mat3& Rg, double sign) {
  step_blocks_valid_ = false;  // the blocks no longer follow block_gradients_
  block_changes_tracked_ = false;
  const RotatedGradients g(Rg);
  const double Vmu = sign * volume_[t] * mu_, Vlambda = sign * volume_[t] * lambda_;
  const auto& slots = tet_blocks_[t];
  for (size_t a = 0; a < 4; ++a) {
    for (size_t b = 0; b < 4; ++b) {
      const int slot = slots[a * 4 + b];  // -1: the block is stored transposed, in the other row
      if (slot >= 0) add_tet_block(g, a, b, Vmu, Vlambda, blocks_[static_cast<size_t>(slot)].data());
    }
  }
}

// Row by row (session 3): each vertex row's blocks are zeroed and summed from the tets around the
// vertex (ascending, the order a tet-by-tet scatter would add them in), so every block is written
// while it is in L1 and the 3x3-block matrix streams out once. The tet-by-tet scatter it replaces
// spent ~60% of its time waiting on first-touch cache misses in the 2 MB of blocks (perf, beam).
// With block_dirty, a block none of whose tets moved is skipped: summed again it would be the same
// sum of the same gradients in the same order, so leaving it is exact (session 12).
void CorotationalFem::assemble_row(size_t i, const Mat3* gradients, const char* block_dirty) {
  // A row whose blocks are all dirty is summed whole: the same sums as with the flags (nothing to
  // skip), without the per-corner and per-slot flag tests (session 13: a step in which every tet
  // moved, the beam's, spent ~10 M instructions on them).
  if (block_dirty != nullptr &&
      std::all_of(block_dirty + block_row_offsets_[i], block_dirty + block_row_offsets_[i + 1],
                  [](char dirty) { return dirty != 0; })) {
    block_dirty = nullptr;
  }
  if (vector_kernels_) {  // the same blocks bit for bit, in AVX2 lanes (stiffness_row_kernels.h)
    static_assert(sizeof(TetCorner) == 2 * sizeof(int) && sizeof(tet_blocks_[0]) == 16 * sizeof(int));
    const StiffnessRowSystem sys{blocks_.data()->data(), gradients->data(), volume_.data(), tet_blocks_.data()->data(),
                                 &corners_.data()->tet, mu_, lambda_, tet_block_lists_.data()};
    sum_stiffness_row(sys, static_cast<size_t>(block_row_offsets_[i]), static_cast<size_t>(block_row_offsets_[i + 1]),
                      static_cast<size_t>(corner_offsets_[i]), static_cast<size_t>(corner_offsets_[i + 1]), block_dirty);
    return;
  }
  double* blocks = blocks_.data()->data();
  const double* volume = volume_.data();
  const TetCorner* corners = corners_.data();
  const auto first = static_cast<size_t>(block_row_offsets_[i]), last = static_cast<size_t>(block_row_offsets_[i + 1]);
  for (size_t k = first; k < last; ++k) {
    if (block_dirty == nullptr || block_dirty[k] != 0) std::fill(blocks + 9 * k, blocks + 9 * k + 9, 0.0);
  }
  const auto corners_end = static_cast<size_t>(corner_offsets_[i + 1]);
  for (auto c = static_cast<size_t>(corner_offsets_[i]); c < corners_end; ++c) {
    const auto t = static_cast<size_t>(corners[c].tet);
    const auto a = static_cast<size_t>(corners[c].local);
    const int* slots = tet_blocks_[t].data() + a * 4;
    if (block_dirty != nullptr && !corner_adds_to_dirty_block(slots, block_dirty)) continue;
    const RotatedGradients g(gradients[t]);
    const double Vmu = volume[t] * mu_, Vlambda = volume[t] * lambda_;
    for (size_t b = 0; b < 4; ++b) {
      if (slots[b] < 0 || (block_dirty != nullptr && block_dirty[slots[b]] == 0)) continue;
      add_tet_block(g, a, b, Vmu, Vlambda, blocks + 9 * static_cast<size_t>(slots[b]));
    }
  }
}

void CorotationalFem::assemble_all_rows(const Mat3* gradients) {
  block_changes_tracked_ = false;  // every block written
  if (vector_kernels_) {  // each block's terms in the rows' order, ascending tet (stiffness_row_kernels.h)
    const StiffnessRowSystem sys{blocks_.data()->data(), gradients->data(), volume_.data(), tet_blocks_.data()->data(),
                                 &corners_.data()->tet, mu_, lambda_, tet_block_lists_.data()};
    sum_stiffness_by_tet(sys, blocks_.size(), static_cast<size_t>(mesh_->tet_count()));
    return;
  }
  const auto n = static_cast<size_t>(mesh_->vertex_count());
  for (size_t i = 0; i < n; ++i) assemble_row(i, gradients);
}

Mat3 CorotationalFem::rotated_gradient(size_t t) const {
  return rotations_[t].toRotationMatrix() * rest_shape_inverse_[t].transpose();
}

void CorotationalFem::refresh_rotated_gradients() const {
  if (gradients_current_) return;
  if (runs_parallel(executor_)) {
    refresh_rotated_gradients_parallel();
    gradients_current_ = true;
    return;
  }
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  if (vector_kernels_ && tet_kernels_on_this_cpu()) {  // the same gradients bit for bit (tet_gradient_kernels.h)
    rotated_gradients_avx2(rotations_.data(), rest_shape_inverse_.data(), nt, rotated_gradients_.data());
  } else {
    for (size_t t = 0; t < nt; ++t) rotated_gradients_[t] = rotated_gradient(t);
  }
  gradients_current_ = true;
}

void CorotationalFem::assemble_stiffness() {
  refresh_rotated_gradients();
  const auto n = static_cast<size_t>(mesh_->vertex_count());
  block_changes_tracked_ = false;  // every block written
  if (runs_parallel(executor_)) {
    assemble_rows_parallel({}, rotated_gradients_.data());
  } else {
    assemble_all_rows(rotated_gradients_.data());
  }
  stiffness_assembled_ = true;
  step_blocks_valid_ = false;
  reassembled_rows_ = n;
}

// K' of a step with rotations reused within stiffness_rotation_tolerance_ (session 5): a tet's
// blocks keep the rotated gradients they were built from (block_gradients_, rotation
// block_rotations_) until its current rotation is more than the tolerance away from that one; only
// the vertex rows around tets that moved further are summed again. Every row is the same function
// of block_gradients_ as a full assembly would compute (no add/subtract drift). Tolerance 0: the
// full assembly from the current rotations, bit for bit the exact path.
void CorotationalFem::assemble_step_stiffness() {
  if (!(stiffness_rotation_tolerance_ > 0.0)) {
    assemble_stiffness();
    return;
  }
  const auto n = static_cast<size_t>(mesh_->vertex_count());
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  if (!step_blocks_valid_) {
    refresh_rotated_gradients();
    block_rotations_ = rotations_;
    block_gradients_ = rotated_gradients_;
    block_changes_tracked_ = false;  // every block written
    if (runs_parallel(executor_)) {
      assemble_rows_parallel({}, block_gradients_.data());
    } else {
      assemble_all_rows(block_gradients_.data());
    }
    stiffness_assembled_ = true;
    step_blocks_valid_ = true;
    reassembled_rows_ = n;
    return;
  }
  // Angle between unit quaternions: |q . p| = cos(angle / 2).
  const double min_cos = std::cos(0.5 * stiffness_rotation_tolerance_);
  if (runs_parallel(executor_)) {
    // Threads: each tet checked on its own, the rows marked serially, the marked rows summed in
    // chunks (each row is the same function of block_gradients_ as below).
    tet_moved_.resize(nt);
    parallel_for_chunks(executor_, nt, 256, [&](size_t begin, size_t end) {
      for (size_t t = begin; t < end; ++t) {
        tet_moved_[t] = std::abs(block_rotations_[t].dot(rotations_[t])) < min_cos;
        if (tet_moved_[t] == 0) continue;
        block_rotations_[t] = rotations_[t];
        block_gradients_[t] = rotated_gradient(t);
      }
    });
    row_dirty_.assign(n, 0);
    for (size_t t = 0; t < nt; ++t) {
      if (tet_moved_[t] == 0) continue;
      for (int v : mesh_->tets()[t]) row_dirty_[static_cast<size_t>(v)] = 1;
    }
    dirty_rows_.clear();
    for (size_t i = 0; i < n; ++i) {
      if (row_dirty_[i] != 0) dirty_rows_.push_back(static_cast<int>(i));
    }
    if (!dirty_rows_.empty()) assemble_rows_parallel(dirty_rows_, block_gradients_.data());
    // The rows summed whole: every block of theirs counts as written (session 17).
    for (int i : dirty_rows_) {
      changed_rows_.push_back(i);
      for (int b = block_row_offsets_[static_cast<size_t>(i)]; b < block_row_offsets_[static_cast<size_t>(i) + 1]; ++b) {
        changed_blocks_.push_back(b);
      }
    }
    reassembled_rows_ = dirty_rows_.size();
    stiffness_assembled_ = true;
    return;
  }
  moved_tets_.clear();
  for (size_t t = 0; t < nt; ++t) {
    if (std::abs(block_rotations_[t].dot(rotations_[t])) >= min_cos) continue;
    block_rotations_[t] = rotations_[t];
    moved_tets_.push_back(static_cast<int>(t));
  }
  // The moved tets' gradients from their current rotations (rotated_gradients_ may be stale:
  // linearise), four at a time in lanes where the kernels run (the same bits, tet_gradient_kernels.h).
  if (vector_kernels_ && tet_kernels_on_this_cpu()) {
    rotated_gradients_at_avx2(rotations_.data(), rest_shape_inverse_.data(), moved_tets_.data(), moved_tets_.size(),
                              block_gradients_.data());
  } else {
    for (int t : moved_tets_) block_gradients_[static_cast<size_t>(t)] = rotated_gradient(static_cast<size_t>(t));
  }
  // Every tet moved (the beam's steps): every block is dirty, and the rows are summed whole without
  // flags, so none are set or cleared (session 14: the two passes over 16 slots per tet were ~2/3 of
  // this function's instructions on the beam). Otherwise only the blocks a moved tet adds to are
  // summed again (the rest of a dirty row is what it was); block_dirty_ is all zero between calls.
  const bool every_tet_moved = moved_tets_.size() == nt;
  // The rows to sum again are marked only when some tet did not move (session 15: when every tet
  // moved, the dirty rows are the vertices in a tet, counted from the mesh).
  if (!every_tet_moved) {
    row_dirty_.assign(n, 0);
    for (int t : moved_tets_) {
      for (int v : mesh_->tets()[static_cast<size_t>(t)]) row_dirty_[static_cast<size_t>(v)] = 1;
    }
  }
  // Setting the flags also records each dirty block once, the blocks written (session 17).
  const auto flag_moved_tets_blocks = [&](char flag) {
    block_dirty_.resize(blocks_.size(), 0);
    for (int t : moved_tets_) {
      for (int slot : tet_blocks_[static_cast<size_t>(t)]) {
        if (slot < 0) continue;
        if (flag != 0 && block_dirty_[static_cast<size_t>(slot)] == 0) changed_blocks_.push_back(slot);
        block_dirty_[static_cast<size_t>(slot)] = flag;
      }
    }
  };
  if (!every_tet_moved) flag_moved_tets_blocks(1);
  size_t rows = 0;
  if (every_tet_moved) {
    // A vertex in no tet has no dirty row; its (diagonal) block is zero since the first assembly,
    // which assemble_all_rows writes again.
    assemble_all_rows(block_gradients_.data());
    for (size_t i = 0; i < n; ++i) rows += mesh_->vertex_tets(static_cast<int>(i)).empty() ? 0 : 1;
  } else {
    for (size_t i = 0; i < n; ++i) {
      if (row_dirty_[i] == 0) continue;
      assemble_row(i, block_gradients_.data(), block_dirty_.data());
      changed_rows_.push_back(static_cast<int>(i));  // a moved tet at i wrote K'_ii
      ++rows;
    }
  }
  if (!every_tet_moved) flag_moved_tets_blocks(0);
  reassembled_rows_ = rows;
  stiffness_assembled_ = true;
}

size_t CorotationalFem::evaluation_batch_lanes() const {
  return vector_kernels_ ? kRotationBatchLanesAvx2 : kRotationBatchLanes;
}

size_t CorotationalFem::evaluation_pass_lanes() const {
  return avx512_lanes() ? kRotationBatchLanesAvx512 : evaluation_batch_lanes();
}

void CorotationalFem::evaluate_tet_batch(std::span<const Vec3> x, const std::vector<Quat>& warm_starts,
                                         std::vector<Quat>& rotations, std::vector<double>& tet_energy, size_t t0,
                                         size_t lanes, Mat3* H) const {
  // Rotations a batch at a time (extract_rotations_batch: the scalar's result bit for bit, the
  // latency-bound iterations of the lanes overlapped), four in AVX2 registers where the CPU has
  // them (session 9, rotation_batch_avx2.h), eight in AVX-512 registers where it has those (session
  // 17, rotation_batch_avx512.h), a short batch tet by tet in order.
  const size_t L = evaluation_batch_lanes();
  const bool lanes_kernels = vector_kernels_ && tet_kernels_on_this_cpu();  // tet_gradient_kernels.h, bit for bit
  if (lanes == kRotationBatchLanesAvx512 && avx512_lanes() && lanes_kernels) {
    // Session 17: F, rotations, energies and element forces in one kernel's lanes (the expressions
    // of deformation_gradients_avx2 and element_forces_avx2, the same bits), the warm starts read
    // where they are.
    evaluate_tets_avx512(x.data()->data(), &mesh_->tets()[t0], &rest_shape_inverse_[t0], &volume_[t0], mu_, lambda_,
                         kElementRotationIterations, kElementRotationTolerance, &warm_starts[t0], &rotations[t0],
                         &tet_energy[t0], H);
    return;
  }
  // The 4-lane kernel reads the warm starts where they are (session 18); the other paths from rotations.
  const bool lanes_read_warm_starts = lanes == L && vector_kernels_;
  if (&rotations != &warm_starts && !lanes_read_warm_starts) std::copy_n(&warm_starts[t0], lanes, &rotations[t0]);
  Mat3 F[kMaxPassLanes];
  if (lanes_kernels) {
    deformation_gradients_avx2(x.data()->data(), &mesh_->tets()[t0], &rest_shape_inverse_[t0], lanes, F);
  } else {
    for (size_t l = 0; l < lanes; ++l) F[l] = deformation_gradient(x, static_cast<int>(t0 + l));
  }
  if (lanes_read_warm_starts) {
    extract_rotations_batch_avx2_from(F, &warm_starts[t0], &rotations[t0], kElementRotationIterations,
                                      kElementRotationTolerance);
  } else if (lanes == L) {
    extract_rotations_batch(F, &rotations[t0], kElementRotationIterations, kElementRotationTolerance);
  } else if (lanes == kRotationBatchLanesAvx512 && avx512_lanes()) {
    extract_rotations_batch_avx512(F, &rotations[t0], kElementRotationIterations, kElementRotationTolerance);
  } else {
    size_t done = 0;  // a short batch of the 8-lane pass: four in AVX2 lanes first, then tet by tet
    for (; done + L <= lanes && vector_kernels_; done += L) {
      extract_rotations_batch_avx2(F + done, &rotations[t0 + done], kElementRotationIterations,
                                   kElementRotationTolerance);
    }
    for (; done < lanes; ++done) {
      extract_rotation(F[done], rotations[t0 + done], kElementRotationIterations, kElementRotationTolerance);
    }
  }
  if (lanes_kernels) {
    element_forces_avx2(&rotations[t0], F, &rest_shape_inverse_[t0], &volume_[t0], mu_, lambda_, lanes, &tet_energy[t0],
                        H);
    return;
  }
  for (size_t l = 0; l < lanes; ++l) {
    const size_t t = t0 + l;
    const Mat3 R = rotations[t].toRotationMatrix();
    // The rotated shape gradients R Dm^-T are left to their readers (rotated_gradient(t)); the
    // trace and F - R are shared by the energy and P (first_piola's expressions, bit for bit).
    const double trace = R.cwiseProduct(F[l]).sum() - 3.0;
    const Mat3 FmR = F[l] - R;
    tet_energy[t] = volume_[t] * (mu_ * FmR.squaredNorm() + 0.5 * lambda_ * trace * trace);
    const Mat3 P = 2.0 * mu_ * FmR + lambda_ * trace * R;
    H[l] = -volume_[t] * P * rest_shape_inverse_[t].transpose();
  }
}

double CorotationalFem::evaluate_pass(std::span<const Vec3> x, const std::vector<Quat>& warm_starts,
                                      std::vector<Quat>& rotations, std::vector<Vec3>& forces,
                                      std::vector<double>& tet_energy) const {
  if (runs_parallel(executor_)) return evaluate_pass_parallel(x, warm_starts, rotations, forces, tet_energy);
  std::fill(forces.begin(), forces.end(), Vec3::Zero());
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  double energy = 0.0;
  const size_t L = evaluation_pass_lanes();
  const bool scatter_kernel = vector_kernels_ && tet_kernels_on_this_cpu();  // decided once (session 18)
  Mat3 H[kMaxPassLanes];
  for (size_t t0 = 0; t0 < nt; t0 += L) {
    const size_t lanes = std::min(L, nt - t0);
    evaluate_tet_batch(x, warm_starts, rotations, tet_energy, t0, lanes, H);
    if (scatter_kernel) {  // the same sums bit for bit (tet_gradient_kernels.h)
      for (size_t l = 0; l < lanes; ++l) energy += tet_energy[t0 + l];
      scatter_element_forces_avx2(&mesh_->tets()[t0], H, lanes, forces.data()->data());
      continue;
    }
    for (size_t l = 0; l < lanes; ++l) {
      energy += tet_energy[t0 + l];
      scatter_tet(mesh_->tets()[t0 + l], H[l], forces);
    }
  }
  return energy;
}

void CorotationalFem::linearise(std::span<const Vec3> x, bool assemble) {
  stiffness_assembled_ = false;
  assemble = assemble && product_ == StiffnessProduct::assembled;
  if (pass_memo_valid_ && pass_memo_version_ == rotations_version_ &&
      std::equal(x.begin(), x.end(), pass_memo_x_.begin(), same_bits)) {
    // An energy query already ran this pass at x from the same warm starts: adopt its result (the
    // values this pass would compute, bit for bit).
    std::swap(rotations_, pass_memo_rotations_);
    std::swap(forces_, pass_memo_forces_);
    std::swap(tet_energy_, pass_memo_tet_energy_);
    energy_ = pass_memo_energy_;
  } else {
    energy_ = evaluate_pass(x, rotations_, rotations_, forces_, tet_energy_);
  }
  pass_memo_valid_ = false;
  ++rotations_version_;
  gradients_current_ = false;
  if (assemble) assemble_stiffness();
  if (x.data() != state_x_.data()) std::copy(x.begin(), x.end(), state_x_.begin());
  state_valid_ = true;
  state_deferred_ = false;
}

void CorotationalFem::refresh_state(std::span<const Vec3> x) {
  const size_t n = x.size();
  // A full pass leaves K' to the next advance (assembly is a pass of its own over the vertex rows).
  if (!state_valid_) {
    linearise(x, false);
    return;
  }
  changed_vertices_.clear();
  const size_t limit = n / kIncrementalFraction + 1;  // the capacity reserved (a copy of the model has less)
  for (size_t i = 0; i < n; ++i) {
    if (same_bits(x[i], state_x_[i])) continue;
    if (changed_vertices_.size() == limit) {
      linearise(x, false);
      return;
    }
    changed_vertices_.push_back(static_cast<int>(i));
  }
  if (changed_vertices_.empty()) return;
  // An assembled K' is kept current tet by tet (old blocks out, new ones in).
  const bool assembled = stiffness_assembled_;
  if (++stamp_ == 0) {  // wrapped: clear the marks
    std::fill(tet_stamp_.begin(), tet_stamp_.end(), 0u);
    stamp_ = 1;
  }
  const std::span<const Vec3> old_x(state_x_);
  for (int v : changed_vertices_) {
    for (int ti : mesh_->vertex_tets(v)) {
      const auto t = static_cast<size_t>(ti);
      if (tet_stamp_[t] == stamp_) continue;
      tet_stamp_[t] = stamp_;
      const auto& tet = mesh_->tets()[t];
      // Take out the tet's old contribution (recomputed exactly as it was added), add the new one.
      const Mat3 F_old = deformation_gradient(old_x, ti);
      const Mat3 R_old = rotations_[t].toRotationMatrix();
      scatter_tet(tet, -element_forces(t, F_old, R_old), forces_);
      const Mat3 F = deformation_gradient(x, ti);
      extract_rotation(F, rotations_[t], kElementRotationIterations, kElementRotationTolerance);
      const Mat3 R = rotations_[t].toRotationMatrix();
      if (assembled) assemble_tet(t, rotated_gradients_[t], -1.0);
      rotated_gradients_[t] = R * rest_shape_inverse_[t].transpose();
      if (assembled) assemble_tet(t, rotated_gradients_[t], 1.0);
      const double trace = R.cwiseProduct(F).sum() - 3.0;
      tet_energy_[t] = volume_[t] * (mu_ * (F - R).squaredNorm() + 0.5 * lambda_ * trace * trace);
      scatter_tet(tet, element_forces(t, F, R), forces_);
    }
  }
  ++rotations_version_;
  for (int v : changed_vertices_) state_x_[static_cast<size_t>(v)] = x[static_cast<size_t>(v)];
  double energy = 0.0;
  for (double e : tet_energy_) energy += e;
  energy_ = energy;
}

void CorotationalFem::update_rotations(std::span<const Vec3> x) { linearise(x, true); }

void CorotationalFem::internal_forces(std::span<const Vec3> x, std::span<Vec3> f) {
  refresh_state(x);
  std::copy(forces_.begin(), forces_.end(), f.begin());
}

// internal_forces_at and internal_forces_at_frozen_rotations: sim/model/corotational_local_query.cpp.

// A pure query (session 6): the linearisation state (rotations, forces, per-tet energies, the
// positions they belong to) is left as it is, so a query between or inside steps changes no later
// result. Its value is the one the state would hold after refresh_state(x), bit for bit: the
// cached energy; the cached per-tet energies with the tets around a few changed vertices
// re-evaluated (warm starts: the cached rotations, which stay); or a full pass from the cached
// rotations. A full pass is kept aside (pass memo) with the positions and the rotations' version it
// started from, and the next linearise at those positions from the same warm starts adopts it
// instead of repeating it: World's report stage queries the energy at the step's end, and the next
// step's advance linearises there, so the pass still runs once per step.
double CorotationalFem::elastic_energy(std::span<const Vec3> x) {
  const size_t n = x.size();
  if (state_valid_) {
    changed_vertices_.clear();
    const size_t limit = n / kIncrementalFraction + 1;  // the capacity reserved (a copy of the model has less)
    bool few = true;
    for (size_t i = 0; i < n && few; ++i) {
      if (same_bits(x[i], state_x_[i])) continue;
      few = changed_vertices_.size() < limit;
      if (few) changed_vertices_.push_back(static_cast<int>(i));
    }
    if (few && changed_vertices_.empty()) return energy_;
    if (few) return energy_with_changed_vertices(x);
  }
  if (pass_memo_valid_ && pass_memo_version_ == rotations_version_ &&
      std::equal(x.begin(), x.end(), pass_memo_x_.begin(), same_bits)) {
    return pass_memo_energy_;
  }
  pass_memo_rotations_.resize(rotations_.size());
  pass_memo_forces_.resize(n);
  pass_memo_tet_energy_.resize(tet_energy_.size());
  // From the warm starts linearise would start from.
  pass_memo_energy_ = evaluate_pass(x, rotations_, pass_memo_rotations_, pass_memo_forces_, pass_memo_tet_energy_);
  pass_memo_x_.assign(x.begin(), x.end());
  pass_memo_version_ = rotations_version_;
  pass_memo_valid_ = true;
  return pass_memo_energy_;
}

double CorotationalFem::energy_with_changed_vertices(std::span<const Vec3> x) {
  // refresh_state's incremental path without its writes: the tets around changed_vertices_
  // evaluated into a scratch, the sum taken in tet order over the cached and the new energies.
  if (++stamp_ == 0) {  // wrapped: clear the marks
    std::fill(tet_stamp_.begin(), tet_stamp_.end(), 0u);
    stamp_ = 1;
  }
  query_tet_energy_.resize(tet_energy_.size());
  for (int v : changed_vertices_) {
    for (int ti : mesh_->vertex_tets(v)) {
      const auto t = static_cast<size_t>(ti);
      if (tet_stamp_[t] == stamp_) continue;
      tet_stamp_[t] = stamp_;
      const Mat3 F = deformation_gradient(x, ti);
      Quat q = rotations_[t];
      extract_rotation(F, q, kElementRotationIterations, kElementRotationTolerance);
      const Mat3 R = q.toRotationMatrix();
      const double trace = R.cwiseProduct(F).sum() - 3.0;
      query_tet_energy_[t] = volume_[t] * (mu_ * (F - R).squaredNorm() + 0.5 * lambda_ * trace * trace);
    }
  }
  double energy = 0.0;
  const size_t nt = tet_energy_.size();
  for (size_t t = 0; t < nt; ++t) energy += tet_stamp_[t] == stamp_ ? query_tet_energy_[t] : tet_energy_[t];
  return energy;
}

// Plain scalars and raw pointers (session 3): with Eigen's block * vector into a Vec3 returned
// through memory, GCC stored the running sum and reloaded the member arrays' pointers every block
// (it cannot rule out aliasing). Row i of the upper triangle: returns y_i + K_ii p_i + sum_j K_ij p_j
// and adds K_ij^T p_i to y_j (j > i), so y_i is complete once the rows before i have run.
static_assert(sizeof(Vec3) == 3 * sizeof(double) && sizeof(Mat3) == 9 * sizeof(double), "packed Eigen types");

namespace {

// Sweeps of symmetric block Gauss-Seidel (SSOR with omega = 1) over the system matrix
// A = D + L + L^T, D_i = (1 + h alpha) m_i I + h (beta + h) K'_ii (3x3 blocks), L_ji = s K'_ij^T for
// the stored upper blocks K'_ij (j > i), s = h (beta + h). Fixed vertices are decoupled: their rows
// carry no off-diagonal block and their D_i is the identity; every vector the sweeps see is exactly
// zero at fixed vertices (the residual and the directions are), so their columns need no test.
struct SsorSweeps {
  const double* blocks;  ///< K' upper-triangle blocks, column-major 3x3
  const int* cols;       ///< block column (vertex) index
  const int* offsets;    ///< row i: blocks [offsets[i], offsets[i + 1]), the first is K'_ii
  const Mat3* D;         ///< diagonal blocks of A
  const Mat3* D_inverse;
  const char* fixed;
  double s;  ///< h (beta + h)
  size_t n;
  /// The scatter by the AVX2/FMA kernel (fused_ssor_kernels.h; session 8), else the exact one (the
  /// solve's first forward sweep and its true-residual check; the iterations call the kernels).
  bool fused = false;

#if defined(__SSE2__)
  /// Rows ahead of the backward sweep whose blocks it asks the cache for (session 7).
  static constexpr size_t kBackwardPrefetchRows = 8;
  /// Asks for every other cache line of row k's blocks (measured as fast as every line, with half
  /// the prefetch instructions; a hint: no effect on any value).
  void prefetch_row(size_t k) const {
    const auto* line = reinterpret_cast<const char*>(blocks + 9 * static_cast<size_t>(offsets[k]));
    const auto* end = reinterpret_cast<const char*>(blocks + 9 * static_cast<size_t>(offsets[k + 1]));
    for (; line < end; line += 128) _mm_prefetch(line, _MM_HINT_T0);
  }
#endif

  /// t = (D + L^T)^-1 u: rows descending, t_i = D_i^-1 (u_i - s sum_{j > i} K'_ij t_j).
  void backward(const Vec3* u, Vec3* t) const {
    const double* T = t->data();
    for (size_t i = n; i-- > 0;) {
      if (fixed[i] != 0) {
        t[i] = u[i];
        continue;
      }
      double a0 = 0.0, a1 = 0.0, a2 = 0.0;
      const auto last = static_cast<size_t>(offsets[i + 1]);
#if defined(__SSE2__)
      // Rows descending, each row's blocks ascending: the hardware prefetcher does not follow that
      // stream (perf: the block loads stalled, 13% of solve_ssor's samples on one instruction).
      if (i >= kBackwardPrefetchRows) prefetch_row(i - kBackwardPrefetchRows);
#endif
      for (auto b = static_cast<size_t>(offsets[i]) + 1; b < last; ++b) {
        const auto j = static_cast<size_t>(cols[b]);
        const double* B = blocks + 9 * b;
        const double p0 = T[3 * j], p1 = T[3 * j + 1], p2 = T[3 * j + 2];
        a0 += B[0] * p0 + B[3] * p1 + B[6] * p2;
        a1 += B[1] * p0 + B[4] * p1 + B[7] * p2;
        a2 += B[2] * p0 + B[5] * p1 + B[8] * p2;
      }
      t[i] = D_inverse[i] * (u[i] - s * Vec3(a0, a1, a2));
    }
  }

  /// y = (D + L)^-1 u(i) for rows ascending, where u(i) gives row i's right-hand side once the
  /// rows before it are solved; out(i, y_i) receives each solution. acc is scratch (n entries).
  template <class Rhs, class Out>
  void forward(Rhs u, Out out, Vec3* acc) const {
    std::fill(acc, acc + n, Vec3::Zero());
    double* A = acc->data();
    for (size_t i = 0; i < n; ++i) {
      if (fixed[i] != 0) {
        out(i, Vec3(u(i)));
        continue;
      }
      const Vec3 y = D_inverse[i] * (u(i) - acc[i]);
      out(i, y);
      scatter_transposed(i, s * y.x(), s * y.y(), s * y.z(), A);
    }
  }

  /// acc_j += K'_ij^T y for the upper blocks of row i (j > i): per entry acc_jk += (B_0k y_0 +
  /// B_1k y_1) + B_2k y_2. Session 7: with SSE2, entries 0 and 1 in the two lanes of a register (y
  /// broadcast once per row; the lanes compute the scalar expressions, bit for bit).
  void scatter_transposed(size_t i, double y0, double y1, double y2, double* A) const {
    const auto last = static_cast<size_t>(offsets[i + 1]);
    if (fused) {
      fused_scatter_row(blocks, cols, static_cast<size_t>(offsets[i]) + 1, last, y0, y1, y2, A);
      return;
    }
#if defined(__SSE2__)
    const __m128d v0 = _mm_set1_pd(y0), v1 = _mm_set1_pd(y1), v2 = _mm_set1_pd(y2);
    for (auto b = static_cast<size_t>(offsets[i]) + 1; b < last; ++b) {
      const auto j = static_cast<size_t>(cols[b]);  // a fixed row ignores what it is sent
      const double* B = blocks + 9 * b;
      const __m128d c0 = _mm_loadh_pd(_mm_load_sd(B), B + 3);  // (B_00, B_01)
      const __m128d c1 = _mm_loadh_pd(_mm_load_sd(B + 1), B + 4);
      const __m128d c2 = _mm_loadh_pd(_mm_load_sd(B + 2), B + 5);
      const __m128d sum = _mm_add_pd(_mm_add_pd(_mm_mul_pd(c0, v0), _mm_mul_pd(c1, v1)), _mm_mul_pd(c2, v2));
      _mm_storeu_pd(A + 3 * j, _mm_add_pd(_mm_loadu_pd(A + 3 * j), sum));
      A[3 * j + 2] += B[6] * y0 + B[7] * y1 + B[8] * y2;
    }
#else
    for (auto b = static_cast<size_t>(offsets[i]) + 1; b < last; ++b) {
      const auto j = static_cast<size_t>(cols[b]);  // a fixed row ignores what it is sent
      const double* B = blocks + 9 * b;
      A[3 * j] += B[0] * y0 + B[1] * y1 + B[2] * y2;
      A[3 * j + 1] += B[3] * y0 + B[4] * y1 + B[5] * y2;
      A[3 * j + 2] += B[6] * y0 + B[7] * y1 + B[8] * y2;
    }
#endif
  }

  /// |(D + L) x|^2 (the true residual from the transformed one: r = (D + L) r~).
  double lower_product_norm_sq(const Vec3* x, Vec3* acc) const {
    std::fill(acc, acc + n, Vec3::Zero());
    double* A = acc->data();
    double sum = 0.0;
    for (size_t i = 0; i < n; ++i) {
      if (fixed[i] != 0) continue;  // zero residual there (x is zero, what it was sent is ignored)
      sum += (D[i] * x[i] + acc[i]).squaredNorm();
      scatter_transposed(i, s * x[i].x(), s * x[i].y(), s * x[i].z(), A);
    }
    return sum;
  }
};

}  // namespace

Vec3 CorotationalFem::row_product(size_t i, std::span<const Vec3> p, std::span<Vec3> y) const {
  if (vector_kernels_) {  // the same sums bit for bit, in AVX2 lanes (stiffness_row_kernels.h)
    Vec3 result;
    stiffness_row_product(blocks_.data()->data(), block_cols_.data(), static_cast<size_t>(block_row_offsets_[i]),
                          static_cast<size_t>(block_row_offsets_[i + 1]), i, p.data()->data(), y.data()->data(),
                          result.data());
    return result;
  }
  const double* __restrict m = blocks_.data()->data();
  const int* __restrict cols = block_cols_.data();
  const double* __restrict q = p.data()->data();
  double* __restrict out = y.data()->data();
  const auto first = static_cast<size_t>(block_row_offsets_[i]), last = static_cast<size_t>(block_row_offsets_[i + 1]);
  const double pi0 = q[3 * i], pi1 = q[3 * i + 1], pi2 = q[3 * i + 2];
  const double* D = m + 9 * first;  // K_ii
  double y0 = out[3 * i] + (D[0] * pi0 + D[3] * pi1 + D[6] * pi2);
  double y1 = out[3 * i + 1] + (D[1] * pi0 + D[4] * pi1 + D[7] * pi2);
  double y2 = out[3 * i + 2] + (D[2] * pi0 + D[5] * pi1 + D[8] * pi2);
  for (size_t b = first + 1; b < last; ++b) {
    const double* B = m + 9 * b;
    const size_t j = 3 * static_cast<size_t>(cols[b]);
    const double p0 = q[j], p1 = q[j + 1], p2 = q[j + 2];
    y0 += B[0] * p0 + B[3] * p1 + B[6] * p2;
    y1 += B[1] * p0 + B[4] * p1 + B[7] * p2;
    y2 += B[2] * p0 + B[5] * p1 + B[8] * p2;
    out[j] += B[0] * pi0 + B[1] * pi1 + B[2] * pi2;
    out[j + 1] += B[3] * pi0 + B[4] * pi1 + B[5] * pi2;
    out[j + 2] += B[6] * pi0 + B[7] * pi1 + B[8] * pi2;
  }
  return Vec3(y0, y1, y2);
}

void CorotationalFem::apply_stiffness(std::span<const Vec3> p, std::span<Vec3> y) const {
  std::fill(y.begin(), y.end(), Vec3::Zero());
  if (stiffness_assembled_) {
    const size_t n = y.size();
    for (size_t i = 0; i < n; ++i) y[i] = row_product(i, p, y);
    return;
  }
  refresh_rotated_gradients();
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

// A skipped row i (session 12) would add K'_ij^T 0 = +-0 to each y_j, j > i. y_j starts at +0 and a
// sum of nonzero terms that cancels is +0 too, so y_j is +0 or nonzero whenever such a term would
// come, and adding +-0 to either leaves its bits (finite blocks; non-finite ones fault the step
// through the other rows anyway).
void CorotationalFem::apply_stiffness_pair(std::span<const Vec3> a, std::span<Vec3> ya, std::span<const Vec3> b,
                                           std::span<Vec3> yb, std::span<const char> unused_rows) const {
  if (runs_parallel(executor_)) {
    apply_stiffness_pair_parallel(a, ya, b, yb);
    return;
  }
  std::fill(ya.begin(), ya.end(), Vec3::Zero());
  std::fill(yb.begin(), yb.end(), Vec3::Zero());
  const size_t n = ya.size();
  const auto exactly_zero = [](const Vec3& x) { return x.x() == 0.0 && x.y() == 0.0 && x.z() == 0.0; };
  for (size_t i = 0; i < n; ++i) {
    if (!unused_rows.empty() && unused_rows[i] != 0 && exactly_zero(a[i]) && exactly_zero(b[i])) {
      ya[i] = Vec3::Zero();
      yb[i] = Vec3::Zero();
      continue;
    }
    ya[i] = row_product(i, a, ya);
    yb[i] = row_product(i, b, yb);  // the row's blocks are still in L1
  }
}

double CorotationalFem::multiply_system(std::span<const Vec3> p, std::span<Vec3> y, double mass_scale,
                                        double stiffness_scale, std::span<const double> masses,
                                        std::span<const char> fixed) const {
  const size_t n = y.size();
  double py = 0.0;
  if (stiffness_assembled_) {
    std::fill(y.begin(), y.end(), Vec3::Zero());
    for (size_t i = 0; i < n; ++i) {
      const Vec3 Kp = row_product(i, p, y);  // complete: rows before i added their K_ki^T p_k
      const Vec3 yi = fixed[i] != 0 ? Vec3::Zero() : Vec3(mass_scale * masses[i] * p[i] + stiffness_scale * Kp);
      y[i] = yi;
      py += p[i].dot(yi);
    }
    return py;
  }
  apply_stiffness(p, y);
  for (size_t i = 0; i < n; ++i) {
    y[i] = fixed[i] != 0 ? Vec3::Zero() : Vec3(mass_scale * masses[i] * p[i] + stiffness_scale * y[i]);
    py += p[i].dot(y[i]);
  }
  return py;
}

CorotationalFem::CgOutcome CorotationalFem::solve_jacobi(double residual, double rhs_norm, double mass_scale,
                                                       double stiffness_scale, std::span<const double> masses,
                                                       std::span<const char> fixed) {
  const PcgOutcome o = preconditioned_cg(
      dv_, r_, p_, q_, z_, residual, rhs_norm, accuracy_.solver_tolerance, accuracy_.max_solver_iterations,
      [&](std::span<const Vec3> p, std::span<Vec3> q) {
        return multiply_system(p, q, mass_scale, stiffness_scale, masses, fixed);
      },
      [&](size_t i) { return Vec3(preconditioner_[i] * r_[i]); });
  return {o.iterations, o.residual};
}

void CorotationalFem::set_fused_sweeps(bool on) { fused_sweeps_ = on && fused_sweeps_available(); }

void CorotationalFem::set_vector_kernels(bool on) {
  vector_kernels_ = on && stiffness_row_kernels_available() && rotation_batch_avx2_available();
  system_valid_ = false;  // the D_i^-1 again from one code path (the kernel's bits equal the scalar's anyway)
}

void CorotationalFem::set_avx512_lanes(bool on) { avx512_lanes_ = on && rotation_batch_avx512_available(); }

void CorotationalFem::build_lower_pattern() const {
  if (block_row_offsets_.empty()) return;  // no assembled K'
  const size_t n = block_row_offsets_.size() - 1;
  if (lower_.offsets.size() == n + 1) return;
  lower_ = lower_triangle_pattern(block_row_offsets_.data(), block_cols_.data(), n);
  lower_entry_of_block_.assign(block_cols_.size(), -1);
  for (size_t k = 0; k < lower_.upper_blocks.size(); ++k) {
    lower_entry_of_block_[static_cast<size_t>(lower_.upper_blocks[k])] = static_cast<int>(k);
  }
}

// Preconditioned CG with the symmetric block Gauss-Seidel preconditioner M = (D + L) D^-1 (D + L^T)
// in Eisenstat's form (Eisenstat 1981; Saad, Iterative Methods for Sparse Linear Systems, 9.2.3):
// with A = (D + L) + (D + L^T) - D, the product A p needs no pass of its own. The recurrences run on
// r~ = (D + L)^-1 r and p^ = (D + L^T) p:
//   t = (D + L^T)^-1 p^ (= p, backward sweep),  w = t + (D + L)^-1 (p^ - D t) (forward sweep),
//   (D + L)^-1 A p = w,  p . A p = p^ . w,  r . z = r~ . D r~,  z = (D + L^T)^-1 D r~,
// so an iteration costs the two sweeps (together the flops of one K' product) instead of a product.
// The relative 2-norm residual |r| / |rhs| of the stopping rule is r = (D + L) r~, computed (a third
// pass) only when the M^-1-norm sqrt(r~ . D r~), scaled by its ratio to |r| at the last check,
// predicts the tolerance, and at the end for the report.
void CorotationalFem::refresh_lower_transposed(std::span<const char> fixed) {
  build_lower_pattern();
  if (incremental_system_ && lower_transposed_valid_ && block_changes_tracked_ && system_fixed_unchanged_) {
    // Session 17: only the blocks written since the last advance, transposed by plain copies (the
    // kernel's permutes copy too: the same bits); the rest are the bits they were.
    for (int b : changed_blocks_) {
      const int k = lower_entry_of_block_[static_cast<size_t>(b)];
      if (k < 0) continue;  // a diagonal block
      double* out = lower_transposed_.data() + 9 * static_cast<size_t>(k);
      if (fixed[static_cast<size_t>(lower_.rows[static_cast<size_t>(k)])] != 0) {
        std::fill(out, out + 9, 0.0);
        continue;
      }
      const double* B = blocks_.data()->data() + 9 * static_cast<size_t>(b);
      for (size_t r = 0; r < 3; ++r) {
        for (size_t c = 0; c < 3; ++c) out[r + 3 * c] = B[c + 3 * r];
      }
    }
  } else {
    lower_transposed_.resize(9 * lower_.rows.size() + 4);
    transpose_lower_blocks(blocks_.data()->data(), lower_.upper_blocks.data(), lower_.rows.data(), fixed.data(),
                           lower_.rows.size(), lower_transposed_.data());
  }
  lower_transposed_refreshed_ = true;
}

CorotationalFem::CgOutcome CorotationalFem::solve_ssor(double residual, double rhs_norm, double stiffness_scale,
                                                       std::span<const char> fixed) {
  const size_t n = dv_.size();
  const SsorSweeps sweeps{blocks_.data()->data(), block_cols_.data(), block_row_offsets_.data(),
                          diagonal_system_blocks_.data(), preconditioner_.data(), fixed.data(),
                          stiffness_scale, n, fused_sweeps_};
  // Coarse correction (session 13, coarse_correction.h): deflation needs the direction between the
  // two sweeps, so it runs the exact sweeps' iteration; the start's residual is made orthogonal to Z.
  bool coarse = false;
  if (coarse_aggregate_size_ > 0) {
    if (!coarse_.built_for(fixed, coarse_aggregate_size_)) {
      coarse_.build_aggregates(mesh_->rest_positions(), fixed, coarse_aggregate_size_);
    }
    coarse = coarse_.assemble({sweeps.blocks, sweeps.cols, sweeps.offsets, sweeps.D, sweeps.fixed, sweeps.s, n});
  }
  if (coarse) {
    coarse_.correct_start(dv_, r_);
    residual = std::sqrt(dot(r_, r_)) / rhs_norm;
  }
  // The forward sweep gathers from the transposed blocks (session 13, the same bits); advance may
  // have refreshed them already for its products (session 18).
  if (fused_sweeps_ && !coarse && !lower_transposed_refreshed_) refresh_lower_transposed(fixed);
  // Session 18: the exact sweep's scatters (the first forward sweep, the true-residual checks) by
  // gathering from them too (exact_sweep_kernels.h: the same bits).
  const bool gathered_exact = fused_sweeps_ && !coarse && gathered_products_ && exact_sweep_kernels_available();
  const GatheredSweepSystem gathered{lower_transposed_.data(), lower_.row_entries.data(), lower_.offsets.data(),
                                     sweeps.D->data(), sweeps.D_inverse->data(), fixed.data(), stiffness_scale, n};
  const auto true_residual_squared = [&]() {
    if (!gathered_exact) return sweeps.lower_product_norm_sq(r_.data(), kv_.data());
    exact_lower_product_rows_gathered(gathered, r_.data()->data(), kv_.data()->data(), sweep_rows_.data()->data());
    double sum = 0.0;
    for (size_t i = 0; i < n; ++i) {
      if (fixed[i] == 0) sum += sweep_rows_[i].squaredNorm();
    }
    return sum;
  };
  // r~ = (D + L)^-1 r; p^ = D r~.
  if (gathered_exact) {
    exact_forward_sweep_gathered(gathered, r_.data()->data(), kv_.data()->data());
  } else {
    sweeps.forward([&](size_t i) { return r_[i]; }, [&](size_t i, const Vec3& y) { r_[i] = y; }, kv_.data());
  }
  double rz = 0.0;
  for (size_t i = 0; i < n; ++i) {
    p_[i] = diagonal_system_blocks_[i] * r_[i];
    rz += r_[i].dot(p_[i]);
  }
  // |r| / |rhs| ~ scale * sqrt(r~ . D r~), recalibrated at every true-residual check.
  double scale = rz > 0.0 ? residual / std::sqrt(rz) : 0.0;
  const double tolerance = accuracy_.solver_tolerance;
  int it = 0;
  const FusedSsorSystem fused{sweeps.blocks, sweeps.cols, sweeps.offsets, sweeps.D->data(),
                              sweeps.D_inverse->data(), sweeps.fixed, sweeps.s, n,
                              lower_transposed_.data(), lower_.rows.data(), lower_.offsets.data(),
                              lower_.column_entries.data(), lower_.row_entries.data()};
  while (residual > tolerance && it < accuracy_.max_solver_iterations) {
    if (!(rz > 0.0)) break;
    double pq = 0.0, rz_next = 0.0, a = 0.0;
    if (fused_sweeps_ && !coarse) {  // the same iteration, AVX2/FMA (fused_ssor_kernels.h)
      pq = fused_eisenstat_sweeps(fused, p_.data()->data(), z_.data()->data(), q_.data()->data(), kv_.data()->data());
      if (!(pq > 0.0)) break;
      a = rz / pq;
      rz_next = fused_cg_update(fused, a, z_.data()->data(), q_.data()->data(), dv_.data()->data(),
                                r_.data()->data(), rhs_.data()->data());
    } else {
      sweeps.backward(p_.data(), z_.data());  // t
      if (coarse) coarse_.project_direction(z_, p_);  // t and p^ = (D + L^T) t A-orthogonal to Z
      sweeps.forward([&](size_t i) { return Vec3(p_[i] - diagonal_system_blocks_[i] * z_[i]); },
                     [&](size_t i, const Vec3& y) {
                       q_[i] = z_[i] + y;
                       pq += p_[i].dot(q_[i]);
                     },
                     kv_.data());  // w
      if (!(pq > 0.0)) break;
      a = rz / pq;
      for (size_t i = 0; i < n; ++i) {
        dv_[i] += a * z_[i];
        r_[i] -= a * q_[i];
        rhs_[i] = diagonal_system_blocks_[i] * r_[i];  // D r~ (the right-hand side is not needed any more)
        rz_next += r_[i].dot(rhs_[i]);
      }
    }
    ++it;
    residual = scale * std::sqrt(std::max(rz_next, 0.0));
    if (residual <= tolerance || it == accuracy_.max_solver_iterations) {
      // The estimate says done (or the cap): measure the true residual.
      residual = std::sqrt(true_residual_squared()) / rhs_norm;
      if (rz_next > 0.0) scale = residual / std::sqrt(rz_next);
      if (residual <= tolerance) break;
    }
    const double b = rz_next / rz;
    rz = rz_next;
    if (fused_sweeps_ && !coarse) {
      fused_direction_update(n, rhs_.data()->data(), b, p_.data()->data());
    } else {
      for (size_t i = 0; i < n; ++i) p_[i] = rhs_[i] + b * p_[i];
    }
  }
  return {it, residual};
}

bool CorotationalFem::build_diagonal_group(size_t g, double mass_scale, double stiffness_scale,
                                           const IntegrationInput& in) {
  const size_t n = preconditioner_.size(), first = 4 * g, count = std::min<size_t>(4, n - first);
  for (size_t i = first; i < first + count; ++i) {
    preconditioner_[i] = Mat3::Identity() * (mass_scale * in.masses[i]);
    preconditioner_[i] += stiffness_scale * blocks_[static_cast<size_t>(diagonal_blocks_[i])];
  }
  return invert_diagonal_rows(preconditioner_.data() + first, in.fixed.data() + first, count, vector_kernels_,
                              diagonal_system_blocks_.data() + first);
}

// Session 17: D_i = (1 + h alpha) m_i I + h (beta + h) K'_ii and D_i^-1 are functions of row i's
// mass, fixed flag, the two scales and K'_ii alone, and the kernel's lanes are independent (a group
// of four computed alone is the bits the whole array's call gives it). With K' reuse most K'_ii keep
// their bits between steps, so when the key is the same only the groups around the rows whose
// K'_ii was written (changed_rows_) are computed again; the SSOR test is kept per group.
bool CorotationalFem::build_diagonal_system(double mass_scale, double stiffness_scale, const IntegrationInput& in) {
  const size_t n = preconditioner_.size(), groups = (n + 3) / 4;
  system_fixed_unchanged_ =
      system_fixed_.size() == n && std::equal(in.fixed.begin(), in.fixed.end(), system_fixed_.begin());
  const bool same_key = system_fixed_unchanged_ && same_double_bits(mass_scale, system_mass_scale_) &&
                        same_double_bits(stiffness_scale, system_stiffness_scale_) && system_masses_.size() == n &&
                        std::memcmp(in.masses.data(), system_masses_.data(), n * sizeof(double)) == 0;
  if (incremental_system_ && system_valid_ && block_changes_tracked_ && same_key) {
    size_t last = groups, rows = 0;
    for (int i : changed_rows_) {
      const size_t g = static_cast<size_t>(i) / 4;
      if (g == last) continue;  // ascending: the group's rows done already
      last = g;
      const char pass = build_diagonal_group(g, mass_scale, stiffness_scale, in) ? 1 : 0;
      if (pass != system_group_pass_[g]) {
        system_failing_groups_ = pass != 0 ? system_failing_groups_ - 1 : system_failing_groups_ + 1;
        system_group_pass_[g] = pass;
      }
      rows += std::min<size_t>(4, n - 4 * g);
    }
    rebuilt_system_rows_ = rows;
    return system_failing_groups_ == 0;
  }
  for (size_t i = 0; i < n; ++i) {
    preconditioner_[i] = Mat3::Identity() * (mass_scale * in.masses[i]);
    preconditioner_[i] += stiffness_scale * blocks_[static_cast<size_t>(diagonal_blocks_[i])];
  }
  const bool pass = invert_diagonal_rows(preconditioner_.data(), in.fixed.data(), n, vector_kernels_,
                                         diagonal_system_blocks_.data());
  system_group_pass_.assign(groups, 1);
  system_failing_groups_ = 0;
  if (!pass) {  // some group failed: which (each group again, the same bits)
    for (size_t g = 0; g < groups; ++g) {
      system_group_pass_[g] = build_diagonal_group(g, mass_scale, stiffness_scale, in) ? 1 : 0;
      system_failing_groups_ += system_group_pass_[g] != 0 ? 0 : 1;
    }
  }
  system_mass_scale_ = mass_scale;
  system_stiffness_scale_ = stiffness_scale;
  system_masses_.assign(in.masses.begin(), in.masses.end());
  system_fixed_.assign(in.fixed.begin(), in.fixed.end());
  system_valid_ = true;
  rebuilt_system_rows_ = n;
  return pass;
}

// Session 18: the right-hand side's two products by stiffness_product_pair_gathered, where the
// fused sweeps' transposed lower blocks exist (their kernels run, no coarse correction), the step is
// serial, and every fixed row's v and warm start dv are exactly zero (apply_stiffness_pair skips
// those rows, and their transposed blocks are zero: a fixed row with a nonzero v would send K'^T v
// that the zeroed copies drop).
bool CorotationalFem::gathered_products_possible(std::span<const Vec3> v, std::span<const char> fixed) const {
  if (!gathered_products_ || !fused_sweeps_ || !vector_kernels_ || coarse_aggregate_size_ > 0 ||
      product_ != StiffnessProduct::assembled || runs_parallel(executor_) || !stiffness_row_kernels_available()) {
    return false;
  }
  const auto exactly_zero = [](const Vec3& x) { return x.x() == 0.0 && x.y() == 0.0 && x.z() == 0.0; };
  const size_t n = v.size();
  for (size_t i = 0; i < n; ++i) {
    if (fixed[i] != 0 && !(exactly_zero(v[i]) && exactly_zero(dv_[i]))) return false;
  }
  return true;
}

IntegrationResult CorotationalFem::advance(std::span<Vec3> x, std::span<Vec3> v, const IntegrationInput& in) {
  IntegrationResult result;
  const double h = in.dt;
  const size_t n = x.size();
  const double mass_scale = 1.0 + h * alpha_;        // M + h alpha M
  const double stiffness_scale = h * (beta_ + h);    // h beta K' + h^2 K'

  // Linearise at x_n: rotations, elastic forces f(x), rotated shape gradients for K'. The state
  // is usually cached already (the previous advance ended by computing it at these positions).
  const bool cached = state_valid_ && std::equal(x.begin(), x.end(), state_x_.begin(), same_bits);
  if (!cached) linearise(x, false);
  if (product_ == StiffnessProduct::assembled && !stiffness_assembled_) assemble_step_stiffness();

  // Linear extrapolation of the last two steps' dv (session 4): the probe scene's steps need 7.4
  // SSOR iterations on average instead of 8.0 from the last dv alone. A start worse than zero is
  // still replaced by zero below; fixed vertices start (and stay) at zero.
  // A constrained solve (a re-solve of this step with contact constraints) starts from the last
  // solve's dv instead and keeps the history as it is.
  const bool constrained = !in.constraint_normals.empty();
  for (size_t i = 0; i < n; ++i) {
    const Vec3 last = in.fixed[i] != 0 || !dv_[i].allFinite() ? Vec3::Zero() : dv_[i];
    if (constrained) {
      dv_[i] = last;
      continue;
    }
    dv_[i] = in.fixed[i] != 0 ? Vec3::Zero() : Vec3(2.0 * last - dv_previous_[i]);
    dv_previous_[i] = last;
  }
  // The SSOR's diagonal blocks D_i and their inverses for the assembled K' (session 18: before the
  // products below, which read the transposed lower blocks this step's fixed flags decide).
  bool ssor = product_ == StiffnessProduct::assembled && preconditioner_kind_ == Preconditioner::ssor;
  if (product_ == StiffnessProduct::assembled) ssor = build_diagonal_system(mass_scale, stiffness_scale, in) && ssor;

  // Right-hand side h (f + f_ext - alpha M v) - h (beta + h) K' v, zero at fixed vertices. With the
  // assembled K', K' dv of the warm start's residual comes from the same pass (q_).
  const bool warm_product = stiffness_assembled_;
  products_gathered_ = warm_product && gathered_products_possible(v, in.fixed);
  if (products_gathered_) {
    // Session 18: by gathering alone, from the transposed lower blocks the fused sweeps read (refreshed
    // here instead of in solve_ssor): the same bits as apply_stiffness_pair.
    if (!lower_transposed_refreshed_) refresh_lower_transposed(in.fixed);
    const StiffnessPairSystem sys{blocks_.data()->data(), lower_.column_entries.data(), block_row_offsets_.data(),
                                  lower_transposed_.data(), lower_.row_entries.data(), lower_.offsets.data(),
                                  in.fixed.data(), n};
    stiffness_product_pair_gathered(sys, v.data()->data(), dv_.data()->data(), kv_.data()->data(),
                                    q_.data()->data());
  } else if (warm_product) {
    apply_stiffness_pair(v, kv_, dv_, q_, in.fixed);  // fixed rows: v = dv = 0, results unused
  } else {
    apply_stiffness(v, kv_);
  }
  // |rhs|^2 summed in the same loop (session 18; the sum dot(rhs_, rhs_) took, in its order).
  double rhs_squared = 0.0;
  for (size_t i = 0; i < n; ++i) {
    rhs_[i] = in.fixed[i] != 0 ? Vec3::Zero()
                               : Vec3(h * (forces_[i] + in.external_forces[i] - alpha_ * in.masses[i] * v[i]) -
                                      stiffness_scale * kv_[i]);
    rhs_squared += rhs_[i].dot(rhs_[i]);
  }

  // Block-Jacobi preconditioner: inverse 3x3 diagonal blocks of the system matrix.
  // SSOR needs every diagonal block positive definite (a massless or degenerate vertex falls back
  // to block-Jacobi, whose zero block drops that vertex from the preconditioner).
  if (product_ != StiffnessProduct::assembled) {
    for (size_t i = 0; i < n; ++i) preconditioner_[i] = Mat3::Identity() * (mass_scale * in.masses[i]);
    refresh_rotated_gradients();
    const auto nt = static_cast<size_t>(mesh_->tet_count());
    for (size_t t = 0; t < nt; ++t) {
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
    invert_diagonal_rows(preconditioner_.data(), in.fixed.data(), n, vector_kernels_, diagonal_system_blocks_.data());
  }
  // A fixed row's inverse: the identity for SSOR, zero for block-Jacobi (where the inversion left
  // it zero; the incremental update may keep a row the last step set, so it is set every step).
  for (size_t i = 0; i < n; ++i) {
    if (in.fixed[i] != 0) preconditioner_[i] = ssor ? Mat3(Mat3::Identity()) : Mat3(Mat3::Zero());
  }

  // Preconditioned conjugate gradients on (M + h D + h^2 K') dv = rhs, warm-started from the last dv.
  const double rhs_norm = std::sqrt(rhs_squared);
  if (!std::isfinite(rhs_norm)) {
    // Non-finite input (e.g. a NaN applied force): NaN comparisons would skip the CG loop and
    // silently reuse the warm start, so make the result non-finite and let World::step report the
    // fault and restore the state. The next step resets the non-finite warm start to zero.
    std::fill(dv_.begin(), dv_.end(), Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
    result.converged = false;
    result.solver_residual = std::numeric_limits<double>::quiet_NaN();
  } else if (constrained) {
    const CgOutcome o = solve_constrained(v, mass_scale, stiffness_scale, in);
    result.solver_iterations = o.iterations;
    result.solver_residual = o.residual;
    result.converged = o.residual <= accuracy_.solver_tolerance;
  } else if (rhs_norm == 0.0) {
    std::fill(dv_.begin(), dv_.end(), Vec3::Zero());
  } else {
    if (!warm_product) multiply_system(dv_, q_, mass_scale, stiffness_scale, in.masses, in.fixed);
    // A dv_0 (from K' dv_0 where the product pass gave it) and the residual in one loop (session 18;
    // the two loops' expressions in their order).
    double rr = 0.0;
    for (size_t i = 0; i < n; ++i) {
      if (warm_product) {
        q_[i] = in.fixed[i] != 0 ? Vec3::Zero() : Vec3(mass_scale * in.masses[i] * dv_[i] + stiffness_scale * q_[i]);
      }
      r_[i] = rhs_[i] - q_[i];
      rr += r_[i].squaredNorm();
    }
    double residual = std::sqrt(rr) / rhs_norm;
    if (residual > 1.0) {
      // The warm start is worse than zero (e.g. after a contact edit): start from zero instead.
      std::fill(dv_.begin(), dv_.end(), Vec3::Zero());
      std::copy(rhs_.begin(), rhs_.end(), r_.begin());
      residual = 1.0;
    }
    if (ssor) {
      const CgOutcome o = solve_ssor(residual, rhs_norm, stiffness_scale, in.fixed);
      result.solver_iterations = o.iterations;
      result.solver_residual = o.residual;
      result.converged = o.residual <= accuracy_.solver_tolerance;
    } else {
      const CgOutcome o = solve_jacobi(residual, rhs_norm, mass_scale, stiffness_scale, in.masses, in.fixed);
      result.solver_iterations = o.iterations;
      result.solver_residual = o.residual;
      result.converged = o.residual <= accuracy_.solver_tolerance;
    }
  }

  // v+ = v + dv, x+ = x + h v+; fixed vertices stay exactly put.
  bool finite = true;
  for (size_t i = 0; i < n; ++i) {
    if (in.fixed[i] != 0) {
      v[i].setZero();
      continue;
    }
    v[i] += dv_[i];
    x[i] += h * v[i];
    finite = finite && x[i].allFinite();
  }
  // The linearisation state at x_{n+1} is deferred to its first use: the energy report, a full
  // force query or the next advance evaluate it at the positions they are given (after the contact
  // stage's edits: one pass, where evaluating here would cost a second pass whenever contact moves
  // many vertices); the frozen-rotation query evaluates it at x_{n+1} itself. Until then the
  // rotations are x_n's (warm starts). K' is assembled by the next advance. A non-finite x_{n+1}
  // (a fault World will undo) is not kept.
  if (product_ == StiffnessProduct::assembled) {
    // The next advance updates what this one built only where K' changes from here on (session 17).
    lower_transposed_valid_ = lower_transposed_refreshed_;
    lower_transposed_refreshed_ = false;
    changed_blocks_.clear();
    changed_rows_.clear();
    block_changes_tracked_ = true;
  }
  state_valid_ = false;
  stiffness_assembled_ = false;
  state_deferred_ = finite;
  if (finite) std::copy(x.begin(), x.end(), state_x_.begin());
  return result;
}

}  // namespace pliant
