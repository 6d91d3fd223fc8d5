// Sleeping bodies (sim/sleep/sleep_settings.h): a block dropped on a fixed floor falls asleep
// once it has settled and its state then stops changing exactly; it wakes in the step a moving
// body or an instrument first touches it; a body in free fall never sleeps (checked against the
// ballistic closed form); bodies that are awake are not affected (bit-identical to a run with
// sleeping off), and sleeping off never puts a body to sleep. Instruments are not fixtures: tissue
// under a probe that presses and then holds still never falls asleep, and the probe's reaction
// force is bit-identical to a run with sleeping off at every step (with the same probe flagged as a
// fixture the tissue falls asleep in the hold and the force drops to zero: the failure it prevents).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "sim/mesh/box_mesh.h"
#include "sim/sleep/sleeping.h"
#include "sim/world.h"
#include <cstring>

namespace pliant {
namespace {

constexpr double kDt = 1e-3;  // s

Material block_material() {
  Material m;
  m.young_modulus = 5e4;  // Pa
  m.poisson_ratio = 0.3;
  m.density = 1000.0;     // kg/m^3
  m.mass_damping = 2.0;   // 1/s: settles within a second
  m.stiffness_damping = 0.0;
  m.friction = 0.4;
  return m;
}

WorldSettings sleep_on() {
  WorldSettings s;
  s.sleep.enabled = true;
  s.sleep.speed = 0.005;  // m/s
  s.sleep.time = 0.2;     // s
  return s;
}

// A kinematic floor slab with its top face at z = 0 and a 50 mm block resting `gap` above it.
struct FloorAndBlock {
  World world;
  BodyId floor, block;
  explicit FloorAndBlock(WorldSettings settings, double gap = 0.002, Vec3 block_xy = Vec3::Zero())
      : world(settings) {
    BodyDef f{.name = "floor", .mesh = make_box_mesh({Vec3(0.6, 0.6, 0.04), 1, 1, 1}),
              .material = block_material(), .motion = BodyMotion::kinematic};
    f.pose.translation = Vec3(0, 0, -0.02);
    floor = world.add_body(f);
    block = add_block(world, "block", block_xy + Vec3(0, 0, 0.025 + gap));
  }
  static BodyId add_block(World& w, const std::string& name, const Vec3& centre) {
    BodyDef b{.name = name, .mesh = make_box_mesh({Vec3(0.05, 0.05, 0.05), 2, 2, 2}), .material = block_material()};
    b.pose.translation = centre;
    return w.add_body(b);
  }
};

// Steps until the block sleeps (or max_steps); returns the step count, or nullopt.
std::optional<int> step_until_asleep(World& world, BodyId id, int max_steps) {
  for (int i = 1; i <= max_steps; ++i) {
    const StepReport& r = world.step(kDt);
    EXPECT_TRUE(r.all_finite);
    if (world.body(id).is_sleeping()) return i;
  }
  return std::nullopt;
}

bool bit_identical(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (std::memcmp(&a[i][k], &b[i][k], sizeof(double)) != 0) return false;
    }
  }
  return true;
}

double min_z(const Body& b) {
  double z = INFINITY;
  for (const Vec3& x : b.positions) z = std::min(z, x.z());
  return z;
}

/// Mean height of a body's vertices (its rest height; unlike min_z, blind to how it is tilted).
double mean_z(const Body& b) {
  double z = 0.0;
  for (const Vec3& x : b.positions) z += x.z();
  return z / static_cast<double>(b.positions.size());
}

TEST(Sleeping, BlockOnFloorFallsAsleepAndItsStateThenStopsChangingExactly) {
  FloorAndBlock s(sleep_on());
  std::vector<Vec3> before_sleep;
  const auto asleep = step_until_asleep(s.world, s.block, 3000);
  ASSERT_TRUE(asleep.has_value()) << "the block never fell asleep within 3 s";
  // It slept only after the landing (free fall over 2 mm takes 20 ms) and after `time` at rest.
  EXPECT_GT(*asleep * kDt, 0.02 + 0.2);
  const Body& block = s.world.body(s.block);
  // Resting on the floor: the lowest vertex within a millimetre of z = 0, no velocity.
  EXPECT_NEAR(min_z(block), 0.0, 1e-3);
  for (const Vec3& v : block.velocities) EXPECT_EQ(v.squaredNorm(), 0.0);
  const std::vector<Vec3> x = block.positions, v = block.velocities;
  const double elastic = s.world.last_report().body_energy[s.block.index].elastic;
  for (int i = 0; i < 300; ++i) {
    const StepReport& r = s.world.step(kDt);
    ASSERT_EQ(r.sleeping_bodies, 1);
    EXPECT_EQ(r.colliding_vertices, 0);  // the still floor and the sleeping block are not paired
    EXPECT_EQ(r.body_energy[s.block.index].kinetic, 0.0);
    EXPECT_EQ(r.body_energy[s.block.index].elastic, elastic);
  }
  EXPECT_TRUE(s.world.body(s.block).is_sleeping());
  EXPECT_TRUE(bit_identical(s.world.body(s.block).positions, x));
  EXPECT_TRUE(bit_identical(s.world.body(s.block).velocities, v));
}

