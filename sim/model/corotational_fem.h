// Corotational linear FEM (Mueller & Gross, "Interactive Virtual Materials", GI 2004) with linearly
// implicit Euler and conjugate gradients. Design note:
// - Energy: the corotated linear energy per tet, V (mu |F - R|^2 + lambda/2 tr(R^T F - I)^2) with R
//   the rotation of F (sim/model/rotation_extraction.h). Its gradient is exactly
//   P = 2 mu (F - R) + lambda tr(R^T F - I) R (the dR term vanishes because R^T F is symmetric at the
//   extracted R), and f_e = -V P Dm^-T equals Mueller & Gross' f_e = -R K_e (R^T x_e - X_e).
// - Step (Baraff & Witkin 1998 form, Mueller & Gross sec. 5): with K' = sum R K R^T frozen at x_n,
//   D = alpha M + beta K': (M + h D + h^2 K') dv = h (f(x) + f_ext - D v - h K' v),
//   v+ = v + dv, x+ = x + h v+. Solved by CG preconditioned by symmetric block Gauss-Seidel in
//   Eisenstat's form (session 4; block-Jacobi with the matrix-free product or on request),
//   warm-started from the extrapolation of the last two dv; fixed vertices are projected out (their
//   rows and columns are zero, dv = 0). Session 8: the iteration in AVX2/FMA, fused_ssor_kernels.h.
// - K' is assembled once per step into 3x3-block CSR rows (by vertex, upper triangle), row by row
//   (each vertex's blocks summed from the tets around it), from the rotated shape gradients r_j = R g_j:
//   R K_ij R^T = V (mu (r_i . r_j) I + mu r_j r_i^T + lambda r_i r_j^T), K_ji = K_ij^T. The block
//   slots of every tet are precomputed (no search during assembly). The matrix-free product per
//   tet, A = sum_j p_j r_j^T, (K' p)_i = V (mu (A + A^T) + lambda tr(A) I) r_i, is kept as an option.
// - Linearisation state (session 2): one pass over the tets gives, at positions x, the rotations,
//   the elastic forces and the per-tet energies (the rotated shape gradients R Dm^-T are computed
//   from the rotations by their readers since session 5: K' reuse reads only a few); it is cached together
//   with a copy of x. `advance` defers that state at its new positions x_{n+1} to the first use
//   (session 3): the energy report or the next step evaluate it at the positions they get, after
//   the contact stage's edits, in one pass; the frozen-rotation query at x_{n+1}. K' is assembled
//   by advance (row by row, a pass of its own) unless a local update kept it current.
//   A query at positions that differ from the cached ones in a few vertices (a contact edit)
//   re-evaluates only the tets around those vertices (and swaps their blocks in the assembled K'),
//   and any other query a full pass. Every value
//   returned is exact for the positions passed in (bitwise comparison); only the warm starts differ.
// - Energy query (session 6): elastic_energy changes no cached state (a query inside or between
//   steps leaves the run bit for bit). A full pass it runs is kept aside (pass memo, keyed by the
//   positions and the version of the warm starts) and adopted by the next linearisation at those
//   positions, so World's report query plus the next advance still cost one pass.
// - K' reuse (session 5): advance keeps a tet's K' blocks from the rotation they were built from
//   while its current rotation is within stiffness_rotation_tolerance (default 1e-3 rad) of it, and
//   sums again only the vertex rows around tets that moved further. Forces and energies stay exact;
//   the solve's matrix is R~ K R~^T with |R~ - R| <= the tolerance, so a step's v+ differs from the
//   exact linearisation's by at most ~2 tolerance |v+| (tested). Tolerance 0 is the exact path, bit
//   for bit the code before.
// - Incremental system (session 17): the SSOR's D_i, D_i^-1 and transposed lower blocks are
//   computed again only where K' blocks were written since the last advance (the reuse step records
//   them; any other writer of K' makes the next advance rebuild all), while h, alpha, beta, the
//   masses and the fixed flags keep their bits: the same bits as the full rebuild.
// - Gathered products (session 18): the right-hand side's K' v and K' dv_0, the exact first forward
//   sweep and the true-residual checks gather K'_ji^T terms from the fused sweeps' transposed lower
//   blocks (refreshed by every advance that runs the fused sweeps) instead of scattering them: the
//   same terms in the same order, the same bits.
#pragma once

