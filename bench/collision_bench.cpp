// Stage 1 and 2 timings: spatial-hash detection vs number of tets (1k..200k, many bodies), brute
// force at small sizes, and penetration depth per colliding point. Compare with Teschner et al. 2003
// (algorithms.md section 1) and Heidelberger et al. 2004 (about 35 us per colliding point).
//
//   build-collision/bench/collision_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// Scenes: boxes of 4x4x4 Kuhn cells (384 tets, 125 vertices, 1 m edge).
//  - pairs: bodies in overlapping pairs (0.25 m overlap, small random rotations), pairs 1.5 m apart
//    on a lattice: the contact density per tet is the same at every size, so the log-log slope
//    measures the algorithm, not the scene.
//  - heap: every body on a 0.9 m lattice overlaps all its lattice neighbours; interior bodies have
//    more partners than boundary ones, so contacts per tet grow with the size.
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <random>

#include "interaction/scene/scene_runner.h"
#include "sim/collision/penetration_depth.h"
#include "sim/collision/spatial_hash.h"
#include "sim/collision/tet_barycentric.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

struct HeapScene {
  TetMeshPtr mesh;
  std::vector<std::vector<Vec3>> positions;
  std::vector<CollisionBody> bodies;
  CollisionFilter filter;
  int tets = 0;
  int vertices = 0;
};

// About `target_tets` tets in overlapping boxes: overlapping pairs (pairs = true) or a heap.
HeapScene make_heap(int target_tets, int cells = 4, bool pairs = false) {
  HeapScene s;
  s.mesh = make_box_mesh({Vec3::Ones(), cells, cells, cells});
  // Pairs: an even count, so that every body has its partner (session 17: an odd count left one body
  // alone, a third of the 1k scene's tets and a fifth of the 2k scene's with nothing to find, which
  // made the small scenes cheaper per tet than the design above intends).
  const double per_body = static_cast<double>(s.mesh->tet_count());
  const int count = pairs ? 2 * std::max(1, static_cast<int>(std::lround(target_tets / (2.0 * per_body))))
                          : std::max(1, static_cast<int>(std::lround(target_tets / per_body)));
  const int side = static_cast<int>(std::ceil(std::cbrt(static_cast<double>(count))));
  std::mt19937 rng(42);
  std::normal_distribution<double> g(0.0, 0.1);
  for (int b = 0; b < count; ++b) {
    Vec3 centre(0.9 * (b % side), 0.9 * ((b / side) % side), 0.9 * (b / (side * side)));
    if (pairs) {
      const int p = b / 2;
      const int pair_side = static_cast<int>(std::ceil(std::cbrt(static_cast<double>((count + 1) / 2))));
      centre = Vec3(2.5 * (p % pair_side), 2.5 * ((p / pair_side) % pair_side), 2.5 * (p / (pair_side * pair_side)));
      if (b % 2 == 1) centre += Vec3(0.75, 0.1, 0.05);
    }
    const Quat q(Eigen::AngleAxisd(g(rng), Vec3(g(rng), g(rng), 1.0).normalized()));
    std::vector<Vec3> x;
    for (const Vec3& p : s.mesh->rest_positions()) x.push_back(q * p + centre);
    s.positions.push_back(std::move(x));
  }
  for (int b = 0; b < count; ++b) {
    CollisionBody cb;
    cb.mesh = s.mesh.get();
    cb.positions = s.positions[static_cast<size_t>(b)];
    s.bodies.push_back(cb);
  }
  s.filter = CollisionFilter::from_bodies(s.bodies);
  s.tets = count * s.mesh->tet_count();
  s.vertices = count * s.mesh->vertex_count();
  return s;
}

void set_counters(benchmark::State& state, const HeapScene& s, size_t colliding) {
  state.counters["tets"] = s.tets;
  state.counters["vertices"] = s.vertices;
  state.counters["bodies"] = static_cast<double>(s.bodies.size());
  state.counters["colliding"] = static_cast<double>(colliding);
  state.counters["time_per_tet"] = benchmark::Counter(s.tets, benchmark::Counter::kIsIterationInvariantRate |
                                                                  benchmark::Counter::kInvert);
}

