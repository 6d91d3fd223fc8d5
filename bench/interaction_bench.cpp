// Interaction costs: one haptic tick (predict + filter), one model refresh (secant fit), and one
// physics step of a probe pressed 3 mm into a block (does full physics fit a 1 kHz tick?).
#include <benchmark/benchmark.h>

#include "interaction/haptic_thread.h"
#include "interaction/instrument.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

void BM_HapticTick(benchmark::State& state) {
  HapticForceModel model;
  for (int i = 0; i < 4; ++i) {
    const Vec3 x(1e-4 * (i == 1), 1e-4 * (i == 2), -1e-4 * i);
    model.update(i * 1e-3, x, Vec3(0.1, 0.2, 1.0) - 200.0 * x);
  }
  VirtualClock clock;
  Vec3 device(0, 0, -3e-4);
  HapticThread haptics(clock, model, HapticLimits{}, [&] { return device; }, [](double, const Vec3&) {});
  double t = 0.0;
  for (auto _ : state) benchmark::DoNotOptimize(haptics.tick(t += 1e-3));
}
BENCHMARK(BM_HapticTick);

void BM_HapticModelUpdate(benchmark::State& state) {
  HapticForceModel model;
  long i = 0;
  for (auto _ : state) {
    const Vec3 x(1e-5 * std::sin(0.1 * i), 1e-5 * std::cos(0.13 * i), -1e-4 - 1e-5 * std::sin(0.07 * i));
    model.update(1e-3 * i++, x, Vec3(0, 0, 1.0) - 200.0 * x);
  }
  benchmark::DoNotOptimize(model.snapshot());
}
BENCHMARK(BM_HapticModelUpdate);

// Block of cells^2 x cells/2 cells, probe held 3 mm deep; one World::step per iteration.
void BM_ProbeContactStep(benchmark::State& state) {
  const int cells = static_cast<int>(state.range(0));
  WorldSettings settings;
  settings.gravity = Vec3::Zero();
  World world(settings);
  BodyDef block;
  block.mesh = make_box_mesh(BoxMeshSpec{Vec3(0.04, 0.04, 0.02), cells, cells, cells / 2});
  block.material.young_modulus = 5e3;
  block.material.poisson_ratio = 0.3;
  for (int v = 0; v < block.mesh->vertex_count(); ++v) {
    if (block.mesh->rest_positions()[static_cast<size_t>(v)].z() < -0.01 + 1e-9) block.fixed_vertices.push_back(v);
  }
  world.add_body(block);
  InstrumentSpec spec;
  spec.name = "probe";
  spec.tip_radius = 0.005;
  spec.shaft_length = 0.0;
  spec.pose.translation = Vec3(0.0013, -0.0007, 0.01 + 0.005 - 0.003);
  Instrument probe = Instrument::create(world, spec);
  probe.apply(world, probe.command());
  for (int i = 0; i < 50; ++i) world.step(1e-3);  // settle into contact
  int colliding = 0;
  for (auto _ : state) colliding = world.step(1e-3).colliding_vertices;
  state.counters["colliding"] = colliding;
  state.counters["tets"] = block.mesh->tet_count();
}
BENCHMARK(BM_ProbeContactStep)->Arg(8)->Arg(12)->Arg(16)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace pliant
