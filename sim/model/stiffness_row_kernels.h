// The K' row assembly's per-block arithmetic, and the row product, in 256-bit lanes (AVX2, no
// FMA), chosen at run time (session 9, issue #3). Design note: CorotationalFem::assemble_row sums vertex row i of the
// upper-triangle K' from the corners of the tets around i, each block
//   R K_ab R^T = V (mu (r_a . r_b) I + mu r_b r_a^T + lambda r_a r_b^T)   (a != b),
//   R K_aa R^T = V ((mu + lambda) r_a r_a^T + mu |r_a|^2 I),
// entry by entry in scalar code (~50 instructions per off-diagonal block). Here the nine entries
// of a column-major block are two 4-lane vectors (entries 0-3 and 4-7) plus entry 8: the factors
// of each entry are permuted into its lane, and every lane performs exactly the scalar
// expression's multiplications and additions in the same order (no FMA: the functions are
// compiled for "avx2" only, so the compiler cannot contract), the sum r_a . r_b stays scalar. So
// the blocks are the scalar code's bit for bit (tested: corotational_stiffness_row_kernels_test),
// and nothing downstream changes. The row product (K' v and K' dv of the right-hand side) the
// same way: the gather sum_j K'_ij p_j column by column in the lanes of y_i, the scatter K'_ij^T p_i
// as products in lanes and pairwise horizontal adds, (B_0k p_0 + B_1k p_1) + B_2k p_2 as the scalar
// (the unused fourth product set to -0.0, which added to any x gives x, signed zeros included). Compiled by function attribute, so the portable build keeps
// running on CPUs without AVX2 (stiffness_row_kernels_available()).
#pragma once

#include <cstddef>

namespace pliant {

/// True when this CPU runs sum_stiffness_row.
bool stiffness_row_kernels_available();

/// What one vertex row's assembly reads and writes (CorotationalFem's arrays as raw pointers).
struct StiffnessRowSystem {
  double* blocks;            ///< K' upper-triangle 3x3 blocks, column-major, 9 doubles each
  const double* gradients;   ///< per tet its rotated shape gradients R Dm^-T (columns r_1..r_3), 9 doubles
  const double* volume;      ///< per tet its rest volume (m^3)
  const int* tet_blocks;     ///< per tet 16 block slots (a * 4 + b; -1: below the diagonal)
  const int* corners;        ///< (tet, local index) pairs of the tets around each vertex
  double mu;                 ///< Lame mu (Pa)
  double lambda;             ///< Lame lambda (Pa)
  const int* tet_block_lists = nullptr;  ///< per tet kTetBlockListSize ints (tet_block_lists); sum_stiffness_by_tet
};

/// Ints per tet of tet_block_lists.
inline constexpr size_t kTetBlockListSize = 11;

/// For each of `tet_count` tets (16 block slots each in tet_blocks, as StiffnessRowSystem::tet_blocks):
/// [0] the stored-slot bits (bit 4 a + b set where slot (a, b) >= 0) when the tet stores exactly one
/// block per corner pair (four distinct vertices), -1 otherwise; [1..4] its diagonal slots (a, a);
/// [5..10] the stored slot of each corner pair (0,1) (0,2) (0,3) (1,2) (1,3) (2,3). Built once per
/// mesh for sum_stiffness_by_tet (session 16).
void tet_block_lists(const int* tet_blocks, size_t tet_count, int* lists);

/// Zeroes the blocks [first_block, last_block) of a vertex row and sums into them the blocks of
/// the corners [first_corner, last_corner) (the vertex's, ascending tet): bit for bit
/// CorotationalFem's scalar assemble_row. With block_dirty (one flag per block of the matrix), only
/// the flagged blocks are zeroed and summed (the same sums, so the same bits); the others are left
/// as they are. Only where stiffness_row_kernels_available().
void sum_stiffness_row(const StiffnessRowSystem& sys, size_t first_block, size_t last_block, size_t first_corner,
                       size_t last_corner, const char* block_dirty = nullptr);

/// Zeroes the blocks [0, block_count) and sums into them every vertex row's blocks from the tets
/// [0, tet_count) in tet order: bit for bit sum_stiffness_row over all rows, whose corners are
/// ascending by tet (the order each block's terms are added in both). Session 16: tets with four
/// distinct vertices run four per call, one per lane, their blocks added tet by tet afterwards (the
/// same sums, the same order); sys.tet_block_lists must hold tet_block_lists of sys.tet_blocks. Only
/// where stiffness_row_kernels_available().
void sum_stiffness_by_tet(const StiffnessRowSystem& sys, size_t block_count, size_t tet_count);

/// True when one of a tet corner's four block slots (-1: stored in the other vertex's row) is
/// flagged in block_dirty: the corner adds to a block being summed again.
inline bool corner_adds_to_dirty_block(const int* slots, const char* block_dirty) {
  for (int b = 0; b < 4; ++b) {
    if (slots[b] >= 0 && block_dirty[slots[b]] != 0) return true;
  }
  return false;
}

/// Row i of the upper-triangle product y = K' p (CorotationalFem::row_product, bit for bit): returns
/// in result y_i + K'_ii p_i + sum_j K'_ij p_j and adds K'_ij^T p_i to y_j, j > i, for the blocks
/// [first_block, last_block) of row i (the first is K'_ii). Vectors packed xyz per vertex. Only
/// where stiffness_row_kernels_available().
void stiffness_row_product(const double* blocks, const int* cols, size_t first_block, size_t last_block, size_t i,
                           const double* p, double* y, double* result);

/// What the gathered pair product reads: K' as stored (upper-triangle CSR rows, the first block of
/// row i is K'_ii) and its lower triangle as transposed copies (fused_ssor_kernels.h's
/// LowerTrianglePattern and transpose_lower_blocks: row i's entries k hold K'_ji^T, j < i ascending).
struct StiffnessPairSystem {
  const double* blocks;          ///< K' upper-triangle 3x3 blocks, column-major, 9 doubles each
  const int* col_entries;        ///< per block 3 cols[b] (the first double of its column vertex)
  const int* offsets;            ///< n + 1 row offsets of blocks
  const double* lower;           ///< per lower entry K'_ji^T (zero where row j is skipped), + 4 padding doubles
  const int* lower_row_entries;  ///< per lower entry 3 j
  const int* lower_offsets;      ///< n + 1 row offsets of the lower entries
  const char* skip;              ///< nonzero: a row whose a and b are exactly zero and whose results are set to zero
  size_t n;                      ///< rows (vertices)
};

/// ya = K' a and yb = K' b, every row by gathering alone (session 18): row i's sum is its lower
/// entries' K'_ji^T a_j (j ascending, each (B_0k a_0 + B_1k a_1) + B_2k a_2 added to a sum that
/// starts at +0), then K'_ii a_i, then each upper block's K'_ij a_j, ascending j; a skipped row's
/// results are zero. That is, term for term and in order, what the upper-triangle row product
/// (stiffness_row_product over the rows ascending, with the skipped rows left out) adds into y_i:
/// the same bits, where every skipped row's a and b are exactly zero and its lower copies are zero
/// or its K'^T (a zero product added to a sum that is never -0 leaves it as it was). Both vectors
/// share each block's loads. Only where stiffness_row_kernels_available().
void stiffness_product_pair_gathered(const StiffnessPairSystem& sys, const double* a, const double* b, double* ya,
                                     double* yb);

}  // namespace pliant
