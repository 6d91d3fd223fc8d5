#include "interaction/tbb_task_executor.h"

#include <stdexcept>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

namespace pliant {

namespace {

// ThreadSanitizer sees no ordering through Debian's libtbb (built without -fsanitize=thread): the
// caller's writes before a loop would "race" with the chunks that read them, and the chunks' writes
// with the caller's reads after it. These two edges are what the arena guarantees (a chunk starts
// after the call, the call returns after every chunk), told to TSan by hand; the chunks stay
// unordered among themselves, so a race between two chunks is still reported. No-ops otherwise.
#if defined(__SANITIZE_THREAD__)
extern "C" void __tsan_acquire(void* address);
extern "C" void __tsan_release(void* address);
void fork_join_release(void* edge) { __tsan_release(edge); }
void fork_join_acquire(void* edge) { __tsan_acquire(edge); }
#else
void fork_join_release(void*) {}
void fork_join_acquire(void*) {}
#endif

}  // namespace

struct TbbTaskExecutor::Arena {
  explicit Arena(int threads) : arena(threads) {}
  tbb::task_arena arena;
};

TbbTaskExecutor::TbbTaskExecutor(int threads) : threads_(threads) {
  if (threads < 1) throw std::invalid_argument("TbbTaskExecutor: threads must be at least 1");
  arena_ = std::make_unique<Arena>(threads);
}

TbbTaskExecutor::~TbbTaskExecutor() = default;

void TbbTaskExecutor::for_each_chunk(size_t count, size_t chunk, ChunkFunction body) {
  if (count == 0) return;
  const size_t chunks = (count + chunk - 1) / chunk;
  char fork = 0, join = 0;  // the addresses of the two edges for ThreadSanitizer
  fork_join_release(&fork);
  // One task per chunk at most (simple_partitioner, grain 1): the chunks are the caller's, fixed by
  // count and chunk, whatever the threads; which thread runs which chunk does not change a result.
  arena_->arena.execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, chunks, 1),
        [&](const tbb::blocked_range<size_t>& r) {
          fork_join_acquire(&fork);
          for (size_t k = r.begin(); k < r.end(); ++k) {
            const size_t begin = k * chunk;
            body(begin, begin + chunk < count ? begin + chunk : count);
          }
          fork_join_release(&join);
        },
        tbb::simple_partitioner());
  });
  fork_join_acquire(&join);
}

std::unique_ptr<TaskExecutor> make_task_executor(int threads) {
  if (threads <= 1) return nullptr;
  return std::make_unique<TbbTaskExecutor>(threads);
}

}  // namespace pliant
