// The corotational FEM's loops on threads (session 9, docs/threads.md). Used only when the World was
// given an executor that runs parallel; otherwise corotational_fem.cpp runs them inline as before.
//
// Design note: every loop here is split into chunks of a fixed size (not a function of the thread
// count) whose outputs are disjoint, and whatever the serial code accumulates across elements is
// done afterwards in the serial code's order:
// - the evaluation pass computes each tet's rotation, energy and element forces -V P Dm^-T into
//   per-tet slots; then each vertex gathers its tets' columns in ascending tet order (the order the
//   serial scatter adds them in, the same expressions), and the energy is summed in tet order;
// - K' rows: assemble_row writes only row i's blocks, so rows are independent as they are.
// So a step gives the same bits for 1, 2 or N threads, and the same as the serial code.
#include <algorithm>

#include "sim/model/corotational_fem.h"
#include "sim/model/rotation_batch_avx2.h"
#include "sim/model/rotation_batch_avx512.h"
#include "sim/model/rotation_extraction.h"
#include "sim/parallel/task_executor.h"

namespace pliant {

namespace {

/// Tets per chunk of the evaluation pass (a multiple of every kRotationBatchLanes, so each chunk
/// batches its rotations as the serial pass does; the batch gives the scalar's bits either way).
constexpr size_t kTetChunk = 128;
/// Vertex rows per chunk of the force gather and of the K' assembly.
constexpr size_t kRowChunk = 64;
static_assert(kTetChunk % kRotationBatchLanes == 0 && kTetChunk % kRotationBatchLanesAvx2 == 0 &&
                  kTetChunk % kRotationBatchLanesAvx512 == 0,
              "chunks hold whole batches");

}  // namespace

double CorotationalFem::evaluate_pass_parallel(std::span<const Vec3> x, const std::vector<Quat>& warm_starts,
                                               std::vector<Quat>& rotations, std::vector<Vec3>& forces,
                                               std::vector<double>& tet_energy) const {
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  tet_force_scratch_.resize(nt);
  // Per tet: rotation, energy, element forces (evaluate_tet_batch, the serial pass's own code; its
  // batches give the same bits as extract_rotation tet by tet, so chunk boundaries change nothing).
  const size_t L = evaluation_pass_lanes();
  parallel_for_chunks(executor_, nt, kTetChunk, [&](size_t begin, size_t end) {
    for (size_t t0 = begin; t0 < end; t0 += L) {
      evaluate_tet_batch(x, warm_starts, rotations, tet_energy, t0, std::min(L, end - t0), &tet_force_scratch_[t0]);
    }
  });
  // Per vertex: the serial scatter_tet's additions to this vertex, in ascending tet order.
  const auto n = static_cast<size_t>(mesh_->vertex_count());
  parallel_for_chunks(executor_, n, kRowChunk, [&](size_t begin, size_t end) {
    for (size_t v = begin; v < end; ++v) {
      Vec3 f = Vec3::Zero();
      for (int ti : mesh_->vertex_tets(static_cast<int>(v))) {
        const auto t = static_cast<size_t>(ti);
        const Mat3& H = tet_force_scratch_[t];
        const auto& tet = mesh_->tets()[t];
        if (tet[0] == static_cast<int>(v)) {
          f -= H.col(0) + H.col(1) + H.col(2);
        } else {
          for (int j = 0; j < 3; ++j) {
            if (tet[static_cast<size_t>(j + 1)] == static_cast<int>(v)) f += H.col(j);
          }
        }
      }
      forces[v] = f;
    }
  });
  double energy = 0.0;
  for (size_t t = 0; t < nt; ++t) energy += tet_energy[t];
  return energy;
}

void CorotationalFem::assemble_rows_parallel(std::span<const int> rows, const Mat3* gradients) {
  const size_t count = rows.empty() ? static_cast<size_t>(mesh_->vertex_count()) : rows.size();
  parallel_for_chunks(executor_, count, kRowChunk, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) assemble_row(rows.empty() ? k : static_cast<size_t>(rows[k]), gradients);
  });
}

void CorotationalFem::apply_stiffness_pair_parallel(std::span<const Vec3> a, std::span<Vec3> ya,
                                                    std::span<const Vec3> b, std::span<Vec3> yb) const {
  const size_t n = ya.size();
  build_lower_pattern();
  const double* m = blocks_.data()->data();
  const int* cols = block_cols_.data();
  // Row i of the serial row_product, with what the rows before it scattered into y_i gathered first
  // (out[j] += B[0] p0 + B[1] p1 + B[2] p2 ... per transposed block, ascending rows, from 0).
  auto row = [&](size_t i, const double* q, double* out) {
    double t0 = 0.0, t1 = 0.0, t2 = 0.0;
    for (auto k = static_cast<size_t>(lower_.offsets[i]); k < static_cast<size_t>(lower_.offsets[i + 1]); ++k) {
      const double* B = m + 9 * static_cast<size_t>(lower_.upper_blocks[k]);
      const size_t j = 3 * static_cast<size_t>(lower_.rows[k]);
      const double pj0 = q[j], pj1 = q[j + 1], pj2 = q[j + 2];
      t0 += B[0] * pj0 + B[1] * pj1 + B[2] * pj2;
      t1 += B[3] * pj0 + B[4] * pj1 + B[5] * pj2;
      t2 += B[6] * pj0 + B[7] * pj1 + B[8] * pj2;
    }
    const auto first = static_cast<size_t>(block_row_offsets_[i]), last = static_cast<size_t>(block_row_offsets_[i + 1]);
    const double pi0 = q[3 * i], pi1 = q[3 * i + 1], pi2 = q[3 * i + 2];
    const double* D = m + 9 * first;  // K_ii
    double y0 = t0 + (D[0] * pi0 + D[3] * pi1 + D[6] * pi2);
    double y1 = t1 + (D[1] * pi0 + D[4] * pi1 + D[7] * pi2);
    double y2 = t2 + (D[2] * pi0 + D[5] * pi1 + D[8] * pi2);
    for (size_t k = first + 1; k < last; ++k) {
      const double* B = m + 9 * k;
      const size_t j = 3 * static_cast<size_t>(cols[k]);
      const double p0 = q[j], p1 = q[j + 1], p2 = q[j + 2];
      y0 += B[0] * p0 + B[3] * p1 + B[6] * p2;
      y1 += B[1] * p0 + B[4] * p1 + B[7] * p2;
      y2 += B[2] * p0 + B[5] * p1 + B[8] * p2;
    }
    out[3 * i] = y0;
    out[3 * i + 1] = y1;
    out[3 * i + 2] = y2;
  };
  parallel_for_chunks(executor_, n, kRowChunk, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      row(i, a.data()->data(), ya.data()->data());
      row(i, b.data()->data(), yb.data()->data());
    }
  });
}

void CorotationalFem::refresh_rotated_gradients_parallel() const {
  const auto nt = static_cast<size_t>(mesh_->tet_count());
  parallel_for_chunks(executor_, nt, kTetChunk * 4, [&](size_t begin, size_t end) {
    for (size_t t = begin; t < end; ++t) rotated_gradients_[t] = rotated_gradient(t);
  });
}

}  // namespace pliant