void BM_SpatialHashDetect(benchmark::State& state) {
  const HeapScene s = make_heap(static_cast<int>(state.range(0)), 4, state.range(1) != 0);
  SpatialHash hash;
  std::vector<VertexInTet> out;
  hash.detect(s.bodies, s.filter, out);  // warm-up: buffers grow once
  for (auto _ : state) {
    hash.detect(s.bodies, s.filter, out);
    benchmark::DoNotOptimize(out.data());
  }
  set_counters(state, s, out.size());
  state.counters["inserted"] = hash.stats().inserted_vertices;
  state.counters["table"] = hash.stats().table_size;
}
BENCHMARK(BM_SpatialHashDetect)
    ->ArgsProduct({{1000, 2000, 5000, 10000, 20000, 50000, 100000, 200000}, {1, 0}})
    ->ArgNames({"tets", "pairs"})
    ->Unit(benchmark::kMillisecond);

// The same scenes as a simulation sees them (session 17): every call gets new positions, cycling
// through kMovingPoses copies of the scene, each body moved by 1 mm in a random direction plus a
// jitter of up to 0.5 mm per vertex (as BM_PenetrationDepth's moving pose). Repeating one pose lets
// the branch predictor and the caches learn a small scene's whole detect (the 1k-tet scene ran at
// an IPC near 4), which no step of a simulation repeats; the log-log slope is quoted from both.
constexpr int kMovingPoses = 8;

void BM_SpatialHashDetectMoving(benchmark::State& state) {
  const HeapScene s = make_heap(static_cast<int>(state.range(0)), 4, state.range(1) != 0);
  std::vector<std::vector<std::vector<Vec3>>> poses(kMovingPoses, s.positions);
  std::vector<std::vector<CollisionBody>> pose_bodies(kMovingPoses, s.bodies);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-5e-4, 5e-4);
  for (int k = 0; k < kMovingPoses; ++k) {
    for (size_t b = 0; b < s.bodies.size(); ++b) {
      const Vec3 shift = 1e-3 * Vec3(u(rng), u(rng), u(rng)).normalized();
      for (Vec3& p : poses[static_cast<size_t>(k)][b]) p += shift + Vec3(u(rng), u(rng), u(rng));
      pose_bodies[static_cast<size_t>(k)][b].positions = poses[static_cast<size_t>(k)][b];
    }
  }
  SpatialHash hash;
  std::vector<VertexInTet> out;
  for (const auto& bodies : pose_bodies) hash.detect(bodies, s.filter, out);  // warm-up: buffers grow once
  size_t k = 0;
  for (auto _ : state) {
    hash.detect(pose_bodies[k], s.filter, out);
    benchmark::DoNotOptimize(out.data());
    k = (k + 1) % pose_bodies.size();
  }
  set_counters(state, s, out.size());
  state.counters["inserted"] = hash.stats().inserted_vertices;
  state.counters["table"] = hash.stats().table_size;
}
BENCHMARK(BM_SpatialHashDetectMoving)
    ->ArgsProduct({{1000, 2000, 5000, 10000, 20000, 50000, 100000, 200000}, {1}})
    ->ArgNames({"tets", "pairs"})
    ->Unit(benchmark::kMillisecond);

// The oracle: every vertex against every tet of every allowed body (AABB, then barycentric).
void BM_BruteForceDetect(benchmark::State& state) {
  const HeapScene s = make_heap(static_cast<int>(state.range(0)), 4, true);
  size_t found = 0;
  for (auto _ : state) {
    found = 0;
    for (size_t b = 0; b < s.bodies.size(); ++b) {
      const auto& x = s.positions[b];
      for (const auto& tet : s.mesh->tets()) {
        const auto f = TetBarycentricFrame::of(x[static_cast<size_t>(tet[0])], x[static_cast<size_t>(tet[1])],
                                               x[static_cast<size_t>(tet[2])], x[static_cast<size_t>(tet[3])]);
        for (size_t a = 0; a < s.bodies.size(); ++a) {
          if (!s.filter.allowed(static_cast<int>(a), static_cast<int>(b))) continue;
          for (const Vec3& p : s.positions[a]) found += f.contains(p) ? 1 : 0;
        }
      }
    }
    benchmark::DoNotOptimize(found);
  }
  set_counters(state, s, found);
}
BENCHMARK(BM_BruteForceDetect)->Arg(1000)->Arg(2000)->Arg(5000)->Arg(10000)->ArgName("tets")
    ->Unit(benchmark::kMillisecond);

