// Stage 1: optimized spatial hashing (Teschner et al., VMV 2003; algorithms.md section 1).
//
// Design note. All bodies share one hash table of prime size n (next prime above 3x the inserted
// vertex count, grown but never shrunk so the allocation is reused; session 17: the inserted, not
// all hashed, vertices). Buckets carry a time stamp
// instead of being cleared: a bucket whose stamp is not the current step's is empty. Each bucket is
// a singly linked list threaded through a flat array of hashed vertices, each of which keeps a copy
// of its position and its integer cell, so pass 2 reads one contiguous record per candidate and
// drops hash collisions from other cells with three integer compares. Bodies are inserted in
// order, so a bucket's list holds each body's entries as one run; every entry links past its run,
// and pass 2 jumps over a whole run of a body that may not touch the tet's body (a tool's own
// vertices crowding the cells of its own tets cost one read per bucket). Pass 1 hashes the vertices
// of every body that may touch some body (CollisionFilter), but only those inside the bounds of a
// body they may touch (a tool's shaft, the tissue away from the tool: never inside a partner's
// tet); pass 2 walks the cells covered by each tet's AABB for every body that may be penetrated,
// after an out-code reject against the bounds of the inserted partner vertices, skips the tet's
// own vertices, tests the AABB, then the barycentric coordinates (closed; within rounding across a
// face shared with another tet, TetBarycentricFrame::contains_in_body, so a vertex on an internal
// face or edge of an aligned body is not lost). Candidates are sorted so the output is ordered by
// (body, vertex, penetrated body) and one tet per (vertex, penetrated body) is kept: the one with
// the largest minimum barycentric coordinate (the tet the vertex is deepest in), ties by index.
// Bodies filtered out cost nothing; no allocation happens once the buffers have grown. A body with
// a rigid pose (a kinematic instrument, CollisionBody::rigid_pose) is searched the other way round
// (session 8): each inserted partner vertex is mapped into the body's rest frame and tested against
// the tets of its cell in a grid built once (RigidTetGrid), with the same test, so the result is
// the cell walk's bit for bit; positions off the pose by more than the grid's pad fall back to it.
// Session 11 (the piled fruit dish): before pass 2 walks a deformable body's tets, the cells of
// its bounds that hold an inserted partner vertex are marked in a bitmap (occupied cells); a tet
// none of whose cells is marked cannot hold a partner vertex, so its hash look-ups are skipped. In
// a pile every fruit lies inside the union of its partners' bounds, but only its rim's cells hold
// a neighbour's vertex. A body no partner's inserted vertices reach is skipped whole. Exact: the
// skipped tets are those whose look-ups would find nothing.
// Session 17: a body's partners are the bodies it may touch whose bounds overlap its own, found by
// a grid over the bodies' bounds (BoundsOverlap) instead of a loop over every body in each of the
// per-body passes: those loops were B^2, the part of detection that grew faster than the tets.
// Session 22 (threads): pass 2 runs over chunks of penetrated bodies, each with its own scratch
// (PenetratedBodyScratch), through the caller's executor; pass 1, the table and the rigid grids are
// built serially before it, and the chunks' candidates are sorted together as before.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sim/collision/bounds_overlap.h"
#include "sim/collision/box_set_outcodes.h"
#include "sim/collision/contact_types.h"
#include "sim/collision/rigid_tet_grid.h"
#include "sim/parallel/task_executor.h"

namespace pliant {

/// Tuning of the spatial hash; the defaults follow Teschner et al. 2003.
struct SpatialHashOptions {
  /// Cell size as a multiple of the average edge length (paper: optimum near 1).
  double cell_size_factor = 1.0;
  /// Table size: the next prime above this multiple of the inserted vertex count.
  double table_size_factor = 3.0;
};

/// What the last detect() did (for benchmarks and diagnostics).
struct SpatialHashStats {
  int hashed_vertices = 0;   ///< vertices of the bodies taking part in pass 1
  int inserted_vertices = 0; ///< of those, inserted: inside the bounds of a body they may touch (sizes the table)
  int table_size = 0;        ///< prime number of buckets
  double cell_size = 0.0;    ///< edge of a cubic cell (m)
  long long tets_visited = 0;       ///< tets whose cells were looked up in pass 2
  long long cells_visited = 0;      ///< cell lookups in pass 2
  long long inside_tests = 0;       ///< barycentric tests performed
  long long candidates_found = 0;   ///< (vertex, tet) pairs found inside, before de-duplication
  long long entries_scanned = 0;    ///< bucket entries read in pass 2 (skipped body runs not counted)
  long long tets_skipped_unoccupied = 0;  ///< tets skipped in pass 2: no partner vertex in their cells
  long long tets_skipped_partner_boxes = 0;  ///< tets skipped in pass 2: their box meets no partner's box of vertices in the body's bounds
};

class SpatialHash {
 public:
  SpatialHash() = default;
  /// A hash with non-default tuning.
  explicit SpatialHash(const SpatialHashOptions& options) : options_(options) {}

