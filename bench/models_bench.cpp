// Deformation model costs on a cantilever beam of 75 x 4 x 4 Kuhn cells (1,900 nodes, 7,200 tets;
// the issue's ~2,000-node / ~7,300-tet beam): internal forces per tet, one K' product (the body of a
// CG iteration) per tet, matrix-free against assembled, a full implicit step at the default
// 20 CG iterations (SOFA's published figure for a comparable beam: 13.8 ms on an i7-4790K), the
// energy query of World's report stage after a step, and the contact stage's local force query.
//
// Every timed step starts from the same state: the beam after 20 sagging steps of 10 ms (rotations
// far from identity, 2 rotation iterations per tet). The model and the state are restored from a
// snapshot outside the timing before each iteration: a free-running beam of this softness
// (E = 1e5 Pa, 1 m) swings through large deformations within ~100 steps, and a benchmark whose
// state drifts with the number of iterations it happens to run measures a different step each time.
// Run: build-models/bench/models_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "sim/mesh/box_mesh.h"
#include "sim/model/corotational_fem.h"
#include "sim/model/fused_ssor_kernels.h"
#include "sim/model/rotation_batch_avx2.h"
#include "sim/model/rotation_batch_avx512.h"
#include "sim/model/rotation_extraction.h"
#include "sim/model/teschner_explicit.h"

namespace pliant {
namespace {

struct Beam {
  TetMeshPtr mesh = make_box_mesh({Vec3(1.0, 0.08, 0.08), 75, 4, 4});
  Material material = [] {
    Material m;
    m.young_modulus = 1e5;
    m.poisson_ratio = 0.45;
    m.density = 1000.0;
    m.stiffness_damping = 0.01;
    return m;
  }();
  std::vector<double> masses = mesh->lumped_masses(material.density);
  std::vector<char> fixed;
  std::vector<Vec3> external;
  std::vector<Vec3> x = mesh->rest_positions();
  std::vector<Vec3> v = std::vector<Vec3>(x.size(), Vec3::Zero());

