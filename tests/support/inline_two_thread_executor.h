// A task executor that claims two threads, so a model takes its threaded paths, but runs the chunks
// inline on the calling thread, last chunk first (an order no serial loop takes).
#pragma once

#include <algorithm>
#include <cstddef>

#include "sim/parallel/task_executor.h"

namespace pliant {

class InlineTwoThreadExecutor : public TaskExecutor {
 public:
  int thread_count() const override { return 2; }
  void for_each_chunk(size_t count, size_t chunk, ChunkFunction body) override {
    for (size_t k = (count + chunk - 1) / chunk; k-- > 0;) body(k * chunk, std::min((k + 1) * chunk, count));
  }
};

}  // namespace pliant
