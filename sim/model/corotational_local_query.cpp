// The corotational model's local force queries (the contact stage's binary search asks for the
// internal forces at a few region vertices, several times per step). Design note (session 4):
// - Tet-wise: a query gives each tet around the asked vertices a slot the first time one of them
//   needs it and evaluates the tet once there (exact: the rotation extraction and P; frozen: R^T F
//   and the force matrix -V P Dm^-T, whose columns are the forces on local vertices 1..3, vertex 0
//   minus their sum). Every asked vertex then sums its tets' forces in its own (ascending) tet
//   order, so the result does not depend on what else is asked, and a tet with three asked
//   vertices is evaluated once, not three times. The exact query keeps the per-vertex query's
//   expression -V P g_j (bitwise the same results as before); the frozen one reads a column.
// - Frozen rotations without the full pass: after `advance` the linearisation state at x_{n+1} is
//   deferred (corotational_fem.h); the frozen query needs the rotations at x_{n+1} only for the
//   tets it touches, so it extracts those lazily (warm start: the stored rotation, as the full pass
//   would) and caches them per tet, keyed by the bits of the tet's F at x_{n+1}. The respond stage
//   then costs O(region), and the full pass stays with its first real user (the report or the next
//   step). A cached rotation is the one the full pass would extract from the same F and warm start.
// - Nearby rotations (session 5): the exact query extracts each touched tet's rotation afresh, 5
//   times per step on a searching contact (4 search iterations and the final evaluation), and the
//   extraction was 63% of the query's time on three cubes. Every exact extraction is remembered per
//   tet with the F it came from; the nearby query reuses it while |F - F_R|_F <= tolerance, in any
//   later query or step (the polar rotation is a function of F, so a key on F needs no step
//   counter and no invalidation), and re-extracts (and remembers) otherwise. With the reused R the
//   stress is the warped-stiffness form R S(sym(R^T F)) of the frozen query: its error is first
//   order in the rotation error times the stress and second order otherwise (the (F - R) form
//   would resist the rotation error itself with 2 mu). The rotation error is about |dF| / 2 for
//   near-rigid tets; a sliver's F changes fast under small vertex moves, so it is re-extracted.
// - K' products (session 6): with rotations frozen the force is linear in x, so the search's later
//   iterations need only f(x1) - K' (x - x1) at the asked rows. The assembled upper-triangle rows of
//   the moved vertices give every needed block: K'_{jc} d_c from row j, K'_{cj} d_j = B_{jc}^T d_j
//   for c > j. Rows that did not move themselves get only the transposed blocks, hence the
//   contract: every asked row is in `moved` (with d = 0 if it stays).
// - Batched extraction (session 7): the exact and nearby queries first give every touched tet its
//   slot, then extract the rotations still needed kRotationBatchLanes at a time
//   (extract_rotations_batch: each lane the scalar extraction's operations, bit for bit, the full
//   pass's path since session 6), then sum per vertex. The warm starts (rotations_) are not
//   written by a query, so the order of the extractions cannot change a result: the forces are
//   the one-tet-at-a-time query's, bit for bit.
// - The full pass's AVX2 kernels (session 11): with vector kernels on (CorotationalFem's default
//   where the CPU has AVX2) the queries extract four rotations per batch in ymm registers
//   (extract_rotations_batch_avx2) and compute F = Ds Dm^-1 with deformation_gradients_avx2, P and
//   the per-vertex sums -V P g_j with query_stress_kernels.h, and the K' products with
//   stiffness_product_kernels.h; each is the scalar code's bits per tet, vertex and row, so the
//   forces are unchanged bit for bit (set_vector_kernels(false): the code before).
// - Session 13: whole in-slot batches take R from the extraction's lanes
//   (extract_rotation_matrices_batch_avx2, q normalised and R built there, the same bits), so the
//   stress kernel does not rebuild R from q per tet.
// - Session 14: the exact query's whole batches of four run F = Ds Dm^-1, the extraction, R and P
//   in one kernel's lanes (exact_query_stresses_avx2), F and R stored straight where the nearby
//   query remembers them: no F per tet gathered again, no R stored and loaded again (same bits).
#include <algorithm>
#include <cstring>

