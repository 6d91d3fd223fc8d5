// The contact search's K' products (CorotationalFem::stiffness_product_at, session 6) in 256-bit
// lanes (AVX2, no FMA), chosen at run time (session 11, issues #5 and #8). Design note: for each
// moved vertex j the product walks j's upper-triangle block row once: K'_jj d_j and, for every
// column c > j, K'_jc^T d_j into c's sum and K'_jc d_c into j's sum when c moved too. In the
// portable build Eigen evaluates B d as rows 0-1 (a_0 + a_1) + a_2, row 2 a_0 + (a_1 + a_2)
// (a_k = B(i, k) d_k), and B^T d as (a_0 + a_1) + a_2 in every row (a_k = B(k, i) d_k; both checked
// on 2e5 random inputs). Here a product is one 4-lane vector: B's columns for B d, its rows (a 3x3
// transpose in registers) for B^T d, each product and sum the scalar code's, separately rounded
// (compiled for "avx2" alone, no contraction): the sums are stiffness_product_at's bit for bit
// (tested: corotational_query_kernels_test). A -march=native build reports the kernel unavailable.
#pragma once

#include <cstddef>

#include "sim/math_types.h"

namespace pliant {

/// True when this CPU runs stiffness_row_product_avx2 and it is the scalar code's bit for bit.
bool stiffness_product_kernels_available();

/// One moved row j of stiffness_product_at: with the row's `count` blocks (blocks[0] = K'_jj, then
/// K'_jc for the columns cols[b] > j), d_j and, per vertex, its entry in the moved list (entry[c] >=
/// 0) with that entry's move d[entry[c]] (m), adds K'_jj d_j + sum K'_jc d_c to sum[j] and K'_jc^T
/// d_j to sum[c], in the scalar loop's order (sum: N/m times m, packed xyz per vertex).
void stiffness_row_product_avx2(const Mat3* blocks, const int* cols, size_t count, size_t j, const Vec3& dj,
                                const int* entry, const Vec3* d, double* sum);

}  // namespace pliant
