#include "apps/frame_output.h"

#include <iomanip>
#include <sstream>

namespace pliant {

struct FrameOutput::Png {
  long written = 0;
  long dropped = 0;
};

FrameOutput::FrameOutput(const Scene& scene, const std::filesystem::path& out, std::ostream* log) {
  if (scene.output.frames && log != nullptr) {
    *log << "pliant run: frames asked for, but PNG frames are not wired in yet; skipping them\n";
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

void FrameOutput::finish() {}

long FrameOutput::written() const { return png_ ? png_->written : vtu_written_; }
long FrameOutput::dropped() const { return png_ ? png_->dropped : 0; }

}  // namespace pliant
