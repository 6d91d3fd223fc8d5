// OffscreenRenderer: draws a RenderSnapshot into an RGBA8 image with OSMesa (llvmpipe), no window
// and no display. One GL context is created in the constructor and reused for every frame.
//
// Design note. The context is a core profile (3.3+) one when OSMesaCreateContextAttribs gives it
// (Debian's Mesa does), else the best legacy context that still runs GLSL 3.30. Geometry is
// re-uploaded every frame into one vertex buffer (positions relative to the scene centre, so float
// precision does not depend on where the scene sits): lit surfaces with area-weighted normals
// smoothed within a crease angle, then an optional wireframe, then contact points and force arrows
// on top. Optional multisampling renders into a multisampled framebuffer and resolves it. Text and
// the legend bar are drawn on the CPU into the read-back image with a built-in bitmap font, so
// they are exact and identical everywhere. llvmpipe is deterministic: the same snapshot and
// settings give bitwise the same image. The caller's floating-point traps are held (feholdexcept)
// while Mesa runs, because its JIT code may legitimately raise invalid/overflow flags.
// Thread use: one thread at a time; the context is made current at the start of each call and
// released at the end, so a renderer may be created on one thread and used on another.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "render/camera.h"
#include "render/image.h"
#include "render/render_snapshot.h"

namespace pliant {

/// How a frame is drawn (everything but the snapshot and the image size).
struct ViewSettings {
  std::optional<Camera> camera;       ///< unset: frame the snapshot's bounds (frame_bounds)
  Rgba8 background{40, 44, 52, 255};  ///< clear colour
  double crease_angle_deg = 50.0;     ///< normals are smoothed across edges flatter than this
  bool wireframe = false;             ///< surface edges drawn over the shaded surface
  Rgba8 wireframe_colour{25, 25, 25, 255};
  bool contact_points = true;         ///< draw RenderSnapshot::contact_points
  Rgba8 contact_point_colour{255, 60, 60, 255};
  float contact_point_size = 4.0f;    ///< pixels
  bool arrows = true;                 ///< draw RenderSnapshot::arrows
  float arrow_width = 2.0f;           ///< pixels
  bool legend = true;                 ///< colour-map bar when a body has a scalar field
  bool text = true;                   ///< RenderSnapshot::overlay_lines in the top-left corner
  int text_scale = 0;                 ///< font pixel size; 0 picks 1 below 720 rows, else 2
};

/// An off-screen OSMesa renderer of a fixed image size.
class OffscreenRenderer {
 public:
  /// Creates the GL context and its buffers; throws RenderError if OSMesa cannot create a context
  /// with GLSL 3.30 or the size is not positive. `samples` > 1 renders into a multisampled
  /// framebuffer and resolves it (anti-aliasing; clamped to the driver's maximum).
  OffscreenRenderer(int width, int height, int samples = 1);
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  /// Draws one frame. Throws RenderError on a GL error.
  Image render(const RenderSnapshot& snapshot, const ViewSettings& view = {});

  int width() const;
  int height() const;
  /// GL_VERSION of the context, e.g. "4.5 (Core Profile) Mesa 22.3.6".
  const std::string& gl_version() const;
  /// GL_RENDERER of the context, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
  const std::string& gl_renderer() const;
  /// True if the context is a core profile one.
  bool core_profile() const;
  /// Samples per pixel actually used (1 = no multisampling).
  int samples() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pliant