#include <array>
#include <utility>
#include <vector>

#include "sim/model/coarse_correction.h"
#include "sim/model/deformation_model.h"
#include "sim/model/fused_ssor_kernels.h"

namespace pliant {

/// How the implicit solver applies K'.
enum class StiffnessProduct {
  matrix_free,  ///< element by element from rotated shape gradients
  assembled,    ///< 3x3-block sparse matrix assembled once per step (default: faster, measured)
};

/// Preconditioner of the implicit step's conjugate gradients.
enum class Preconditioner {
  block_jacobi,  ///< inverse 3x3 diagonal blocks (the only choice with the matrix-free product)
  ssor,          ///< symmetric block Gauss-Seidel, Eisenstat's form (default with the assembled K')
};

class CorotationalFem final : public DeformationModel {
 public:
  /// Precomputes inverse rest shapes; `product` selects how K' is applied in CG.
  CorotationalFem(TetMeshPtr mesh, const Material& material, const ModelSettings& settings,
                  StiffnessProduct product = StiffnessProduct::assembled);

  ModelKind kind() const override { return ModelKind::corotational_fem; }
  void internal_forces(std::span<const Vec3> x, std::span<Vec3> f) override;
  void internal_forces_at(std::span<const Vec3> x, std::span<const int> vertices, std::span<Vec3> f) override;
  /// Forces at `vertices` with each element's rotation frozen at the cached linearisation state
  /// (after `advance`: the positions it produced), f_e = -R K_e (R^T x_e - X_e): no rotation
  /// extraction. Exact at the cached positions; away from them the error is first order in the
  /// rotation change (docs/deformation-models.md gives the measured error).
  void internal_forces_at_frozen_rotations(std::span<const Vec3> x, std::span<const int> vertices,
                                           std::span<Vec3> f) override;
  /// Forces at `vertices` reusing each element's last exactly extracted rotation R (any earlier
  /// exact or nearby query) while |F - F_R|_F <= rotation_tolerance, with the warped-stiffness
  /// stress R S(sym(R^T F)) (second-order error in the rotation error); elsewhere exact (and R
  /// cached). Design note in corotational_local_query.cpp.
  void internal_forces_at_nearby_rotations(std::span<const Vec3> x, std::span<const int> vertices,
                                           std::span<Vec3> f, double rotation_tolerance) override;
  /// K' d from the assembled blocks of the last advance (rotations of x_n, reused within
  /// stiffness_rotation_tolerance); false unless the product is assembled and the state is the one
  /// advance left, or if a move exceeds the strain tolerance (corotational_local_query.cpp).
  bool stiffness_product_at(std::span<const int> moved, std::span<const Vec3> d, std::span<const int> rows,
                            std::span<Vec3> y, double strain_tolerance) override;
  /// Elastic energy (J) at x, a pure query: the cached linearisation state is not changed (a full
  /// pass it needs is kept aside for the next linearisation at x to adopt, bit for bit).
  double elastic_energy(std::span<const Vec3> x) override;
  IntegrationResult advance(std::span<Vec3> x, std::span<Vec3> v, const IntegrationInput& in) override;
  void set_accuracy(const ModelAccuracy& accuracy) override { accuracy_ = accuracy; }
  /// Threads for the evaluation pass, the rotated gradients and the K' rows (corotational_parallel.cpp).
  void set_executor(TaskExecutor* executor) override { executor_ = executor; }
  ModelAccuracy accuracy() const override { return accuracy_; }

