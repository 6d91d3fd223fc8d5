#include "apps/side_by_side_frames.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>

#ifdef PLIANT_HAS_RENDER
#include "apps/scene_camera.h"
#include "render/bitmap_font.h"
#include "render/offscreen_renderer.h"
#include "render/png_writer.h"
#endif

namespace pliant {

std::filesystem::path SideBySideFrames::frame_path(const std::filesystem::path& folder, long index) {
  std::ostringstream name;
  name << "frame_" << std::setw(6) << std::setfill('0') << index << ".png";
  return folder / name.str();
}

void share_field_range(RenderSnapshot& a, RenderSnapshot& b) {
  const double lo = std::min(a.field_min, b.field_min), hi = std::max(a.field_max, b.field_max);
  a.field_min = b.field_min = lo;
  a.field_max = b.field_max = hi;
}

#ifdef PLIANT_HAS_RENDER

struct SideBySideFrames::Impl {
  Impl(SideBySideSettings s) : settings(std::move(s)), renderer(settings.panel_width, settings.panel_height, 4) {}
  SideBySideSettings settings;
  OffscreenRenderer renderer;
  ViewSettings view;
  SnapshotOptions options;
  std::map<long, RenderSnapshot> left;  ///< kept until the right run reaches the frame
  long next[2] = {0, 0};
  long written = 0;

  Image panel(const RenderSnapshot* snapshot, const std::string& label) {
    Image image = snapshot != nullptr
                      ? renderer.render(*snapshot, view)
                      : Image(settings.panel_width, settings.panel_height, view.background);
    const int scale = settings.panel_height >= 720 ? 2 : 1;
    const std::string text = snapshot != nullptr ? label : label + ": stopped";
    const int x = (settings.panel_width - text_width(text, scale)) / 2;
    draw_text(image, x, settings.panel_height - (kLineHeight + 4) * scale, text, Rgba8{255, 255, 255, 255}, scale);
    return image;
  }

  void write(long index, RenderSnapshot* l, RenderSnapshot* r) {
    // One colour scale for both panels: the union of the two frames' field ranges.
    if (l != nullptr && r != nullptr) share_field_range(*l, *r);
    if (!view.camera) {
      const RenderSnapshot* first = l != nullptr ? l : r;
      view.camera = frame_bounds(first->bounds(),
                                 static_cast<double>(settings.panel_width) / settings.panel_height);
    }
    const Image a = panel(l, settings.left_label), b = panel(r, settings.right_label);
    Image out(2 * settings.panel_width, settings.panel_height);
    for (int y = 0; y < settings.panel_height; ++y) {
      for (int x = 0; x < settings.panel_width; ++x) {
        out.set_pixel(x, y, a.pixel(x, y));
        out.set_pixel(settings.panel_width + x, y, b.pixel(x, y));
      }
    }
    for (int y = 0; y < settings.panel_height; ++y) out.set_pixel(settings.panel_width, y, Rgba8{0, 0, 0, 255});
    write_png(out, frame_path(settings.folder, index));
    ++written;
  }
};

SideBySideFrames::SideBySideFrames(const Scene& scene, SideBySideSettings settings, std::ostream* log) {
  try {
    std::filesystem::create_directories(settings.folder);
    impl_ = std::make_unique<Impl>(std::move(settings));
    if (scene.camera) impl_->view.camera = render_camera(*scene.camera);
    impl_->options.field = ScalarField::displacement;
    impl_->options.reaction_arrows = false;
  } catch (const std::exception& e) {
    impl_.reset();
    if (log != nullptr) *log << "pliant experiment: cannot render frames (" << e.what() << "); going on without them\n";
  }
}

SideBySideFrames::~SideBySideFrames() = default;

bool SideBySideFrames::enabled() const { return impl_ != nullptr; }

long SideBySideFrames::due(int side, double time) {
  if (!impl_) return -1;
  long& next = impl_->next[side];
  // Half a step of slack: frame k is due at the first step whose time reaches k / rate.
  if (time + 1e-9 < static_cast<double>(next) / impl_->settings.frame_rate) return -1;
  return next++;
}

void SideBySideFrames::keep_left(const World& world, long index) {
  if (impl_) impl_->left[index] = take_snapshot(world, impl_->options);
}

void SideBySideFrames::write_right(const World& world, long index) {
  if (!impl_) return;
  RenderSnapshot right = take_snapshot(world, impl_->options);
  auto it = impl_->left.find(index);
  impl_->write(index, it != impl_->left.end() ? &it->second : nullptr, &right);
  if (it != impl_->left.end()) impl_->left.erase(it);
}

void SideBySideFrames::finish() {
  if (!impl_) return;
  for (auto& [index, snapshot] : impl_->left) impl_->write(index, &snapshot, nullptr);
  impl_->left.clear();
}

long SideBySideFrames::written() const { return impl_ ? impl_->written : 0; }

#else

struct SideBySideFrames::Impl {};

SideBySideFrames::SideBySideFrames(const Scene&, SideBySideSettings, std::ostream* log) {
  if (log != nullptr) *log << "pliant experiment: no frames: this build has no renderer (PLIANT_RENDER=OFF)\n";
}
SideBySideFrames::~SideBySideFrames() = default;
bool SideBySideFrames::enabled() const { return false; }
long SideBySideFrames::due(int, double) { return -1; }
void SideBySideFrames::keep_left(const World&, long) {}
void SideBySideFrames::write_right(const World&, long) {}
void SideBySideFrames::finish() {}
long SideBySideFrames::written() const { return 0; }

#endif

}  // namespace pliant
