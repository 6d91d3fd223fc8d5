// Off-screen rendering cost per 640x480 frame (llvmpipe): a ~1,000-vertex box and a
// ~16,000-vertex scene of 250 small boxes, with wireframe and 4x MSAA variants; also the snapshot copy and the PNG encoding, the other
// two parts of a recorded frame.
//   build-render/bench/render_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <filesystem>

#include "render/offscreen_renderer.h"
#include "render/png_writer.h"
#include "render/render_snapshot.h"
#include "sim/mesh/box_mesh.h"
#include "sim/world.h"

namespace pliant {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;

void add_box(World& world, double size, int cells, const Vec3& centre) {
  BodyDef def;
  def.mesh = make_box_mesh({Vec3::Constant(size), cells, cells, cells});
  def.motion = BodyMotion::kinematic;
  def.pose.translation = centre;
  world.add_body(std::move(def));
}

// One box of 9^3 cells: 1,000 vertices, 972 surface triangles.
void build_single_box(World& world) { add_box(world, 0.2, 9, Vec3::Zero()); }

// 250 boxes of 3^3 cells (64 vertices each): 16,000 vertices.
void build_many_boxes(World& world) {
  for (int i = 0; i < 250; ++i) {
    add_box(world, 0.03, 3, Vec3(0.05 * (i % 25), 0.05 * (i / 25), 0.02 * (i % 3)));
  }
}

OffscreenRenderer& renderer(int samples = 1) {
  static OffscreenRenderer single(kWidth, kHeight, 1);
  static OffscreenRenderer multi(kWidth, kHeight, 4);
  return samples > 1 ? multi : single;
}

long vertex_count(const RenderSnapshot& snap) {
  long n = 0;
  for (const auto& b : snap.bodies) n += static_cast<long>(b.positions.size());
  return n;
}

void render_scene(benchmark::State& state, void (*build)(World&), bool wireframe, int samples = 1) {
  World world;
  build(world);
  const RenderSnapshot snap = take_snapshot(world);
  ViewSettings view;
  view.wireframe = wireframe;
  for (auto _ : state) {
    Image image = renderer(samples).render(snap, view);
    benchmark::DoNotOptimize(image.rgba.data());
  }
  state.counters["vertices"] = static_cast<double>(vertex_count(snap));
}

void BM_RenderBox1k(benchmark::State& state) { render_scene(state, build_single_box, false); }
void BM_RenderBox1kWireframe(benchmark::State& state) { render_scene(state, build_single_box, true); }
void BM_RenderManyBoxes16k(benchmark::State& state) { render_scene(state, build_many_boxes, false); }
void BM_RenderManyBoxes16kWireframe(benchmark::State& state) { render_scene(state, build_many_boxes, true); }

void BM_RenderBox1kMsaa4(benchmark::State& state) { render_scene(state, build_single_box, false, 4); }
void BM_RenderManyBoxes16kMsaa4(benchmark::State& state) { render_scene(state, build_many_boxes, false, 4); }

void BM_TakeSnapshot16k(benchmark::State& state) {
  World world;
  build_many_boxes(world);
  for (auto _ : state) {
    RenderSnapshot snap = take_snapshot(world);
    benchmark::DoNotOptimize(snap.bodies.data());
  }
}

void BM_WritePng640x480(benchmark::State& state) {
  World world;
  build_single_box(world);
  const Image image = renderer().render(take_snapshot(world));
  const auto path = std::filesystem::temp_directory_path() / "pliant_render_bench.png";
  for (auto _ : state) write_png(image, path);
  std::filesystem::remove(path);
}

BENCHMARK(BM_RenderBox1k)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderBox1kWireframe)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderManyBoxes16k)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderManyBoxes16kWireframe)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderBox1kMsaa4)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderManyBoxes16kMsaa4)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TakeSnapshot16k)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_WritePng640x480)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace pliant
