// Side-by-side frames for `pliant experiment`: one PNG per frame with the contact-surface run on
// the left and the penalty run on the right at the same simulated time, each panel labelled.
// The two runs happen one after the other, so the left run's snapshots are kept in memory (copies
// of the positions, a few MB) and each frame is rendered and written while the right run passes
// its time. Both panels share one camera (the scene's, or one framing the first left snapshot)
// and, in each frame, one colour scale for the displacement field (the union of the two ranges).
// Without the renderer (PLIANT_RENDER=OFF) nothing is written and enabled() is false.
#pragma once

#include <filesystem>
#include <memory>
#include <ostream>
#include <string>

#include "interaction/scene/scene.h"
#include "render/render_snapshot.h"

namespace pliant {

/// Gives both snapshots the union of their colour-map ranges (field_min, field_max), so equal
/// colours mean equal values in the two panels of a frame.
void share_field_range(RenderSnapshot& a, RenderSnapshot& b);

/// Size and cadence of the side-by-side frames.
struct SideBySideSettings {
  std::filesystem::path folder = "frames";  ///< frame_NNNNNN.png are written here
  int panel_width = 480;                    ///< px, each of the two panels
  int panel_height = 360;                   ///< px
  double frame_rate = 30.0;                 ///< frames per simulated second
  std::string left_label = "contact surface";
  std::string right_label = "penalty";
};

class SideBySideFrames {
 public:
  /// Creates the folder and the renderer. If the renderer cannot start, `log` gets a note and
  /// enabled() is false.
  SideBySideFrames(const Scene& scene, SideBySideSettings settings, std::ostream* log);
  ~SideBySideFrames();
  SideBySideFrames(const SideBySideFrames&) = delete;
  SideBySideFrames& operator=(const SideBySideFrames&) = delete;

  bool enabled() const;
  /// Index of the frame due at simulated time t (s), or -1 if no new frame is due for `side`
  /// (0 left, 1 right). Frame k shows time k / frame_rate (the first step at or after it).
  long due(int side, double time);
  /// Keeps the left run's state as frame `index`.
  void keep_left(const World& world, long index);
  /// Renders the right run's state with the kept left frame `index` and writes the PNG.
  void write_right(const World& world, long index);
  /// Writes kept left frames the right run did not reach (right panel left blank, "stopped").
  void finish();
  long written() const;

  /// Path of frame `index`: folder/frame_NNNNNN.png.
  static std::filesystem::path frame_path(const std::filesystem::path& folder, long index);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pliant