// Stage 2 on the heap's colliding vertices: time per colliding point (includes bringing the
// penetrated bodies' surface hierarchies to the current positions, and their vertex normals).
// Calls alternate between the scene and a copy whose bodies moved by 1 mm (a rigid shift plus a
// jitter per vertex of up to 0.5 mm), as consecutive steps would: every call sees new positions,
// so no cached surface data can be reused as is. range(2) = 0 repeats one pose instead (the
// session-2 benchmark; with unchanged positions the hierarchies are then kept between calls).
// range(3) (probe: range(1)), PenetrationDepthOptions::surface_query: 0 = BVH queries, 1 = contact
// rays by the tet walk, 2 = edges and rays by the tet walk.
PenetrationDepthOptions depth_options(int64_t walk) {
  PenetrationDepthOptions o;
  o.surface_query = walk == 2 ? SurfaceQueryMethod::tet_walk
                    : walk == 1 ? SurfaceQueryMethod::tet_walk_rays
                                : SurfaceQueryMethod::bvh;
  return o;
}

// Walk counters of one verifying compute per pose (outside the timed loop): edges and rays walked,
// walks that fell back to the BVH, and walked answers that differ from the BVH's (edges and rays walked).
void walk_counters(benchmark::State& state, const std::vector<CollisionBody>* const bodies[2],
                   const std::vector<VertexInTet> colliding[2]) {
  PenetrationDepthOptions o = depth_options(2);
  o.tet_walk_verify = true;
  PenetrationDepthSolver verify(o);
  std::vector<VertexContact> contacts;
  double edges = 0, rays = 0, fallbacks = 0, mismatches = 0, tets = 0;
  for (int k = 0; k < 2; ++k) {
    verify.compute(*bodies[k], colliding[k], contacts);
    const auto& st = verify.stats();
    edges += static_cast<double>(st.walked_edges + st.walk_edge_fallbacks);
    rays += st.walked_rays + st.walk_ray_fallbacks;
    fallbacks += static_cast<double>(st.walk_edge_fallbacks + st.walk_ray_fallbacks);
    mismatches += static_cast<double>(st.walk_mismatches);
    tets += static_cast<double>(st.walk_tets);
  }
  state.counters["tets_per_walk"] = tets / std::max(1.0, edges + rays);
  state.counters["walk_queries"] = edges + rays;
  state.counters["walk_fallbacks"] = fallbacks;
  state.counters["walk_mismatches"] = mismatches;
}

void BM_PenetrationDepth(benchmark::State& state) {
  HeapScene s = make_heap(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), true);
  const bool moving = state.range(2) != 0;
  std::vector<std::vector<Vec3>> moved = s.positions;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-5e-4, 5e-4);
  for (auto& body : moved) {
    const Vec3 shift = 1e-3 * Vec3(u(rng), u(rng), u(rng)).normalized();
    for (Vec3& p : body) p += shift + Vec3(u(rng), u(rng), u(rng));
  }
  std::vector<CollisionBody> moved_bodies = s.bodies;
  for (size_t b = 0; b < moved_bodies.size(); ++b) moved_bodies[b].positions = moved[b];
  const std::vector<CollisionBody>* bodies[2] = {&s.bodies, moving ? &moved_bodies : &s.bodies};
  SpatialHash hash;
  std::vector<VertexInTet> colliding[2];
  hash.detect(*bodies[0], s.filter, colliding[0]);
  hash.detect(*bodies[1], s.filter, colliding[1]);
  PenetrationDepthSolver solver(depth_options(state.range(3)));
  std::vector<VertexContact> contacts;
  solver.compute(*bodies[0], colliding[0], contacts);
  int k = 0;
  for (auto _ : state) {
    k ^= 1;
    solver.compute(*bodies[k], colliding[k], contacts);
    benchmark::DoNotOptimize(contacts.data());
  }
  const double points = 0.5 * static_cast<double>(colliding[0].size() + colliding[1].size());
  set_counters(state, s, colliding[k].size());
  state.counters["colliding"] = points;
  const auto& st = solver.stats();
  state.counters["border"] = st.border_points;
  state.counters["propagated"] = st.propagated_points;
  state.counters["enclosed"] = st.enclosed_fallback_points;
  state.counters["edges_per_point"] = static_cast<double>(st.edge_intersections) / static_cast<double>(colliding[k].size());
  if (state.range(3) != 0) walk_counters(state, bodies, colliding);
  state.counters["time_per_point"] =
      benchmark::Counter(points, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_PenetrationDepth)
    ->ArgsProduct({{1000, 10000, 30000, 100000}, {4}, {1}, {0, 1, 2}})
    ->Args({100000, 8, 1, 0})->Args({100000, 8, 1, 1})->Args({100000, 8, 1, 2})
    ->Args({10000, 4, 0, 0})->Args({100000, 4, 0, 0})->Args({100000, 8, 0, 0})
    ->Args({10000, 4, 0, 2})->Args({100000, 4, 0, 2})->Args({100000, 8, 0, 2})
    ->ArgNames({"tets", "cells", "moving", "walk"})->Unit(benchmark::kMillisecond);

