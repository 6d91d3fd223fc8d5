// The executor a World may be given to run loops on more than one thread (DESIGN.md: sim/ has "no
// threads it did not ask for"). sim/ declares only this interface; the caller supplies an
// implementation (interaction/tbb_task_executor.h). Without one, every loop runs inline, in order:
// the single-threaded step, bit for bit.
//
// Determinism contract (docs/threads.md): a parallel loop hands out chunks [begin, end) of a fixed
// size chosen by the caller (never by the thread count), and each chunk writes only its own
// outputs. Sums, maxima and any other combination across chunks are done afterwards, serially, in
// index order. So the result of a step is the same bits for every thread count.
#pragma once

#include <cstddef>
#include <type_traits>
#include <utility>

namespace pliant {

/// A non-owning reference to a callable taking a chunk [begin, end) (no allocation, unlike
/// std::function: the step allocates nothing once warm).
class ChunkFunction {
 public:
  template <class F, class = std::enable_if_t<!std::is_same_v<std::decay_t<F>, ChunkFunction>>>
  ChunkFunction(F& f)  // NOLINT: implicit on purpose, like std::function_ref
      : object_(static_cast<void*>(&f)),
        call_([](void* o, size_t begin, size_t end) { (*static_cast<F*>(o))(begin, end); }) {}
  /// Runs the referenced callable on [begin, end).
  void operator()(size_t begin, size_t end) const { call_(object_, begin, end); }

 private:
  void* object_;
  void (*call_)(void*, size_t, size_t);
};

/// Runs the chunks of a loop, possibly on several threads at once.
class TaskExecutor {
 public:
  virtual ~TaskExecutor() = default;
  /// Threads the executor may use (1: it runs everything inline).
  virtual int thread_count() const = 0;
  /// Calls body(begin, end) once for each chunk [k chunk, min((k + 1) chunk, count)) of [0, count),
  /// in any order and on any of its threads; returns when all chunks are done.
  virtual void for_each_chunk(size_t count, size_t chunk, ChunkFunction body) = 0;
};

/// True when `executor` would run a loop on more than one thread.
inline bool runs_parallel(const TaskExecutor* executor) {
  return executor != nullptr && executor->thread_count() > 1;
}

/// body(begin, end) over the chunks of [0, count): through the executor when it runs parallel,
/// else inline, chunks ascending (the same chunks either way).
template <class F>
void parallel_for_chunks(TaskExecutor* executor, size_t count, size_t chunk, F&& body) {
  if (count == 0) return;
  if (runs_parallel(executor) && count > chunk) {
    executor->for_each_chunk(count, chunk, ChunkFunction(body));
    return;
  }
  for (size_t begin = 0; begin < count; begin += chunk) body(begin, begin + chunk < count ? begin + chunk : count);
}

}  // namespace pliant