// Once the block sleeps, a second block is dropped from 30 mm above its top (z = 0.05): it lands
// after ~78 ms. Steps until the lower block wakes (at most 200 steps), checking that it stays
// bit-identical until then and is woken by the contact of that very step.
struct Landing {
  int woken_at = -1;            ///< step of the wake after the drop (-1: never)
  BodyId top;
  std::vector<Vec3> asleep_at;  ///< the lower block's positions while it slept
};
Landing drop_a_block_on_the_sleeping_one(FloorAndBlock& s) {
  Landing landing;
  if (!step_until_asleep(s.world, s.block, 3000).has_value()) return landing;
  landing.asleep_at = s.world.body(s.block).positions;
  landing.top = FloorAndBlock::add_block(s.world, "top", Vec3(0.01, 0, 0.05 + 0.03 + 0.025));
  for (int i = 1; i <= 200 && landing.woken_at < 0; ++i) {
    const StepReport& r = s.world.step(kDt);
    EXPECT_TRUE(r.all_finite);
    if (!s.world.body(s.block).is_sleeping()) {
      landing.woken_at = i;
      EXPECT_EQ(r.bodies_woken, 1);
      EXPECT_GT(r.colliding_vertices, 0);
    } else {
      EXPECT_TRUE(bit_identical(s.world.body(s.block).positions, landing.asleep_at)) << "sleeping block moved at step " << i;
    }
  }
  return landing;
}

TEST(Sleeping, WakesInTheStepAnotherBodyLandsOnIt) {
  FloorAndBlock s(sleep_on());
  const Landing landing = drop_a_block_on_the_sleeping_one(s);
  ASSERT_GT(landing.woken_at, 0) << "the lower block never slept or never woke";
  // Closed form: the top block falls 30 mm in sqrt(2 h / g) = 78 ms before it touches.
  EXPECT_NEAR(landing.woken_at * kDt, std::sqrt(2 * 0.03 / 9.81), 0.006);
  EXPECT_FALSE(s.world.body(landing.top).is_sleeping());
  // Awake, the lower block responds to the load: it moves again.
  for (int i = 0; i < 20; ++i) s.world.step(kDt);
  EXPECT_FALSE(bit_identical(s.world.body(s.block).positions, landing.asleep_at));
}

TEST(Sleeping, WakesWhenAnInstrumentTouchesIt) {
  FloorAndBlock s(sleep_on());
  // A kinematic probe 10 x 10 x 10 mm hovering 5 mm above the block's top (z = 0.05).
  BodyDef p{.name = "probe", .mesh = make_box_mesh({Vec3(0.01, 0.01, 0.01), 1, 1, 1}),
            .material = block_material(), .motion = BodyMotion::kinematic, .instrument = true};
  p.pose.translation = Vec3(0.004, 0.003, 0.05 + 0.005 + 0.005);
  const BodyId probe = s.world.add_body(p);
  ASSERT_TRUE(step_until_asleep(s.world, s.block, 3000).has_value());
  // The still probe does not wake it.
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(s.world.step(kDt).all_finite);
  ASSERT_TRUE(s.world.body(s.block).is_sleeping());
  // Move the probe down at 0.1 m/s. It first overlaps the block when its bottom face passes the
  // highest block vertex under its footprint (the block's top-face centre, about 5 mm below it:
  // the block sags a little under its weight; the face around it is lower).
  double top_z = -INFINITY;
  for (const Vec3& x : s.world.body(s.block).positions) {
    if (std::abs(x.x() - 0.004) < 0.005 && std::abs(x.y() - 0.003) < 0.005) top_z = std::max(top_z, x.z());
  }
  const double gap = (p.pose.translation.z() - 0.005) - top_z;
  const int expected = static_cast<int>(std::ceil(gap / (0.1 * kDt)));
  Pose pose = p.pose;
  int woken_at = -1;
  for (int i = 1; i <= 100 && woken_at < 0; ++i) {
    pose.translation.z() -= 0.1 * kDt;
    s.world.set_kinematic_pose(probe, pose);
    const StepReport& r = s.world.step(kDt);
    ASSERT_TRUE(r.all_finite);
    if (!s.world.body(s.block).is_sleeping()) {
      woken_at = i;
      EXPECT_GT(r.colliding_vertices, 0);
      // The instrument feels the block in the step it wakes it.
      bool felt = false;
      for (const auto& reaction : r.reactions) felt |= reaction.body == static_cast<int>(probe.index) && reaction.force.norm() > 0.0;
      EXPECT_TRUE(felt);
    }
  }
  ASSERT_GT(woken_at, 0);
  EXPECT_NEAR(woken_at, expected, 1) << "gap " << gap << " m";
}

// A tissue slab 60 x 60 x 20 mm fixed at its base, and a 10 mm cube probe above its centre that
// presses 2 mm in at 20 mm/s (100 steps) and then holds still for 0.6 s (three times the rest time).
struct ProbeHold {
  World world;
  BodyId tissue, probe;
  Pose pose;
  ProbeHold(WorldSettings settings, bool instrument) : world(settings) {
    Material m = block_material();
    m.young_modulus = 1e4;  // Pa, soft tissue
    BodyDef t{.name = "tissue", .mesh = make_box_mesh({Vec3(0.06, 0.06, 0.02), 4, 4, 2}), .material = m};
    t.pose.translation = Vec3(0, 0, -0.01);  // top face at z = 0
    const auto& rest = t.mesh->rest_positions();
    for (size_t v = 0; v < rest.size(); ++v) {
      if (rest[v].z() < -0.01 + 1e-9) t.fixed_vertices.push_back(static_cast<int>(v));
    }
    tissue = world.add_body(t);
    BodyDef p{.name = "probe", .mesh = make_box_mesh({Vec3(0.01, 0.01, 0.01), 1, 1, 1}),
              .material = block_material(), .motion = BodyMotion::kinematic, .instrument = instrument};
    p.pose.translation = Vec3(0.001, 0.002, 0.005 + 1e-4);  // bottom face 0.1 mm above the tissue
    pose = p.pose;
    probe = world.add_body(p);
  }
  // Steps once (moving the probe down 20 mm/s for the first 100 steps); the probe's reaction force.
  Vec3 step(int i) {
    if (i < 100) {
      pose.translation.z() -= 0.02 * kDt;
      world.set_kinematic_pose(probe, pose);
    }
    const StepReport& r = world.step(kDt);
    EXPECT_TRUE(r.all_finite);
    for (const auto& reaction : r.reactions) {
      if (reaction.body == static_cast<int>(probe.index)) return reaction.force;
    }
    ADD_FAILURE() << "no reaction entry for the probe";
    return Vec3::Zero();
  }
};