  /// Updates element rotations at x, their rotated shape gradients (the K' of the next solve, and
  /// its assembled blocks), the forces and the energy (a full pass; the cached state then belongs to x).
  void update_rotations(std::span<const Vec3> x);
  /// y = K' p with the rotations of the last linearisation (fixed vertices not projected); uses
  /// the assembled blocks when they are current (inside advance, after update_rotations), else the
  /// matrix-free product.
  void apply_stiffness(std::span<const Vec3> p, std::span<Vec3> y) const;
  /// Selects the CG preconditioner (ssor needs the assembled K'; block_jacobi otherwise).
  void set_preconditioner(Preconditioner preconditioner) { preconditioner_kind_ = preconditioner; }
  /// The CG preconditioner asked for (the matrix-free product always runs block-Jacobi).
  Preconditioner preconditioner() const { return preconditioner_kind_; }
  /// SSOR sweeps with the AVX2/FMA block kernels (session 8; on by default where the CPU has them):
  /// the same solve rounded differently, within the bound of docs/deformation-models.md "Session 8".
  /// false: the exact sweeps, bit for bit the solve before. Ignored where the CPU lacks AVX2/FMA.
  void set_fused_sweeps(bool on);
  /// True when the SSOR sweeps run the AVX2/FMA kernels.
  bool fused_sweeps() const { return fused_sweeps_; }
  /// The coarse correction of the SSOR-PCG (session 13, coarse_correction.h): deflation by the
  /// translations of boxes of about `vertices` free vertices, with the exact sweeps; 0: off.
  void set_coarse_aggregate_size(int vertices) { coarse_aggregate_size_ = vertices; }
  /// Free vertices per coarse aggregate asked for (0: no coarse correction).
  int coarse_aggregate_size() const { return coarse_aggregate_size_; }
  /// Aggregates of the last solve's coarse space (0 if none was used).
  int coarse_aggregates() const { return coarse_aggregate_size_ > 0 ? coarse_.aggregate_count() : 0; }
  /// The step's fixed part in AVX2 lanes (session 9; on by default where the CPU has AVX2): K' rows
  /// (stiffness_row_kernels.h) and the evaluation pass's rotations four tets at a time
  /// (rotation_batch_avx2.h), and since session 11 the local queries' rotations, F, P, sums and K'
  /// products, bit for bit the scalar code's results. false: the code before.
  /// Ignored without AVX2.
  void set_vector_kernels(bool on);
  /// True when the fixed part runs the AVX2 kernels.
  bool vector_kernels() const { return vector_kernels_; }
  /// The evaluation pass's rotations eight tets at a time in AVX-512 registers (session 17; on by
  /// default where the CPU has AVX-512 and the vector kernels are on), bit for bit the 4-lane batch's
  /// and the scalar's. false: four at a time (AVX2). Ignored without AVX-512 or the vector kernels.
  void set_avx512_lanes(bool on);
  /// True when the evaluation pass extracts rotations eight tets at a time.
  bool avx512_lanes() const { return vector_kernels_ && avx512_lanes_; }
  /// True while the assembled K' matches the current rotations: set inside advance and by
  /// update_rotations, kept by local updates, cleared when advance returns (its result is deferred)
  /// and by a query's full pass.
  bool stiffness_is_assembled() const { return stiffness_assembled_; }
  /// Reuses a tet's K' blocks in advance while its rotation stays within `radians` of the one they
  /// were built from (0: K' from the current rotations every step, Mueller & Gross' linearisation
  /// at x_n). Forces and energies are always exact; only the solve's matrix is approximated.
  void set_stiffness_rotation_tolerance(double radians) { stiffness_rotation_tolerance_ = radians; }
  /// The rotation tolerance (rad) of K' reuse; 0: none.
  double stiffness_rotation_tolerance() const { return stiffness_rotation_tolerance_; }
  /// Diagonal 3x3 blocks D_i = (1 + h alpha) m_i I + h (beta + h) K'_ii of the last advance's system
  /// (kg; identity at fixed vertices), e.g. a contact solve's local compliance h^2 n^T D_i^-1 n.
  std::span<const Mat3> diagonal_system_blocks() const { return diagonal_system_blocks_; }
  /// Vertex rows of K' the last advance summed again (all of them without reuse).
  size_t reassembled_rows() const { return reassembled_rows_; }
  /// Session 17: advance rebuilds the SSOR's per-step data (the diagonal system blocks D_i, their
  /// inverses, the transposed lower blocks of the fused sweeps) only where K' changed since the last
  /// advance, when h, alpha, beta, the masses and the fixed flags are the bits they were (on by
  /// default; the same bits as the full rebuild). false: all of it rebuilt every step.
  void set_incremental_system(bool on) {
    incremental_system_ = on;
    system_valid_ = false;
  }
  /// Session 18: advance forms K' v and K' dv_0 of its right-hand side by gathering alone, from the
  /// upper blocks and the fused sweeps' transposed lower blocks, and the SSOR's exact first forward
  /// sweep and true-residual checks gather from those blocks too (on by default where the fused sweeps
  /// run; the same bits as the scatters). false: apply_stiffness_pair and the scatters, the code before.
  void set_gathered_stiffness_products(bool on) { gathered_products_ = on; }
  /// True when advance may form its right-hand side's products by gathering (where the fused sweeps run).
  bool gathered_stiffness_products() const { return gathered_products_; }
  /// True when the last advance formed its right-hand side's products by gathering.
  bool last_products_gathered() const { return products_gathered_; }
  /// True when advance updates the SSOR's per-step data incrementally.
  bool incremental_system() const { return incremental_system_; }
  /// Diagonal system block rows (D_i, D_i^-1) the last advance computed (all of them on a full rebuild).
  size_t rebuilt_system_rows() const { return rebuilt_system_rows_; }
  /// Element rotation (from the last evaluation of the linearisation state).
  Mat3 element_rotation(int tet) const { return rotations_[static_cast<size_t>(tet)].toRotationMatrix(); }
  /// Deformation gradient F = Ds Dm^-1 of a tet at positions x.
  Mat3 deformation_gradient(std::span<const Vec3> x, int tet) const;
  const TetMesh& mesh() const { return *mesh_; }

