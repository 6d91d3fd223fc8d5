// Which stage keeps the resting churn going (session 9, issue #8; docs/contact-surface.md "Resting
// churn, session 9"). The late kinetic energy of two stacked free blocks at dt 1 ms is chaotic in
// sub-micron shifts of the start (session 8), so every variant is measured over an ensemble of
// shifted starts and summarised by the geometric mean and the median of the late KE, and the time
// from which the KE stays below the rest floor (1/2) M (g dt)^2. Each variant changes one candidate
// stage against the default: the binary search's resolution, the finishing projection, the held
// forces, the FEM solve's tolerance, the K' reuse between steps.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "sim/model/corotational_fem.h"
#include "support/block_stack.h"

namespace pliant {
namespace {

constexpr double kShifts_m[] = {0.0, 1e-7, 3e-7, 7e-7, 1.5e-6, 3e-6, 7e-6, 1.5e-5};

struct Variant {
  const char* name;
  std::function<void(ContactSettings&)> contact;
  std::function<void(World&, const std::vector<BodyId>&)> bodies;
};

/// Ensemble summary of one variant (J, s).
struct Ensemble {
  double geometric_mean = 0.0, median = 0.0, largest = 0.0, rest_time_median = 0.0;
  int resting = 0;  ///< runs whose late KE stays below the rest floor
};

Ensemble run_ensemble(const Variant& v, double mu, double dt, bool fixed_base) {
  std::vector<double> late, rest;
  double log_sum = 0.0;
  Ensemble e;
  for (double shift : kShifts_m) {
    const ChurnRun r = run_block_stack(2, mu, dt, fixed_base, v.contact, shift, v.bodies);
    late.push_back(r.kinetic_late_max);
    rest.push_back(r.rest_time);
    log_sum += std::log(r.kinetic_late_max);
    if (r.kinetic_late_max < r.rest_floor) ++e.resting;
  }
  std::sort(late.begin(), late.end());
  std::sort(rest.begin(), rest.end());
  const size_t n = late.size();
  e.geometric_mean = std::exp(log_sum / static_cast<double>(n));
  e.median = 0.5 * (late[n / 2 - 1] + late[n / 2]);
  e.largest = late.back();
  e.rest_time_median = 0.5 * (rest[n / 2 - 1] + rest[n / 2]);
  return e;
}

std::vector<Variant> variants() {
  auto accuracy = [](double tolerance, int iterations) {
    return [=](World& w, const std::vector<BodyId>& ids) {
      for (BodyId id : ids) w.body(id).model->set_accuracy({iterations, tolerance});
    };
  };
  return {
      {"default", {}, {}},
      {"search 6 iterations", [](ContactSettings& c) { c.binary_search_iterations = 6; }, {}},
      {"search 8 iterations", [](ContactSettings& c) { c.binary_search_iterations = 8; }, {}},
      {"secant refinement", [](ContactSettings& c) { c.secant_refinement = true; }, {}},
      {"no finishing projection", [](ContactSettings& c) { c.finishing_projection = false; }, {}},
      {"held fraction 0.8", [](ContactSettings& c) { c.held_force_fraction = 0.8; }, {}},
      {"deformable pairs held 0.8", [](ContactSettings& c) { c.deformable_pair_held_force_fraction = 0.8; }, {}},
      {"deformable pairs held derived", [](ContactSettings& c) { c.deformable_pair_held_force_derived = true; }, {}},
      {"solve to 1e-10, 200 iterations", {}, accuracy(1e-10, 200)},
      {"no K' reuse between steps", {},
       [](World& w, const std::vector<BodyId>& ids) {
         for (BodyId id : ids) {
           if (auto* fem = dynamic_cast<CorotationalFem*>(w.body(id).model.get())) {
             fem->set_stiffness_rotation_tolerance(0.0);
           }
         }
       }},
  };
}

const Variant& variant(const std::vector<Variant>& all, const std::string& name) {
  const auto it = std::find_if(all.begin(), all.end(), [&](const Variant& v) { return name == v.name; });
  EXPECT_NE(it, all.end()) << name;
  return *it;
}

Ensemble measure(const Variant& v, double mu, double dt, bool fixed_base) {
  const Ensemble e = run_ensemble(v, mu, dt, fixed_base);
  std::printf("%-32s mu %.1f dt %.1f ms%s: late KE gmean %.3g median %.3g max %.3g J, resting %d/%zu, rest time median "
              "%.3f s\n",
              v.name, mu, dt * 1e3, fixed_base ? " fixed base" : "", e.geometric_mean, e.median, e.largest, e.resting,
              std::size(kShifts_m), e.rest_time_median);
  std::fflush(stdout);
  return e;
}

// The stack with friction (mu 0.5, dt 1 ms; the membrane stack's and the fruit dish's case): none
// of the search, projection or solver candidates moves the churn (measured: geometric means
// 1.42e-5..1.60e-5 J against the default's 1.37e-5, no run resting), while holding 0.8 of the
// contact force instead of all of it rests every start (2.2e-6 J < the floor 2.6e-6 J). The churn
// is the held force's one-step lag at full strength, not the search's resolution, the FEM solve's
// tolerance or the K' reuse. Measuring switch: PLIANT_CHURN_VARIANTS=name,name (default: all).
TEST(ContactChurnMechanism, LongOnlyTheHeldFractionRestsTheStackWithFriction) {
  const std::vector<Variant> all = variants();
  const char* env = std::getenv("PLIANT_CHURN_VARIANTS");
  const std::string wanted = env != nullptr ? env : "";
  const Ensemble reference = measure(variant(all, "default"), 0.5, 1e-3, false);
  EXPECT_EQ(reference.resting, 0);
  for (const char* name : {"search 6 iterations", "search 8 iterations", "secant refinement", "no finishing projection",
                           "solve to 1e-10, 200 iterations", "no K' reuse between steps"}) {
    if (!wanted.empty() && wanted.find(name) == std::string::npos) continue;
    const Ensemble e = measure(variant(all, name), 0.5, 1e-3, false);
    EXPECT_EQ(e.resting, 0) << name;
    EXPECT_GT(e.geometric_mean, reference.geometric_mean / 1.5) << name;
    EXPECT_LT(e.geometric_mean, reference.geometric_mean * 1.5) << name;
  }
  const Ensemble held = measure(variant(all, "held fraction 0.8"), 0.5, 1e-3, false);
  EXPECT_EQ(held.resting, static_cast<int>(std::size(kShifts_m)));
}

// ContactSettings::deformable_pair_held_force_fraction 0.8 (opt-in) against the default over the
// ensemble. Measured (session 9): fixed-base block at 0.5 ms 1.89e-4 -> 6.8e-7 J; two free blocks
// at 1 ms mu 0 7.96e-5 -> 1.8e-5 J, mu 0.5 1.37e-5 -> 8.4e-6 J (2 of 8 rest); at 0.5 ms both still
// rest every start (mu 0 9.3e-8 -> 5.9e-7 J against the floor 6.5e-7 J: closer to it).
TEST(ContactChurnMechanism, LongDeformablePairHeldFractionCutsTheChurn) {
  const std::vector<Variant> all = variants();
  const Variant& fix = variant(all, "deformable pairs held 0.8");
  const Variant& reference = variant(all, "default");
  EXPECT_LT(measure(fix, 0.0, 5e-4, true).geometric_mean, measure(reference, 0.0, 5e-4, true).geometric_mean / 100.0);
  EXPECT_LT(measure(fix, 0.0, 1e-3, false).geometric_mean, measure(reference, 0.0, 1e-3, false).geometric_mean / 2.0);
  EXPECT_LT(measure(fix, 0.5, 1e-3, false).geometric_mean, measure(reference, 0.5, 1e-3, false).geometric_mean);
  for (double mu : {0.0, 0.5}) EXPECT_EQ(measure(fix, mu, 5e-4, false).resting, static_cast<int>(std::size(kShifts_m)));
}

// Session 10: the derived strength (ContactSettings::deformable_pair_held_force_derived: 0.78 for
// the free blocks at 1 ms, 0.93 at 0.5 ms; 0.88 / 0.97 on the fixed base, whose upper block moves
// alone) against the default and 0.8, printed side by side. Measured (geometric means, J; default /
// 0.8 / derived): free mu 0 1 ms 7.96e-5 / 1.80e-5 / 1.73e-5; free mu 0.5 1 ms 1.37e-5 / 8.37e-6 (2
// of 8 rest) / 1.55e-5 (0 of 8: constant 0.783 gives the same, 1.54e-5; with friction only <= 0.75
// rests every start, docs/contact-surface.md "Resting churn, session 10"); fixed base 0.5 ms 1.89e-4
// / 6.78e-7 / 3.10e-5, 1 ms 8.7e-3 / 2.67e-5 / 1.7e-3; at 0.5 ms the free stack rests 8 / 8 / 7 of 8
// (mu 0) and 8 / 8 / 8 (mu 0.5). Asserted: what the derived strength does against the default.
TEST(ContactChurnMechanism, LongDerivedPairHeldStrength) {
  const std::vector<Variant> all = variants();
  struct Case {
    double mu, dt;
    bool fixed_base;
  };
  for (const Case& c : {Case{0.0, 1e-3, false}, Case{0.5, 1e-3, false}, Case{0.0, 5e-4, false}, Case{0.5, 5e-4, false},
                        Case{0.0, 5e-4, true}, Case{0.0, 1e-3, true}}) {
    const Ensemble reference = measure(variant(all, "default"), c.mu, c.dt, c.fixed_base);
    measure(variant(all, "deformable pairs held 0.8"), c.mu, c.dt, c.fixed_base);
    const Ensemble derived = measure(variant(all, "deformable pairs held derived"), c.mu, c.dt, c.fixed_base);
    if (reference.resting == 0 && c.mu == 0.0) {
      // The frictionless churning cases (free at 1 ms, fixed base at both steps): cut 2x or more.
      EXPECT_LT(derived.geometric_mean, reference.geometric_mean / 2.0) << c.mu << " " << c.dt << " " << c.fixed_base;
    }
    if (reference.resting == static_cast<int>(std::size(kShifts_m))) {
      // Resting cases (free at 0.5 ms) stay resting: all starts but at most one.
      EXPECT_GE(derived.resting, reference.resting - 1) << c.mu << " " << c.dt;
    }
  }
}

}  // namespace
}  // namespace pliant
