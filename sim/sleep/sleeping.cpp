#include "sim/sleep/sleeping.h"

#include <algorithm>
#include <cmath>


namespace pliant {

namespace {

// A body that cannot set another in motion this step (an instrument always can: it presses).
bool is_resting(const Body* body) {
  if (body == nullptr) return true;
  if (body->instrument) return false;
  return body->is_kinematic() ? !body->moved_this_step : body->is_sleeping();
}

bool has_applied_force(const Body& body) {
  return std::any_of(body.applied_forces.begin(), body.applied_forces.end(),
                     [](const Vec3& f) { return f.squaredNorm() > 0.0; });
}

struct Box {
  Vec3 lo = Vec3::Constant(INFINITY);
  Vec3 hi = Vec3::Constant(-INFINITY);
  bool overlaps(const Box& o, double margin) const {
    return (lo.array() <= o.hi.array() + margin).all() && (o.lo.array() <= hi.array() + margin).all();
  }
};

Box bounds(const Body& body) {
  Box b;
  for (const Vec3& x : body.positions) {
    b.lo = b.lo.cwiseMin(x);
    b.hi = b.hi.cwiseMax(x);
  }
  return b;
}

// Every vertex within the rest ball around the rest's anchor (which must exist).
bool within_rest_distance(const Body& body, const SleepSettings& settings) {
  const auto& anchor = body.sleep.rest_anchor;
  const double r2 = settings.rest_distance() * settings.rest_distance();
  for (size_t v = 0; v < anchor.size(); ++v) {
    if ((body.positions[v] - anchor[v]).squaredNorm() > r2) return false;
  }
  return true;
}

// Mass-weighted mean of `x` over the body's lumped masses.
Vec3 centre_of_mass(const Body& body, const std::vector<Vec3>& x) {
  Vec3 sum = Vec3::Zero();
  double mass = 0.0;
  for (size_t v = 0; v < x.size(); ++v) {
    sum += body.masses[v] * x[v];
    mass += body.masses[v];
  }
  return sum / mass;
}

Vec3 centre_of_mass(const Body& body) { return centre_of_mass(body, body.positions); }

// rest_by_centre_when_supported: the centre within the rest ball's radius of the anchor's centre.
bool centre_within_rest_distance(const Body& body, const SleepSettings& settings) {
  return (centre_of_mass(body) - centre_of_mass(body, body.sleep.rest_anchor)).norm() <= settings.rest_distance();
}

// Held to the world by at least one fixed vertex.
bool is_clamped(const Body& body) {
  return std::any_of(body.fixed.begin(), body.fixed.end(), [](char f) { return f != 0; });
}

// A partner that does not move on its own: asleep, a fixture, or clamped (awake or not).
bool is_support(const Body& body) {
  if (body.is_kinematic()) return !body.instrument;
  return body.is_sleeping() || is_clamped(body);
}

// wake_on_centre_motion: whether the centre of mass left the ball around where the body last woke
// its neighbours (a new body counts as moved). The anchor moves only when the body wakes them, so
// a drift in small steps is caught once it adds up to the ball's radius.
void note_centre_motion(Body& body, const SleepSettings& settings) {
  SleepState& sleep = body.sleep;
  const Vec3 centre = centre_of_mass(body);
  sleep.centre_moved = !sleep.has_wake_centre || (centre - sleep.wake_centre).norm() > settings.rest_distance();
  if (sleep.centre_moved) {
    sleep.wake_centre = centre;
    sleep.has_wake_centre = true;
  }
}

}  // namespace

void filter_resting_pairs(std::span<Body* const> bodies, CollisionFilter& filter) {
  const int n = static_cast<int>(bodies.size());
  for (int a = 0; a < n; ++a) {
    if (!is_resting(bodies[static_cast<size_t>(a)])) continue;
    for (int b = a; b < n; ++b) {
      if (is_resting(bodies[static_cast<size_t>(b)])) filter.set(a, b, false);
    }
  }
}

bool nothing_moves(std::span<Body* const> bodies) {
  return std::all_of(bodies.begin(), bodies.end(), is_resting);
}

int note_instrument_contacts(std::span<Body* const> bodies, const std::vector<VertexInTet>& colliding,
                             std::span<const VertexContact> held) {
  for (Body* b : bodies) {
    if (b != nullptr) b->sleep.instrument_contact = false;
  }
  int marked = 0;
  auto mark_pair = [&](int a, int b) {
    Body* first = bodies[static_cast<size_t>(a)];
    Body* second = bodies[static_cast<size_t>(b)];
    if (first == nullptr || second == nullptr) return;  // a held contact with a removed body
    for (Body* touched : {first, second}) {
      const Body* other = touched == first ? second : first;
      if (!other->instrument || touched->is_kinematic() || touched->sleep.instrument_contact) continue;
      touched->sleep.instrument_contact = true;
      ++marked;
    }
  };
  for (const VertexInTet& c : colliding) mark_pair(c.body, c.penetrated_body);
  for (const VertexContact& c : held) {
    if (c.body < 0 || c.penetrated_body < 0) continue;
    if (static_cast<size_t>(c.body) >= bodies.size() || static_cast<size_t>(c.penetrated_body) >= bodies.size()) {
      continue;
    }
    mark_pair(c.body, c.penetrated_body);
  }
  return marked;
}

int note_supported_bodies(std::span<Body* const> bodies, const std::vector<VertexInTet>& colliding,
                          std::span<const VertexContact> held) {
  // Per slot: 1 has a support partner, 2 has a partner that is none (2 wins).
  std::vector<char> seen(bodies.size(), 0);
  auto note_pair = [&](int a, int b) {
    if (a == b || a < 0 || b < 0) return;
    if (static_cast<size_t>(a) >= bodies.size() || static_cast<size_t>(b) >= bodies.size()) return;
    const Body* first = bodies[static_cast<size_t>(a)];
    const Body* second = bodies[static_cast<size_t>(b)];
    if (first == nullptr || second == nullptr) return;  // a held contact with a removed body
    seen[static_cast<size_t>(a)] = std::max<char>(seen[static_cast<size_t>(a)], is_support(*second) ? 1 : 2);
    seen[static_cast<size_t>(b)] = std::max<char>(seen[static_cast<size_t>(b)], is_support(*first) ? 1 : 2);
  };
  for (const VertexInTet& c : colliding) note_pair(c.body, c.penetrated_body);
  for (const VertexContact& c : held) note_pair(c.body, c.penetrated_body);
  int supported = 0;
  for (size_t i = 0; i < bodies.size(); ++i) {
    Body* b = bodies[i];
    if (b == nullptr || b->is_kinematic()) continue;
    b->sleep.supported = !b->is_sleeping() && seen[i] != 2 && (seen[i] == 1 || is_clamped(*b));
    if (b->sleep.supported) ++supported;
  }
  return supported;
}

void wake_body(Body& body) {
  body.sleep.sleeping = false;
  // Its rest goes on around the anchor it slept at (its positions have not changed since): it
  // counts as moving, and wakes its sleeping neighbours, only once it leaves that ball.
  body.sleep.resting = body.sleep.rest_anchor.size() == body.positions.size();
  body.sleep.rest_time = 0.0;
  body.sleep.has_elastic_energy = false;
  body.sleep.has_frozen_energy = false;
  body.sleep.centre_moved = false;  // likewise for wake_on_centre_motion: its centre has not moved
}

int wake_touched_bodies(std::span<Body* const> bodies, const std::vector<VertexInTet>& colliding,
                        const SleepSettings& settings) {
  // An awake deformable body moves unless it stayed inside its rest ball in its last step (or,
  // wake_on_centre_motion, unless its centre stayed within the ball's radius of its wake centre).
  auto moves = [&](int index) {
    const Body* b = bodies[static_cast<size_t>(index)];
    if (b == nullptr || b->is_sleeping()) return false;
    if (b->is_kinematic()) return b->instrument || b->moved_this_step;
    return settings.wake_on_centre_motion ? b->sleep.centre_moved : !b->sleep.resting;
  };
  int woken = 0;
  auto wake = [&](int index) {
    Body* b = bodies[static_cast<size_t>(index)];
    if (b == nullptr || !b->is_sleeping()) return;
    wake_body(*b);
    ++woken;
  };
  for (const VertexInTet& c : colliding) {
    const Body* a = bodies[static_cast<size_t>(c.body)];
    const Body* p = bodies[static_cast<size_t>(c.penetrated_body)];
    if (a->is_sleeping() && moves(c.penetrated_body)) wake(c.body);
    if (p->is_sleeping() && moves(c.body)) wake(c.penetrated_body);
  }
  // A contact that still holds a force with an instrument wakes a body too (it may show no overlap).
  for (size_t i = 0; i < bodies.size(); ++i) {
    const Body* b = bodies[i];
    if (b != nullptr && b->sleep.instrument_contact) wake(static_cast<int>(i));
  }
  // A deformable body that left its rest ball wakes the sleepers near it, touching or not (a body
  // lying on one that moves away must not hover). Not transitively: a woken body wakes its own
  // neighbours only once it leaves its ball in turn (before session 5 waking spread at once to
  // every sleeper whose box overlapped a woken one, which in a pile woke the whole pile whenever
  // any fruit moved: docs/experiments.md "Session 5").
  const auto asleep = [](const Body* b) { return b != nullptr && b->is_sleeping(); };
  if (std::none_of(bodies.begin(), bodies.end(), asleep)) return woken;
  for (size_t i = 0; i < bodies.size(); ++i) {
    const Body* mover = bodies[i];
    if (mover == nullptr || mover->is_kinematic() || !moves(static_cast<int>(i))) continue;
    const Box box = bounds(*mover);
    for (size_t s = 0; s < bodies.size(); ++s) {
      const Body* b = bodies[s];
      if (!asleep(b)) continue;
      const Box sleeper{b->sleep.box_lo, b->sleep.box_hi};
      if (box.overlaps(sleeper, settings.wake_margin)) wake(static_cast<int>(s));
    }
  }
  return woken;
}

int update_sleep(std::span<Body* const> bodies, double dt, const SleepSettings& settings,
                 std::span<const EnergyReport> body_energy, bool has_energy) {
  int asleep = 0;
  for (size_t i = 0; i < bodies.size(); ++i) {
    Body* body = bodies[i];
    if (body == nullptr || body->is_kinematic()) continue;
    SleepState& sleep = body->sleep;
    const bool pushed = has_applied_force(*body);
    if (pushed && sleep.sleeping) wake_body(*body);
    if (sleep.sleeping) {
      ++asleep;
      continue;
    }
    const bool begun = sleep.rest_anchor.size() == body->positions.size();
    const bool by_centre = settings.rest_by_centre_when_supported && sleep.supported;
    sleep.resting = begun && (by_centre ? centre_within_rest_distance(*body, settings)
                                        : within_rest_distance(*body, settings));
    if (sleep.resting) {
      sleep.rest_time += dt;
    } else {
      // New, woken, or a vertex left the ball: a rest begins here.
      sleep.rest_time = 0.0;
      sleep.rest_anchor = body->positions;  // reuses its capacity
    }
    if (settings.wake_on_centre_motion) note_centre_motion(*body, settings);
    if (sleep.instrument_contact || pushed) sleep.rest_time = 0.0;  // under an instrument or a force: awake
    if (sleep.rest_time >= settings.time) {
      sleep.sleeping = true;
      const Box box = bounds(*body);  // kept: a sleeper's positions do not change
      sleep.box_lo = box.lo;
      sleep.box_hi = box.hi;
      for (Vec3& v : body->velocities) v.setZero();
      sleep.has_elastic_energy = has_energy;
      sleep.elastic_energy = has_energy && i < body_energy.size() ? body_energy[i].elastic : 0.0;
      ++asleep;
    }
  }
  return asleep;
}

}  // namespace pliant