 private:
  Mat3 first_piola(const Mat3& F, const Mat3& R) const;
  /// Mueller & Gross's warped-stiffness stress P = R (mu (G + G^T) + (lambda tr(G - I) - 2 mu) I),
  /// G = R^T F: the linear stress of sym(R^T F) - I rotated by R (Pa), for a rotation held fixed.
  Mat3 warped_stiffness_stress(const Mat3& F, const Mat3& R) const;
  /// -V P Dm^-T: columns are the forces (N) on local vertices 1..3 (vertex 0 gets minus their sum).
  Mat3 element_forces(size_t t, const Mat3& F, const Mat3& R) const;
  /// One full evaluation at x into the given arrays: rotations extracted from `warm_starts` (may be
  /// `rotations` itself), forces (N), per-tet energies (J); returns the energy (J).
  double evaluate_pass(std::span<const Vec3> x, const std::vector<Quat>& warm_starts, std::vector<Quat>& rotations,
                       std::vector<Vec3>& forces, std::vector<double>& tet_energy) const;
  /// Tets in one rotation batch of the local queries (four with the AVX2 lanes, kRotationBatchLanes
  /// otherwise).
  size_t evaluation_batch_lanes() const;
  /// Tets in one batch of evaluate_pass: evaluation_batch_lanes(), eight with the AVX-512 lanes.
  size_t evaluation_pass_lanes() const;
  /// evaluate_pass's per-tet work for tets t0 .. t0 + lanes - 1 (lanes <= evaluation_pass_lanes()):
  /// rotations from `warm_starts` into `rotations`, energies (J) into `tet_energy`, and each tet's
  /// -V P Dm^-T (N) into H[l]; shared by the serial and the threaded pass, so both are the same bits.
  void evaluate_tet_batch(std::span<const Vec3> x, const std::vector<Quat>& warm_starts, std::vector<Quat>& rotations,
                          std::vector<double>& tet_energy, size_t t0, size_t lanes, Mat3* H) const;
  /// Full pass at x: rotations, forces, energies, rotated gradients [and assembled K'] (adopts the
  /// pass memo when it belongs to x and the current warm starts).
  void linearise(std::span<const Vec3> x, bool assemble);
  /// Energy at x differing from state_x_ in changed_vertices_ only, without changing the state.
  double energy_with_changed_vertices(std::span<const Vec3> x);
  /// Makes the cached state belong to x: nothing if x is the cached positions, the tets around the
  /// changed vertices if few changed, else a full pass.
  void refresh_state(std::span<const Vec3> x);
  /// Rotated shape gradients R Dm^-T of tet t from its current rotation (bit for bit what
  /// rotated_gradients_ hold when current).
  Mat3 rotated_gradient(size_t t) const;
  /// Fills rotated_gradients_ from rotations_ unless they are current.
  void refresh_rotated_gradients() const;
  /// Adds sign times the tet's R K_e R^T blocks (from its rotated shape gradients) to the assembled K'.
  void assemble_tet(size_t t, const Mat3& rotated_gradients, double sign);
  /// Assembles K' row by row from the rotated shape gradients of every tet.
  void assemble_stiffness();
  /// Sums vertex row i of K' from `gradients` (per tet, rotated shape gradients) of the tets around i;
  /// with block_dirty (a flag per block), only the flagged blocks (the same sums, the same bits).
  void assemble_row(size_t i, const Mat3* gradients, const char* block_dirty = nullptr);
  /// Every vertex row of K' from `gradients`, serially: assemble_row for each i, bit for bit (by tet
  /// in AVX2 lanes where the kernels run, stiffness_row_kernels.h).
  void assemble_all_rows(const Mat3* gradients);
  /// advance's K': assemble_stiffness, or only the rows around tets whose rotation left the
  /// tolerance of stiffness_rotation_tolerance_.
  void assemble_step_stiffness();
  /// (K' p)_i from the upper-triangle row i plus the partial sum already in y_i; adds the row's
  /// transposed blocks times p_i to y_j, j > i.
  Vec3 row_product(size_t i, std::span<const Vec3> p, std::span<Vec3> y) const;
  /// Iterations run and the final relative residual |rhs - A dv| / |rhs| of a CG solve.
  struct CgOutcome {
    int iterations = 0;
    double residual = 0.0;
  };
  /// CG with block-Jacobi from the warm start in dv_ (its residual r_ and relative residual given).
  CgOutcome solve_jacobi(double residual, double rhs_norm, double mass_scale, double stiffness_scale,
                         std::span<const double> masses, std::span<const char> fixed);
  /// advance's diagonal system blocks D_i = mass_scale m_i I + stiffness_scale K'_ii (identity at
  /// fixed rows) and their inverses (zero at fixed rows and where det D_i <= 0), in
  /// diagonal_system_blocks_ and preconditioner_, for the assembled K': every row, or only the
  /// groups of four rows around the rows whose K'_ii changed since the last advance (session 17).
  /// Returns SSOR's test: every unfixed D_i passes (det > 0 and its leading minors positive).
  bool build_diagonal_system(double mass_scale, double stiffness_scale, const IntegrationInput& in);
  /// D_i and D_i^-1 of rows 4 g .. 4 g + 3 (fewer in the last group), the full build's expressions
  /// and kernel lanes (so the same bits); returns the group's SSOR test.
  bool build_diagonal_group(size_t g, double mass_scale, double stiffness_scale, const IntegrationInput& in);
  /// CG with symmetric block Gauss-Seidel in Eisenstat's form (assembled K'; same inputs).
  CgOutcome solve_ssor(double residual, double rhs_norm, double stiffness_scale, std::span<const char> fixed);
  /// Filtered CG (Baraff & Witkin 1998, sec. 5.3) for advance with in.constraint_normals: each
  /// constrained vertex's dv . n is prescribed, the rest solved with block-Jacobi filtered by
  /// S_i = I - n n^T; constraints that pull are released and the solve repeated (design note in
  /// corotational_constrained_solve.cpp).
  CgOutcome solve_constrained(std::span<const Vec3> v, double mass_scale, double stiffness_scale,
                              const IntegrationInput& in);
  /// ya = K' a and yb = K' b from the assembled blocks in one pass over the rows (each result as
  /// apply_stiffness gives it, bit for bit). Rows flagged in `unused_rows` where a and b are exactly
  /// zero (advance: the fixed vertices) are not multiplied and their results set to zero; every
  /// other row's result is unchanged bit for bit.
  void apply_stiffness_pair(std::span<const Vec3> a, std::span<Vec3> ya, std::span<const Vec3> b, std::span<Vec3> yb,
                            std::span<const char> unused_rows = {}) const;
  /// y = (mass_scale M + stiffness_scale K') p with fixed rows zeroed; returns p . y.
  double multiply_system(std::span<const Vec3> p, std::span<Vec3> y, double mass_scale, double stiffness_scale,
                         std::span<const double> masses, std::span<const char> fixed) const;

