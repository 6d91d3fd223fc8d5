// Counts heap allocations in a test executable by replacing the global operator new/delete.
// Include it in exactly one translation unit of an executable (a test file; test_main.cpp does not).
#pragma once

#include <atomic>
#include <cstdlib>
#include <new>

namespace pliant::testing {
/// Number of operator new calls so far in this process.
inline std::atomic<long long> g_allocations{0};
}  // namespace pliant::testing

void* operator new(std::size_t size) {
  pliant::testing::g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
