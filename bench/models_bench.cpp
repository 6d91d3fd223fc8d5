// Deformation model costs on a cantilever beam of 75 x 4 x 4 Kuhn cells (1,900 nodes, 7,200 tets;
// the issue's ~2,000-node / ~7,300-tet beam): internal forces per tet, one K' product (the body of a
// CG iteration) per tet, matrix-free against assembled, and a full implicit step at the default
// 20 CG iterations (SOFA's published figure for a comparable beam: 13.8 ms on an i7-4790K).
// Run: build-models/bench/models_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "sim/mesh/box_mesh.h"
#include "sim/model/corotational_fem.h"
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
  /// Sags the beam for a few steps so rotations are not identity.
  void settle(DeformationModel& model, int steps = 20) {
    for (int s = 0; s < steps; ++s) model.advance(x, v, {masses, fixed, external, 1e-2});
  }
};

void per_tet(benchmark::State& state, const Beam& beam) {
  state.counters["tets"] = beam.mesh->tet_count();
  state.counters["nodes"] = beam.mesh->vertex_count();
  state.counters["ns_per_tet"] = benchmark::Counter(static_cast<double>(beam.mesh->tet_count()) * 1e-9,
                                                    benchmark::Counter::kIsIterationInvariantRate |
                                                        benchmark::Counter::kInvert);
}

void BM_CorotationalInternalForces(benchmark::State& state) {
  Beam beam;
  CorotationalFem model(beam.mesh, beam.material, {});
  beam.settle(model);
  std::vector<Vec3> f(beam.x.size());
  for (auto _ : state) {
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

void BM_CorotationalInternalForcesAt8Vertices(benchmark::State& state) {
  Beam beam;
  CorotationalFem model(beam.mesh, beam.material, {});
  beam.settle(model);
  const std::vector<int> vertices = {100, 300, 500, 700, 900, 1100, 1300, 1500};
  std::vector<Vec3> f(vertices.size());
  for (auto _ : state) {
    model.internal_forces_at(beam.x, vertices, f);
    benchmark::DoNotOptimize(f.data());
  }
}
BENCHMARK(BM_CorotationalInternalForcesAt8Vertices)->Unit(benchmark::kNanosecond);

// One K' product: the body of one CG iteration (plus O(n) vector updates).
void BM_StiffnessProduct(benchmark::State& state) {
  const auto product = static_cast<StiffnessProduct>(state.range(0));
  Beam beam;
  CorotationalFem model(beam.mesh, beam.material, {}, product);
  beam.settle(model);  // leaves K' (and, if assembled, its blocks) at the last step
  std::vector<Vec3> y(beam.x.size());
  for (auto _ : state) {
    model.apply_stiffness(beam.v, y);
    benchmark::DoNotOptimize(y.data());
  }
  per_tet(state, beam);
  state.SetLabel(product == StiffnessProduct::matrix_free ? "matrix_free" : "assembled");
}
BENCHMARK(BM_StiffnessProduct)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// A full implicit step (rotations, forces, [assembly], preconditioner, 20 CG iterations, update).
void BM_CorotationalImplicitStep(benchmark::State& state) {
  const auto product = static_cast<StiffnessProduct>(state.range(0));
  Beam beam;
  ModelSettings settings;
  settings.accuracy.max_solver_iterations = 20;
  settings.accuracy.solver_tolerance = 1e-12;  // always runs the 20 iterations
  CorotationalFem model(beam.mesh, beam.material, settings, product);
  beam.settle(model);
  int iterations = 0;
  for (auto _ : state) {
    iterations = model.advance(beam.x, beam.v, {beam.masses, beam.fixed, beam.external, 1e-2}).solver_iterations;
  }
  per_tet(state, beam);
  state.counters["cg_iterations"] = iterations;
  state.SetLabel(product == StiffnessProduct::matrix_free ? "matrix_free" : "assembled");
}
BENCHMARK(BM_CorotationalImplicitStep)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// One explicit step of 1 ms (substeps as the stability estimate requires).
void BM_TeschnerStep1ms(benchmark::State& state) {
  Beam beam;
  TeschnerExplicit model(beam.mesh, beam.material, {});
  int substeps = 0;
  for (auto _ : state) {
    substeps = model.advance(beam.x, beam.v, {beam.masses, beam.fixed, beam.external, 1e-3}).substeps;
  }
  state.counters["substeps"] = substeps;
}
BENCHMARK(BM_TeschnerStep1ms)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace pliant