  TetMeshPtr mesh_;
  double mu_ = 0.0;      ///< Lame mu (Pa)
  double lambda_ = 0.0;  ///< Lame lambda (Pa)
  double alpha_ = 0.0;   ///< Rayleigh mass damping (1/s)
  double beta_ = 0.0;    ///< Rayleigh stiffness damping (s)
  ModelAccuracy accuracy_;
  StiffnessProduct product_;

  // Constant per tet.
  std::vector<Mat3> rest_shape_inverse_;  ///< Dm^-1
  std::vector<double> volume_;            ///< rest volume V (m^3)

  // Linearisation state at positions state_x_ (valid when state_valid_).
  std::vector<Quat> rotations_;
  /// Columns V-free r_1..r_3 = R Dm^-T columns; filled on demand from rotations_ (session 5: the
  /// full pass does not write them, most steps read only the few of tets whose K' blocks change).
  mutable std::vector<Mat3> rotated_gradients_;
  mutable bool gradients_current_ = true;  ///< rotated_gradients_ belong to rotations_
  std::vector<double> tet_energy_;       ///< elastic energy per tet (J)
  std::vector<Vec3> forces_;             ///< elastic forces (N)
  double energy_ = 0.0;                  ///< sum of tet_energy_ (J)
  std::vector<Vec3> state_x_;            ///< the positions (m) all of the above belong to
  bool state_valid_ = false;
  bool state_deferred_ = false;          ///< advance left x_{n+1} in state_x_, not yet evaluated
  std::vector<int> changed_vertices_;    ///< scratch of refresh_state (capacity reserved)
  std::vector<unsigned> tet_stamp_;      ///< visit marks of refresh_state and the energy query
  unsigned stamp_ = 0;
  unsigned long rotations_version_ = 0;  ///< counts writes of rotations_ (the pass memo's key)
  // Pass memo (elastic_energy): a full pass at pass_memo_x_ from the warm starts of version
  // pass_memo_version_, for linearise to adopt.
  bool pass_memo_valid_ = false;
  unsigned long pass_memo_version_ = 0;
  std::vector<Vec3> pass_memo_x_;
  std::vector<Quat> pass_memo_rotations_;
  std::vector<Vec3> pass_memo_forces_;
  std::vector<double> pass_memo_tet_energy_;
  double pass_memo_energy_ = 0.0;
  std::vector<double> query_tet_energy_;  ///< scratch of energy_with_changed_vertices (J)

