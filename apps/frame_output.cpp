#include "apps/frame_output.h"

#include <iomanip>
#include <sstream>

#ifdef PLIANT_HAS_RENDER
#include "apps/scene_camera.h"
#include "render/frame_recorder.h"
#endif

namespace pliant {

#ifdef PLIANT_HAS_RENDER
struct FrameOutput::Png {
  explicit Png(FrameRecorderSettings settings) : recorder(std::move(settings)) {}
  FrameRecorder recorder;
  SnapshotOptions options;
};
#else
struct FrameOutput::Png {};
#endif

FrameOutput::FrameOutput(const Scene& scene, const std::filesystem::path& out, std::ostream* log) {
  if (scene.output.frames) {
#ifdef PLIANT_HAS_RENDER
    FrameRecorderSettings settings;
    settings.folder = out / "frames";
    settings.width = scene.output.width;
    settings.height = scene.output.height;
    settings.asynchronous = false;  // offline runs are deterministic; FrameOutput::write picks the cadence
    if (scene.camera) settings.view.camera = render_camera(*scene.camera);
    try {
      png_ = std::make_unique<Png>(std::move(settings));
      png_->options.field = ScalarField::displacement;
      png_enabled_ = true;
    } catch (const std::exception& e) {
      if (log != nullptr) *log << "pliant run: cannot render frames (" << e.what() << "); going on without them\n";
    }
#else
    if (log != nullptr) *log << "pliant run: frames asked for, but this build has no renderer (PLIANT_RENDER=OFF)\n";
#endif
  }
  if (scene.output.vtu) {
    vtu_enabled_ = true;
    vtu_dir_ = out / "vtu";
    std::filesystem::create_directories(vtu_dir_);
    series_ = std::make_unique<PvdSeries>((out / "vtu" / "series.pvd").string());
  }
}

FrameOutput::~FrameOutput() = default;

void FrameOutput::write(const World& world, const StepReport& report, long index) {
  (void)report;
#ifdef PLIANT_HAS_RENDER
  if (png_enabled_) png_->recorder.submit(take_snapshot(world, png_->options), index);
#endif
  if (!vtu_enabled_) return;
  // One .vtu per body and frame; the .pvd lists them at the frame's time.
  const auto bodies = world.bodies();
  for (size_t b = 0; b < bodies.size(); ++b) {
    const Body* body = bodies[b];
    if (body == nullptr) continue;
    std::ostringstream name;
    name << (body->name.empty() ? "body" + std::to_string(b) : body->name) << "_" << std::setw(6)
         << std::setfill('0') << index << ".vtu";
    std::string file = name.str();
    for (char& c : file) {
      if (c == '/' || c == '\\') c = '_';
    }
    VtuPointField velocity{"velocity", 3, {}};
    velocity.values.reserve(body->velocities.size() * 3);
    for (const Vec3& v : body->velocities) velocity.values.insert(velocity.values.end(), {v.x(), v.y(), v.z()});
    const VtuPointField fields[] = {velocity};
    write_tet_mesh_vtu((vtu_dir_ / file).string(), *body->mesh, body->positions, fields);
    series_->add(world.time(), file);
  }
  ++vtu_written_;
}

void FrameOutput::finish() {
#ifdef PLIANT_HAS_RENDER
  if (png_enabled_) png_->recorder.finish();
#endif
}

#ifdef PLIANT_HAS_RENDER
long FrameOutput::written() const { return png_enabled_ ? png_->recorder.frames_written() : vtu_written_; }
long FrameOutput::dropped() const { return png_enabled_ ? png_->recorder.frames_dropped() : 0; }
#else
long FrameOutput::written() const { return vtu_written_; }
long FrameOutput::dropped() const { return 0; }
#endif

}  // namespace pliant