TEST(Sleeping, TissueUnderAStillInstrumentNeverSleepsAndItsForceMatchesSleepingOff) {
  for (const double held : {0.0, 1.0}) {
    WorldSettings on = sleep_on(), off = sleep_on();
    on.contact.held_force_fraction = held;
    off.contact.held_force_fraction = held;
    off.sleep.enabled = false;
    ProbeHold with_sleep(on, true), without(off, true);
    int pressing_steps = 0;
    for (int i = 0; i < 700; ++i) {
      const Vec3 f_on = with_sleep.step(i), f_off = without.step(i);
      ASSERT_FALSE(with_sleep.world.body(with_sleep.tissue).is_sleeping()) << "held " << held << " step " << i;
      for (int k = 0; k < 3; ++k) {
        ASSERT_EQ(std::memcmp(&f_on[k], &f_off[k], sizeof(double)), 0)
            << "held " << held << " step " << i << ": " << f_on.transpose() << " vs " << f_off.transpose();
      }
      // From the first contact on (2 mm in, then held) the tissue pushes the probe up every step.
      if (f_off.z() > 0.0) ++pressing_steps;
      if (pressing_steps > 0 && i >= 100) {
        ASSERT_GT(f_on.z(), 0.0) << "held " << held << " step " << i;
      }
    }
    EXPECT_GT(pressing_steps, 600) << "held " << held;
    EXPECT_TRUE(bit_identical(with_sleep.world.body(with_sleep.tissue).positions,
                              without.world.body(without.tissue).positions)) << "held " << held;
  }
}

// The failure the instrument flag prevents: the same probe as a fixture lets the tissue fall asleep
// during the hold (a sleeping body is immovable and the still fixture's pairs with it are not
// detected), and the reported force drops to zero.
TEST(Sleeping, TissueUnderAStillFixtureFallsAsleepAndItsForceDropsToZero) {
  ProbeHold s(sleep_on(), false);
  int asleep_at = -1;
  Vec3 last = Vec3::Zero();
  for (int i = 0; i < 700; ++i) {
    last = s.step(i);
    if (asleep_at < 0 && s.world.body(s.tissue).is_sleeping()) asleep_at = i;
  }
  // The rest rule (every vertex within 1 mm of where the rest began, for 0.2 s = 200 steps) can
  // start counting once the press has at most 1 mm left (0.02 mm per step: from step 50); with
  // held contact forces (the default) the tissue follows the probe smoothly and sleeps at 279.
  ASSERT_GE(asleep_at, 50 + 200) << "slept before the rest rule allows";
  EXPECT_EQ(last.norm(), 0.0);
  EXPECT_EQ(s.world.last_report().colliding_vertices, 0);
}

TEST(Sleeping, BodyInFreeFallNeverSleepsEvenAtTheTopOfItsFlight) {
  WorldSettings settings = sleep_on();
  World world(settings);
  Material m = block_material();
  m.mass_damping = 0.0;
  BodyDef b{.name = "ball", .mesh = make_box_mesh({Vec3(0.05, 0.05, 0.05), 2, 2, 2}), .material = m,
            .initial_velocity = Vec3(0, 0, 1.0)};
  const BodyId id = world.add_body(b);
  const double v0 = 1.0, g = 9.81;
  for (int i = 1; i <= 300; ++i) {  // the apex is at v0 / g = 0.10 s
    const StepReport& r = world.step(kDt);
    ASSERT_TRUE(r.all_finite);
    ASSERT_EQ(r.sleeping_bodies, 0) << "at t = " << i * kDt;
    ASSERT_FALSE(world.body(id).is_sleeping());
  }
  // Ballistic closed form for the centre of mass (backward Euler: O(dt) error in z).
  const Body& body = world.body(id);
  Vec3 com = Vec3::Zero();
  for (size_t v = 0; v < body.positions.size(); ++v) com += body.masses[v] * body.positions[v];
  com /= body.total_mass();
  const double t = 0.3;
  EXPECT_NEAR(com.z(), v0 * t - 0.5 * g * t * t, 0.5 * g * t * kDt + 1e-6);
}