  // Assembled K' (3x3 blocks, CSR by vertex rows, upper triangle: K_ii first, then j > i).
  std::vector<int> block_row_offsets_, block_cols_;
  std::vector<int> diagonal_blocks_;             ///< block index of (i, i)
  std::vector<std::array<int, 16>> tet_blocks_;  ///< block index of (i, j) for local i, j; -1 below the diagonal
  std::vector<int> tet_block_lists_;  ///< tet_block_lists of tet_blocks_ (the K' sum by tet, session 16)
  /// A tet around a vertex and the vertex's local index (0..3) in it.
  struct TetCorner {
    int tet;
    int local;
  };
  std::vector<TetCorner> corners_;   ///< by vertex, ascending tet (row-by-row assembly, local queries)
  std::vector<int> corner_offsets_;  ///< corners_ of vertex v: [corner_offsets_[v], corner_offsets_[v + 1])
  std::vector<Mat3> blocks_;
  bool stiffness_assembled_ = false;
  // K' reuse (assemble_step_stiffness): the rotation and rotated gradients each tet's blocks hold.
  double stiffness_rotation_tolerance_ = kDefaultStiffnessRotationTolerance;  ///< rad; 0: no reuse (the constructor: ModelSettings)
  std::vector<Quat> block_rotations_;
  std::vector<Mat3> block_gradients_;
  std::vector<char> row_dirty_;                ///< scratch: rows to sum again
  bool step_blocks_valid_ = false;             ///< blocks_ = the rows of block_gradients_
  size_t reassembled_rows_ = 0;

  // Per-step scratch, sized once.
  std::vector<Vec3> rhs_, dv_, r_, z_, p_, q_, kv_;
  std::vector<Vec3> sweep_rows_;  ///< solve_ssor scratch: the rows of (D + L) r of a true-residual check
  std::vector<Vec3> dv_previous_;  ///< the dv of the step before the last
  std::vector<Vec3> constraint_normal_;  ///< solve_constrained scratch: active unit normals (0: free)
  std::vector<Mat3> preconditioner_;         ///< inverse diagonal blocks D_i^-1 of the system (0 or I: fixed)
  std::vector<Mat3> diagonal_system_blocks_;  ///< D_i = (1 + h alpha) m_i I + h (beta + h) K'_ii (I: fixed)
  Preconditioner preconditioner_kind_ = Preconditioner::ssor;
  bool fused_sweeps_ = false;  ///< set_fused_sweeps (the constructor: ModelSettings::fused_sweeps where available)
  bool vector_kernels_ = false;  ///< set_vector_kernels (the constructor: on where available)
  bool avx512_lanes_ = false;    ///< set_avx512_lanes (the constructor: on where available)
  int coarse_aggregate_size_ = 0;  ///< set_coarse_aggregate_size (the constructor: ModelSettings)
  CoarseSpace coarse_;             ///< aggregates and deflation operators of the coarse correction

