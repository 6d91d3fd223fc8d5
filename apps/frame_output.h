// Frames for `pliant run`: PNGs through the renderer when it is built (PLIANT_RENDER), and
// optional .vtu files with a .pvd series for ParaView (always available).
#pragma once

#include <filesystem>
#include <memory>
#include <ostream>

#include "interaction/scene/scene.h"
#include "sim/io/vtu_writer.h"

namespace pliant {

class FrameOutput {
 public:
  /// Prepares out/frames (PNG) and out/vtu (VTU) as the scene's output section asks. `log` gets a
  /// note when frames were asked for but the renderer is not built or cannot start (may be null).
  FrameOutput(const Scene& scene, const std::filesystem::path& out, std::ostream* log);
  ~FrameOutput();
  FrameOutput(const FrameOutput&) = delete;
  FrameOutput& operator=(const FrameOutput&) = delete;

  bool enabled() const { return png_enabled_ || vtu_enabled_; }
  /// Writes frame `index` of the world's current state.
  void write(const World& world, const StepReport& report, long index);
  /// Waits for queued frames and closes the series.
  void finish();
  long written() const;
  long dropped() const;

 private:
  struct Png;  // renderer state, only with PLIANT_HAS_RENDER
  std::unique_ptr<Png> png_;
  bool png_enabled_ = false;
  bool vtu_enabled_ = false;
  std::filesystem::path vtu_dir_;
  std::unique_ptr<PvdSeries> series_;
  long vtu_written_ = 0;
};

}  // namespace pliant