  Beam() {
    fixed.assign(x.size(), 0);
    external.resize(x.size());
    for (size_t i = 0; i < x.size(); ++i) {
      fixed[i] = x[i].x() < -0.5 + 1e-12 ? 1 : 0;
      external[i] = masses[i] * Vec3(0, 0, -9.81);
    }
  }
  IntegrationInput input(double dt = 1e-2) const { return {masses, fixed, external, dt}; }
  /// Sags the beam for a few steps so rotations are not identity.
  void settle(DeformationModel& model, int steps = 20) {
    for (int s = 0; s < steps; ++s) model.advance(x, v, input());
  }
};

/// The contact stage's vertices: 8 surface vertices spread along the beam's top.
const std::vector<int>& probe_vertices() {
  static const std::vector<int> vertices = {100, 300, 500, 700, 900, 1100, 1300, 1500};
  return vertices;
}

void per_tet(benchmark::State& state, const Beam& beam) {
  state.counters["tets"] = beam.mesh->tet_count();
  state.counters["nodes"] = beam.mesh->vertex_count();
  state.counters["ns_per_tet"] = benchmark::Counter(static_cast<double>(beam.mesh->tet_count()) * 1e-9,
                                                    benchmark::Counter::kIsIterationInvariantRate |
                                                        benchmark::Counter::kInvert);
}

// A full evaluation pass at a new state: rotations (warm-started from the previous step's), forces.
void BM_CorotationalInternalForces(benchmark::State& state) {
  Beam beam;
  CorotationalFem model(beam.mesh, beam.material, {});
  beam.settle(model);
  const std::vector<Vec3> x_prev = beam.x;
  beam.settle(model, 1);
  model.update_rotations(x_prev);  // warm start: the rotations one step (10 ms) before beam.x
  const CorotationalFem snapshot = model;
  std::vector<Vec3> f(beam.x.size());
  for (auto _ : state) {
    state.PauseTiming();
    model = snapshot;
    state.ResumeTiming();
    model.internal_forces(beam.x, f);
    benchmark::DoNotOptimize(f.data());
  }
  per_tet(state, beam);
}
BENCHMARK(BM_CorotationalInternalForces)->Unit(benchmark::kMicrosecond);

void BM_TeschnerInternalForces(benchmark::State& state) {
  Beam beam;
  TeschnerExplicit model(beam.mesh, beam.material, {});
  beam.settle(model);
  std::vector<Vec3> f(beam.x.size());
  for (auto _ : state) {
    model.internal_forces(beam.x, f);
    benchmark::DoNotOptimize(f.data());
  }
  per_tet(state, beam);
}
BENCHMARK(BM_TeschnerInternalForces)->Unit(benchmark::kMicrosecond);

// The contact stage's query after a step, at positions where the 8 vertices were pushed by 1 mm
// (a contact displacement): exact (rotations re-extracted) and, arg 1, rotations frozen at the step.
void BM_CorotationalInternalForcesAt8Vertices(benchmark::State& state) {
  Beam beam;
  CorotationalFem model(beam.mesh, beam.material, {});
  beam.settle(model);
  std::vector<Vec3> x = beam.x;
  for (int v : probe_vertices()) x[static_cast<size_t>(v)] += Vec3(0.0, 0.0, -1e-3);
  std::vector<Vec3> f(probe_vertices().size());
  const bool frozen = state.range(0) == 1;
  for (auto _ : state) {
    if (frozen) {
      model.internal_forces_at_frozen_rotations(x, probe_vertices(), f);
    } else {
      model.internal_forces_at(x, probe_vertices(), f);
    }
    benchmark::DoNotOptimize(f.data());
  }
  state.SetLabel(frozen ? "frozen rotations" : "exact");
}
BENCHMARK(BM_CorotationalInternalForcesAt8Vertices)->Arg(0)->Arg(1)->Unit(benchmark::kNanosecond);

// World's report stage after a step: elastic_energy at the step's result, arg 0, and after the
// contact stage moved 8 vertices by 1 mm, arg 1. Since session 3 advance defers the evaluation at
// its result to this query, so this is a full pass (rotations, forces, energies; not K').
// Arg 2: unmoved, the rotations four tets at a time (AVX2) where arg 0 takes eight (AVX-512, session 17).
void BM_CorotationalEnergyAfterStep(benchmark::State& state) {
  Beam beam;
  CorotationalFem model(beam.mesh, beam.material, {});
  if (state.range(0) == 2) model.set_avx512_lanes(false);
  beam.settle(model);
  if (state.range(0) == 1) {
    for (int v : probe_vertices()) beam.x[static_cast<size_t>(v)] += Vec3(0.0, 0.0, -1e-3);
  }
  const CorotationalFem snapshot = model;
  double energy = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    model = snapshot;
    state.ResumeTiming();
    energy = model.elastic_energy(beam.x);
    benchmark::DoNotOptimize(energy);
  }
  state.SetLabel(state.range(0) == 1 ? "8 vertices moved" : state.range(0) == 2 ? "unmoved, 4 lanes" : "unmoved");
}
BENCHMARK(BM_CorotationalEnergyAfterStep)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

// The evaluation pass's rotation batch alone (session 17): 4,320 tets (the probe's tissue) through
// extract_rotations_batch_avx2 (arg 0 = 4) or _avx512 (8), from warm starts copied in before each
// batch. Arg 1 the mix: 0, every tet a small strain of a rotated tet with its warm start ~1e-3 rad
// away (1-2 iterations, the probe's); 1, the same with every eighth tet a large stretch from a far
// warm start (~5-7 iterations): each 8-lane batch then waits for one slow lane, half the 4-lane
// batches do; 2, every tet slow.
void BM_RotationBatch(benchmark::State& state) {
  const int lanes = static_cast<int>(state.range(0)), mix = static_cast<int>(state.range(1));
  if (lanes == kRotationBatchLanesAvx512 ? !rotation_batch_avx512_available() : !rotation_batch_avx2_available()) {
    state.SkipWithError("no kernel for these lanes on this CPU");
    return;
  }
  constexpr size_t kTets = 4320;
  std::vector<Mat3> F(kTets);
  std::vector<Quat> warm(kTets), q(kTets);
  uint64_t seed = 20261128;
  const auto uniform = [&seed] {  // [-1, 1), a fixed sequence (splitmix64)
    seed += 0x9e3779b97f4a7c15ull;
    uint64_t z = seed;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-52 - 1.0;
  };
  const auto rotation = [&] { return Quat(uniform(), uniform(), uniform(), uniform()).normalized(); };
  for (size_t t = 0; t < kTets; ++t) {
    const bool slow = mix == 2 || (mix == 1 && t % 8 == 3);
    const Quat R = rotation();
    Mat3 S = Mat3::Identity();
    for (int k = 0; k < 9; ++k) S.data()[k] += (slow ? 0.5 : 1e-3) * uniform();
    F[t] = R.toRotationMatrix() * S;
    // the warm start ~1e-3 rad (fast) or up to ~1 rad (slow; facing F, so no SVD start) from R
    const double away = slow ? 0.5 : 5e-4;
    warm[t] = (R * Quat(1.0, away * uniform(), away * uniform(), away * uniform()).normalized()).normalized();
  }
  for (auto _ : state) {
    std::copy(warm.begin(), warm.end(), q.begin());
    for (size_t t = 0; t < kTets; t += static_cast<size_t>(lanes)) {
      if (lanes == kRotationBatchLanesAvx512) {
        extract_rotations_batch_avx512(&F[t], &q[t], kElementRotationIterations, kElementRotationTolerance);
      } else {
        extract_rotations_batch_avx2(&F[t], &q[t], kElementRotationIterations, kElementRotationTolerance);
      }
    }
    benchmark::DoNotOptimize(q.data());
  }
  int iterations = 0;  // per tet, from the scalar extraction
  for (size_t t = 0; t < kTets; ++t) {
    Quat r = warm[t];
    iterations += extract_rotation(F[t], r, kElementRotationIterations, kElementRotationTolerance);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(kTets));
  state.SetLabel(std::to_string(lanes) + " lanes, " + std::to_string(static_cast<double>(iterations) / kTets).substr(0, 4) +
                 " iterations per tet");
}
BENCHMARK(BM_RotationBatch)->ArgsProduct({{4, 8}, {0, 1, 2}})->Unit(benchmark::kMicrosecond);

// One K' product: the body of one CG iteration (plus O(n) vector updates).
void BM_StiffnessProduct(benchmark::State& state) {
  const auto product = static_cast<StiffnessProduct>(state.range(0));
  Beam beam;
  CorotationalFem model(beam.mesh, beam.material, {}, product);
  beam.settle(model);
  model.update_rotations(beam.x);  // the state advance deferred, with K' (and its blocks) at x
  std::vector<Vec3> y(beam.x.size());
  for (auto _ : state) {
    model.apply_stiffness(beam.v, y);
    benchmark::DoNotOptimize(y.data());
  }
  per_tet(state, beam);
  state.SetLabel(product == StiffnessProduct::matrix_free ? "matrix_free" : "assembled");
}
BENCHMARK(BM_StiffnessProduct)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// Times one advance of `model` from the beam's settled state, restored (untimed) before every
// iteration; returns the last iteration's result.
IntegrationResult time_advance_from_settled(benchmark::State& state, Beam& beam, CorotationalFem& model) {
  const CorotationalFem snapshot = model;
  const std::vector<Vec3> x0 = beam.x, v0 = beam.v;
  IntegrationResult result;
  for (auto _ : state) {
    state.PauseTiming();
    model = snapshot;
    std::copy(x0.begin(), x0.end(), beam.x.begin());
    std::copy(v0.begin(), v0.end(), beam.v.begin());
    state.ResumeTiming();
    result = model.advance(beam.x, beam.v, beam.input());
  }
  return result;
}

// A full implicit step (rotations, forces, [assembly], preconditioner, 20 CG iterations, update),
// always the same step: model and state are restored from a snapshot outside the timing.
// Arg 0: matrix-free K' (block-Jacobi); 1: assembled K' with the default preconditioner (SSOR,
// session 4); 2: assembled K' with block-Jacobi (the default before session 4); 3: as 1 without
// K' reuse between steps (session 5: tolerance 0, every row summed); 4: as 1 stopped before the
// first CG iteration (session 7: the step's cost besides its iterations, i.e. linearisation, K'
// rows, preconditioner, right-hand side, warm start, the residual's first transform and the update;
// (/1 - /4) / 20 is one SSOR-PCG iteration); 5, 6: as 1 with the exact / the AVX2-FMA sweeps
// (session 8); 7: as 1 with the fixed part's AVX2 kernels off (session 9: the scalar K' rows and 2-lane
// rotations, the same result bit for bit). The residual counter is the relative CG residual the
// iterations reach, rows_summed the K' rows the step summed again.
void BM_CorotationalImplicitStep(benchmark::State& state) {
  const auto arg = state.range(0);
  const auto product = arg == 0 ? StiffnessProduct::matrix_free : StiffnessProduct::assembled;
  Beam beam;
  ModelSettings settings;
  settings.accuracy.max_solver_iterations = 20;
  settings.accuracy.solver_tolerance = 1e-12;  // always runs the 20 iterations
  CorotationalFem model(beam.mesh, beam.material, settings, product);
  if (arg == 2) model.set_preconditioner(Preconditioner::block_jacobi);
  if (arg == 3) model.set_stiffness_rotation_tolerance(0.0);
  if (arg == 5) model.set_fused_sweeps(false);
  if (arg == 6) model.set_fused_sweeps(true);
  if (arg == 7) model.set_vector_kernels(false);
  beam.settle(model);
  if (arg == 4) {  // the same settled state, then no iteration
    ModelAccuracy accuracy = model.accuracy();
    accuracy.max_solver_iterations = 0;
    model.set_accuracy(accuracy);
  }
  const IntegrationResult result = time_advance_from_settled(state, beam, model);
  per_tet(state, beam);
  state.counters["cg_iterations"] = result.solver_iterations;
  state.counters["residual"] = result.solver_residual;
  state.counters["rows_summed"] = static_cast<double>(model.reassembled_rows());
  state.SetLabel(arg == 0   ? "matrix_free"
                 : arg == 1 ? "assembled, ssor"
                 : arg == 2 ? "assembled, block_jacobi"
                 : arg == 3 ? "assembled, ssor, no K' reuse"
                 : arg == 4 ? "assembled, ssor, no iteration"
                 : arg == 5 ? "assembled, ssor, exact sweeps"
                 : arg == 6 ? "assembled, ssor, fused sweeps"
                            : "assembled, ssor, scalar fixed part");
}
BENCHMARK(BM_CorotationalImplicitStep)->DenseRange(0, 7)->Unit(benchmark::kMillisecond);

// One SSOR-PCG iteration alone (session 11, issue #3): the fused kernels (fused_ssor_kernels.h)
// on a beam's block pattern (upper triangle) and fixed vertices. cells 75: the benchmark beam,
// 1,900 rows, 12,231 blocks with the diagonal ones, ~1.5 MB in all; cells 15: 400 rows, ~0.3 MB,
// inside a core's 512 KB L2; cells 300: 7,525 rows, ~6 MB, from L3. The iteration as the solver
// runs it (session 8: backward + forward sweep, CG update, direction update; session 11 measured
// a three-pass cut at no gain; session 12 zeroes acc in the backward sweep instead of a memset,
// docs/deformation-models.md). The values are random (what is timed does not depend on them;
// a = b = 0 keeps them from growing, and an FMA by 0 costs what any other does).
// bytes_per_second: the bytes each cut reads and writes per iteration (arrays counted once per
// pass, read-modify-write twice; the gathered t_j and scattered acc_j hit L1, counted once) over
// its time, the effective bandwidth to set against memory_bench; ns_per_row: time per row.
void BM_SsorIteration(benchmark::State& state) {
  if (!fused_sweeps_available()) {
    state.SkipWithError("no AVX2/FMA on this CPU");
    return;
  }
  Beam beam;
  if (state.range(0) != 75) {
    beam.mesh = make_box_mesh({Vec3(1.0, 0.08, 0.08), static_cast<int>(state.range(0)), 4, 4});
    beam.x = beam.mesh->rest_positions();
    beam.fixed.assign(beam.x.size(), 0);
    for (size_t i = 0; i < beam.x.size(); ++i) beam.fixed[i] = beam.x[i].x() < -0.5 + 1e-12 ? 1 : 0;
  }
  const size_t n = beam.x.size();
  std::vector<int> offsets{0}, cols;
  for (size_t i = 0; i < n; ++i) {
    std::vector<int> row{static_cast<int>(i)};
    for (int j : beam.mesh->vertex_neighbors(static_cast<int>(i))) {
      if (j > static_cast<int>(i) && beam.fixed[i] == 0) row.push_back(j);
    }
    std::sort(row.begin() + 1, row.end());
    cols.insert(cols.end(), row.begin(), row.end());
    offsets.push_back(static_cast<int>(cols.size()));
  }
  std::vector<double> blocks(9 * cols.size()), D(9 * n), D_inverse(9 * n);
  for (size_t k = 0; k < blocks.size(); ++k) blocks[k] = 1e-3 * std::sin(static_cast<double>(k));
  for (size_t i = 0; i < n; ++i) {
    const Mat3 d = Mat3::Identity() * 4.0 + Mat3::Constant(0.5);
    const Mat3 inverse = d.inverse();
    std::copy(d.data(), d.data() + 9, D.begin() + 9 * static_cast<long>(i));
    std::copy(inverse.data(), inverse.data() + 9, D_inverse.begin() + 9 * static_cast<long>(i));
  }
  FusedSsorSystem system{blocks.data(), cols.data(), offsets.data(), D.data(), D_inverse.data(),
                         beam.fixed.data(), 1e-4, n};
  // gathered 1 (session 13, what the solver runs): the forward sweep gathers from the transposed
  // lower blocks (the upper blocks by column, rows ascending); 0: session 12's scatter.
  LowerTrianglePattern lower;
  std::vector<double> lower_blocks;
  if (state.range(1) == 1) {
    lower = lower_triangle_pattern(offsets.data(), cols.data(), n);
    lower_blocks.resize(9 * lower.rows.size() + 4);
    transpose_lower_blocks(blocks.data(), lower.upper_blocks.data(), lower.rows.data(), beam.fixed.data(),
                           lower.rows.size(), lower_blocks.data());
    system.lower_blocks = lower_blocks.data();
    system.lower_rows = lower.rows.data();
    system.lower_offsets = lower.offsets.data();
  }
  std::vector<double> p(3 * n, 1.0), t(3 * n), q(3 * n), acc(3 * n), dv(3 * n), r(3 * n, 1.0), Dr(3 * n);
  for (size_t i = 0; i < n; ++i) {
    if (beam.fixed[i] != 0) std::fill_n(p.begin() + 3 * static_cast<long>(i), 3, 0.0);
  }
  double sum = 0.0;
  for (auto _ : state) {
    sum += fused_eisenstat_sweeps(system, p.data(), t.data(), q.data(), acc.data());
    sum += fused_cg_update(system, 0.0, t.data(), q.data(), dv.data(), r.data(), Dr.data());
    fused_direction_update(n, Dr.data(), 0.0, p.data());
  }
  benchmark::DoNotOptimize(sum);
  // Bytes per iteration: B blocks (with the diagonal slots, which share their cache lines), C
  // column indices, M = 9 doubles per row (D or D^-1), V = one packed vector.
  const double B = 72.0 * static_cast<double>(cols.size()), C = 4.0 * static_cast<double>(cols.size()),
               M = 72.0 * static_cast<double>(n), V = 24.0 * static_cast<double>(n);
  // Backward B + C + M + p + t + acc (zeroed); forward B + C + 2M + p + t + 2 acc + q; CG update
  // t + 2 dv + q + 2 r + M + Dr; direction Dr + 2 p.
  const double bytes = 2 * B + 2 * C + 4 * M + 18 * V;
  state.counters["bytes_per_iteration"] = bytes;
  state.counters["ns_per_row"] = benchmark::Counter(static_cast<double>(n) * 1e-9,
                                                    benchmark::Counter::kIsIterationInvariantRate |
                                                        benchmark::Counter::kInvert);
  state.SetBytesProcessed(static_cast<int64_t>(static_cast<double>(state.iterations()) * bytes));
}
BENCHMARK(BM_SsorIteration)
    ->ArgsProduct({{15, 75, 300}, {0, 1}})
    ->ArgNames({"cells", "gathered"})
    ->Unit(benchmark::kMicrosecond);

// The same step solved to a relative residual instead of a fixed iteration count (session 4): arg
// 0 to the residual that 20 block-Jacobi iterations reach on this step (measured 0.428, see
// ImplicitStep/2), arg 1 to the default tolerance 1e-6; SSOR (default) against block-Jacobi
// (arg + 2), the iteration cap raised to 1000.
void BM_CorotationalImplicitStepToResidual(benchmark::State& state) {
  const auto arg = state.range(0);
  Beam beam;
  ModelSettings settings;
  settings.accuracy.max_solver_iterations = 1000;
  settings.accuracy.solver_tolerance = arg % 2 == 0 ? 0.43 : 1e-6;
  CorotationalFem model(beam.mesh, beam.material, settings);
  if (arg >= 2) model.set_preconditioner(Preconditioner::block_jacobi);
  beam.settle(model);
  const IntegrationResult result = time_advance_from_settled(state, beam, model);
  state.counters["cg_iterations"] = result.solver_iterations;
  state.counters["residual"] = result.solver_residual;
  state.counters["rows_summed"] = static_cast<double>(model.reassembled_rows());
  state.SetLabel(std::string(arg >= 2 ? "block_jacobi" : "ssor") + (arg % 2 == 0 ? ", to 0.43" : ", to 1e-6"));
}
BENCHMARK(BM_CorotationalImplicitStepToResidual)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

// The coarse correction (session 13, coarse_correction.h) beside the solve it runs on: the exact
// SSOR sweeps to 1e-6, without (arg 0) and with deflation by boxes of about arg free vertices.
void BM_CorotationalImplicitStepToResidualCoarse(benchmark::State& state) {
  Beam beam;
  ModelSettings settings;
  settings.accuracy.max_solver_iterations = 1000;
  settings.accuracy.solver_tolerance = 1e-6;
  settings.fused_sweeps = false;
  settings.coarse_aggregate_size = static_cast<int>(state.range(0));
  CorotationalFem model(beam.mesh, beam.material, settings);
  beam.settle(model);
  const IntegrationResult result = time_advance_from_settled(state, beam, model);
  state.counters["cg_iterations"] = result.solver_iterations;
  state.counters["residual"] = result.solver_residual;
  state.counters["aggregates"] = model.coarse_aggregates();
  state.SetLabel(state.range(0) == 0 ? "exact ssor, to 1e-6" : "exact ssor + coarse, to 1e-6");
}
BENCHMARK(BM_CorotationalImplicitStepToResidualCoarse)->Arg(0)->Arg(20)->Arg(40)->Arg(80)->Unit(benchmark::kMillisecond);

// The model's share of one World step: advance from a state whose linearisation is evaluated (the
// previous report stage did it), then elastic_energy at the result (the report stage), arg 0; with
// 8 vertices moved by 1 mm in between (a contact edit), arg 1; with every vertex moved by 0.1 mm
// (contact with many vertices of a small body), arg 2. One evaluation pass and one solve each.
// Session 2's code has no such row: its equivalent is ImplicitStep/1 + EnergyAfterStep/0 or /1.
void BM_CorotationalStepAndReport(benchmark::State& state) {
  Beam beam;
  ModelSettings settings;
  settings.accuracy.max_solver_iterations = 20;
  settings.accuracy.solver_tolerance = 1e-12;  // always runs the 20 iterations
  CorotationalFem model(beam.mesh, beam.material, settings);
  beam.settle(model);
  model.elastic_energy(beam.x);  // the previous step's report stage
  const CorotationalFem snapshot = model;
  const std::vector<Vec3> x0 = beam.x, v0 = beam.v;
  const auto edit = state.range(0);
  double energy = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    model = snapshot;
    std::copy(x0.begin(), x0.end(), beam.x.begin());
    std::copy(v0.begin(), v0.end(), beam.v.begin());
    state.ResumeTiming();
    model.advance(beam.x, beam.v, beam.input());
    if (edit == 1) {
      for (int v : probe_vertices()) beam.x[static_cast<size_t>(v)] += Vec3(0.0, 0.0, -1e-3);
    } else if (edit == 2) {
      for (auto& p : beam.x) p += Vec3(0.0, 0.0, -1e-4);
    }
    energy = model.elastic_energy(beam.x);
    benchmark::DoNotOptimize(energy);
  }
  state.SetLabel(edit == 0 ? "no edit" : edit == 1 ? "8 vertices moved" : "all vertices moved");
}
BENCHMARK(BM_CorotationalStepAndReport)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// One explicit step of 1 ms (substeps as the stability estimate requires).
void BM_TeschnerStep1ms(benchmark::State& state) {
  Beam beam;
  TeschnerExplicit model(beam.mesh, beam.material, {});
  int substeps = 0;
  for (auto _ : state) {
    substeps = model.advance(beam.x, beam.v, beam.input(1e-3)).substeps;
  }
  state.counters["substeps"] = substeps;
}
BENCHMARK(BM_TeschnerStep1ms)->Unit(benchmark::kMillisecond);

