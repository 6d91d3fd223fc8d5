// Stage 3 of the contact-surface method (paper section 4.3): the deformation region and the
// displacement vector of each of its vertices (Eq. 1), plus, for stage 4, each vertex's
// comparison partners on the other body (the vertices of Eq. 2).
//
// The region is the union of the colliding vertices and the vertices of their contact triangles.
// For a displacement vertex v with own contacts d_j (v collides) and contributions d_i of the
// other body's colliding vertices whose contact triangle contains v (barycentric weight w_i):
//   s = (sum_i w_i (-d_i) + sum_j d_j) / (sum_i w_i + n_own)                       (Eq. 1)
// The sign: d_i points out of v's body, and v must move into it, hence -d_i. The paper's "+1"
// counts only when v itself collides (n_own = number of its own contacts): then a non-colliding
// triangle vertex can close the whole gap and the first halving lands exactly in the middle of
// the intersection, as Fig. 4 says. docs/contact-surface.md gives the reasoning.
#pragma once

#include <span>
#include <vector>

#include "sim/body.h"
#include "sim/collision/contact_types.h"

namespace pliant {

/// The area a vertex's force acts on, for pressure (section 4.4.3, [open] in algorithms.md): one
/// third of its adjacent surface triangles, each projected onto the plane normal to the vertex's
/// displacement (triangles facing away count nothing). Projection keeps a rim vertex's side faces
/// from diluting its pressure; one third keeps bodies meshed at different densities comparable.
/// Falls back to the unprojected share when nothing faces the displacement.
double comparison_area(const Body& body, int vertex, const Vec3& displacement);

/// comparison_area() and, in the same pass, the unprojected share (one third of the adjacent
/// surface triangles' area, m^2).
struct VertexAreas {
  double comparison = 0.0;
  double unprojected = 0.0;
};
VertexAreas vertex_areas(const Body& body, int vertex, const Vec3& displacement);

/// One vertex of the deformation region.
struct DisplacementVertex {
  int body = -1;
  int vertex = -1;
  Vec3 rest_of_step = Vec3::Zero();  ///< x before the response (m)
  Vec3 displacement = Vec3::Zero();  ///< s, Eq. 1 (m)
  double displacement_length = 0.0;  ///< |s| (m), set with s by build(): read per entry and evaluation
  double fraction = 0.0;             ///< lambda: the vertex sits at x + lambda s
  double area = 0.0;                 ///< comparison area (m^2), see comparison_area()
  double length = 0.0;               ///< local edge length (m): sqrt of a third of the adjacent surface area
  double pressure = 0.0;             ///< elastic restoring pressure along s (Pa), from the last evaluation
  bool immovable = false;            ///< kinematic body or fixed vertex: never displaced
  bool rigid_partner = false;        ///< touches an immovable vertex: takes the whole displacement
  bool colliding = false;            ///< the vertex itself penetrates the other body
  bool searching = false;            ///< takes part in the binary search (movable, s != 0, no rigid partner)
  int partner_begin = 0;             ///< first comparison partner in DeformationRegion::partners()
  int partner_count = 0;
};

/// A comparison partner of a displacement vertex: a vertex of the other body and its weight.
struct ComparisonPartner {
  int region_vertex = -1;  ///< index into DeformationRegion::vertices()
  double weight = 0.0;     ///< barycentric weight w_i (Eq. 2)
};

class DeformationRegion {
 public:
  /// Builds the region and displacement vectors from the colliding vertices of this step.
  /// `weighted` = false replaces every barycentric weight by 1 (for comparison only).
  void build(std::span<Body* const> bodies, std::span<const VertexContact> contacts, bool weighted = true);

  std::vector<DisplacementVertex>& vertices() { return vertices_; }
  const std::vector<DisplacementVertex>& vertices() const { return vertices_; }
  const std::vector<ComparisonPartner>& partners() const { return partners_; }
  std::span<const ComparisonPartner> partners_of(const DisplacementVertex& v) const {
    return {partners_.data() + v.partner_begin, static_cast<size_t>(v.partner_count)};
  }
  /// Region index of (body, vertex), or -1.
  int find(int body, int vertex) const;
  /// Region index of the colliding vertex of contact c, and of its contact triangle's vertices.
  int contact_vertex(size_t c) const { return contact_vertex_[c]; }
  const std::array<int, 3>& contact_triangle_vertices(size_t c) const { return contact_triangle_[c]; }

  /// Bodies with movable region vertices, with those vertices' ids and region indices, for the
  /// local force query. The first `search_count` entries are the vertices the binary search needs
  /// (searching vertices and their comparison partners); the rest are evaluated only once, at the
  /// final contact surface.
  struct BodyGroup {
    int body = -1;
    std::vector<int> vertices;        ///< vertex ids in the body
    std::vector<int> region_indices;  ///< matching DisplacementVertex indices
    std::vector<Vec3> forces;         ///< scratch for internal_forces_at
    size_t search_count = 0;          ///< leading entries needed by the search
    // Scratch of one local query over a subset of the entries (ids, entry index, forces).
    std::vector<int> query_vertices, query_entries;
    std::vector<Vec3> query_forces;
    // Linearised search (session 6), over the leading search_count entries: where the first search
    // evaluation found them (m) and their forces there (N); the moves since (m) and K' times them (N).
    bool linearised = false;  ///< this step's later search iterations use f(x1) - K' (x - x1)
    std::vector<Vec3> start_positions, start_forces, moves, stiffness_moves;
  };
  std::span<BodyGroup> groups() { return {groups_.data(), group_count_}; }
  /// True if some vertex searches (else the binary search has nothing to do: every movable vertex
  /// faces an immovable one, e.g. tissue against an instrument).
  bool has_searching_vertices() const { return searching_count_ > 0; }

 private:
  int add_vertex(std::span<Body* const> bodies, int body, int vertex);
  /// Sorts triples_ by (owner, partner) into std::sort's order (deformation_region.cpp).
  void sort_triples();

  std::vector<DisplacementVertex> vertices_;
  std::vector<ComparisonPartner> partners_;
  std::vector<std::vector<int>> index_of_;  ///< per body slot: vertex -> region index or -1
  std::vector<int> contact_vertex_;
  std::vector<std::array<int, 3>> contact_triangle_;
  std::vector<BodyGroup> groups_;  ///< the first group_count_ are this step's (the rest keep buffers)
  size_t group_count_ = 0;
  size_t searching_count_ = 0;

  // Scratch of build(), kept so a step allocates nothing once the buffers have grown.
  struct Triple {
    int owner, partner;
    double weight;
  };
  std::vector<Vec3> numerator_;
  std::vector<double> denominator_;
  std::vector<Triple> triples_;
  std::vector<char> flag_;      ///< per region vertex: has a partner / needed by the search
  std::vector<Triple> sorted_triples_;  ///< scratch of sort_triples()
  std::vector<int> owner_offsets_;      ///< scratch of sort_triples(): per owner, where its triples go
  std::vector<int> group_of_;   ///< per body slot: group index or -1
};

}  // namespace pliant