  // Local queries (sim/model/corotational_local_query.cpp): each tet around the asked vertices is
  // evaluated once per query, into a slot; buffers sized on first use and kept.
  /// Starts a local query: forgets the slots of the last one (sizes the per-tet marks once).
  void begin_local_query();
  /// Slot of tet t in this query, and whether it was just created (the caller fills it).
  std::pair<size_t, bool> local_query_slot(size_t t);
  /// Rotation of tet t at the state the last advance left (state_x_), for the frozen query:
  /// rotations_ when the state is evaluated, else extracted lazily (warm start rotations_) and
  /// cached per tet, keyed by the bits of its deformation gradient at state_x_.
  Mat3 frozen_rotation(size_t t);
  std::vector<unsigned> query_mark_;    ///< per tet: query_generation_ when it has a slot
  std::vector<int> query_slot_;         ///< per tet: its slot (valid when marked)
  unsigned query_generation_ = 0;
  size_t query_slots_ = 0;              ///< slots used by the current query
  std::vector<Mat3> query_forces_;      ///< per slot: exact query P (Pa); frozen: -V P Dm^-T (N)
  std::vector<Mat3> frozen_rotation_;   ///< per tet: rotation at the deferred state (cache)
  std::vector<Mat3> frozen_key_;        ///< per tet: F at state_x_ the cached rotation belongs to
  std::vector<char> frozen_cached_;     ///< per tet: 1 when the cache entry is filled
  /// Records tet t's exactly extracted rotation R at deformation gradient F for nearby queries.
  void remember_rotation(size_t t, const Mat3& F, const Mat3& R);
  /// The exact query's stress P of tet t at F: rotation extracted warm-started from rotations_ (left
  /// as it is) and remembered for nearby queries.
  Mat3 exact_query_stress(size_t t, const Mat3& F);
  /// Fills the slots of the tets in query_pending_ (their F parked in query_forces_) with the exact
  /// query's stress, extracting four rotations per call with the vector kernels (else
  /// kRotationBatchLanes; bit for bit the scalar's either way).
  void exact_query_stresses_batched();
  /// Deformation gradient of tet t at x for a query, into F: deformation_gradient's bits, in AVX2
  /// lanes when `kernels` (vector kernels on and tet_gradient_kernels_available()).
  void query_deformation_gradient(std::span<const Vec3> x, size_t t, bool kernels, Mat3& F) const;
  /// f at `vertices` from the current query's slots: -V P g_j summed over each vertex's tets.
  void sum_query_stresses(std::span<const int> vertices, std::span<Vec3> f) const;
  std::vector<int> query_pending_;      ///< tets of the current query waiting for an exact extraction
  std::vector<Vec3> corner_gradients_;  ///< per corner (corners_): rest shape gradient g_j (1/m), constant
  std::vector<Mat3> nearby_rotation_;   ///< per tet: last exactly extracted rotation
  std::vector<Mat3> nearby_key_;        ///< per tet: the F it was extracted from
  std::vector<char> nearby_cached_;     ///< per tet: 1 when filled
  // stiffness_product_at scratch (session 6): per vertex its entry in `moved` or -1, and K' d.
  std::vector<int> product_entry_;
  std::vector<Vec3> product_sum_;
  std::vector<double> vertex_gradient_bound_;  ///< per vertex: largest |grad N| over its tets (1/m)

