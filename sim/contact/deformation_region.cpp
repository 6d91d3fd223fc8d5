#include "sim/contact/deformation_region.h"

#include <algorithm>
#include <cmath>

namespace pliant {

VertexAreas vertex_areas(const Body& body, int vertex, const Vec3& displacement) {
  const TetMesh& mesh = *body.mesh;
  const double len = displacement.norm();
  const Vec3 dir = len > 0.0 ? Vec3(displacement / len) : Vec3::Zero();
  double projected = 0.0, total = 0.0;
  for (int t : mesh.vertex_surface_triangles(vertex)) {
    const auto& tri = mesh.surface_triangles()[static_cast<size_t>(t)];
    const Vec3& a = body.positions[static_cast<size_t>(tri[0])];
    const Vec3 n = (body.positions[static_cast<size_t>(tri[1])] - a).cross(body.positions[static_cast<size_t>(tri[2])] - a);
    total += 0.5 * n.norm();
    // facing * area = -(n / |n|) . dir * |n| / 2
    const double facing_area = -0.5 * n.dot(dir);
    if (facing_area > 0.0) projected += facing_area;
  }
  VertexAreas areas;
  areas.unprojected = total / 3.0;
  areas.comparison = projected > 0.0 ? projected / 3.0 : areas.unprojected;
  return areas;
}

double comparison_area(const Body& body, int vertex, const Vec3& displacement) {
  return vertex_areas(body, vertex, displacement).comparison;
}

int DeformationRegion::find(int body, int vertex) const {
  const auto b = static_cast<size_t>(body);
  if (b >= index_of_.size() || index_of_[b].empty()) return -1;
  return index_of_[b][static_cast<size_t>(vertex)];
}

int DeformationRegion::add_vertex(std::span<Body* const> bodies, int body, int vertex) {
  auto& map = index_of_[static_cast<size_t>(body)];
  const Body& b = *bodies[static_cast<size_t>(body)];
  if (map.empty()) map.assign(static_cast<size_t>(b.vertex_count()), -1);
  int& slot = map[static_cast<size_t>(vertex)];
  if (slot < 0) {
    slot = static_cast<int>(vertices_.size());
    DisplacementVertex dv;
    dv.body = body;
    dv.vertex = vertex;
    dv.rest_of_step = b.positions[static_cast<size_t>(vertex)];
    dv.immovable = b.is_immovable(vertex);
    vertices_.push_back(dv);
  }
  return slot;
}

void DeformationRegion::sort_triples() {
  auto before = [](const Triple& a, const Triple& b) {
    return a.owner != b.owner ? a.owner < b.owner : a.partner < b.partner;
  };
  // Session 12: the owners are region indices (dense) with a few partners each, so a counting sort
  // by owner and an insertion sort within each owner's run cost O(triples + region) instead of
  // std::sort's ~290 instructions per triple (3% of three cubes' respond stage). Distinct keys have
  // one sorted order, std::sort's included; two equal keys (a vertex with two contacts whose
  // triangles share a vertex) std::sort orders in its own way, and their weights are summed in
  // that order, so then std::sort runs on the untouched triples as before.
  const size_t owners = vertices_.size();
  owner_offsets_.assign(owners + 1, 0);
  for (const Triple& t : triples_) ++owner_offsets_[static_cast<size_t>(t.owner) + 1];
  for (size_t o = 0; o < owners; ++o) owner_offsets_[o + 1] += owner_offsets_[o];
  sorted_triples_.resize(triples_.size());
  for (const Triple& t : triples_) sorted_triples_[static_cast<size_t>(owner_offsets_[static_cast<size_t>(t.owner)]++)] = t;
  bool equal_keys = false;
  for (size_t i = 1; i < sorted_triples_.size() && !equal_keys; ++i) {  // moves only within an owner's run
    const Triple t = sorted_triples_[i];
    size_t j = i;
    for (; j > 0 && before(t, sorted_triples_[j - 1]); --j) sorted_triples_[j] = sorted_triples_[j - 1];
    sorted_triples_[j] = t;
    equal_keys = j > 0 && !before(sorted_triples_[j - 1], t);
  }
  if (equal_keys) {
    std::sort(triples_.begin(), triples_.end(), before);
    return;
  }
  triples_.swap(sorted_triples_);
}

void DeformationRegion::build(std::span<Body* const> bodies, std::span<const VertexContact> contacts,
                              bool weighted) {
  // Forget the previous step's region (only the touched map entries are reset).
  for (const auto& v : vertices_) index_of_[static_cast<size_t>(v.body)][static_cast<size_t>(v.vertex)] = -1;
  vertices_.clear();
  partners_.clear();
  contact_vertex_.clear();
  contact_triangle_.clear();
  index_of_.resize(bodies.size());

  // Eq. 1 numerator and denominator per region vertex, and (owner, partner, weight) triples.
  std::vector<Vec3>& numerator = numerator_;
  std::vector<double>& denominator = denominator_;
  std::vector<Triple>& triples = triples_;
  numerator.clear();
  denominator.clear();
  triples.clear();
  auto grow = [&](int idx) {
    if (static_cast<size_t>(idx) >= numerator.size()) {
      numerator.resize(static_cast<size_t>(idx) + 1, Vec3::Zero());
      denominator.resize(static_cast<size_t>(idx) + 1, 0.0);
    }
  };

  for (const auto& c : contacts) {
    const int x = add_vertex(bodies, c.body, c.vertex);
    grow(x);
    vertices_[static_cast<size_t>(x)].colliding = true;
    const Vec3 d = c.depth_vector();
    numerator[static_cast<size_t>(x)] += d;
    denominator[static_cast<size_t>(x)] += 1.0;
    const Body& n = *bodies[static_cast<size_t>(c.penetrated_body)];
    const auto& tri = n.mesh->surface_triangles()[static_cast<size_t>(c.contact_triangle)];
    std::array<int, 3> tri_region{};
    for (int k = 0; k < 3; ++k) {
      const int y = add_vertex(bodies, c.penetrated_body, tri[static_cast<size_t>(k)]);
      grow(y);
      tri_region[static_cast<size_t>(k)] = y;
      const double w = weighted ? c.contact_barycentric[k] : (c.contact_barycentric[k] > 0.0 ? 1.0 : 0.0);
      numerator[static_cast<size_t>(y)] -= w * d;  // y moves into its own body: -d
      denominator[static_cast<size_t>(y)] += w;
      if (w > 0.0) triples.push_back({y, x, w});  // x lies in y's comparison area (Eq. 2)
    }
    contact_vertex_.push_back(x);
    contact_triangle_.push_back(tri_region);
  }

  // Fallback of section 4.4.3: a colliding vertex with no vertex of the other body in its
  // comparison area compares against the vertices of its own contact triangle.
  std::vector<char>& has_partner = flag_;
  has_partner.assign(vertices_.size(), 0);
  for (const auto& t : triples) has_partner[static_cast<size_t>(t.owner)] = 1;
  for (size_t c = 0; c < contacts.size(); ++c) {
    const int x = contact_vertex_[c];
    if (has_partner[static_cast<size_t>(x)] != 0) continue;
    for (int k = 0; k < 3; ++k) {
      const double b = contacts[c].contact_barycentric[k];
      if (b > 0.0) triples.push_back({x, contact_triangle_[c][static_cast<size_t>(k)], weighted ? b : 1.0});
    }
  }

  // Partners as compressed rows, in a deterministic order.
  sort_triples();
  // Geometric growth (reserve(n) would set the capacity to exactly n, so every step with a region
  // one partner larger than any before would reallocate).
  if (partners_.capacity() < triples.size()) partners_.reserve(2 * triples.size());
  // Session 15: the rows written by index after one resize (push_back's capacity test and end
  // pointer store per triple were ~40% of this loop); the same entries in the same places.
  partners_.resize(triples.size());
  for (size_t i = 0; i < triples.size(); ++i) {
    const Triple& t = triples[i];
    auto& v = vertices_[static_cast<size_t>(t.owner)];
    if (i == 0 || triples[i - 1].owner != t.owner) v.partner_begin = static_cast<int>(i);
    v.partner_count++;
    partners_[i] = {t.partner, t.weight};
  }

  for (size_t i = 0; i < vertices_.size(); ++i) {
    auto& v = vertices_[i];
    if (!v.colliding) denominator[i] += 1.0;  // Eq. 1's "+1" with d = 0
    v.displacement = denominator[i] > 0.0 ? Vec3(numerator[i] / denominator[i]) : Vec3::Zero();
    v.displacement_length = v.displacement.norm();
    // An immovable vertex's pressure is never compared (it does not search, and is not evaluated).
    if (!v.immovable) {
      const Body& b = *bodies[static_cast<size_t>(v.body)];
      const VertexAreas areas = vertex_areas(b, v.vertex, v.displacement);
      v.area = areas.comparison;
      v.length = std::sqrt(areas.unprojected);
    }
    for (const auto& p : partners_of(v)) {
      if (vertices_[static_cast<size_t>(p.region_vertex)].immovable) v.rigid_partner = true;
    }
    if (v.immovable) {
      v.fraction = 0.0;
    } else if (v.rigid_partner) {
      v.fraction = 1.0;  // the soft side takes the whole displacement
    } else {
      v.fraction = 0.5;  // first halving (section 4.4.1)
    }
  }

  // Which vertices search, and which the search needs (searching vertices and their partners).
  searching_count_ = 0;
  std::vector<char>& needed = flag_;
  needed.assign(vertices_.size(), 0);
  for (auto& v : vertices_) {
    v.searching = !v.immovable && !v.rigid_partner && v.displacement.squaredNorm() > 0.0;
    if (!v.searching) continue;
    ++searching_count_;
    needed[static_cast<size_t>(&v - vertices_.data())] = 1;
    for (const auto& p : partners_of(v)) needed[static_cast<size_t>(p.region_vertex)] = 1;
  }

  // Group movable vertices per body for the local force query: the search's vertices first.
  for (auto& g : groups_) {  // all, so a group left over from an earlier step is empty
    g.vertices.clear();
    g.region_indices.clear();
    g.search_count = 0;
  }
  size_t used = 0;
  group_of_.assign(bodies.size(), -1);
  for (int pass = 0; pass < 2; ++pass) {
    for (size_t i = 0; i < vertices_.size(); ++i) {
      const auto& v = vertices_[i];
      if (v.immovable || (needed[i] != 0) != (pass == 0)) continue;
      int& g = group_of_[static_cast<size_t>(v.body)];
      if (g < 0) {
        g = static_cast<int>(used++);
        if (groups_.size() < used) groups_.emplace_back();
        groups_[static_cast<size_t>(g)].body = v.body;
      }
      auto& group = groups_[static_cast<size_t>(g)];
      group.vertices.push_back(v.vertex);
      group.region_indices.push_back(static_cast<int>(i));
      if (pass == 0) group.search_count = group.vertices.size();
    }
  }
  group_count_ = used;
  for (auto& g : groups()) g.forces.resize(g.vertices.size());
}

}  // namespace pliant
