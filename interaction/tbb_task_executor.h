// A TaskExecutor (sim/parallel/task_executor.h) on oneTBB: the threads a World runs its step's
// loops on when a scene or the command line asks for more than one ("threads", --threads).
#pragma once

#include <memory>

#include "sim/parallel/task_executor.h"

namespace pliant {

/// Runs chunks on a oneTBB task arena of a fixed number of threads (the caller's thread included).
class TbbTaskExecutor final : public TaskExecutor {
 public:
  /// An arena of `threads` threads (>= 1; 1 runs everything on the calling thread).
  explicit TbbTaskExecutor(int threads);
  ~TbbTaskExecutor() override;
  TbbTaskExecutor(const TbbTaskExecutor&) = delete;
  TbbTaskExecutor& operator=(const TbbTaskExecutor&) = delete;

  int thread_count() const override { return threads_; }
  void for_each_chunk(size_t count, size_t chunk, ChunkFunction body) override;

 private:
  struct Arena;
  int threads_;
  std::unique_ptr<Arena> arena_;
};

/// An executor for `threads` threads, or null for 1 (the World's inline default).
std::unique_ptr<TaskExecutor> make_task_executor(int threads);

}  // namespace pliant
