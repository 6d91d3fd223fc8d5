// The deformation region's comparison partners (paper Eq. 2) in their deterministic order: the
// (owner, partner, weight) triples of stage 3 sorted by (owner, partner) with std::sort, the code
// before session 12's counting sort. Random contact sets between two boxes, with and without a
// vertex that has two contacts on triangles sharing a vertex (two equal keys, whose order only
// std::sort itself gives), and with colliding vertices that have no partner (the fallback).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <tuple>
#include <vector>

#include "sim/contact/deformation_region.h"
#include "sim/mesh/box_mesh.h"
#include "sim/world.h"

namespace pliant {
namespace {

struct Triple {
  int owner, partner;
  double weight;
};

// The triples build() makes (Eq. 1's contact triangles, then the fallback of section 4.4.3),
// sorted as before session 12.
std::vector<Triple> reference_triples(const DeformationRegion& region, std::span<const VertexContact> contacts,
                                      bool& fallback) {
  std::vector<Triple> triples;
  for (size_t c = 0; c < contacts.size(); ++c) {
    const auto& tri = region.contact_triangle_vertices(c);
    for (int k = 0; k < 3; ++k) {
      const double w = contacts[c].contact_barycentric[k];
      if (w > 0.0) triples.push_back({tri[static_cast<size_t>(k)], region.contact_vertex(c), w});
    }
  }
  const size_t direct = triples.size();
  std::vector<char> has_partner(region.vertices().size(), 0);
  for (const auto& t : triples) has_partner[static_cast<size_t>(t.owner)] = 1;
  for (size_t c = 0; c < contacts.size(); ++c) {
    const int x = region.contact_vertex(c);
    if (has_partner[static_cast<size_t>(x)] != 0) continue;
    for (int k = 0; k < 3; ++k) {
      const double b = contacts[c].contact_barycentric[k];
      if (b > 0.0) triples.push_back({x, region.contact_triangle_vertices(c)[static_cast<size_t>(k)], b});
    }
  }
  fallback = triples.size() > direct;
  std::sort(triples.begin(), triples.end(), [](const Triple& a, const Triple& b) {
    return a.owner != b.owner ? a.owner < b.owner : a.partner < b.partner;
  });
  return triples;
}

TEST(DeformationRegionPartners, AreStdSortsOrderOfTheTriplesWithAndWithoutEqualKeys) {
  World world{WorldSettings{.gravity = Vec3::Zero()}};
  const auto mesh = make_box_mesh({Vec3(0.1, 0.1, 0.04), 6, 6, 2});
  const BodyId a = world.add_body(BodyDef{.name = "a", .mesh = mesh});
  const BodyId b = world.add_body(BodyDef{.name = "b", .mesh = mesh});
  std::vector<Body*> bodies{&world.body(a), &world.body(b)};
  const auto& triangles = mesh->surface_triangles();
  std::mt19937 rng(12);
  std::uniform_int_distribution<size_t> triangle(0, triangles.size() - 1);
  std::uniform_int_distribution<int> corner(0, 2), count(1, 40);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  DeformationRegion region;  // reused, as the response reuses it step after step
  int equal_key_sets = 0, fallback_sets = 0;
  for (int set = 0; set < 400; ++set) {
    std::vector<VertexContact> contacts;
    const int n = count(rng);
    for (int i = 0; i < n; ++i) {
      VertexContact c;
      const bool from_a = unit(rng) < 0.7;
      c.body = from_a ? 0 : 1;
      c.penetrated_body = from_a ? 1 : 0;
      c.vertex = triangles[triangle(rng)][static_cast<size_t>(corner(rng))];
      c.contact_triangle = static_cast<int>(triangle(rng));
      Vec3 w(unit(rng), unit(rng), unit(rng));
      if (unit(rng) < 0.3) w[corner(rng)] = 0.0;  // on an edge
      c.contact_barycentric = w / w.sum();
      c.penetration_depth = 1e-3 * unit(rng);
      c.penetration_direction = Vec3(unit(rng) - 0.5, unit(rng) - 0.5, 1.0).normalized();
      contacts.push_back(c);
      if (set % 2 == 0 && unit(rng) < 0.2) {
        // The same vertex on a triangle sharing a vertex: the owner gets this vertex twice.
        VertexContact twin = c;
        const int shared = triangles[static_cast<size_t>(c.contact_triangle)][0];
        for (size_t t = 0; t < triangles.size(); ++t) {
          const auto& tri = triangles[t];
          if (static_cast<int>(t) != c.contact_triangle && std::find(tri.begin(), tri.end(), shared) != tri.end()) {
            twin.contact_triangle = static_cast<int>(t);
            break;
          }
        }
        twin.contact_barycentric = Vec3(0.2 + 0.6 * unit(rng), 0.1, 0.1).normalized();
        contacts.push_back(twin);
      }
    }
    region.build(bodies, contacts);
    bool fallback = false;
    const std::vector<Triple> expected = reference_triples(region, contacts, fallback);
    std::vector<std::tuple<int, int>> keys;
    for (const auto& t : expected) keys.emplace_back(t.owner, t.partner);
    equal_key_sets += std::adjacent_find(keys.begin(), keys.end()) != keys.end() ? 1 : 0;
    // Each region vertex's partners are its run of the sorted triples, weights bit for bit.
    size_t next = 0;
    for (size_t i = 0; i < region.vertices().size(); ++i) {
      const auto& v = region.vertices()[i];
      for (const ComparisonPartner& p : region.partners_of(v)) {
        ASSERT_LT(next, expected.size()) << "set " << set;
        EXPECT_EQ(expected[next].owner, static_cast<int>(i)) << "set " << set;
        EXPECT_EQ(expected[next].partner, p.region_vertex) << "set " << set;
        EXPECT_EQ(expected[next].weight, p.weight) << "set " << set;
        ++next;
      }
    }
    EXPECT_EQ(next, expected.size()) << "set " << set;
    fallback_sets += fallback ? 1 : 0;
  }
  // The cases the test is for did occur.
  EXPECT_GT(equal_key_sets, 20);
  EXPECT_GT(fallback_sets, 20);
}

}  // namespace
}  // namespace pliant