TEST(Sleeping, AwakeBodiesAreBitIdenticalToARunWithSleepingOff) {
  // Block A settles and sleeps at the origin; block B, 0.2 m away, is dropped from 0.1 m after
  // 1 s and bounces while A sleeps. B must not notice that A sleeps.
  // With held contact forces (the default) B settles within about 0.6 s of landing and falls asleep
  // itself (step 913): from then on its velocities are zero in the sleeping run, so B is compared
  // bit for bit while it is awake, and afterwards it must stay where the sleeping-off run keeps it,
  // within the rest distance (1 mm: the sleeping run froze it there).
  WorldSettings off = sleep_on();
  off.sleep.enabled = false;
  FloorAndBlock on_run(sleep_on()), off_run(off);
  const BodyId b_on = FloorAndBlock::add_block(on_run.world, "b", Vec3(0.2, 0, 0.5));
  const BodyId b_off = FloorAndBlock::add_block(off_run.world, "b", Vec3(0.2, 0, 0.5));
  bool a_slept = false, b_slept = false;
  for (int i = 0; i < 1500; ++i) {
    const StepReport& r_on = on_run.world.step(kDt);
    const StepReport& r_off = off_run.world.step(kDt);
    ASSERT_TRUE(r_on.all_finite && r_off.all_finite);
    ASSERT_EQ(r_off.sleeping_bodies, 0);
    ASSERT_FALSE(off_run.world.body(off_run.block).is_sleeping());
    a_slept |= on_run.world.body(on_run.block).is_sleeping();
    b_slept |= on_run.world.body(b_on).is_sleeping();
    if (b_slept) {
      const auto& x_on = on_run.world.body(b_on).positions;
      const auto& x_off = off_run.world.body(b_off).positions;
      for (size_t v = 0; v < x_on.size(); ++v) {
        ASSERT_LT((x_on[v] - x_off[v]).norm(), on_run.world.settings().sleep.rest_distance()) << i;
      }
      continue;
    }
    ASSERT_TRUE(bit_identical(on_run.world.body(b_on).positions, off_run.world.body(b_off).positions)) << i;
    ASSERT_TRUE(bit_identical(on_run.world.body(b_on).velocities, off_run.world.body(b_off).velocities)) << i;
    // Until A falls asleep, A is bit-identical too.
    if (!a_slept) {
      ASSERT_TRUE(bit_identical(on_run.world.body(on_run.block).positions,
                                off_run.world.body(off_run.block).positions)) << i;
    }
  }
  EXPECT_TRUE(a_slept);
  EXPECT_TRUE(b_slept);
  // B landed (0.5 m fall: 0.32 s) and came to rest on the floor too, and then slept.
  EXPECT_NEAR(min_z(on_run.world.body(b_on)), 0.0, 1e-3);
}

// The rest ball, closed form: with no gravity and no damping a block glides at constant velocity
// v. Its rest begins in the first step (the anchor) and it sleeps after `time` at rest only if it
// stays within speed x time (1 mm) of the anchor meanwhile: v < speed. At 4 mm/s (0.8 mm in
// 0.2 s) it sleeps in step 1 + time / dt; at 6 mm/s (1.2 mm) it never does: the rest restarts
// whenever it has crept 1 mm.
TEST(Sleeping, ACreepingBodySleepsOnlyIfItStaysWithinRestDistance) {
  for (const double v : {0.004, 0.006}) {
    WorldSettings settings = sleep_on();
    settings.gravity = Vec3::Zero();
    ASSERT_DOUBLE_EQ(settings.sleep.rest_distance(), 1e-3);
    World world(settings);
    Material m = block_material();
    m.mass_damping = 0.0;
    BodyDef b{.name = "glider", .mesh = make_box_mesh({Vec3(0.05, 0.05, 0.05), 2, 2, 2}), .material = m,
              .initial_velocity = Vec3(v, 0, 0)};
    const BodyId id = world.add_body(b);
    const int expected = 1 + static_cast<int>(std::lround(settings.sleep.time / kDt));
    const auto asleep = step_until_asleep(world, id, 2000);
    if (v < settings.sleep.speed) {
      ASSERT_TRUE(asleep.has_value()) << v;
      EXPECT_NEAR(*asleep, expected, 1) << v;
    } else {
      EXPECT_FALSE(asleep.has_value()) << v << " m/s slept at step " << *asleep;
      // It kept gliding at v (closed form x = v t, rigid translation: no elastic force).
      EXPECT_NEAR(world.body(id).positions[0].x() - (-0.025), v * 2000 * kDt, 1e-9);
    }
  }
}

TEST(Sleeping, TurningSleepingOffWakesEveryBody) {
  FloorAndBlock s(sleep_on());
  ASSERT_TRUE(step_until_asleep(s.world, s.block, 3000).has_value());
  s.world.settings().sleep.enabled = false;
  const StepReport& r = s.world.step(kDt);
  EXPECT_EQ(r.sleeping_bodies, 0);
  EXPECT_FALSE(s.world.body(s.block).is_sleeping());
  // Awake on the floor again: gravity pulls it back into contact with the floor.
  for (int i = 0; i < 5; ++i) s.world.step(kDt);
  EXPECT_GT(s.world.last_report().colliding_vertices, 0);
}

// Largest distance of any vertex from where it was.
double max_displacement(const std::vector<Vec3>& x, const std::vector<Vec3>& x0) {
  double d = 0.0;
  for (size_t v = 0; v < x.size(); ++v) d = std::max(d, (x[v] - x0[v]).norm());
  return d;
}

