// FrameRecorder: renders snapshots to <folder>/frame_NNNNNN.png. The API `pliant run` uses:
//
//   FrameRecorder recorder({.folder = out / "frames", .width = 640, .height = 480,
//                           .every_k_steps = 10, .asynchronous = realtime});
//   recorder.record(world, snapshot_options);   // after each step; a frame every k-th step
//   // or, when the caller picks the cadence:  recorder.submit(take_snapshot(world), index);
//   recorder.finish();                           // drain the queue, join, rethrow a write error
//   recorder.frames_written(), recorder.frames_dropped()
//
// Synchronous mode (the default) renders and writes inside record/submit: deterministic, for tests
// and offline runs. Asynchronous mode copies the snapshot into a bounded queue served by one
// worker thread, so a real-time loop never waits for the renderer: when the queue is full the new
// frame is dropped and counted. Without a camera in the view settings the first frame's bounds
// fix the camera for the whole sequence (a camera that re-framed every frame would jitter).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <filesystem>
#include <mutex>
#include <thread>
#include <utility>

#include "render/offscreen_renderer.h"
#include "render/render_snapshot.h"

namespace pliant {

/// Where and how frames are recorded.
struct FrameRecorderSettings {
  std::filesystem::path folder = "frames";  ///< created if missing
  int width = 640;                          ///< pixels
  int height = 480;                         ///< pixels
  int samples = 4;                          ///< multisample anti-aliasing (1 = off)
  int every_k_steps = 1;                    ///< record(): a frame when world.step_count() % k == 0
  bool asynchronous = false;                ///< render and write on a worker thread
  std::size_t queue_capacity = 4;           ///< asynchronous: snapshots that may wait; more are dropped
  ViewSettings view;                        ///< camera unset: framed on the first frame, then kept
};

/// Writes a sequence of rendered frames as PNG files.
class FrameRecorder {
 public:
  /// Creates the folder and the GL context; throws RenderError if either fails.
  explicit FrameRecorder(FrameRecorderSettings settings);
  /// Finishes (waits for queued frames); errors at this point are swallowed, call finish() first.
  ~FrameRecorder();
  FrameRecorder(const FrameRecorder&) = delete;
  FrameRecorder& operator=(const FrameRecorder&) = delete;

  /// If world.step_count() is a multiple of every_k_steps, snapshots the world and submits it as
  /// frame step_count / k. Returns true if a frame was recorded or queued.
  bool record(const World& world, const SnapshotOptions& options = {});
  /// Renders the snapshot as frame `frame_index` (file frame_<index, 6 digits>.png). Returns false
  /// if it was dropped because the queue was full. Rethrows an earlier worker error.
  bool submit(RenderSnapshot snapshot, long frame_index);
  /// Waits until every queued frame is written and stops the worker; rethrows the first error
  /// met while rendering or writing. Later submits run synchronously.
  void finish();

  long frames_written() const { return written_.load(); }
  long frames_dropped() const { return dropped_.load(); }
  const FrameRecorderSettings& settings() const { return settings_; }
  /// Path of frame `index` in `folder`: folder/frame_NNNNNN.png.
  static std::filesystem::path frame_path(const std::filesystem::path& folder, long index);

 private:
  void render_and_write(const RenderSnapshot& snapshot, long frame_index);
  void worker_loop();
  void rethrow_worker_error();

  FrameRecorderSettings settings_;
  OffscreenRenderer renderer_;
  std::atomic<long> written_{0};
  std::atomic<long> dropped_{0};

  std::mutex mutex_;
  std::condition_variable queue_changed_;
  std::deque<std::pair<RenderSnapshot, long>> queue_;
  bool stopping_ = false;
  std::exception_ptr worker_error_;
  std::thread worker_;
};

}  // namespace pliant
