#include "sim/collision/spatial_hash.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "sim/collision/cell_coordinate.h"
#include "sim/collision/tet_barycentric.h"

namespace pliant {
namespace {

double min_coefficient(const Vec4& b) { return b.minCoeff(); }

/// Pass 2's chunk with threads: a fixed count (never from the thread count), small enough that the
/// fruit dish's 143 bodies balance over two threads (a box's rigid pass is worth a few fruits).
constexpr size_t kPenetratedBodiesPerChunk = 2;

/// One tet of body b under test: its corners, bounds and (built on first need) barycentric frame.
/// The cell walk and the rigid pass test candidates through it, so both find the same bits.
struct TetUnderTest {
  const CollisionBody& cb;
  int b;
  int t;
  const TetIndices& tet;
  const Vec3* x[4];
  Aabb box;
  bool frame_ready = false;
  TetBarycentricFrame frame;

  TetUnderTest(const CollisionBody& body, int body_index, int tet_index)
      : cb(body), b(body_index), t(tet_index), tet(body.mesh->tets()[static_cast<size_t>(tet_index)]) {
    for (int k = 0; k < 4; ++k) {
      x[k] = &cb.positions[static_cast<size_t>(tet[static_cast<size_t>(k)])];
      box.extend(*x[k]);
    }
  }
  /// Vertex `vertex` of body `body` at p: not one of the tet's own vertices, inside its bounds, then
  /// inside it (closed across internal faces); appends the pair to `out` when inside.
  void test(const Vec3& p, int body, int vertex, SpatialHashStats& stats, std::vector<VertexInTet>& out) {
    if (body == b && (vertex == tet[0] || vertex == tet[1] || vertex == tet[2] || vertex == tet[3])) return;
    if ((p.array() < box.min.array()).any() || (p.array() > box.max.array()).any()) return;
    if (!frame_ready) {
      frame = TetBarycentricFrame::of(*x[0], *x[1], *x[2], *x[3]);
      frame_ready = true;
    }
    ++stats.inside_tests;
    Vec4 bary;
    if (frame.contains_in_body(p, [&](int k) { return is_internal_tet_face(*cb.mesh, t, k); }, &bary)) {
      out.push_back(VertexInTet{body, vertex, b, t, bary});
    }
  }
};

}  // namespace

bool SpatialHash::rigid_pass(int b, const CollisionBody& cb, PenetratedBodyScratch& s) const {
  const TetMesh& mesh = *cb.mesh;
  const Pose& pose = *cb.rigid_pose;
  if (!(std::abs(pose.rotation.squaredNorm() - 1.0) <= 1e-12)) return false;  // the inverse below needs a unit q
  const auto i = static_cast<size_t>(b);
  const RigidTetGrid& grid = rigid_grids_[i];  // built before pass 2 (detect)
  assert(grid.built_for(mesh));
  // A point the inside test accepts lies within 1e-12 x (largest |coordinate|, longest edge) of the
  // tet (TetBarycentricFrame); in the rest frame add how far the positions are from pose(rest) and
  // the frame change's rounding. 1e-9 x the largest coordinate covers the tolerance and the rounding.
  const auto& rest = mesh.rest_positions();
  double deviation = 0.0;
  double magnitude = pose.translation.cwiseAbs().maxCoeff();
  for (size_t v = 0; v < rest.size(); ++v) {
    const Vec3& x = cb.positions[v];
    deviation = std::max(deviation, (x - pose.apply(rest[v])).norm());
    magnitude = std::max(magnitude, x.cwiseAbs().maxCoeff());
  }
  if (!(deviation + 1e-9 * magnitude <= grid.pad())) return false;  // also false for non-finite positions
  const Quat inverse = pose.rotation.conjugate();
  // A vertex outside b's bounds is in none of its tets (each tet's box lies inside them). The grid's
  // cells are as large as the body's tets, so without this a dish wall's grid reaches far into the
  // dish and lists every fruit vertex there against each of its tets (session 11).
  // Partners are read body by body through their runs of hashed_ (the same order as one pass over
  // it), and a partner none of whose inserted vertices can be inside b's bounds is skipped whole:
  // in the piled dish each box used to read every inserted fruit vertex (session 15).
  const Aabb& own = body_bounds_[i];
  for (int a : s.partners) {
    const auto ai = static_cast<size_t>(a);
    if (!vertex_bounds_[ai].overlaps(own)) continue;
    for (int e = hashed_begin_[ai]; e < hashed_begin_[ai + 1]; ++e) {
      const HashedVertex& hv = hashed_[static_cast<size_t>(e)];
      if ((hv.x.array() < own.min.array()).any() || (hv.x.array() > own.max.array()).any()) continue;
      for (int t : grid.tets_near(inverse * (hv.x - pose.translation))) {
        ++s.stats.tets_visited;
        TetUnderTest(cb, b, t).test(hv.x, hv.body, hv.vertex, s.stats, s.candidates);
      }
    }
  }
  return true;
}

long long SpatialHash::gather_partner_vertices(int b, double inv_l, PenetratedBodyScratch& s) const {
  const Aabb& own = body_bounds_[static_cast<size_t>(b)];
  s.partner_outcodes.clear_boxes();
  int hi[3];
  double cells = 1.0;
  for (int k = 0; k < 3; ++k) {
    s.occupied_origin[k] = cell_coordinate(own.min[k], inv_l);
    hi[k] = cell_coordinate(own.max[k], inv_l);
    cells *= static_cast<double>(hi[k]) - s.occupied_origin[k] + 1.0;
  }
  s.occupied_dims[0] = s.occupied_dims[1] = s.occupied_dims[2] = 0;
  // No cell at all: b's bounds are empty (every vertex non-finite: Aabb::extend drops NaN), so no
  // partner vertex can lie in one of its tets. (A negative count cast to size_t was std::bad_alloc.)
  if (!(cells >= 1.0)) return 0;
  // A bitmap of more than 8 bits per inserted vertex would cost more to clear than its look-ups:
  // none then (a body much larger than its share of the vertices), and no tet is skipped by cells.
  const bool bitmap = cells <= std::max(4096.0, 8.0 * static_cast<double>(hashed_.size()));
  if (bitmap) {
    for (int k = 0; k < 3; ++k) s.occupied_dims[k] = hi[k] - s.occupied_origin[k] + 1;
    s.occupied.assign((static_cast<size_t>(cells) + 63) / 64, 0);
  }
  long long inside = 0;
  for (int a : s.partners) {
    // A partner vertex inside a tet of b lies in b's bounds, hence in both boxes.
    if (!vertex_bounds_[static_cast<size_t>(a)].overlaps(own)) continue;
    Aabb inside_b;  // a's inserted vertices inside b's bounds: for two touching fruits, their lens
    for (int e = hashed_begin_[static_cast<size_t>(a)]; e < hashed_begin_[static_cast<size_t>(a) + 1]; ++e) {
      const HashedVertex& hv = hashed_[static_cast<size_t>(e)];
      // The complement of the tet's own box test (TetUnderTest::test), with b's bounds for the box.
      if ((hv.x.array() < own.min.array()).any() || (hv.x.array() > own.max.array()).any()) continue;
      inside_b.extend(hv.x);
      ++inside;
      if (!bitmap) continue;
      // Inside b's bounds, so inside its cells (the cell coordinate is monotone in x).
      const int* c = hv.cell;
      assert(c[0] >= s.occupied_origin[0] && c[0] <= hi[0] && c[1] >= s.occupied_origin[1] && c[1] <= hi[1] &&
             c[2] >= s.occupied_origin[2] && c[2] <= hi[2]);
      const auto bit = (static_cast<size_t>(c[0] - s.occupied_origin[0]) * static_cast<size_t>(s.occupied_dims[1]) +
                        static_cast<size_t>(c[1] - s.occupied_origin[1])) *
                           static_cast<size_t>(s.occupied_dims[2]) +
                       static_cast<size_t>(c[2] - s.occupied_origin[2]);
      s.occupied[bit / 64] |= std::uint64_t{1} << (bit % 64);
    }
    if (!inside_b.empty()) s.partner_outcodes.add_box(inside_b);
  }
  return inside;
}

bool SpatialHash::any_cell_occupied(const PenetratedBodyScratch& s, int i0, int i1, int j0, int j1, int k0, int k1) {
  if (s.occupied_dims[0] == 0) return true;
  assert(i0 >= s.occupied_origin[0] && i1 < s.occupied_origin[0] + s.occupied_dims[0]);
  assert(j0 >= s.occupied_origin[1] && j1 < s.occupied_origin[1] + s.occupied_dims[1]);
  assert(k0 >= s.occupied_origin[2] && k1 < s.occupied_origin[2] + s.occupied_dims[2]);
  const auto ny = static_cast<size_t>(s.occupied_dims[1]), nz = static_cast<size_t>(s.occupied_dims[2]);
  for (int i = i0; i <= i1; ++i) {
    for (int j = j0; j <= j1; ++j) {
      const size_t row = (static_cast<size_t>(i - s.occupied_origin[0]) * ny + static_cast<size_t>(j - s.occupied_origin[1])) * nz;
      for (int k = k0; k <= k1; ++k) {
        const size_t bit = row + static_cast<size_t>(k - s.occupied_origin[2]);
        if ((s.occupied[bit / 64] >> (bit % 64)) & 1u) return true;
      }
    }
  }
  return false;
}

std::uint64_t SpatialHash::hash_cell(int i, int j, int k, std::uint64_t table_size) {
  // Teschner et al. 2003, eq. (1); conversion of a negative int to uint64 is well defined (mod 2^64).
  const std::uint64_t h = (static_cast<std::uint64_t>(static_cast<std::int64_t>(i)) * 73856093ull) ^
                          (static_cast<std::uint64_t>(static_cast<std::int64_t>(j)) * 19349663ull) ^
                          (static_cast<std::uint64_t>(static_cast<std::int64_t>(k)) * 83492791ull);
  return h % table_size;
}

std::uint64_t SpatialHash::next_prime(std::uint64_t n) {
  if (n <= 2) return 2;
  if (n % 2 == 0) ++n;
  for (;; n += 2) {
    bool prime = true;
    for (std::uint64_t d = 3; d * d <= n; d += 2) {
      if (n % d == 0) {
        prime = false;
        break;
      }
    }
    if (prime) return n;
  }
}

void SpatialHash::penetrate(int b, const CollisionBody& cb, const CollisionFilter& filter, double inv_l,
                            PenetratedBodyScratch& s) const {
  // The last body's partner marks go (each body marks only its own partners).
  for (int a : s.partners) s.partner[static_cast<size_t>(a)] = 0;
  s.partners.clear();
  const std::uint64_t n = table_size_;
  // The bodies whose vertices may enter this one, ascending: those it may touch whose bounds
  // overlap its own (another body's vertex inside b's tet is in both bounds; a body whose bounds
  // miss b's would be skipped by every tet's box test). None inserted a vertex: nothing to find.
  bool partner_inserted = false;
  auto mark = [&](int a) {
    if (!hashes_vertices_[static_cast<size_t>(a)] || !filter.allowed(a, b)) return;
    s.partner[static_cast<size_t>(a)] = 1;
    s.partners.push_back(a);
    partner_inserted = partner_inserted || !vertex_bounds_[static_cast<size_t>(a)].empty();
  };
  const auto others = bounds_overlap_.overlapping(b);
  const auto after_b = std::upper_bound(others.begin(), others.end(), b);
  for (auto it = others.begin(); it != after_b; ++it) mark(*it);
  mark(b);  // self-collision
  for (auto it = after_b; it != others.end(); ++it) mark(*it);
  if (!partner_inserted) return;
  if (cb.rigid_pose != nullptr && rigid_pass(b, cb, s)) return;
  // The partners' inserted vertices inside b's bounds, boxed per partner and marked by cell; none:
  // no tet of b can hold one.
  if (gather_partner_vertices(b, inv_l, s) == 0) return;
  // Out-codes against those boxes: a tet whose box meets none of them cannot hold a partner vertex
  // (the tet's own box test would reject every one), so it is skipped before any look-up. In a pile
  // this leaves the tets near a neighbour's lens; one box around all partners left every tet.
  const int nv = cb.mesh->vertex_count();
  s.partner_outcodes.assign_codes(cb.positions.first(static_cast<size_t>(nv)));
  const auto& tets = cb.mesh->tets();
  const size_t nt = tets.size();
  for (size_t next = 0;; ++next) {
    // The tets before the next one that meets a box are skipped (misses_every_box, in one loop).
    const size_t meeting = s.partner_outcodes.first_tet_meeting_a_box(tets, next);
    s.stats.tets_skipped_partner_boxes += static_cast<long long>(meeting - next);
    if (meeting >= nt) break;
    next = meeting;
    const int t = static_cast<int>(meeting);
    TetUnderTest under_test(cb, b, t);
    const Aabb& box = under_test.box;
    const int i0 = cell_coordinate(box.min.x(), inv_l), i1 = cell_coordinate(box.max.x(), inv_l);
    const int j0 = cell_coordinate(box.min.y(), inv_l), j1 = cell_coordinate(box.max.y(), inv_l);
    const int k0 = cell_coordinate(box.min.z(), inv_l), k1 = cell_coordinate(box.max.z(), inv_l);
    // A partner vertex inside the tet lies in one of its cells: none marked, nothing to find.
    if (!any_cell_occupied(s, i0, i1, j0, j1, k0, k1)) {
      ++s.stats.tets_skipped_unoccupied;
      continue;
    }
    ++s.stats.tets_visited;
    // Candidate test: filter, own vertices, AABB, then barycentric coordinates.
    auto test = [&](const HashedVertex& hv) { under_test.test(hv.x, hv.body, hv.vertex, s.stats, s.candidates); };

    const double cells = (static_cast<double>(i1) - i0 + 1) * (static_cast<double>(j1) - j0 + 1) *
                         (static_cast<double>(k1) - k0 + 1);
    if (cells > static_cast<double>(hashed_.size())) {
      // A tet far larger than a cell (badly stretched): scanning all vertices is cheaper.
      for (const HashedVertex& hv : hashed_) {
        if (s.partner[static_cast<size_t>(hv.body)]) test(hv);
      }
      continue;
    }
    for (int i = i0; i <= i1; ++i) {
      for (int j = j0; j <= j1; ++j) {
        for (int k = k0; k <= k1; ++k) {
          ++s.stats.cells_visited;
          const auto h = static_cast<size_t>(hash_cell(i, j, k, n));
          const Bucket& bucket = buckets_[h];
          if (bucket.stamp != stamp_) continue;
          for (int e = bucket.head; e >= 0;) {
            const HashedVertex& hv = hashed_[static_cast<size_t>(e)];
            ++s.stats.entries_scanned;
            // A body that may not touch this one (e.g. the tet's own body): skip its whole run.
            if (!s.partner[static_cast<size_t>(hv.body)]) {
              e = hv.next_body;
              continue;
            }
            e = hv.next;
            // Another cell hashed to this bucket: its vertices are found (or not) from that cell.
            if (hv.cell[0] != i || hv.cell[1] != j || hv.cell[2] != k) continue;
            test(hv);
          }
        }
      }
    }
  }
}

void SpatialHash::detect(std::span<const CollisionBody> bodies, const CollisionFilter& filter,
                         std::vector<VertexInTet>& out, TaskExecutor* executor) {
  out.clear();
  stats_ = SpatialHashStats{};
  const int body_count = static_cast<int>(bodies.size());
  assert(filter.body_count() == body_count);
  auto usable = [&](int b) {
    const CollisionBody& cb = bodies[static_cast<size_t>(b)];
    return cb.active && cb.mesh != nullptr && cb.mesh->vertex_count() > 0;
  };

  // Which bodies take part: a body's vertices are hashed if it may touch some body, its tets are
  // tested if some body may touch it. Everything else costs nothing below. The filter is symmetric,
  // so the two are the same set; a row is scanned only up to its first usable partner.
  hashes_vertices_.assign(static_cast<size_t>(body_count), 0);
  has_tets_.assign(static_cast<size_t>(body_count), 0);
  for (int a = 0; a < body_count; ++a) {
    if (!usable(a)) continue;
    for (int b = filter.next_allowed(a, 0); b < body_count; b = filter.next_allowed(a, b + 1)) {
      if (usable(b)) {
        hashes_vertices_[static_cast<size_t>(a)] = has_tets_[static_cast<size_t>(a)] = 1;
        break;
      }
    }
  }

  // Cell size: average edge length over all participating bodies (Teschner 2003, section 4.1).
  double edge_length_sum = 0.0;
  double edge_count = 0.0;
  int vertex_total = 0;
  for (int a = 0; a < body_count; ++a) {
    const auto i = static_cast<size_t>(a);
    if (!hashes_vertices_[i] && !has_tets_[i]) continue;
    const TetMesh& mesh = *bodies[i].mesh;
    edge_length_sum += mesh.mean_edge_length() * static_cast<double>(mesh.edges().size());
    edge_count += static_cast<double>(mesh.edges().size());
    if (hashes_vertices_[i]) vertex_total += mesh.vertex_count();
  }
  if (vertex_total == 0 || edge_count == 0.0 || !(edge_length_sum > 0.0)) return;
  const double l = options_.cell_size_factor * edge_length_sum / edge_count;
  const double inv_l = 1.0 / l;

  stats_.hashed_vertices = vertex_total;
  stats_.cell_size = l;

  // Bounds of every participating body's vertices; its tets lie inside them.
  body_bounds_.assign(static_cast<size_t>(body_count), Aabb{});
  takes_part_.resize(static_cast<size_t>(body_count));
  for (int a = 0; a < body_count; ++a) {
    const auto i = static_cast<size_t>(a);
    if (!hashes_vertices_[i] && !has_tets_[i]) continue;
    // Into a local box (session 18: extending the member in place stored it back per vertex; the same
    // comparisons in the same order).
    Aabb bounds;
    for (const Vec3& x : bodies[i].positions.first(static_cast<size_t>(bodies[i].mesh->vertex_count()))) {
      bounds.extend(x);
    }
    body_bounds_[i] = bounds;
  }

  // The body pairs whose bounds overlap (session 17): only these can hold each other's vertices.
  // Every per-body loop over partners below reads these lists, not all bodies.
  for (size_t i = 0; i < body_bounds_.size(); ++i) takes_part_[i] = hashes_vertices_[i] || has_tets_[i];
  bounds_overlap_.compute(body_bounds_, takes_part_);

  // Pass 1: hash the vertices of the bodies that may touch something, but only those inside the
  // bounds of some body they may touch: no other vertex can be inside one of its tets.
  hashed_.clear();
  vertex_bounds_.assign(static_cast<size_t>(body_count), Aabb{});
  hashed_begin_.assign(static_cast<size_t>(body_count) + 1, 0);
  for (int a = 0; a < body_count; ++a) {
    hashed_begin_[static_cast<size_t>(a)] = static_cast<int>(hashed_.size());  // bodies go in in order
    if (!hashes_vertices_[static_cast<size_t>(a)]) continue;
    const CollisionBody& cb = bodies[static_cast<size_t>(a)];
    const Aabb& own = body_bounds_[static_cast<size_t>(a)];
    partner_boxes_.clear();
    if (has_tets_[static_cast<size_t>(a)] && filter.allowed(a, a) && !own.empty()) partner_boxes_.push_back(own);  // self-collision
    for (int b : bounds_overlap_.overlapping(a)) {
      if (has_tets_[static_cast<size_t>(b)] && filter.allowed(a, b)) partner_boxes_.push_back(body_bounds_[static_cast<size_t>(b)]);
    }
    if (partner_boxes_.empty()) continue;
    Aabb& bounds = vertex_bounds_[static_cast<size_t>(a)];
    const int nv = cb.mesh->vertex_count();
    for (int v = 0; v < nv; ++v) {
      const Vec3& x = cb.positions[static_cast<size_t>(v)];
      bool inside = false;
      for (const Aabb& box : partner_boxes_) {
        if ((x.array() >= box.min.array()).all() && (x.array() <= box.max.array()).all()) {
          inside = true;
          break;
        }
      }
      if (!inside) continue;
      bounds.extend(x);
      hashed_.push_back(HashedVertex{x, {cell_coordinate(x.x(), inv_l), cell_coordinate(x.y(), inv_l),
                                         cell_coordinate(x.z(), inv_l)}, a, v, -1, -1});
    }
  }
  stats_.inserted_vertices = static_cast<int>(hashed_.size());
  hashed_begin_[static_cast<size_t>(body_count)] = static_cast<int>(hashed_.size());

  // Table: prime size for the inserted vertices (session 17: for all hashed vertices it was 12x
  // larger in the collision benchmark's 200k-tet scene, 1.6 MB of buckets against 0.4 MB, most of
  // them never read), grown only and then at least doubled, so a rising count reallocates O(log n)
  // times; a new step stamp instead of clearing.
  const auto wanted = static_cast<std::uint64_t>(options_.table_size_factor * static_cast<double>(hashed_.size())) + 1;
  if (table_size_ < wanted) {
    table_size_ = next_prime(std::max(wanted, 2 * table_size_));
    buckets_.assign(table_size_, Bucket{0u, -1});
    stamp_ = 0;
  }
  const std::uint64_t n = table_size_;
  if (++stamp_ == 0) {  // wrapped around after 2^32 steps: clear once
    std::fill(buckets_.begin(), buckets_.end(), Bucket{0u, -1});
    stamp_ = 1;
  }
  stats_.table_size = static_cast<int>(n);
  // Link the inserted vertices into their buckets, in insertion order (bodies ascending), so each
  // bucket's list holds a body's entries as one run.
  for (size_t e = 0; e < hashed_.size(); ++e) {
    HashedVertex& hv = hashed_[e];
    Bucket& bucket = buckets_[static_cast<size_t>(hash_cell(hv.cell[0], hv.cell[1], hv.cell[2], n))];
    if (bucket.stamp != stamp_) {
      bucket.stamp = stamp_;
      bucket.head = -1;
    }
    hv.next = bucket.head;
    if (bucket.head >= 0) {
      // Same body as the head: share its run's exit; else this entry starts a new run.
      const HashedVertex& head = hashed_[static_cast<size_t>(bucket.head)];
      hv.next_body = head.body == hv.body ? head.next_body : bucket.head;
    }
    bucket.head = static_cast<int>(e);
  }

  // Pass 2: for each tet of a body that may be penetrated, visit the cells of its AABB. Chunks of
  // penetrated bodies, each with its own scratch (threads: side by side); the rigid bodies' grids
  // are built first, so pass 2 only reads what the passes above wrote.
  for (int b = 0; b < body_count; ++b) {
    const CollisionBody& cb = bodies[static_cast<size_t>(b)];
    if (!has_tets_[static_cast<size_t>(b)] || cb.rigid_pose == nullptr) continue;
    if (rigid_grids_.size() <= static_cast<size_t>(b)) rigid_grids_.resize(static_cast<size_t>(b) + 1);
    RigidTetGrid& grid = rigid_grids_[static_cast<size_t>(b)];
    if (!grid.built_for(*cb.mesh)) grid.build(*cb.mesh);
  }
  const auto bodies_total = static_cast<size_t>(body_count);
  const size_t chunk = runs_parallel(executor) ? kPenetratedBodiesPerChunk : std::max<size_t>(bodies_total, 1);
  const size_t chunks = (bodies_total + chunk - 1) / chunk;
  if (pass_two_.size() < chunks) pass_two_.resize(chunks);
  for (size_t c = 0; c < chunks; ++c) {
    PenetratedBodyScratch& s = pass_two_[c];
    s.stats = SpatialHashStats{};
    s.candidates.clear();
    s.partner.assign(bodies_total, 0);
    s.partners.clear();
  }
  parallel_for_chunks(executor, bodies_total, chunk, [&](size_t begin, size_t end) {
    PenetratedBodyScratch& s = pass_two_[begin / chunk];
    for (size_t b = begin; b < end; ++b) {
      if (has_tets_[b]) penetrate(static_cast<int>(b), bodies[b], filter, inv_l, s);
    }
  });
  for (size_t c = 0; c < chunks; ++c) {
    const SpatialHashStats& chunk_stats = pass_two_[c].stats;
    stats_.tets_visited += chunk_stats.tets_visited;
    stats_.cells_visited += chunk_stats.cells_visited;
    stats_.inside_tests += chunk_stats.inside_tests;
    stats_.entries_scanned += chunk_stats.entries_scanned;
    stats_.tets_skipped_unoccupied += chunk_stats.tets_skipped_unoccupied;
    stats_.tets_skipped_partner_boxes += chunk_stats.tets_skipped_partner_boxes;
  }
  // One chunk (no threads): its candidates are sorted where they are; several are gathered first.
  std::vector<VertexInTet>* candidates = &pass_two_[0].candidates;
  if (chunks > 1) {
    size_t found = 0;
    for (size_t c = 0; c < chunks; ++c) found += pass_two_[c].candidates.size();
    // Grown to twice what is needed: an exact reserve would reallocate at every new candidate.
    candidates_.clear();
    if (candidates_.capacity() < found) candidates_.reserve(2 * found);
    for (size_t c = 0; c < chunks; ++c) {
      candidates_.insert(candidates_.end(), pass_two_[c].candidates.begin(), pass_two_[c].candidates.end());
    }
    candidates = &candidates_;
  }
  stats_.candidates_found = static_cast<long long>(candidates->size());

  // Deterministic order; per (vertex, penetrated body) keep the tet it is deepest in.
  std::sort(candidates->begin(), candidates->end(), [](const VertexInTet& p, const VertexInTet& q) {
    if (p.body != q.body) return p.body < q.body;
    if (p.vertex != q.vertex) return p.vertex < q.vertex;
    if (p.penetrated_body != q.penetrated_body) return p.penetrated_body < q.penetrated_body;
    const double mp = min_coefficient(p.barycentric), mq = min_coefficient(q.barycentric);
    if (mp != mq) return mp > mq;
    return p.tet < q.tet;
  });
  for (const VertexInTet& c : *candidates) {
    if (!out.empty() && out.back().body == c.body && out.back().vertex == c.vertex &&
        out.back().penetrated_body == c.penetrated_body) {
      continue;
    }
    out.push_back(c);
  }
}

}  // namespace pliant