// Waking does not spread through a resting row (session 5: before, a woken body woke every sleeper
// whose bounding box came within wake_margin of it, transitively, so in the fruit dish any fruit
// that moved woke the whole pile). Four blocks sleep in a row on the floor, 1 mm apart (each box
// within the 2 mm margin of the next); a fifth block lands on the first. The first wakes in the
// step of contact; the others wake only if a neighbour leaves its rest ball (1 mm) and come within
// the margin. The reference is the same scene with sleeping off: there the far blocks are never
// touched (they stay within round-off of where they were), so nothing may wake them; and once the
// load has settled every block is asleep again, the struck one where the sleeping-off run has it.
TEST(Sleeping, WakingDoesNotSpreadThroughARestingRow) {
  WorldSettings off = sleep_on();
  off.sleep.enabled = false;
  FloorAndBlock on_run(sleep_on(), 0.0), off_run(off, 0.0);  // block 0 resting on the floor at x = 0
  std::vector<BodyId> row_on{on_run.block}, row_off{off_run.block};
  for (int k = 1; k < 4; ++k) {
    const Vec3 at(k * 0.051, 0, 0.025);  // 50 mm blocks, 1 mm gaps
    row_on.push_back(FloorAndBlock::add_block(on_run.world, "row" + std::to_string(k), at));
    row_off.push_back(FloorAndBlock::add_block(off_run.world, "row" + std::to_string(k), at));
  }
  for (int i = 0; i < 1500 && on_run.world.last_report().sleeping_bodies < 4; ++i) {
    ASSERT_TRUE(on_run.world.step(kDt).all_finite);
    ASSERT_TRUE(off_run.world.step(kDt).all_finite);
  }
  ASSERT_EQ(on_run.world.last_report().sleeping_bodies, 4) << "the row never fell asleep";
  std::vector<std::vector<Vec3>> asleep_at;
  for (BodyId id : row_on) asleep_at.push_back(on_run.world.body(id).positions);
  // A block dropped 10 mm onto the first one (lands after sqrt(2 h / g) = 45 ms).
  const BodyId top_on = FloorAndBlock::add_block(on_run.world, "top", Vec3(-0.005, 0, 0.05 + 0.01 + 0.025));
  FloorAndBlock::add_block(off_run.world, "top", Vec3(-0.005, 0, 0.05 + 0.01 + 0.025));
  std::vector<std::vector<Vec3>> off_before;
  for (BodyId id : row_off) off_before.push_back(off_run.world.body(id).positions);
  bool first_woke = false;
  double far_moved_off = 0.0;
  for (int i = 0; i < 1500; ++i) {
    ASSERT_TRUE(on_run.world.step(kDt).all_finite);
    ASSERT_TRUE(off_run.world.step(kDt).all_finite);
    first_woke |= !on_run.world.body(row_on[0]).is_sleeping();
    for (int k = 2; k < 4; ++k) {
      far_moved_off = std::max(far_moved_off, max_displacement(off_run.world.body(row_off[k]).positions, off_before[k]));
      // Blocks 2 and 3: nothing comes near them, so they sleep on, bit for bit.
      ASSERT_TRUE(on_run.world.body(row_on[k]).is_sleeping()) << "block " << k << " woken at step " << i;
      ASSERT_TRUE(bit_identical(on_run.world.body(row_on[k]).positions, asleep_at[k]));
    }
  }
  EXPECT_TRUE(first_woke) << "the struck block never woke";
  // Sleeping off, the far blocks only settle further on their own (measured 0.58 mm in 1.5 s),
  // less than the rest distance: freezing them changes nothing the rest rule would not allow.
  EXPECT_LT(far_moved_off, on_run.world.settings().sleep.rest_distance());
  // The struck block and the landed one where the sleeping-off run has them. (They do not fall
  // asleep again within 1.5 s: a block on a block keeps moving more than 1 mm per 0.2 s,
  // docs/experiments.md "Session 5".)
  EXPECT_LT(max_displacement(on_run.world.body(row_on[0]).positions, off_run.world.body(row_off[0]).positions),
            2.0 * on_run.world.settings().sleep.rest_distance());
  // The landed block rests on it as high as sleeping off has it (its sideways drift differs: 6.6 mm).
  // Its mean height, not its lowest vertex: a block on a block rocks (the churn above), and a tilt
  // of a few degrees moves its lowest corner by millimetres while its height stays (session-5
  // merge: lowest vertex 45.8 vs 42.4 mm, the sleeping-off block tilted; mean 73.3 vs 73.0 mm).
  EXPECT_NEAR(mean_z(on_run.world.body(top_on)), mean_z(*off_run.world.bodies().back()),
              2.0 * on_run.world.settings().sleep.rest_distance());
}