  // Threads (sim/model/corotational_parallel.cpp; session 9): used only when executor_ runs parallel.
  TaskExecutor* executor_ = nullptr;
  /// evaluate_pass on threads: per tet rotation, energy and element forces in chunks, then the
  /// forces gathered per vertex in ascending tet order and the energy summed in tet order (the
  /// serial pass's operations in its order: the same bits).
  double evaluate_pass_parallel(std::span<const Vec3> x, const std::vector<Quat>& warm_starts,
                                std::vector<Quat>& rotations, std::vector<Vec3>& forces,
                                std::vector<double>& tet_energy) const;
  /// assemble_row(i, gradients) for every i in `rows` (all rows when empty), on threads.
  void assemble_rows_parallel(std::span<const int> rows, const Mat3* gradients);
  /// rotated_gradients_[t] = rotated_gradient(t) for every tet, on threads.
  void refresh_rotated_gradients_parallel() const;
  /// apply_stiffness_pair on threads: each row gathers its transposed blocks K'_ji^T p_j (j < i,
  /// ascending j: the order the serial product scatters them in) before its own row, the same bits.
  void apply_stiffness_pair_parallel(std::span<const Vec3> a, std::span<Vec3> ya, std::span<const Vec3> b,
                                     std::span<Vec3> yb) const;
  /// Refreshes lower_transposed_ from blocks_ and `fixed` (only the blocks written since the last
  /// advance where that is valid, session 17) and sets lower_transposed_refreshed_.
  void refresh_lower_transposed(std::span<const char> fixed);
  /// True when advance may use stiffness_product_pair_gathered for K' v and K' dv (session 18).
  bool gathered_products_possible(std::span<const Vec3> v, std::span<const char> fixed) const;
  bool gathered_products_ = true;   ///< set_gathered_stiffness_products
  bool products_gathered_ = false;  ///< last_products_gathered
  /// Builds lower_ from the block pattern (once: the sparsity is the mesh's).
  void build_lower_pattern() const;
  /// The upper blocks by column: for row i, the blocks (j, i) with j < i, ascending j.
  mutable LowerTrianglePattern lower_;
  /// The fused forward sweep's K'_ji^T in lower_'s order, zero for fixed rows j, + 4 padding (per solve).
  std::vector<double> lower_transposed_;
  mutable std::vector<Mat3> tet_force_scratch_;  ///< per tet: -V P Dm^-T of the parallel pass (N)
  std::vector<int> dirty_rows_;                  ///< rows the reuse step sums again (parallel path)
  std::vector<char> tet_moved_;                  ///< per tet: its rotation left the reuse tolerance
  std::vector<int> moved_tets_;                  ///< scratch: tets the serial reuse step rebuilds, ascending
  std::vector<char> block_dirty_;                ///< scratch: per block, one of its tets is in moved_tets_ (0 between steps)

  // Incremental system update (session 17): with K' reuse most K' blocks keep their bits from one
  // step to the next, and so do the D_i, D_i^-1 and transposed lower blocks made from them.
  bool incremental_system_ = true;  ///< set_incremental_system
  /// diagonal_system_blocks_ and preconditioner_ (up to the fixed rows' inverse, set each step) were
  /// built by the last advance from its key below and blocks_ as they were then.
  bool system_valid_ = false;
  double system_mass_scale_ = 0.0, system_stiffness_scale_ = 0.0;  ///< the key: 1 + h alpha, h (beta + h)
  std::vector<double> system_masses_;                               ///< the key: masses (kg)
  std::vector<char> system_fixed_;                                  ///< the key: fixed flags
  std::vector<char> system_group_pass_;  ///< per group of four rows: its SSOR test passed
  size_t system_failing_groups_ = 0;     ///< groups whose SSOR test failed
  size_t rebuilt_system_rows_ = 0;       ///< rebuilt_system_rows()
  /// True while changed_blocks_ and changed_rows_ hold every block and diagonal row of K' written
  /// since the end of the last advance (the K' reuse step records them; any other writer of blocks_
  /// clears it).
  bool block_changes_tracked_ = false;
  std::vector<int> changed_blocks_;  ///< blocks_ written since the last advance (repeats allowed)
  std::vector<int> changed_rows_;    ///< rows whose K'_ii was written since then, ascending per step
  /// lower_transposed_ belongs to blocks_ as they were at the end of the last advance and to
  /// system_fixed_ (it is refreshed by every advance that solves with the fused sweeps, else dropped).
  bool lower_transposed_valid_ = false;
  bool lower_transposed_refreshed_ = false;  ///< scratch of advance: solve_ssor refreshed it
  bool system_fixed_unchanged_ = false;      ///< scratch of advance: in.fixed equals the last advance's
  mutable std::vector<int> lower_entry_of_block_;  ///< per upper block, its entry in lower_ (-1: diagonal)
};

}  // namespace pliant