  /// Finds every vertex lying inside a tetrahedron of a body it may collide with (per `filter`),
  /// including the same body when self-collision is allowed (a tet's own vertices excluded).
  /// `out` is cleared first; results are ordered by (body, vertex) so the step is deterministic.
  /// With an `executor` of two or more threads pass 2 runs over chunks of penetrated bodies side by
  /// side; the result and the counters are the serial run's, bit for bit (docs/threads.md).
  void detect(std::span<const CollisionBody> bodies, const CollisionFilter& filter,
              std::vector<VertexInTet>& out, TaskExecutor* executor = nullptr);

  /// Counters of the last detect().
  const SpatialHashStats& stats() const { return stats_; }
  /// The tuning in use.
  const SpatialHashOptions& options() const { return options_; }

  /// Teschner's hash of cell (i, j, k) into [0, table_size), products in unsigned 64-bit arithmetic.
  static std::uint64_t hash_cell(int i, int j, int k, std::uint64_t table_size);
  /// Smallest prime >= n (n >= 2).
  static std::uint64_t next_prime(std::uint64_t n);

 private:
  /// One vertex of pass 1: its position, cell and the next vertex in the same bucket.
  struct HashedVertex {
    Vec3 x;
    int cell[3];
    int body;
    int vertex;
    int next;  ///< index of the next hashed vertex in this bucket, -1 at the end
    int next_body;  ///< first entry after this one's run of same-body entries in the bucket, -1 at the end
  };

  SpatialHashOptions options_;
  SpatialHashStats stats_;
  std::uint32_t stamp_ = 0;
  std::uint64_t table_size_ = 0;  ///< current prime table size; grows, never shrinks
  /// One bucket: the step stamp of its last insert and the head of its list (one cache line read).
  struct Bucket {
    std::uint32_t stamp;
    int head;
  };
  std::vector<Bucket> buckets_;
  std::vector<HashedVertex> hashed_;
  std::vector<char> hashes_vertices_;   ///< per body: its vertices go into the table
  std::vector<char> has_tets_;          ///< per body: its tets are tested in pass 2
  std::vector<Aabb> body_bounds_;       ///< per body: bounds of all its vertices (participating bodies)
  std::vector<Aabb> vertex_bounds_;     ///< per body: bounds of its inserted vertices
  std::vector<Aabb> partner_boxes_;     ///< pass 1 scratch: bounds of the bodies one body may touch
  std::vector<char> takes_part_;        ///< per body: hashes its vertices or has its tets tested
  BoundsOverlap bounds_overlap_;        ///< the body pairs whose bounds overlap (this detect's)
  std::vector<VertexInTet> candidates_;  ///< with several chunks: all chunks' candidates, gathered for the sort
  std::vector<RigidTetGrid> rigid_grids_;  ///< per body with a rigid pose: its tets in the rest frame
  std::vector<int> hashed_begin_;       ///< per body (and one past the last): its first entry in hashed_

  /// Pass 2's scratch for one chunk of penetrated bodies (one chunk: the serial pass). Each chunk
  /// writes only its own, so chunks may run side by side; the candidates and counters are merged
  /// afterwards, and the candidates' sort makes the merged order the serial one.
  struct PenetratedBodyScratch {
    SpatialHashStats stats;              ///< pass 2's counters over this chunk's bodies
    std::vector<VertexInTet> candidates;  ///< pairs found in this chunk's bodies, before the sort
    BoxSetOutcodes partner_outcodes;     ///< per partner, its inserted vertices in the penetrated body's bounds
    std::vector<char> partner;           ///< 1 for the bodies in partners
    std::vector<int> partners;           ///< the penetrated body's partners (overlapping bounds, allowed), ascending
    std::vector<std::uint64_t> occupied;  ///< bitmap of the penetrated body's cells holding a partner vertex
    int occupied_origin[3] = {0, 0, 0};  ///< cell of the bitmap's bit 0
    int occupied_dims[3] = {0, 0, 0};    ///< cells of the bitmap along x, y, z (0: no bitmap, no skipping)
  };
  std::vector<PenetratedBodyScratch> pass_two_;  ///< one per chunk; grown, never shrunk

  /// Pass 2 for penetrated body b: every partner vertex inside one of its tets into s.candidates.
  void penetrate(int b, const CollisionBody& cb, const CollisionFilter& filter, double inv_l,
                 PenetratedBodyScratch& s) const;
  /// Gathers the inserted vertices of b's partners (s.partners) that lie in b's bounds: per partner
  /// their box (s.partner_outcodes), and the cells holding them (the occupied bitmap; none when b's
  /// bounds span too many cells). Returns how many there are.
  long long gather_partner_vertices(int b, double inv_l, PenetratedBodyScratch& s) const;
  /// Whether some cell of [i0, i1] x [j0, j1] x [k0, k1] (inside b's bounds) holds a partner vertex;
  /// true when there is no bitmap.
  static bool any_cell_occupied(const PenetratedBodyScratch& s, int i0, int i1, int j0, int j1, int k0, int k1);

  /// Pass 2 for a rigid body b from the inserted partner vertices (each looked up in b's rest-frame
  /// grid, built before pass 2); false (nothing done) when b's positions are not pose(rest) within
  /// the grid's pad.
  bool rigid_pass(int b, const CollisionBody& cb, PenetratedBodyScratch& s) const;
};

}  // namespace pliant
