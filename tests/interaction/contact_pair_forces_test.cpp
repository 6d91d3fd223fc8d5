// The per-pair contact forces of a step with many bodies (the fruit dish's first landing: tens of
// fruit-dish and fruit-fruit pairs, so a body's pair list holds many entries; session 10 finds a
// pair through its lower body's list instead of a scan over all pairs). A second method: each
// kinematic body's reaction (accumulated contact by contact, apart from the pairs) must be the sum
// of the forces its pairs carry, and each pair's contact count the number of the step's contacts
// between its bodies (counted here from World::contacts); each pair appears once, sorted, with
// equal and opposite forces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <utility>

#include "interaction/scene/scene.h"
#include "interaction/scene/scene_runner.h"

namespace pliant {
namespace {

TEST(ContactPairForces, EachPairOnceAndTheDishReactionsAreTheSumsOfTheirPairs) {
  const Scene scene = load_scene(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/fruit_dish.json");
  SceneRunner run(scene);
  size_t pairs_max = 0;
  int steps_with_reaction = 0;
  for (int step = 0; step < 80; ++step) {
    ASSERT_TRUE(run.tick()) << run.fault();
    const StepReport& report = run.report();
    const auto& pairs = report.pair_forces;
    pairs_max = std::max(pairs_max, pairs.size());
    for (size_t i = 0; i < pairs.size(); ++i) {
      const PairContactForce& p = pairs[i];
      ASSERT_LT(p.body_a, p.body_b);
      if (i > 0) {  // strictly sorted: no pair twice
        const PairContactForce& q = pairs[i - 1];
        ASSERT_TRUE(q.body_a < p.body_a || (q.body_a == p.body_a && q.body_b < p.body_b)) << "step " << step;
      }
      // The same impulses added to one side and subtracted from the other, in the same order.
      ASSERT_EQ(p.force_on_a, Vec3(-p.force_on_b)) << "step " << step;
    }
    // Each pair counts the step's contacts between its two bodies (World::contacts, counted here).
    std::map<std::pair<int, int>, int> contacts_of_pair;
    for (const VertexContact& c : run.world().contacts()) {
      ++contacts_of_pair[{std::min(c.body, c.penetrated_body), std::max(c.body, c.penetrated_body)}];
    }
    for (const PairContactForce& p : pairs) {
      const auto it = contacts_of_pair.find({p.body_a, p.body_b});
      ASSERT_EQ(p.contacts, it == contacts_of_pair.end() ? 0 : it->second)
          << "step " << step << " pair " << p.body_a << "-" << p.body_b;
      if (it != contacts_of_pair.end()) contacts_of_pair.erase(it);
    }
    ASSERT_TRUE(contacts_of_pair.empty()) << "step " << step << ": a pair with contacts has no entry";
    for (const KinematicReaction& r : report.reactions) {
      Vec3 sum = Vec3::Zero();
      double magnitude = 0.0;
      for (const PairContactForce& p : pairs) {
        if (p.body_a == r.body) sum += p.force_on_a;
        if (p.body_b == r.body) sum += p.force_on_b;
        if (p.body_a == r.body || p.body_b == r.body) magnitude += p.force_on_a.norm();
      }
      // Reactions sum the same contact forces in contact order, the pairs per pair: round-off only.
      EXPECT_LE((r.force - sum).norm(), 1e-12 * magnitude + 1e-300) << "step " << step << " body " << r.body;
      if (r.force.norm() > 0.0) ++steps_with_reaction;
    }
  }
  // The test is about many pairs: the fruits' landing makes tens of them.
  EXPECT_GE(pairs_max, 20u);
  EXPECT_GT(steps_with_reaction, 10);
  std::printf("fruit dish, 80 steps: up to %zu body pairs in a step\n", pairs_max);
}

}  // namespace
}  // namespace pliant
