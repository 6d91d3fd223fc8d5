// RenderSnapshot: a plain copy of what is drawn, taken from a World between steps, so a frame can
// be rendered on another thread while the physics goes on. Nothing in it points into the World
// except the shared, immutable TetMesh (for the surface triangles).
//
// Use from a simulation loop (the whole API the `pliant run` app needs):
//   FrameRecorder recorder({.folder = out / "frames", .every_k_steps = 10});
//   for (...) { world.step(dt); recorder.record(world, snapshot_options); }
//   recorder.finish();  // waits for queued frames; reports frames_written / frames_dropped
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "render/image.h"
#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

class World;

/// One body as drawn: its current positions and surface, colour and kind.
struct BodySnapshot {
  std::string name;
  TetMeshPtr mesh;               ///< surface triangles (shared, immutable)
  std::vector<Vec3> positions;   ///< all vertices (m), copied
  Rgba8 colour;                  ///< base colour of the surface
  bool kinematic = false;        ///< instruments and fixtures
  std::vector<double> scalar_field;  ///< optional per-vertex value drawn with the colour map
};

/// An arrow from `origin` along `vector` (both m: forces are already scaled to lengths).
struct ForceArrow {
  Vec3 origin = Vec3::Zero();
  Vec3 vector = Vec3::Zero();
  Rgba8 colour{255, 220, 40, 255};
};

/// Everything a frame shows.
struct RenderSnapshot {
  double time = 0.0;  ///< simulated time (s)
  long step = 0;      ///< steps taken
  std::vector<BodySnapshot> bodies;
  std::vector<Vec3> contact_points;  ///< contact triangle hit points (m)
  std::vector<ForceArrow> arrows;
  std::vector<std::string> overlay_lines;  ///< text drawn in the top-left corner
  std::string field_name;   ///< legend title of the scalar field ("" when none)
  double field_min = 0.0;   ///< value at the bottom of the colour map
  double field_max = 1.0;   ///< value at the top of the colour map

  /// True if any body carries a scalar field.
  bool has_scalar_field() const;
  /// Box around all body positions and arrows (empty if there is nothing to draw).
  Aabb bounds() const;
};

/// Per-vertex scalar fields that take_snapshot can compute from the World.
enum class ScalarField {
  none,
  displacement,  ///< |x - rest position placed by the body's pose| (m), deformable bodies
  speed,         ///< |v| (m/s)
};

/// What take_snapshot copies and how it decorates it.
struct SnapshotOptions {
  ScalarField field = ScalarField::none;
  /// Fixed colour-map range; when unset the range of the field in this frame is used.
  std::optional<std::pair<double, double>> field_range;
  bool contact_points = true;   ///< copy the contact points of the last step
  bool reaction_arrows = true;  ///< an arrow per kinematic body showing the tissue's force on it
  bool depth_vectors = false;   ///< an arrow per colliding vertex along its depth vector d r
  /// Arrow length per newton (m/N); 0 picks a scale where the largest force is a quarter of the
  /// scene's diagonal (per frame: set a fixed scale for a sequence whose arrows must compare).
  /// Forces below 1e-9 N get no arrow.
  double force_scale = 0.0;
  bool overlay_text = true;                ///< time, step and instrument forces as text lines
  std::optional<double> step_ms;           ///< wall time of the last step, shown when given (ms)
  std::vector<std::string> extra_lines;    ///< appended to the overlay text
  /// Colour overrides by body name; other bodies get the default palette (instruments grey).
  std::vector<std::pair<std::string, Rgba8>> body_colours;
};

/// Copies the drawable state of `world` (positions, contacts, last step's reactions).
RenderSnapshot take_snapshot(const World& world, const SnapshotOptions& options = {});

/// Default colour of the k-th deformable body (tissue tones) or of a kinematic body.
Rgba8 default_body_colour(int deformable_index, bool kinematic);

}  // namespace pliant
