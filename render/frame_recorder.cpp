#include "render/frame_recorder.h"

#include <array>
#include <cstdio>
#include <string>
#include <system_error>

#include "render/png_writer.h"
#include "render/render_error.h"
#include "sim/world.h"

namespace pliant {

std::filesystem::path FrameRecorder::frame_path(const std::filesystem::path& folder, long index) {
  std::array<char, 32> name{};
  std::snprintf(name.data(), name.size(), "frame_%06ld.png", index);
  return folder / name.data();
}

FrameRecorder::FrameRecorder(FrameRecorderSettings settings)
    : settings_(std::move(settings)), renderer_(settings_.width, settings_.height, settings_.samples) {
  if (settings_.every_k_steps < 1) {
    throw RenderError("FrameRecorder: every_k_steps must be at least 1, got " + std::to_string(settings_.every_k_steps));
  }
  std::error_code ec;
  std::filesystem::create_directories(settings_.folder, ec);
  if (ec || !std::filesystem::is_directory(settings_.folder)) {
    throw RenderError(settings_.folder.string() + ": cannot create the frame folder" + (ec ? ": " + ec.message() : ""));
  }
  if (settings_.asynchronous) {
    if (settings_.queue_capacity < 1) settings_.queue_capacity = 1;
    worker_ = std::thread([this] { worker_loop(); });
  }
}

FrameRecorder::~FrameRecorder() {
  try {
    finish();
  } catch (...) {  // NOLINT(bugprone-empty-catch): a destructor must not throw; finish() reports
  }
}

bool FrameRecorder::record(const World& world, const SnapshotOptions& options) {
  const long step = world.step_count();
  if (step % settings_.every_k_steps != 0) return false;
  return submit(take_snapshot(world, options), step / settings_.every_k_steps);
}

bool FrameRecorder::submit(RenderSnapshot snapshot, long frame_index) {
  rethrow_worker_error();
  // Fix the camera on the first frame so the sequence does not jitter.
  if (!settings_.view.camera) {
    settings_.view.camera =
        frame_bounds(snapshot.bounds(), static_cast<double>(settings_.width) / static_cast<double>(settings_.height));
  }
  if (!worker_.joinable()) {
    render_and_write(snapshot, frame_index);
    return true;
  }
  {
    std::lock_guard lock(mutex_);
    if (queue_.size() >= settings_.queue_capacity) {
      ++dropped_;
      return false;
    }
    queue_.emplace_back(std::move(snapshot), frame_index);
  }
  queue_changed_.notify_all();
  return true;
}

void FrameRecorder::render_and_write(const RenderSnapshot& snapshot, long frame_index) {
  const Image image = renderer_.render(snapshot, settings_.view);
  write_png(image, frame_path(settings_.folder, frame_index));
  ++written_;
}

void FrameRecorder::worker_loop() {
  for (;;) {
    std::pair<RenderSnapshot, long> item;
    {
      std::unique_lock lock(mutex_);
      queue_changed_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping and drained
      item = std::move(queue_.front());
      queue_.pop_front();
    }
    try {
      render_and_write(item.first, item.second);
    } catch (...) {
      std::lock_guard lock(mutex_);
      if (!worker_error_) worker_error_ = std::current_exception();
    }
  }
}

void FrameRecorder::finish() {
  if (worker_.joinable()) {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    queue_changed_.notify_all();
    worker_.join();
  }
  rethrow_worker_error();
}

void FrameRecorder::rethrow_worker_error() {
  std::exception_ptr error;
  {
    std::lock_guard lock(mutex_);
    error = std::exchange(worker_error_, nullptr);
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace pliant