// The probe scene of `pliant bench probe --warm-up 700 --steps 100` (assets/scenes/probe.json:
// 1,931 vertices, tissue 12x12x5 cells and a sphere-tipped probe being pressed in): stages 1 and 2
// alone, on the exact positions stage 1 saw in steps `step` + 1 and + 2 (750: the middle of that
// window, probe touching; 1100: pressed 12 mm, held), recorded by a StepProfiler when the detect
// stage begins, alternated per iteration so positions change every call as in a run.
struct ProbeSnapshots {
  std::vector<std::vector<std::vector<Vec3>>> positions;  // [snapshot][body]
  std::vector<const TetMesh*> meshes;
  std::vector<bool> kinematic;
  std::vector<int> world_colliding;     // colliding vertices World reported in those steps
  std::unique_ptr<SceneRunner> runner;  // owns the meshes
};

// Copies every body's positions when the detect stage begins (after integration, before response).
class DetectInputRecorder : public StepProfiler {
 public:
  explicit DetectInputRecorder(const World& world) : world_(world) {}
  void begin(StepStage stage) override {
    if (stage != StepStage::detect) return;
    positions.clear();
    for (const Body* body : world_.bodies()) positions.emplace_back(body->positions.begin(), body->positions.end());
  }
  void end(StepStage) override {}
  std::vector<std::vector<Vec3>> positions;

 private:
  const World& world_;
};

const ProbeSnapshots& probe_snapshots(int warm_up_steps) {
  static std::map<int, ProbeSnapshots> cache;
  auto it = cache.find(warm_up_steps);
  if (it != cache.end()) return it->second;
  return cache[warm_up_steps] = [&] {
    ProbeSnapshots s;
    const auto file = std::filesystem::path(__FILE__).parent_path().parent_path() / "assets/scenes/probe.json";
    s.runner = std::make_unique<SceneRunner>(load_scene(file.string()));
    for (int i = 0; i < warm_up_steps; ++i) s.runner->tick();
    DetectInputRecorder recorder(s.runner->world());
    for (int k = 0; k < 2; ++k) {
      s.runner->tick(&recorder);
      s.positions.push_back(recorder.positions);
      s.world_colliding.push_back(s.runner->report().colliding_vertices);
    }
    for (const Body* body : s.runner->world().bodies()) {
      s.meshes.push_back(body->mesh.get());
      s.kinematic.push_back(body->is_kinematic());
    }
    return s;
  }();
}

// Collision bodies and filter as World::detect builds them (no self-collision, kinematic pairs off).
std::vector<CollisionBody> probe_bodies(const ProbeSnapshots& s, int snapshot, CollisionFilter& filter) {
  std::vector<CollisionBody> bodies;
  for (size_t b = 0; b < s.meshes.size(); ++b) {
    CollisionBody cb;
    cb.mesh = s.meshes[b];
    cb.positions = s.positions[static_cast<size_t>(snapshot)][b];
    bodies.push_back(cb);
  }
  filter = CollisionFilter::from_bodies(bodies);
  for (size_t a = 0; a < bodies.size(); ++a) {
    for (size_t b = a + 1; b < bodies.size(); ++b) {
      if (s.kinematic[a] && s.kinematic[b]) filter.set(static_cast<int>(a), static_cast<int>(b), false);
    }
  }
  return bodies;
}

