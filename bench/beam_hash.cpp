// A fixed workload for checking that a change to the corotational model's kernels is bit-exact, and
// for counting its instructions (valgrind --tool=callgrind) without a benchmark's repetitions: the
// benchmark beam of models_bench (75 x 4 x 4 Kuhn cells, 1,900 nodes, 7,200 tets, E = 1e5 Pa,
// nu = 0.45, sagging under gravity from rest, dt 10 ms) advanced 60 times with SSOR-PCG at tolerance
// 1e-12 and an iteration cap of 20 (the benchmark's setting), 60 (still cap-bound) and 200 (ends at
// the tolerance). After every advance the bytes of x and v go into an FNV-1a 64-bit hash; the
// program prints, per cap, the hash, the CG iterations summed over the 60 advances and the last
// advance's relative residual. Two builds whose lines agree computed the same beam bit for bit (on
// one machine and compiler).
// Run: build/bench/beam_hash          (all three caps)
//      build/bench/beam_hash one      (cap 20 only: the benchmark's step, for callgrind)
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include "sim/mesh/box_mesh.h"
#include "sim/model/corotational_fem.h"

namespace {

using namespace pliant;

uint64_t fnv1a(uint64_t hash, const void* data, size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < bytes; ++i) {
    hash ^= p[i];
    hash *= 1099511628211ull;
  }
  return hash;
}

struct BeamRun {
  uint64_t hash = 14695981039346656037ull;
  long iterations = 0;
  double last_residual = 0.0;
};

BeamRun run_beam(int iteration_cap, int advances) {
  const TetMeshPtr mesh = make_box_mesh({Vec3(1.0, 0.08, 0.08), 75, 4, 4});
  Material material;
  material.young_modulus = 1e5;
  material.poisson_ratio = 0.45;
  material.density = 1000.0;
  material.stiffness_damping = 0.01;
  const std::vector<double> masses = mesh->lumped_masses(material.density);
  std::vector<Vec3> x = mesh->rest_positions();
  std::vector<Vec3> v(x.size(), Vec3::Zero());
  std::vector<char> fixed(x.size(), 0);
  std::vector<Vec3> external(x.size());
  for (size_t i = 0; i < x.size(); ++i) {
    fixed[i] = x[i].x() < -0.5 + 1e-12 ? 1 : 0;
    external[i] = masses[i] * Vec3(0, 0, -9.81);
  }
  ModelSettings settings;
  settings.accuracy.max_solver_iterations = iteration_cap;
  settings.accuracy.solver_tolerance = 1e-12;
  CorotationalFem model(mesh, material, settings, StiffnessProduct::assembled);
  BeamRun run;
  for (int a = 0; a < advances; ++a) {
    const IntegrationResult result = model.advance(x, v, {masses, fixed, external, 1e-2});
    run.iterations += result.solver_iterations;
    run.last_residual = result.solver_residual;
    run.hash = fnv1a(run.hash, x.data(), x.size() * sizeof(Vec3));
    run.hash = fnv1a(run.hash, v.data(), v.size() * sizeof(Vec3));
  }
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  const bool one = argc > 1 && std::strcmp(argv[1], "one") == 0;
  for (const int cap : {20, 60, 200}) {
    const BeamRun run = run_beam(cap, 60);
    std::printf("cap %3d: hash %016llx, %ld iterations, last residual %.6e\n", cap,
                static_cast<unsigned long long>(run.hash), run.iterations, run.last_residual);
    if (one) break;
  }
  return 0;
}