// K' reuse with a few percent of the tets moving in a step, spread over the body (session 19): the
// probe's press, where ~9% of its tissue's 4,320 tets leave the rotation tolerance every step and
// those steps set the probe's p99. The probe's tissue (box 100 x 100 x 40 mm, 12 x 12 x 5 cells,
// E = 5 kPa, nu 0.45, probe.json's CG tolerance 1e-3, base fixed) with K' built at a bent pose A;
// the timed advance starts at pose B, A with range(0) random vertices moved 0.3 mm (every tet
// around them leaves the 1e-3 rad tolerance), from a snapshot restored outside the timing, so
// every iteration rebuilds the same tets' blocks. The time is the whole advance (rotations, K',
// SSOR data, CG, update); rows says how many K' rows it summed again. Session 19 tried two caches
// of per-tet K' terms against it; both ran slower (docs/deformation-models.md "Session 19").
void BM_StiffnessReuseSpread(benchmark::State& state) {
  const TetMeshPtr mesh = make_box_mesh({Vec3(0.1, 0.1, 0.04), 12, 12, 5});
  Material material;
  material.young_modulus = 5e3;
  material.poisson_ratio = 0.45;
  material.density = 1000.0;
  material.mass_damping = 2.0;
  material.stiffness_damping = 0.01;
  ModelSettings settings;
  settings.accuracy.solver_tolerance = 1e-3;
  CorotationalFem model(mesh, material, settings);
  const std::vector<double> masses = mesh->lumped_masses(material.density);
  std::vector<Vec3> x = mesh->rest_positions();
  std::vector<char> fixed(x.size(), 0);
  for (size_t i = 0; i < x.size(); ++i) fixed[i] = x[i].z() < -0.02 + 1e-9 ? 1 : 0;
  const std::vector<Vec3> external(x.size(), Vec3::Zero());
  const IntegrationInput input{masses, fixed, external, 1e-3};
  for (auto& p : x) {
    if (fixed[&p - x.data()] == 0) p += Vec3(0.05 * (p.z() + 0.02) * p.y(), 0.0, -0.2 * p.x() * p.x());  // bent
  }
  std::vector<Vec3> v(x.size(), Vec3::Zero());
  std::vector<Vec3> b = x;
  model.advance(x, v, input);  // K' built at the bent pose (the rotations there)
  std::copy(b.begin(), b.end(), x.begin());
  std::fill(v.begin(), v.end(), Vec3::Zero());
  model.advance(x, v, input);  // again from there: no tet moved, the caches made (a running body's state)
  std::mt19937 rng(19);
  std::uniform_int_distribution<size_t> vertex(0, b.size() - 1);
  std::uniform_real_distribution<double> shift(-3e-4, 3e-4);
  for (int k = 0; k < state.range(0); ++k) {
    const size_t i = vertex(rng);
    if (fixed[i] == 0) b[i] += Vec3(shift(rng), shift(rng), shift(rng));
  }
  const CorotationalFem snapshot = model;
  const std::vector<Vec3> v0 = v;
  for (auto _ : state) {
    state.PauseTiming();
    model = snapshot;
    std::copy(b.begin(), b.end(), x.begin());
    std::copy(v0.begin(), v0.end(), v.begin());
    state.ResumeTiming();
    benchmark::DoNotOptimize(model.advance(x, v, input));
  }
  state.counters["rows"] = static_cast<double>(model.reassembled_rows());
  state.counters["tets"] = mesh->tet_count();
}
BENCHMARK(BM_StiffnessReuseSpread)->ArgName("moved_vertices")->Arg(6)->Arg(24)->Arg(100)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace pliant
