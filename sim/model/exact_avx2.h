// The shared preamble of the exact AVX2 kernels (tet_gradient_kernels, diagonal_block_kernels,
// query_stress_kernels, stiffness_product_kernels; sessions 10-11). Design note: each kernel runs
// a few tets or blocks in the lanes of 256-bit registers, each lane the scalar code's operations
// in its order, inside functions compiled for "avx2" alone: with "fma" enabled GCC would contract
// a * b + c (its C++ default is -ffp-contract=fast) and the lanes would no longer give the scalar
// code's bits. Only portable GCC x86-64 builds get them (a build with AVX on everywhere contracts
// its scalar code too, so there is nothing exact to match).
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__AVX__)
#include <immintrin.h>
#define PLIANT_EXACT_AVX2_KERNELS 1
#define PLIANT_AVX2_ONLY __attribute__((target("avx2")))
#endif

namespace pliant {

/// True when the exact AVX2 kernels are built in and this CPU runs AVX2 (checked once).
bool exact_avx2_kernels_available();

}  // namespace pliant
