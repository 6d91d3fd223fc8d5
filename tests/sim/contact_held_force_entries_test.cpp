// The held contact forces are cleared entry by entry between steps (session 9: only the vertices
// last step's held contacts wrote, not every vertex of every body; docs/contact-surface.md
// "Response time, session 9"). Reference: the held contacts themselves. After every step the held
// force array of each body may be non-zero only at a held contact's colliding vertex (its own
// body) or at a vertex of that contact's triangle (the penetrated body); a stale entry of a
// contact that ended would break this. Two free blocks landing on a kinematic floor, friction and
// the held-force release on (the release writes the same entries), so the contact set changes.
#include <gtest/gtest.h>

#include <set>
#include <utility>
#include <vector>

#include "sim/contact/contact_surface_response.h"
#include "sim/world.h"
#include "support/block_stack.h"

namespace pliant {
namespace {

TEST(ContactHeldForceEntries, NonZeroOnlyAtTheHeldContactsVertices) {
  WorldSettings settings;
  settings.contact.method = ContactMethod::none;  // the test applies the response itself
  World world(settings);
  ContactSettings contact;
  contact.held_force_fraction = 1.0;
  contact.friction = true;
  contact.finishing_projection = true;
  contact.held_force_release = true;
  const std::vector<BodyId> ids = add_block_stack(world, 2, 0.5);
  ContactSurfaceResponse response;
  const double dt = 1e-3;
  int steps_with_held = 0, contact_sets_changed = 0;
  std::set<std::pair<int, int>> previous;  // (body, vertex) of the last step's held contacts
  for (int i = 1; i <= 300; ++i) {
    world.step(dt);
    if (!world.contacts().empty() || response.has_held_contacts()) {
      StepReport report;
      response.respond(world.bodies(), world.contacts(), dt, contact, report);
    }
    // Where the held contacts may have written.
    std::set<std::pair<int, int>> allowed, colliding;
    for (const VertexContact& c : response.held_contacts()) {
      allowed.insert({c.body, c.vertex});
      colliding.insert({c.body, c.vertex});
      const Body& n = *world.bodies()[static_cast<size_t>(c.penetrated_body)];
      for (int v : n.mesh->surface_triangles()[static_cast<size_t>(c.contact_triangle)]) allowed.insert({c.penetrated_body, v});
    }
    if (colliding != previous) ++contact_sets_changed;
    previous = colliding;
    bool any = false;
    for (BodyId id : ids) {
      Body& b = world.body(id);
      std::fill(b.applied_forces.begin(), b.applied_forces.end(), Vec3::Zero());
      response.take_held_forces(b, b.applied_forces);  // the next integration adds them
      const int slot = [&] {
        for (size_t k = 0; k < world.bodies().size(); ++k) {
          if (world.bodies()[k] == &b) return static_cast<int>(k);
        }
        return -1;
      }();
      for (size_t v = 0; v < b.applied_forces.size(); ++v) {
        if (b.applied_forces[v] == Vec3::Zero()) continue;
        any = true;
        EXPECT_TRUE(allowed.count({slot, static_cast<int>(v)}) == 1) << "step " << i << ", body " << slot << ", vertex " << v;
      }
    }
    if (any) ++steps_with_held;
  }
  // The check had something to look at: held forces on most steps, a contact set that changed.
  EXPECT_GT(steps_with_held, 100);
  EXPECT_GT(contact_sets_changed, 5);
}

}  // namespace
}  // namespace pliant