#include "sim/model/corotational_fem.h"
#include "sim/model/query_stress_kernels.h"
#include "sim/model/rotation_batch_avx2.h"
#include "sim/model/rotation_batch_avx512.h"
#include "sim/model/rotation_extraction.h"
#include "sim/model/stiffness_product_kernels.h"
#include "sim/model/tet_gradient_kernels.h"

namespace pliant {

namespace {

/// Local index (0..3) of vertex v in tet, or -1.
inline int local_index(const TetIndices& tet, int v) {
  for (int j = 0; j < 4; ++j) {
    if (tet[static_cast<size_t>(j)] == v) return j;
  }
  return -1;
}

/// Rest shape gradient of local vertex j from Dm^-1: row j-1 for j >= 1, minus their sum for 0.
inline Vec3 shape_gradient(const Mat3& rest_shape_inverse, int j) {
  if (j == 0) return -rest_shape_inverse.colwise().sum().transpose();
  return rest_shape_inverse.row(j - 1).transpose();
}

/// Force on local vertex j of a tet from its force matrix H = -V P Dm^-T (columns: local vertices
/// 1..3; vertex 0 gets minus their sum), as the whole-body scatter adds it.
inline Vec3 corner_force(const Mat3& H, int j) {
  if (j == 0) return -(H.col(0) + H.col(1) + H.col(2));
  return H.col(j - 1);
}

inline bool same_bits(const Mat3& a, const Mat3& b) { return std::memcmp(a.data(), b.data(), sizeof(double) * 9) == 0; }

}  // namespace

void CorotationalFem::begin_local_query() {
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  if (query_mark_.size() != nt) {
    query_mark_.assign(nt, 0u);
    query_slot_.assign(nt, -1);
    query_generation_ = 0;
    // Constant per corner (session 9): g_j as shape_gradient gives it, computed once, not per sum.
    corner_gradients_.resize(corners_.size());
    for (size_t c = 0; c < corners_.size(); ++c) {
      corner_gradients_[c] = shape_gradient(rest_shape_inverse_[static_cast<size_t>(corners_[c].tet)], corners_[c].local);
    }
    nearby_cached_.assign(nt, 0);  // sized here so remember_rotation only stores
    nearby_rotation_.resize(nt);
    nearby_key_.resize(nt);
  }
  if (++query_generation_ == 0) {  // wrapped: clear the marks
    std::fill(query_mark_.begin(), query_mark_.end(), 0u);
    query_generation_ = 1;
  }
  query_slots_ = 0;
}

std::pair<size_t, bool> CorotationalFem::local_query_slot(size_t t) {
  if (query_mark_[t] == query_generation_) return {static_cast<size_t>(query_slot_[t]), false};
  query_mark_[t] = query_generation_;
  const size_t slot = query_slots_++;
  query_slot_[t] = static_cast<int>(slot);
  if (query_forces_.size() < query_slots_) {  // grows to the largest region seen, then stays
    query_forces_.resize(query_slots_);
  }
  return {slot, true};
}

void CorotationalFem::query_deformation_gradient(std::span<const Vec3> x, size_t t, bool kernels, Mat3& F) const {
  if (!kernels) {
    F = deformation_gradient(x, static_cast<int>(t));
    return;
  }
  // The same bits in AVX2 lanes (tet_gradient_kernels.h), one tet per call (the query's tets are
  // scattered), written where the query keeps F (session 12: no copy through a returned Mat3).
  deformation_gradients_avx2(x.data()->data(), &mesh_->tets()[t], &rest_shape_inverse_[t], 1, &F);
}

void CorotationalFem::internal_forces_at(std::span<const Vec3> x, std::span<const int> vertices,
                                         std::span<Vec3> f) {
  begin_local_query();
  query_pending_.clear();
  const bool gradient_kernels = vector_kernels_ && tet_gradient_kernels_available();
  // Session 14: whole batches of four compute F in the extraction's lanes (exact_query_stresses_avx2),
  // so F is not computed here one tet at a time and gathered again by the extraction.
  const bool whole_batch_kernel = gradient_kernels && query_stress_kernels_available() &&
                                  evaluation_batch_lanes() == kRotationBatchLanesAvx2;
  for (const int v : vertices) {
    for (int t : mesh_->vertex_tets(v)) {
      const auto ts = static_cast<size_t>(t);
      const auto [slot, fresh] = local_query_slot(ts);
      if (!fresh) continue;
      // F, until the extraction below (for whole batches: in the kernel)
      if (!whole_batch_kernel) query_deformation_gradient(x, ts, gradient_kernels, query_forces_[slot]);
      query_pending_.push_back(t);
    }
  }
  if (whole_batch_kernel) {
    // Every slot is a pending tet, in order (slot k = pending tet k), so batch i's stresses go to
    // slots i .. i + 3; F and R go straight to the nearby query's memory (remember_rotation).
    // Session 18: eight at a time in AVX-512 lanes where the evaluation pass has them, then four at a
    // time; each lane is the scalar query's bits whatever batch it is in.
    constexpr size_t L = kRotationBatchLanesAvx2, L8 = kRotationBatchLanesAvx512;
    Quat q[L8];
    Mat3 *F[L8], *R[L8];
    const auto batch = [&](size_t i, size_t lanes) {
      for (size_t l = 0; l < lanes; ++l) {
        const auto t = static_cast<size_t>(query_pending_[i + l]);
        q[l] = rotations_[t];  // warm start; the stored rotation is left as it is
        F[l] = &nearby_key_[t];
        R[l] = &nearby_rotation_[t];
        nearby_cached_[t] = 1;
      }
    };
    size_t i = 0;
    if (avx512_lanes()) {
      for (; i + L8 <= query_pending_.size(); i += L8) {
        batch(i, L8);
        exact_query_stresses_avx512(x.data()->data(), mesh_->tets().data(), rest_shape_inverse_.data(),
                                    query_pending_.data() + i, q, mu_, lambda_, kElementRotationIterations,
                                    kElementRotationTolerance, F, R, query_forces_.data() + i);
      }
    }
    for (; i + L <= query_pending_.size(); i += L) {
      batch(i, L);
      exact_query_stresses_avx2(x.data()->data(), mesh_->tets().data(), rest_shape_inverse_.data(),
                                query_pending_.data() + i, q, mu_, lambda_, kElementRotationIterations,
                                kElementRotationTolerance, F, R, query_forces_.data() + i);
    }
    const size_t whole = i;
    // The last few: F into their slots, then the batched path below on them alone (a short batch
    // there, as before).
    for (size_t k = whole; k < query_pending_.size(); ++k) {
      query_deformation_gradient(x, static_cast<size_t>(query_pending_[k]), gradient_kernels, query_forces_[k]);
    }
    query_pending_.erase(query_pending_.begin(), query_pending_.begin() + static_cast<std::ptrdiff_t>(whole));
  }
  exact_query_stresses_batched();
  sum_query_stresses(vertices, f);
}

void CorotationalFem::sum_query_stresses(std::span<const int> vertices, std::span<Vec3> f) const {
  if (vector_kernels_ && query_stress_kernels_available()) {  // the sums below, bit for bit (query_stress_kernels.h)
    static_assert(sizeof(TetCorner) == 2 * sizeof(int), "corners walked by a stride of two ints");
    for (size_t k = 0; k < vertices.size(); ++k) {
      const auto v = static_cast<size_t>(vertices[k]);
      const auto first = static_cast<size_t>(corner_offsets_[v]), last = static_cast<size_t>(corner_offsets_[v + 1]);
      corner_stress_sum_avx2(&(corners_.data() + first)->tet, 2, corner_gradients_.data() + first, last - first,
                             query_slot_.data(), query_forces_.data(), volume_.data(), f[k].data());
    }
    return;
  }
  for (size_t k = 0; k < vertices.size(); ++k) {
    const auto v = static_cast<size_t>(vertices[k]);
    Vec3 sum = Vec3::Zero();
    const auto last = static_cast<size_t>(corner_offsets_[v + 1]);
    for (auto c = static_cast<size_t>(corner_offsets_[v]); c < last; ++c) {  // the vertex's tets, ascending
      const auto ts = static_cast<size_t>(corners_[c].tet);
      const auto slot = static_cast<size_t>(query_slot_[ts]);
      // -V P g_j per vertex-tet pair: the per-vertex query's expression, bit for bit (the held-force
      // floor test's jitter measure moved from 2.0 to 2.17 mm/s with the force-matrix form's round-off).
      sum -= volume_[ts] * (query_forces_[slot] * corner_gradients_[c]);
    }
    f[k] = sum;
  }
}

Mat3 CorotationalFem::exact_query_stress(size_t t, const Mat3& F) {
  Quat q = rotations_[t];  // warm start; the stored rotation is left as it is
  extract_rotation(F, q, kElementRotationIterations, kElementRotationTolerance);
  const Mat3 R = q.toRotationMatrix();
  remember_rotation(t, F, R);
  return first_piola(F, R);
}

void CorotationalFem::exact_query_stresses_batched() {
  // Four lanes in AVX2 registers where the CPU has them (the full pass's extraction, session 11),
  // else kRotationBatchLanes. Each lane is the scalar extraction bit for bit whatever else shares
  // the batch, so a short last batch is filled up with copies of its last tet (results discarded).
  // Session 18: eight lanes in AVX-512 registers where the evaluation pass has them and more than
  // four tets are left (a last batch of at most four takes the four lanes: the same work, half wide).
  const size_t batch_lanes = evaluation_batch_lanes();
  const bool wide = avx512_lanes();
  const size_t count = query_pending_.size();
  constexpr size_t kMaxLanes = std::max({kRotationBatchLanesAvx512, kRotationBatchLanesAvx2, kRotationBatchLanes});
  Mat3 F[kMaxLanes];
  Quat q[kMaxLanes];
  Mat3 R[kMaxLanes], P[kMaxLanes];
  const bool stress_kernels = vector_kernels_ && query_stress_kernels_available();
  // Session 12: in the exact query every slot is a pending tet, taken in order (slot k = pending
  // tet k), so whole batches need no gather of F nor a copy of P back into the slot.
  const bool in_slot_order = stress_kernels && batch_lanes == kRotationBatchLanesAvx2 && count == query_slots_;
  size_t i = 0, L = batch_lanes;
  for (; i < count; i += L) {
    L = wide && !in_slot_order && count - i > batch_lanes ? kRotationBatchLanesAvx512 : batch_lanes;
    const size_t lanes = std::min(L, count - i);
    if (lanes < L && !vector_kernels_) break;  // the code before: the last few one at a time
    if (in_slot_order && lanes == L) {
      // The batch's F already lie side by side in slots i .. i + L - 1: extract there, and let P
      // overwrite each F in place (the kernel reads a lane's F whole before it stores its P), after
      // the F is remembered. The same operations on the same bits as the copying loop below.
      Mat3* slots = query_forces_.data() + i;
      for (size_t l = 0; l < L; ++l) q[l] = rotations_[static_cast<size_t>(query_pending_[i + l])];
      // Session 13: the extraction hands over R (normalised and built in its lanes, the same bits
      // as q's toRotationMatrix), so the stress kernel does not rebuild it per tet.
      extract_rotation_matrices_batch_avx2(slots, q, R, kElementRotationIterations, kElementRotationTolerance);
      for (size_t l = 0; l < L; ++l) nearby_key_[static_cast<size_t>(query_pending_[i + l])] = slots[l];
      first_piola_stresses_from_rotations_avx2(R, slots, mu_, lambda_, L, slots);
      for (size_t l = 0; l < L; ++l) {
        const auto t = static_cast<size_t>(query_pending_[i + l]);
        nearby_rotation_[t] = R[l];
        nearby_cached_[t] = 1;
      }
      continue;
    }
    for (size_t l = 0; l < L; ++l) {
      const auto t = static_cast<size_t>(query_pending_[i + std::min(l, lanes - 1)]);
      F[l] = query_forces_[static_cast<size_t>(query_slot_[t])];
      q[l] = rotations_[t];  // warm start; the stored rotation is left as it is
    }
    if (L == kRotationBatchLanesAvx512) {
      extract_rotations_batch_avx512(F, q, kElementRotationIterations, kElementRotationTolerance);
    } else if (vector_kernels_) {
      extract_rotations_batch_avx2(F, q, kElementRotationIterations, kElementRotationTolerance);
    } else {
      extract_rotations_batch(F, q, kElementRotationIterations, kElementRotationTolerance);
    }
    if (stress_kernels) {  // first_piola's bits in lanes (query_stress_kernels.h)
      first_piola_stresses_avx2(q, F, mu_, lambda_, lanes, R, P);
      for (size_t l = 0; l < lanes; ++l) {
        const auto t = static_cast<size_t>(query_pending_[i + l]);
        remember_rotation(t, F[l], R[l]);
        query_forces_[static_cast<size_t>(query_slot_[t])] = P[l];
      }
      continue;
    }
    for (size_t l = 0; l < lanes; ++l) {
      const auto t = static_cast<size_t>(query_pending_[i + l]);
      const Mat3 R = q[l].toRotationMatrix();
      remember_rotation(t, F[l], R);
      query_forces_[static_cast<size_t>(query_slot_[t])] = first_piola(F[l], R);
    }
  }
  for (; i < count; ++i) {
    const auto t = static_cast<size_t>(query_pending_[i]);
    Mat3& slot = query_forces_[static_cast<size_t>(query_slot_[t])];
    slot = exact_query_stress(t, Mat3(slot));
  }
}

Mat3 CorotationalFem::warped_stiffness_stress(const Mat3& F, const Mat3& R) const {
  const Mat3 G = R.transpose() * F;
  Mat3 S = mu_ * (G + G.transpose());
  S.diagonal().array() += lambda_ * (G.trace() - 3.0) - 2.0 * mu_;
  return R * S;
}

void CorotationalFem::remember_rotation(size_t t, const Mat3& F, const Mat3& R) {
  nearby_rotation_[t] = R;  // sized by begin_local_query
  nearby_key_[t] = F;
  nearby_cached_[t] = 1;
}

void CorotationalFem::internal_forces_at_nearby_rotations(std::span<const Vec3> x, std::span<const int> vertices,
                                                          std::span<Vec3> f, double rotation_tolerance) {
  if (!(rotation_tolerance > 0.0)) {  // nothing may be reused: the exact query, bit for bit
    internal_forces_at(x, vertices, f);
    return;
  }
  begin_local_query();
  query_pending_.clear();
  const double tolerance_sq = rotation_tolerance * rotation_tolerance;
  const bool gradient_kernels = vector_kernels_ && tet_gradient_kernels_available();
  for (const int v : vertices) {
    for (int t : mesh_->vertex_tets(v)) {
      const auto ts = static_cast<size_t>(t);
      const auto [slot, fresh] = local_query_slot(ts);
      if (!fresh) continue;
      Mat3& F = query_forces_[slot];
      query_deformation_gradient(x, ts, gradient_kernels, F);
      const bool nearby = nearby_cached_[ts] != 0 &&
                          (F - nearby_key_[ts]).squaredNorm() <= tolerance_sq;
      // Within the tolerance: the frozen query's stress with the remembered rotation. Else F waits
      // for the batched extraction (a tet's remembered rotation is looked up before any of this
      // query's extractions, as in the one-at-a-time query: a tet is met once per query).
      if (nearby) {
        F = warped_stiffness_stress(F, nearby_rotation_[ts]);  // evaluated into a temporary first
      } else {
        query_pending_.push_back(t);
      }
    }
  }
  exact_query_stresses_batched();
  sum_query_stresses(vertices, f);
}

Mat3 CorotationalFem::frozen_rotation(size_t t) {
  if (!state_deferred_) return rotations_[t].toRotationMatrix();
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  if (frozen_cached_.size() != nt) {
    frozen_cached_.assign(nt, 0);
    frozen_rotation_.resize(nt);
    frozen_key_.resize(nt);
  }
  const Mat3 F = deformation_gradient(state_x_, static_cast<int>(t));
  if (frozen_cached_[t] == 0 || !same_bits(F, frozen_key_[t])) {
    Quat q = rotations_[t];  // the full pass's warm start (x_n's rotation)
    extract_rotation(F, q, kElementRotationIterations, kElementRotationTolerance);
    frozen_rotation_[t] = q.toRotationMatrix();
    frozen_key_[t] = F;
    frozen_cached_[t] = 1;
  }
  return frozen_rotation_[t];
}

void CorotationalFem::internal_forces_at_frozen_rotations(std::span<const Vec3> x, std::span<const int> vertices,
                                                          std::span<Vec3> f) {
  begin_local_query();
  for (size_t k = 0; k < vertices.size(); ++k) {
    const int v = vertices[k];
    Vec3 sum = Vec3::Zero();
    for (int t : mesh_->vertex_tets(v)) {
      const auto ts = static_cast<size_t>(t);
      const auto [slot, fresh] = local_query_slot(ts);
      // Mueller & Gross's warped stiffness f = -R K (R^T x - X): the linear stress of the symmetric
      // strain sym(R^T F) - I, rotated by R. (2 mu (F - R) would also resist a rotation away from R.)
      if (fresh) {
        // Forces -V P Dm^-T as element_forces.
        const Mat3 P = warped_stiffness_stress(deformation_gradient(x, t), frozen_rotation(ts));
        query_forces_[slot] = -volume_[ts] * P * rest_shape_inverse_[ts].transpose();
      }
      sum += corner_force(query_forces_[slot], local_index(mesh_->tets()[ts], v));
    }
    f[k] = sum;
  }
}

bool CorotationalFem::stiffness_product_at(std::span<const int> moved, std::span<const Vec3> d,
                                           std::span<const int> rows, std::span<Vec3> y, double strain_tolerance) {
  // The blocks are the last advance's K' only while its state is deferred (nothing re-linearised
  // since) and the product is assembled.
  if (product_ != StiffnessProduct::assembled || !state_deferred_ || blocks_.empty()) return false;
  const auto n = static_cast<size_t>(mesh_->vertex_count());
  if (product_entry_.size() != n) {
    product_entry_.assign(n, -1);
    product_sum_.assign(n, Vec3::Zero());
    // A move d of vertex j changes F of each of its tets by d g_j^T, |d g_j^T|_F = |d| |g_j|.
    vertex_gradient_bound_.assign(n, 0.0);
    const auto nt = static_cast<size_t>(mesh_->tet_count());
    for (size_t t = 0; t < nt; ++t) {
      for (int j = 0; j < 4; ++j) {
        auto& bound = vertex_gradient_bound_[static_cast<size_t>(mesh_->tets()[t][static_cast<size_t>(j)])];
        bound = std::max(bound, shape_gradient(rest_shape_inverse_[t], j).norm());
      }
    }
  }
  // Each moved vertex's own share of its tets' |dF| (a tet's is at most the sum over its corners).
  for (size_t k = 0; k < moved.size(); ++k) {
    if (d[k].norm() * vertex_gradient_bound_[static_cast<size_t>(moved[k])] > strain_tolerance) return false;
  }
  for (size_t k = 0; k < moved.size(); ++k) product_entry_[static_cast<size_t>(moved[k])] = static_cast<int>(k);
  const bool row_kernels = vector_kernels_ && stiffness_product_kernels_available();
  if (row_kernels) {  // the scalar loop's sums bit for bit, in AVX2 lanes (stiffness_product_kernels.h)
    for (size_t k = 0; k < moved.size(); ++k) {
      const auto j = static_cast<size_t>(moved[k]);
      const auto first = static_cast<size_t>(block_row_offsets_[j]), last = static_cast<size_t>(block_row_offsets_[j + 1]);
      stiffness_row_product_avx2(blocks_.data() + first, block_cols_.data() + first, last - first, j, d[k],
                                 product_entry_.data(), d.data(), product_sum_.data()->data());
    }
  }
  for (size_t k = 0; k < moved.size() && !row_kernels; ++k) {
    const auto j = static_cast<size_t>(moved[k]);
    const Vec3& dj = d[k];
    const auto first = static_cast<size_t>(block_row_offsets_[j]), last = static_cast<size_t>(block_row_offsets_[j + 1]);
    product_sum_[j] += blocks_[first] * dj;  // K'_jj
    for (size_t b = first + 1; b < last; ++b) {
      const auto c = static_cast<size_t>(block_cols_[b]);
      const Mat3& B = blocks_[b];  // K'_jc, c > j
      product_sum_[c] += B.transpose() * dj;
      const int e = product_entry_[c];
      if (e >= 0) product_sum_[j] += B * d[static_cast<size_t>(e)];
    }
  }
  for (size_t k = 0; k < rows.size(); ++k) y[k] = product_sum_[static_cast<size_t>(rows[k])];
  // Clear what was touched: the moved rows and their columns.
  for (const int v : moved) {
    const auto j = static_cast<size_t>(v);
    product_entry_[j] = -1;
    const auto first = static_cast<size_t>(block_row_offsets_[j]), last = static_cast<size_t>(block_row_offsets_[j + 1]);
    for (size_t b = first; b < last; ++b) product_sum_[static_cast<size_t>(block_cols_[b])] = Vec3::Zero();
  }
  return true;
}

}  // namespace pliant
