#include "interaction/tbb_task_executor.h"

#include <stdexcept>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

namespace pliant {

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
  // One task per chunk at most (simple_partitioner, grain 1): the chunks are the caller's, fixed by
  // count and chunk, whatever the threads; which thread runs which chunk does not change a result.
  arena_->arena.execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, chunks, 1),
        [&](const tbb::blocked_range<size_t>& r) {
          for (size_t k = r.begin(); k < r.end(); ++k) {
            const size_t begin = k * chunk;
            body(begin, begin + chunk < count ? begin + chunk : count);
          }
        },
        tbb::simple_partitioner());
  });
}

std::unique_ptr<TaskExecutor> make_task_executor(int threads) {
  if (threads <= 1) return nullptr;
  return std::make_unique<TbbTaskExecutor>(threads);
}

}  // namespace pliant