void BM_ProbeDetect(benchmark::State& state) {
  const ProbeSnapshots& s = probe_snapshots(static_cast<int>(state.range(0)));
  CollisionFilter filter[2];
  const std::vector<CollisionBody> bodies[2] = {probe_bodies(s, 0, filter[0]), probe_bodies(s, 1, filter[1])};
  SpatialHash hash;
  std::vector<VertexInTet> out;
  hash.detect(bodies[0], filter[0], out);
  int k = 0;
  for (auto _ : state) {
    k ^= 1;
    hash.detect(bodies[k], filter[k], out);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["colliding"] = static_cast<double>(out.size());
  state.counters["world_colliding"] = s.world_colliding[static_cast<size_t>(k)];
  state.counters["tets_visited"] = static_cast<double>(hash.stats().tets_visited);
  state.counters["cells_visited"] = static_cast<double>(hash.stats().cells_visited);
  state.counters["inside_tests"] = static_cast<double>(hash.stats().inside_tests);
  state.counters["cell_size_mm"] = 1e3 * hash.stats().cell_size;
  state.counters["entries_scanned"] = static_cast<double>(hash.stats().entries_scanned);
}
BENCHMARK(BM_ProbeDetect)->Arg(750)->Arg(1100)->ArgName("step")->Unit(benchmark::kMicrosecond);

// The pair filter World::detect rebuilds every step, on the probe scene's two bodies: a new filter
// (from_bodies: one allocation, as before session 3) or in place (assign_from_bodies).
void BM_ProbeFilterRebuild(benchmark::State& state) {
  const ProbeSnapshots& s = probe_snapshots(750);
  CollisionFilter filter;
  const std::vector<CollisionBody> bodies = probe_bodies(s, 0, filter);
  for (auto _ : state) {
    if (state.range(0) != 0) {
      filter.assign_from_bodies(bodies);
    } else {
      filter = CollisionFilter::from_bodies(bodies);
    }
    benchmark::DoNotOptimize(&filter);
  }
}
BENCHMARK(BM_ProbeFilterRebuild)->Arg(0)->Arg(1)->ArgName("in_place")->Unit(benchmark::kNanosecond);

void BM_ProbeDepth(benchmark::State& state) {
  const ProbeSnapshots& s = probe_snapshots(static_cast<int>(state.range(0)));
  CollisionFilter filter[2];
  const std::vector<CollisionBody> bodies[2] = {probe_bodies(s, 0, filter[0]), probe_bodies(s, 1, filter[1])};
  SpatialHash hash;
  std::vector<VertexInTet> colliding[2];
  hash.detect(bodies[0], filter[0], colliding[0]);
  hash.detect(bodies[1], filter[1], colliding[1]);
  PenetrationDepthSolver solver(depth_options(state.range(1)));
  std::vector<VertexContact> contacts;
  solver.compute(bodies[0], colliding[0], contacts);
  int k = 0;
  for (auto _ : state) {
    k ^= 1;
    solver.compute(bodies[k], colliding[k], contacts);
    benchmark::DoNotOptimize(contacts.data());
  }
  state.counters["colliding"] = static_cast<double>(colliding[k].size());
  state.counters["time_per_point"] = benchmark::Counter(static_cast<double>(colliding[k].size()),
                                                        benchmark::Counter::kIsIterationInvariantRate |
                                                            benchmark::Counter::kInvert);
  if (state.range(1) != 0) {
    const std::vector<CollisionBody>* const b[2] = {&bodies[0], &bodies[1]};
    walk_counters(state, b, colliding);
  }
}
BENCHMARK(BM_ProbeDepth)->ArgsProduct({{750, 1100}, {0, 1, 2}})->ArgNames({"step", "walk"})->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace pliant
