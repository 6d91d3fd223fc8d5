#include "sim/collision/penetration_depth.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "sim/collision/contact_triangle.h"
#include "sim/collision/tet_walk.h"
#include "sim/collision/vertex_normal_scratch_inl.h"

namespace pliant {
namespace {

/// Chunks of penetrated bodies with threads: a fixed count (never from the thread count).
constexpr size_t kPenetratedBodiesPerChunk = 2;

/// Adds one chunk's counters to the call's (sums; the deepest layer is a maximum).
void add_stats(const PenetrationDepthStats& a, PenetrationDepthStats& sum) {
  sum.border_points += a.border_points;
  sum.propagated_points += a.propagated_points;
  sum.enclosed_fallback_points += a.enclosed_fallback_points;
  sum.direction_fallbacks += a.direction_fallbacks;
  sum.clamped_negative_depths += a.clamped_negative_depths;
  sum.ray_misses += a.ray_misses;
  sum.dropped += a.dropped;
  sum.edge_intersections += a.edge_intersections;
  sum.max_layer = std::max(sum.max_layer, a.max_layer);
  sum.surfaces_unchanged += a.surfaces_unchanged;
  sum.surfaces_lazy += a.surfaces_lazy;
  sum.surfaces_refitted += a.surfaces_refitted;
  sum.surfaces_built += a.surfaces_built;
  sum.walked_edges += a.walked_edges;
  sum.walk_edge_fallbacks += a.walk_edge_fallbacks;
  sum.walked_rays += a.walked_rays;
  sum.walk_ray_fallbacks += a.walk_ray_fallbacks;
  sum.walk_mismatches += a.walk_mismatches;
  sum.walk_tets += a.walk_tets;
  sum.enclosed_ray_overshoots += a.enclosed_ray_overshoots;
}

}  // namespace

PenetrationDepthSolver::Surface& PenetrationDepthSolver::surface_of(std::span<const CollisionBody> bodies,
                                                                    int body, bool need_bvh,
                                                                    PenetrationDepthStats& stats) {
  Surface& s = surfaces_[static_cast<size_t>(body)];
  if (s.built_in_call != call_) {
    const CollisionBody& cb = bodies[static_cast<size_t>(body)];
    s.mesh = cb.mesh;
    s.x = cb.positions;
    s.built_in_call = call_;
    // With edges walked, the walks' face normals are reused within this call (a border point's
    // edges and ray start in one tet; the positions change between calls). Rays alone rarely enter
    // a tet twice: there the cache cost more than it saved, so they walk without it.
    if (options_.surface_query == SurfaceQueryMethod::tet_walk) s.planes.new_pose(cb.mesh->tet_count());
  }
  if (need_bvh) ensure_bvh(s, stats);
  return s;
}

void PenetrationDepthSolver::ensure_bvh(Surface& s, PenetrationDepthStats& stats) {
  if (s.bvh_in_call == call_) return;
  if (s.bvh.mesh() != s.mesh) {
    s.bvh.build(*s.mesh, s.x);
    s.refits = 0;
    ++stats.surfaces_built;
  } else {
    // Lazy while the surface stays near where its boxes were fitted; a full refit otherwise, and
    // every bvh_rebuild_interval-th full update a rebuild (restores the tree after deformation).
    const SurfaceBvhUpdate u =
        s.bvh.refit(s.x, options_.bvh_lazy_refit_edges, s.refits + 1 >= options_.bvh_rebuild_interval);
    switch (u) {
      case SurfaceBvhUpdate::unchanged: ++stats.surfaces_unchanged; break;
      case SurfaceBvhUpdate::lazy: ++stats.surfaces_lazy; break;
      case SurfaceBvhUpdate::refit: ++s.refits; ++stats.surfaces_refitted; break;
      case SurfaceBvhUpdate::rebuild: s.refits = 0; ++stats.surfaces_built; break;
    }
  }
  s.bvh_in_call = call_;
}

void PenetrationDepthSolver::walk_fan(Surface& surface, const VertexInTet& c, const Vec3& p, GroupScratch& g) {
  g.fan_failed.clear();
  for (size_t e = 0; e < g.fan_origins.size(); ++e) {
    int steps = 0;
    const bool hit = walk_edge_hit(*surface.mesh, surface.x, c.tet, p, g.fan_origins[e], options_.tet_walk_max_steps,
                                   g.fan_hits[e], &steps, &surface.planes);
    g.stats.walk_tets += steps;
    if (hit) {
      g.fan_found[e] = 1;
      ++g.stats.walked_edges;
    } else {
      g.fan_found[e] = 0;
      g.fan_failed.push_back(static_cast<int>(e));
      ++g.stats.walk_edge_fallbacks;
    }
  }
  const bool verify = options_.tet_walk_verify;
  if (g.fan_failed.empty() && !verify) return;
  ensure_bvh(surface, g.stats);
  // The failed edges (or, to verify, all of them) through the BVH's fan query.
  g.fallback_origins.clear();
  g.fallback_exclude.clear();
  for (size_t e = 0; e < g.fan_origins.size(); ++e) {
    if (!verify && !g.fan_found[e]) g.fallback_origins.push_back(g.fan_origins[e]);
    if (verify) g.fallback_origins.push_back(g.fan_origins[e]);
  }
  g.fallback_exclude.assign(g.fallback_origins.size(), -1);
  g.fallback_hits.resize(g.fallback_origins.size());
  g.fallback_found.resize(g.fallback_origins.size());
  surface.bvh.first_segment_hits(p, -1, g.fallback_origins, g.fallback_exclude, g.fallback_hits, g.fallback_found);
  if (verify) {
    for (size_t e = 0; e < g.fan_origins.size(); ++e) {
      if (!g.fan_found[e]) {
        g.fan_found[e] = g.fallback_found[e];
        g.fan_hits[e] = g.fallback_hits[e];
      } else if (!g.fallback_found[e] || g.fallback_hits[e].triangle != g.fan_hits[e].triangle ||
                 g.fallback_hits[e].t != g.fan_hits[e].t) {
        ++g.stats.walk_mismatches;
      }
    }
    return;
  }
  for (size_t i = 0; i < g.fan_failed.size(); ++i) {
    const auto e = static_cast<size_t>(g.fan_failed[i]);
    g.fan_found[e] = g.fallback_found[i];
    g.fan_hits[e] = g.fallback_hits[i];
  }
}

Vec3 PenetrationDepthSolver::smoothed_normal(const Surface& surface, const SurfacePoint& hit, GroupScratch& g) {
  // Heidelberger 2004, section 4.2: barycentric interpolation of the hit face's vertex normals.
  const TetMesh& mesh = *surface.mesh;
  const auto& tri = mesh.surface_triangles()[static_cast<size_t>(hit.triangle)];
  Vec3 n = Vec3::Zero();
  for (int k = 0; k < 3; ++k) {
    n += hit.barycentric[k] * g.normals.normal(tri[static_cast<size_t>(k)]);
  }
  const double len = n.norm();
  if (len > 1e-12) return n / len;
  // Opposite vertex normals cancel (a sharp fold): the flat face normal instead.
  return mesh.triangle_normal(surface.x, hit.triangle);
}

void PenetrationDepthSolver::compute(std::span<const CollisionBody> bodies, std::span<const VertexInTet> colliding,
                                     std::vector<VertexContact>& out, TaskExecutor* executor) {
  out.clear();
  stats_ = PenetrationDepthStats{};
  ++call_;
  if (colliding.empty()) return;
  if (surfaces_.size() < bodies.size()) surfaces_.resize(bodies.size());

  // Group entries by (colliding body, penetrated body), vertices ascending inside a group.
  const int n = static_cast<int>(colliding.size());
  order_.resize(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) order_[static_cast<size_t>(i)] = i;
  auto before = [&](int a, int b) {
    const VertexInTet& p = colliding[static_cast<size_t>(a)];
    const VertexInTet& q = colliding[static_cast<size_t>(b)];
    if (p.body != q.body) return p.body < q.body;
    if (p.penetrated_body != q.penetrated_body) return p.penetrated_body < q.penetrated_body;
    if (p.vertex != q.vertex) return p.vertex < q.vertex;
    return a < b;
  };
  // Stage 1's order (body, vertex, penetrated body) already is this one unless some vertex lies in
  // two bodies: then sort.
  if (!std::is_sorted(order_.begin(), order_.end(), before)) std::sort(order_.begin(), order_.end(), before);
  results_.resize(static_cast<size_t>(n));
  has_result_.assign(static_cast<size_t>(n), 0);
  group_begin_.clear();
  for (int begin = 0; begin < n;) {
    const VertexInTet& first = colliding[static_cast<size_t>(order_[static_cast<size_t>(begin)])];
    int end = begin + 1;
    while (end < n) {
      const VertexInTet& c = colliding[static_cast<size_t>(order_[static_cast<size_t>(end)])];
      if (c.body != first.body || c.penetrated_body != first.penetrated_body) break;
      ++end;
    }
    group_begin_.push_back(begin);
    begin = end;
  }
  group_begin_.push_back(n);
  const size_t groups = group_begin_.size() - 1;
  auto penetrated = [&](size_t group) {
    return colliding[static_cast<size_t>(order_[static_cast<size_t>(group_begin_[group])])].penetrated_body;
  };

  // The groups by penetrated body (a counting sort: groups ascending within a body), so that each
  // surface, with its hierarchy and its walk's plane cache, belongs to one chunk of bodies. A
  // group's result depends only on its entries and its surface at this call, not on which groups
  // came before it, so this order gives the serial order's values.
  const size_t body_count = bodies.size();
  surface_begin_.assign(body_count + 1, 0);
  for (size_t k = 0; k < groups; ++k) ++surface_begin_[static_cast<size_t>(penetrated(k)) + 1];
  for (size_t b = 0; b < body_count; ++b) surface_begin_[b + 1] += surface_begin_[b];
  by_surface_.resize(groups);
  {
    std::vector<int>& fill = surface_fill_;
    fill.assign(surface_begin_.begin(), surface_begin_.end() - 1);
    for (size_t k = 0; k < groups; ++k) by_surface_[static_cast<size_t>(fill[static_cast<size_t>(penetrated(k))]++)] = static_cast<int>(k);
  }

  const size_t chunk = runs_parallel(executor) ? kPenetratedBodiesPerChunk : std::max<size_t>(body_count, 1);
  const size_t chunks = (body_count + chunk - 1) / chunk;
  if (scratch_.size() < chunks) scratch_.resize(chunks);
  for (size_t c = 0; c < chunks; ++c) scratch_[c].stats = PenetrationDepthStats{};
  parallel_for_chunks(executor, body_count, chunk, [&](size_t begin, size_t end) {
    GroupScratch& g = scratch_[begin / chunk];
    for (int i = surface_begin_[begin]; i < surface_begin_[end]; ++i) {
      const auto k = static_cast<size_t>(by_surface_[static_cast<size_t>(i)]);
      solve_group(bodies, colliding,
                  std::span<const int>(order_.data() + group_begin_[k], static_cast<size_t>(group_begin_[k + 1] - group_begin_[k])),
                  g);
    }
  });
  for (size_t c = 0; c < chunks; ++c) add_stats(scratch_[c].stats, stats_);
  for (int i = 0; i < n; ++i) {
    if (has_result_[static_cast<size_t>(i)]) out.push_back(results_[static_cast<size_t>(i)]);
  }
}

void PenetrationDepthSolver::solve_group(std::span<const CollisionBody> bodies,
                                         std::span<const VertexInTet> colliding, std::span<const int> group,
                                         GroupScratch& g) {
  const VertexInTet& first = colliding[static_cast<size_t>(group[0])];
  const CollisionBody& body = bodies[static_cast<size_t>(first.body)];
  const TetMesh& mesh = *body.mesh;
  const std::span<const Vec3> x = body.positions;
  const bool self = first.body == first.penetrated_body;
  // The walk needs the stage-1 tet of p in the penetrated body and leaves by any boundary face: it
  // does not fit self-collision, whose queries skip the triangles holding p or q.
  const bool walk = options_.surface_query != SurfaceQueryMethod::bvh && !self;          // contact rays
  const bool walk_edges = options_.surface_query == SurfaceQueryMethod::tet_walk && !self;
  Surface& surface = surface_of(bodies, first.penetrated_body, !walk_edges, g.stats);
  // Vertex normals only where a hit needs them, in a scratch of this group's reached vertices.
  g.normals.begin(*surface.mesh, surface.x);
  const int count = static_cast<int>(group.size());
  // Weights 1/|.|^2 are capped where two points (nearly) coincide.
  const double min_distance_squared = std::pow(1e-9 * std::max(mesh.mean_edge_length(), 1e-300), 2);

  // Mark this group's colliding vertices (stamped: no clearing of the per-vertex arrays).
  if (g.vertex_stamp.size() < static_cast<size_t>(mesh.vertex_count())) {
    g.vertex_stamp.resize(static_cast<size_t>(mesh.vertex_count()), 0u);
    g.vertex_slot.resize(static_cast<size_t>(mesh.vertex_count()), -1);
  }
  if (++g.group_stamp == 0) {
    std::fill(g.vertex_stamp.begin(), g.vertex_stamp.end(), 0u);
    g.group_stamp = 1;
  }
  for (int k = 0; k < count; ++k) {
    const auto v = static_cast<size_t>(colliding[static_cast<size_t>(group[static_cast<size_t>(k)])].vertex);
    g.vertex_stamp[v] = g.group_stamp;
    g.vertex_slot[v] = k;
  }
  // Whether a neighbour collides is the unpredictable branch of this function (session 11): the
  // loops below classify neighbours by selects and counters, not by branches. `colliding_vertex`
  // reads the stamp alone; `slot_or_dummy` maps a non-colliding vertex to the dummy entry `count`
  // of g.layer, whose value never passes a layer test (INT_MAX).
  auto colliding_vertex = [&](int v) { return g.vertex_stamp[static_cast<size_t>(v)] == g.group_stamp; };
  auto slot_or_dummy = [&](int v) {
    // A mask, not `?:`: GCC 12 compiles the conditional to a branch here.
    const int in = -static_cast<int>(colliding_vertex(v));
    return (g.vertex_slot[static_cast<size_t>(v)] & in) | (count & ~in);
  };
  auto result = [&](int k) -> VertexContact& {
    return results_[static_cast<size_t>(group[static_cast<size_t>(k)])];
  };

  constexpr int kNoLayer = std::numeric_limits<int>::max();  // the dummy entry's layer
  g.layer.assign(static_cast<size_t>(count) + 1, -1);
  g.layer[static_cast<size_t>(count)] = kNoLayer;
  g.hint.assign(static_cast<size_t>(count), -1);
  g.frontier.clear();

  // Border points (Heidelberger 2004, eq. (2) and (3)).
  for (int k = 0; k < count; ++k) {
    const VertexInTet& c = colliding[static_cast<size_t>(group[static_cast<size_t>(k)])];
    VertexContact& r = result(k);
    r = VertexContact{};
    r.body = c.body;
    r.vertex = c.vertex;
    r.penetrated_body = c.penetrated_body;
    r.tet = c.tet;
    const Vec3& p = x[static_cast<size_t>(c.vertex)];
    double depth_sum = 0.0, weight_sum = 0.0, nearest_d2 = std::numeric_limits<double>::max();
    Vec3 direction_sum = Vec3::Zero();
    // Outgoing edges to non-colliding neighbours q. Keep the intersection nearest q: the first
    // hit of the segment from q towards p (t in [0, 1]); one traversal for all of p's edges.
    // Every neighbour is written; the count advances only past non-colliding ones (same order).
    // The fan buffers only grow (edges: the entries in use).
    const std::span<const int> neighbors = mesh.vertex_neighbors(c.vertex);
    if (g.fan_origins.size() < neighbors.size()) {
      g.fan_origins.resize(neighbors.size());
      g.fan_exclude.resize(neighbors.size());
      g.fan_hits.resize(neighbors.size());
      g.fan_found.resize(neighbors.size());
    }
    size_t edges = 0;
    for (int q : neighbors) {
      g.fan_origins[edges] = x[static_cast<size_t>(q)];
      g.fan_exclude[edges] = self ? q : -1;
      edges += static_cast<size_t>(!colliding_vertex(q));
    }
    g.stats.edge_intersections += static_cast<long long>(edges);
    if (walk_edges) {
      // walk_fan reads the whole buffers.
      g.fan_origins.resize(edges);
      g.fan_hits.resize(edges);
      g.fan_found.resize(edges);
      walk_fan(surface, c, p, g);
    } else {
      surface.bvh.first_segment_hits(p, self ? c.vertex : -1, std::span<const Vec3>(g.fan_origins.data(), edges),
                                     std::span<const int>(g.fan_exclude.data(), edges),
                                     std::span<SurfacePoint>(g.fan_hits.data(), edges),
                                     std::span<char>(g.fan_found.data(), edges));
    }
    int nearest_edge = -1;  // the nearest hit, by selects; its normal is recomputed if needed
    for (size_t e = 0; e < edges; ++e) {
      if (!g.fan_found[e]) continue;
      const SurfacePoint& best = g.fan_hits[e];
      const Vec3 normal = smoothed_normal(surface, best, g);
      const double d2 = (best.point - p).squaredNorm();
      const double w = 1.0 / std::max(d2, min_distance_squared);
      depth_sum += w * (best.point - p).dot(normal);
      direction_sum += w * normal;
      weight_sum += w;
      const bool nearer = d2 < nearest_d2;
      nearest_edge = nearer ? static_cast<int>(e) : nearest_edge;
      nearest_d2 = nearer ? d2 : nearest_d2;
    }
    if (weight_sum == 0.0) continue;  // all edges missed: an inner point after all
    const int nearest_triangle = nearest_edge >= 0 ? g.fan_hits[static_cast<size_t>(nearest_edge)].triangle : -1;
    r.penetration_depth = depth_sum / weight_sum;
    const double len = direction_sum.norm();
    if (len > 1e-12 * weight_sum) {
      r.penetration_direction = direction_sum / len;
    } else {
      // Normals cancel: the nearest hit's normal (the same value the sum used).
      r.penetration_direction =
          nearest_edge >= 0 ? smoothed_normal(surface, g.fan_hits[static_cast<size_t>(nearest_edge)], g) : Vec3::Zero();
      ++g.stats.direction_fallbacks;
    }
    r.depth_source = DepthSource::border;
    r.layer = 0;
    g.hint[static_cast<size_t>(k)] = nearest_triangle;
    g.layer[static_cast<size_t>(k)] = 0;
    g.frontier.push_back(k);
    ++g.stats.border_points;
  }

  // Propagation inward, layer by layer; only earlier layers contribute (eq. (4) and (5)).
  for (int layer = 1; !g.frontier.empty(); ++layer) {
    // Unprocessed colliding neighbours of the front join this layer: every neighbour is written
    // to g.next, the count advances only for those (a non-joining one marks the dummy entry).
    size_t joined = 0;
    for (int k : g.frontier) {
      const std::span<const int> neighbors = mesh.vertex_neighbors(result(k).vertex);
      if (g.next.size() < joined + neighbors.size()) g.next.resize(joined + neighbors.size());
      for (int q : neighbors) {
        const int s = slot_or_dummy(q);
        const bool joins = g.layer[static_cast<size_t>(s)] < 0;
        g.next[joined] = s;
        g.layer[static_cast<size_t>(joins ? s : count)] = joins ? layer : kNoLayer;
        joined += static_cast<size_t>(joins);
      }
    }
    g.next.resize(joined);
    std::sort(g.next.begin(), g.next.end());  // order does not change values; keeps traces readable
    for (int k : g.next) {
      VertexContact& r = result(k);
      const Vec3& p = x[static_cast<size_t>(r.vertex)];
      double depth_sum = 0.0, weight_sum = 0.0, nearest_d2 = std::numeric_limits<double>::max();
      Vec3 direction_sum = Vec3::Zero();
      int nearest = -1;  // slot of the nearest contributor, by selects
      for (int q : mesh.vertex_neighbors(r.vertex)) {
        // Only neighbours processed in an earlier layer contribute (one test: the dummy never does).
        const int s = slot_or_dummy(q);
        const int l = g.layer[static_cast<size_t>(s)];
        if (l < 0 || l >= layer) continue;
        const VertexContact& nb = result(s);
        const Vec3 e = x[static_cast<size_t>(q)] - p;
        const double d2 = e.squaredNorm();
        const double mu = 1.0 / std::max(d2, min_distance_squared);
        depth_sum += mu * (e.dot(nb.penetration_direction) + nb.penetration_depth);
        direction_sum += mu * nb.penetration_direction;
        weight_sum += mu;
        const bool nearer = d2 < nearest_d2;
        nearest = nearer ? s : nearest;
        nearest_d2 = nearer ? d2 : nearest_d2;
      }
      assert(weight_sum > 0.0);
      r.penetration_depth = depth_sum / weight_sum;
      const double len = direction_sum.norm();
      if (len > 1e-12 * weight_sum) {
        r.penetration_direction = direction_sum / len;
      } else {
        r.penetration_direction = nearest >= 0 ? result(nearest).penetration_direction : Vec3::Zero();
        ++g.stats.direction_fallbacks;
      }
      r.depth_source = DepthSource::propagated;
      r.layer = layer;
      g.hint[static_cast<size_t>(k)] = nearest >= 0 ? g.hint[static_cast<size_t>(nearest)] : -1;
      ++g.stats.propagated_points;
      g.stats.max_layer = std::max(g.stats.max_layer, layer);
    }
    std::swap(g.frontier, g.next);
  }

  // Every point: enclosed fallback if no layer reached it, then the contact triangle.
  for (int k = 0; k < count; ++k) {
    VertexContact& r = result(k);
    const Vec3& p = x[static_cast<size_t>(r.vertex)];
    const int exclude = self ? r.vertex : -1;
    const bool enclosed = g.layer[static_cast<size_t>(k)] < 0;
    SurfacePoint nearest;
    if (enclosed) {
      // Beyond the paper: nearest point of the penetrated surface (docs/penetration-depth.md).
      if (walk) ensure_bvh(surface, g.stats);
      if (!surface.bvh.nearest_point(p, exclude, nearest)) {
        ++g.stats.dropped;
        continue;
      }
      const Vec3 e = nearest.point - p;
      r.penetration_depth = e.norm();
      r.penetration_direction =
          r.penetration_depth > 1e-300 ? Vec3(e / r.penetration_depth) : smoothed_normal(surface, nearest, g);
      r.depth_source = DepthSource::enclosed_fallback;
      r.layer = 0;
      ++g.stats.enclosed_fallback_points;
    }
    if (r.penetration_depth < 0.0) {
      r.penetration_depth = 0.0;
      ++g.stats.clamped_negative_depths;
    }
    // Session 19: an enclosed point's ray aims at its nearest surface point c, at t = d, and nothing
    // of the surface lies nearer; a hit beyond d (plus rounding) means the ray slipped past c
    // between the triangles around it (c on an edge or a vertex) and left the body elsewhere. Then c
    // itself is the contact point, as the contract x + d r requires.
    const double overshoot = enclosed ? r.penetration_depth + 1e-9 * (r.penetration_depth + p.cwiseAbs().maxCoeff() +
                                                                        surface.mesh->mean_edge_length())
                                      : std::numeric_limits<double>::max();
    const auto take = [&](ContactTriangleSource source, const SurfacePoint& point) {
      r.triangle_source = source;
      r.contact_triangle = point.triangle;
      r.contact_barycentric = point.barycentric;
      r.contact_point = point.point;
      has_result_[static_cast<size_t>(group[static_cast<size_t>(k)])] = 1;
    };
    const auto take_nearest = [&] {
      ++g.stats.enclosed_ray_overshoots;
      take(ContactTriangleSource::nearest_point_fallback, nearest);
    };
    // Contact triangle: first hit of the ray x + t r, t >= 0; else the nearest surface triangle.
    if (walk && r.penetration_direction.squaredNorm() > 0.5) {
      // The walk from p's stage-1 tet finds the first crossing from p: the ray query's answer.
      SurfacePoint h;
      int steps = 0;
      const bool hit = walk_ray_hit(*surface.mesh, surface.x, r.tet, p, r.penetration_direction,
                                    options_.tet_walk_max_steps, h, &steps,
                                    walk_edges ? &surface.planes : nullptr);
      g.stats.walk_tets += steps;
      if (hit && h.t > overshoot) {
        take_nearest();
        continue;
      }
      if (hit) {
        ++g.stats.walked_rays;
        if (options_.tet_walk_verify) {
          ensure_bvh(surface, g.stats);
          SurfacePoint b;
          if (!surface.bvh.first_ray_hit(p, r.penetration_direction, -1, b) || b.triangle != h.triangle || b.t != h.t) {
            ++g.stats.walk_mismatches;
          }
        }
        take(ContactTriangleSource::ray, h);
        continue;
      }
      ++g.stats.walk_ray_fallbacks;
    }
    if (walk) ensure_bvh(surface, g.stats);
    // The triangle its nearest edge hit (or nearest inner neighbour's) crossed usually is the
    // answer: its ray parameter, plus a rounding margin, bounds the search (same answer, fewer nodes).
    double t_bound = std::numeric_limits<double>::max();
    const int hint = g.hint[static_cast<size_t>(k)];
    double t_hint = 0.0;
    if (hint >= 0 && r.penetration_direction.squaredNorm() > 0.5 &&
        surface.bvh.ray_hits_triangle(p, r.penetration_direction, hint, t_hint)) {
      t_bound = t_hint + 1e-9 * (t_hint + p.cwiseAbs().maxCoeff() + surface.mesh->mean_edge_length());
    }
    const auto hit = find_contact_triangle(surface.bvh, p, r.penetration_direction, exclude, t_bound);
    if (!hit) {
      ++g.stats.dropped;
      continue;
    }
    if (hit->source == ContactTriangleSource::ray && hit->point.t > overshoot) {
      take_nearest();
      continue;
    }
    if (hit->source == ContactTriangleSource::nearest_point_fallback) {
      ++g.stats.ray_misses;
      if (r.penetration_direction.squaredNorm() < 0.5) {  // no direction at all: towards the hit
        const Vec3 e = hit->point.point - p;
        const double len = e.norm();
        r.penetration_direction = len > 1e-300 ? Vec3(e / len) : smoothed_normal(surface, hit->point, g);
      }
    }
    take(hit->source, hit->point);
  }
}

}  // namespace pliant