// The wake rule itself, on bodies whose sleep state is set by hand (no dynamics): three blocks in a
// row 1 mm apart (each box within the 2 mm wake margin of the next), no vertex of one inside
// another. The middle one awake, the outer ones asleep. If the middle one stayed inside its rest
// ball in its last step it wakes nobody; if it left the ball it wakes both neighbours although it
// touches neither (a body lying on one that moves away must not hover). A sleeper farther than the
// margin stays asleep, and waking does not pass on: a woken body is not a mover until it leaves
// its own ball (before session 5 a woken body woke every sleeper near it at once, transitively).
TEST(Sleeping, OnlyABodyThatLeftItsRestBallWakesTheSleepersNearIt) {
  World world(sleep_on());
  std::vector<BodyId> ids;
  for (int k = 0; k < 4; ++k) {
    const double x = k < 3 ? k * 0.051 : 3 * 0.051 + 0.004;  // the fourth is 5 mm from the third
    ids.push_back(FloorAndBlock::add_block(world, std::string(1, static_cast<char>('a' + k)), Vec3(x, 0, 0.5)));
  }
  auto set_asleep = [&](int k, bool asleep) {
    Body& b = world.body(ids[static_cast<size_t>(k)]);
    b.sleep.rest_anchor = b.positions;
    b.sleep.sleeping = asleep;
    b.sleep.resting = true;
    Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
    for (const Vec3& x : b.positions) {
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
    b.sleep.box_lo = lo;
    b.sleep.box_hi = hi;
  };
  const std::vector<VertexInTet> none;  // no vertex inside another body
  for (const bool left_ball : {false, true}) {
    set_asleep(0, true);
    set_asleep(1, false);
    set_asleep(2, true);
    set_asleep(3, true);
    world.body(ids[1]).sleep.resting = !left_ball;
    const int woken = wake_touched_bodies(world.bodies(), none, world.settings().sleep);
    EXPECT_EQ(woken, left_ball ? 2 : 0);
    EXPECT_EQ(world.body(ids[0]).is_sleeping(), !left_ball);
    EXPECT_EQ(world.body(ids[2]).is_sleeping(), !left_ball);
    // Body 3 is 4 mm beyond body 2's box (margin 2 mm): not near the mover, and body 2's waking
    // does not pass on to it.
    EXPECT_TRUE(world.body(ids[3]).is_sleeping());
    // A woken body keeps its anchor: it is at rest where it slept, not a mover.
    if (left_ball) {
      EXPECT_TRUE(world.body(ids[2]).sleep.resting);
    }
  }
}


// SleepSettings::wake_on_centre_motion (session 12, opt-in), on hand-set states as above: the
// middle of three blocks 1 mm apart is awake and both neighbours sleep. Turned in place about its
// centre of mass by 0.05 rad, its corners (35 mm out) move 1.8 mm, out of its 1 mm rest ball, while
// its centre stays: the default rule wakes both neighbours, the centre rule neither (and the body
// still cannot fall asleep: its rest restarts). Moved 1.5 mm, its centre leaves the ball and both
// wake. A drift in small steps is caught once it adds up: 0.6 mm, a turn (which restarts its rest
// ball there), 0.6 mm again: inside its new rest ball, so the default rule wakes nobody, but 1.2 mm
// from where it last woke its neighbours, so the centre rule wakes both.
TEST(Sleeping, CentreMotionWakesTheNeighboursOnlyWhenTheCentreMoves) {
  for (const bool centre_rule : {false, true}) {
    WorldSettings settings = sleep_on();
    settings.sleep.wake_on_centre_motion = centre_rule;
    World world(settings);
    std::vector<BodyId> ids;
    for (int k = 0; k < 3; ++k) {
      ids.push_back(FloorAndBlock::add_block(world, std::string(1, static_cast<char>('a' + k)), Vec3(k * 0.051, 0, 0.5)));
    }
    Body& mover = world.body(ids[1]);
    const double r = settings.sleep.rest_distance();
    auto put_neighbours_to_sleep = [&] {
      for (int k : {0, 2}) {
        Body& b = world.body(ids[static_cast<size_t>(k)]);
        b.sleep.rest_anchor = b.positions;
        b.sleep.sleeping = true;
        b.sleep.resting = true;
        b.sleep.box_lo = b.positions[0];
        b.sleep.box_hi = b.positions[0];
        for (const Vec3& x : b.positions) {
          b.sleep.box_lo = b.sleep.box_lo.cwiseMin(x);
          b.sleep.box_hi = b.sleep.box_hi.cwiseMax(x);
        }
      }
    };
    const std::vector<VertexInTet> none;
    // One step of the rule: update the mover's rest (and wake centre), then wake from its motion.
    auto step_rule = [&] {
      put_neighbours_to_sleep();
      update_sleep(world.bodies(), kDt, world.settings().sleep, {}, false);
      return wake_touched_bodies(world.bodies(), none, world.settings().sleep);
    };
    auto centre = [&] {
      Vec3 c = Vec3::Zero();
      double m = 0.0;
      for (size_t v = 0; v < mover.positions.size(); ++v) {
        c += mover.masses[v] * mover.positions[v];
        m += mover.masses[v];
      }
      return Vec3(c / m);
    };
    auto turn = [&](double angle) {
      const Vec3 c = centre();
      const Eigen::Matrix3d rot = Eigen::AngleAxisd(angle, Vec3::UnitZ()).toRotationMatrix();
      for (Vec3& x : mover.positions) x = c + rot * (x - c);
      EXPECT_LT((centre() - c).norm(), 1e-12);
    };
    auto shift = [&](double dy) {
      for (Vec3& x : mover.positions) x.y() += dy;
    };
    step_rule();     // the first look at the mover starts its rest ball (a new body counts as moving)
    step_rule();     // at rest, nobody woken
    ASSERT_TRUE(mover.sleep.resting);
    EXPECT_EQ(step_rule(), 0);
    turn(0.05);
    EXPECT_EQ(step_rule(), centre_rule ? 0 : 2) << "turned in place";
    EXPECT_FALSE(mover.sleep.resting) << "it left its rest ball, so it does not rest";
    EXPECT_EQ(mover.sleep.rest_time, 0.0);
    shift(1.5 * r);
    EXPECT_EQ(step_rule(), 2) << "centre moved 1.5 r";
    shift(0.6 * r);
    EXPECT_EQ(step_rule(), 0) << "0.6 r: inside both balls";
    turn(-0.05);
    EXPECT_EQ(step_rule(), centre_rule ? 0 : 2) << "turned back in place";
    shift(0.6 * r);
    EXPECT_EQ(step_rule(), centre_rule ? 2 : 0) << "drift of 1.2 r since it last woke its neighbours";
    EXPECT_TRUE(mover.sleep.resting) << "0.6 r inside the rest ball restarted at the turn";
  }
}

// With the centre rule a block landing on a sleeping one still wakes it in the step of first
// contact (the closed-form fall time, as WakesInTheStepAnotherBodyLandsOnIt): a falling body's
// centre leaves its ball every step.
TEST(Sleeping, CentreMotionStillWakesTheBlockALandingBlockHits) {
  WorldSettings settings = sleep_on();
  settings.sleep.wake_on_centre_motion = true;
  FloorAndBlock s(settings);
  const Landing landing = drop_a_block_on_the_sleeping_one(s);
  ASSERT_GT(landing.woken_at, 0) << "the lower block never slept or never woke";
  EXPECT_NEAR(landing.woken_at * kDt, std::sqrt(2 * 0.03 / 9.81), 0.006);
}


// Session 13: a sleeper's kinetic and gravitational energy are computed once and reused while it
// sleeps (SleepState::has_frozen_energy). Reference: the sums over the block's state written out
// here (m v^2 / 2 and -m g.(x - x0), x0 its positions when it was added), at every step while it
// sleeps, after gravity is changed under it, and after it was woken by a landing block and fell
// asleep again lower down (a cache kept across the wake would report the first sleep's energy).
struct FrozenEnergy {
  double kinetic = 0.0, gravitational = 0.0;
};
FrozenEnergy energy_by_hand(const Body& b, const std::vector<Vec3>& x0, const Vec3& gravity) {
  FrozenEnergy e;
  for (size_t v = 0; v < b.positions.size(); ++v) {
    e.kinetic += 0.5 * b.masses[v] * b.velocities[v].squaredNorm();
    e.gravitational -= b.masses[v] * gravity.dot(b.positions[v] - x0[v]);
  }
  return e;
}

TEST(Sleeping, ASleepersReportedEnergiesAreTheSumsOverItsFrozenState) {
  FloorAndBlock s(sleep_on());
  const std::vector<Vec3> x0 = s.world.body(s.block).positions;
  ASSERT_TRUE(step_until_asleep(s.world, s.block, 3000).has_value());
  auto expect_report_is_the_sum = [&](const char* when) {
    const FrozenEnergy hand = energy_by_hand(s.world.body(s.block), x0, s.world.settings().gravity);
    const EnergyReport& r = s.world.last_report().body_energy[s.block.index];
    EXPECT_EQ(r.kinetic, hand.kinetic) << when;
    EXPECT_EQ(r.gravitational, hand.gravitational) << when;
    EXPECT_EQ(s.world.last_report().energy.gravitational, hand.gravitational) << when;  // the only deformable body
  };
  // (The report of the step it fell asleep in still has the velocities update_sleep then zeroed.)
  const double first_sleep = s.world.last_report().body_energy[s.block.index].gravitational;
  for (int i = 0; i < 50; ++i) {
    s.world.step(kDt);
    ASSERT_TRUE(s.world.body(s.block).is_sleeping());
    expect_report_is_the_sum("asleep");
  }
  // Gravity changed under a sleeper (it stays asleep: no force of its own): the cache follows.
  s.world.settings().gravity = Vec3(0.0, 0.0, -4.0);
  s.world.step(kDt);
  ASSERT_TRUE(s.world.body(s.block).is_sleeping());
  expect_report_is_the_sum("after gravity changed");
  EXPECT_NE(s.world.last_report().body_energy[s.block.index].gravitational, first_sleep);
  s.world.settings().gravity = Vec3(0.0, 0.0, -9.81);
  // Woken by a landing block, then asleep again under its weight: a new frozen state.
  const BodyId top = FloorAndBlock::add_block(s.world, "top", Vec3(0.01, 0, 0.05 + 0.01 + 0.025));
  const std::vector<Vec3> top_x0 = s.world.body(top).positions;
  bool woke = false;
  for (int i = 0; i < 4000 && !(woke && s.world.body(s.block).is_sleeping()); ++i) {
    s.world.step(kDt);
    woke = woke || !s.world.body(s.block).is_sleeping();
  }
  ASSERT_TRUE(woke && s.world.body(s.block).is_sleeping()) << "the block did not wake and fall asleep again";
  for (int i = 0; i < 20; ++i) s.world.step(kDt);
  ASSERT_TRUE(s.world.body(s.block).is_sleeping());
  const FrozenEnergy hand = energy_by_hand(s.world.body(s.block), x0, s.world.settings().gravity);
  EXPECT_EQ(s.world.last_report().body_energy[s.block.index].gravitational, hand.gravitational);
  EXPECT_EQ(s.world.last_report().body_energy[s.block.index].kinetic, 0.0);
  EXPECT_NE(hand.gravitational, first_sleep);  // it lies lower under the top block
  const FrozenEnergy top_hand = energy_by_hand(s.world.body(top), top_x0, s.world.settings().gravity);
  EXPECT_EQ(s.world.last_report().body_energy[top.index].gravitational, top_hand.gravitational);
}

// Session 13: with every body resting (the block asleep, the floor a still fixture) detection is
// skipped (nothing_moves). The floor then rising 1 mm into the block's lowest face must be detected
// and wake it in that very step, as a moving fixture always did.
TEST(Sleeping, AFixtureRisingIntoAFullyAsleepWorldWakesTheBlockItReaches) {
  FloorAndBlock s(sleep_on());
  ASSERT_TRUE(step_until_asleep(s.world, s.block, 3000).has_value());
  for (int i = 0; i < 10; ++i) {
    const StepReport& r = s.world.step(kDt);
    EXPECT_TRUE(nothing_moves(std::vector<Body*>{&s.world.body(s.floor), &s.world.body(s.block)}));
    EXPECT_EQ(r.colliding_vertices, 0);
    EXPECT_EQ(r.bodies_woken, 0);
  }
  ASSERT_LT(min_z(s.world.body(s.block)), 0.0005);  // resting within 0.5 mm of the floor's top
  s.world.body(s.floor).target_pose.translation += Vec3(0, 0, 0.001);
  const StepReport& r = s.world.step(kDt);
  EXPECT_GT(r.colliding_vertices, 0);
  EXPECT_EQ(r.bodies_woken, 1);
  EXPECT_FALSE(s.world.body(s.block).is_sleeping());
}

// sleep.rest_by_centre_when_supported (session 14, opt-in): a clamped slab whose surface vertices
// churn in place (two top corners pushed apart, each by at least 3 r with equal mass x distance,
// and back every other step: a vertex leaves the rest ball of radius r at every push, the centre of
// mass does not move) under
// a sleeping block is supported and rests by its centre, so it falls asleep after `time` (200
// steps of 1 ms, the hand count: the first look anchors the rest, each later one adds dt); the
// vertex rule (the default) never lets it; under an awake block it is not supported and stays
// awake; asleep, it wakes in the step a moving block touches it.
TEST(Sleeping, AClampedSlabChurningUnderASleeperRestsByItsCentreOnlyWhenSupported) {
  const std::vector<VertexInTet> block_on_slab{{.body = 1, .vertex = 0, .penetrated_body = 0, .tet = 0}};
  for (const bool rule : {false, true}) {
    for (const bool block_asleep : {true, false}) {
      WorldSettings settings = sleep_on();
      settings.sleep.rest_by_centre_when_supported = rule;
      World world(settings);
      BodyDef slab_def{.name = "slab", .mesh = make_box_mesh({Vec3(0.2, 0.2, 0.01), 4, 4, 1}),
                       .material = block_material()};
      for (int v = 0; v < slab_def.mesh->vertex_count(); ++v) {
        if (slab_def.mesh->rest_positions()[static_cast<size_t>(v)].z() < -0.0049) slab_def.fixed_vertices.push_back(v);
      }
      const BodyId slab_id = world.add_body(slab_def);
      const BodyId block_id = FloorAndBlock::add_block(world, "block", Vec3(0, 0, 0.0305));
      Body& slab = world.body(slab_id);
      Body& block = world.body(block_id);
      block.sleep.sleeping = block_asleep;
      // Two top corners on a diagonal, pushed apart with equal mass x distance: the centre of mass
      // stays where it was.
      int lo = -1, hi = -1;
      for (int v = 0; v < slab.vertex_count(); ++v) {
        const Vec3& x = slab.positions[static_cast<size_t>(v)];
        if (x.z() > 0.0049 && x.x() < -0.0999 && x.y() < -0.0999) lo = v;
        if (x.z() > 0.0049 && x.x() > 0.0999 && x.y() > 0.0999) hi = v;
      }
      ASSERT_GE(lo, 0);
      ASSERT_GE(hi, 0);
      const double m_lo = slab.masses[static_cast<size_t>(lo)], m_hi = slab.masses[static_cast<size_t>(hi)];
      const double push_lo = 3.0 * settings.sleep.rest_distance() * std::max(1.0, m_hi / m_lo);
      const double push_hi = push_lo * m_lo / m_hi;
      ASSERT_GE(std::min(push_lo, push_hi), 3.0 * settings.sleep.rest_distance() * (1 - 1e-12));
      std::optional<int> slept_at;
      for (int step = 1; step <= 400 && !slept_at; ++step) {
        const double sign = step % 2 == 1 ? 1.0 : -1.0;  // out, back, out, ...
        slab.positions[static_cast<size_t>(lo)].x() -= sign * push_lo;
        slab.positions[static_cast<size_t>(hi)].x() += sign * push_hi;
        const int supported = note_supported_bodies(world.bodies(), block_on_slab, {});
        EXPECT_EQ(slab.sleep.supported, block_asleep) << "step " << step;
        EXPECT_EQ(supported, 1) << "the slab under the sleeper, or the awake block on the clamped slab";
        update_sleep(world.bodies(), kDt, world.settings().sleep, {}, false);
        block.sleep.sleeping = block_asleep;  // update_sleep runs the block's rule too: keep it as set
        if (slab.is_sleeping()) slept_at = step;
      }
      SCOPED_TRACE(std::string("rule ") + (rule ? "on" : "off") + ", block " + (block_asleep ? "asleep" : "awake"));
      if (rule && block_asleep) {
        ASSERT_TRUE(slept_at.has_value());
        EXPECT_GE(*slept_at, 201);
        EXPECT_LE(*slept_at, 202);  // 200 sums of 1 ms may round below 0.2 s
        // A block that moves (it left its rest ball) and touches the slab wakes it in that step.
        block.sleep.sleeping = false;
        block.sleep.resting = false;
        EXPECT_EQ(wake_touched_bodies(world.bodies(), block_on_slab, world.settings().sleep), 1);
        EXPECT_FALSE(slab.is_sleeping());
      } else {
        EXPECT_FALSE(slept_at.has_value()) << "slept at step " << slept_at.value_or(-1);
      }
    }
  }
}

}  // namespace
}  // namespace pliant
