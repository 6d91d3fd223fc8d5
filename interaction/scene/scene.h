// Scene files (DESIGN.md "Scenes, scripts, outputs"; schema in docs/scene-format.md): one JSON
// file describing bodies, instruments, the tool script, contact settings, time step, loop rate,
// camera and output. Loading checks everything once and names the JSON path of any problem;
// instantiating builds a World with its instruments and pose sources.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "interaction/fixed_rate_loop.h"
#include "interaction/haptic_output_filter.h"
#include "interaction/instrument.h"
#include "interaction/pose_source.h"
#include "interaction/tool_script.h"
#include "sim/parallel/task_executor.h"
#include "sim/world.h"

namespace pliant {

/// Camera from the scene; absent means "frame the scene's bounds".
struct SceneCamera {
  Vec3 position = Vec3(0.3, -0.3, 0.25);  ///< m
  Vec3 target = Vec3::Zero();             ///< m
  Vec3 up = Vec3::UnitZ();
  double fov_deg = 40.0;                  ///< vertical field of view
};

/// What `pliant run` writes besides summary.json, steps.csv and tool_forces.csv.
struct SceneOutput {
  bool frames = true;         ///< render frames (when the renderer is built)
  double frame_rate = 30.0;   ///< frames per simulated second
  int width = 640;            ///< px
  int height = 480;           ///< px
  bool vtu = false;           ///< write a .vtu per frame and a .pvd series
};

/// A loaded, validated scene: everything needed to build a World, nothing built yet.
struct Scene {
  std::string file;            ///< path of the scene file
  std::string name;
  double time_step = 1e-3;     ///< s
  double duration = 1.0;       ///< s, default run length
  WorldSettings world;
  std::vector<BodyDef> bodies;
  std::vector<std::pair<std::string, std::string>> disabled_pairs;  ///< body names
  std::vector<InstrumentSpec> instruments;
  std::optional<ToolScript> script;
  LoopSettings loop;
  HapticSettings haptics;      ///< "haptics": limits of the force sent at 1 kHz (run --realtime)
  std::optional<SceneCamera> camera;
  SceneOutput output;
  int threads = 1;             ///< "threads": threads the step runs on (1: the serial step; docs/threads.md)
};

/// Reads and validates a scene file. Throws InputError naming the file and JSON path.
Scene load_scene(const std::string& path);
/// The same from JSON text (`source` names it in errors; relative mesh paths resolve against
/// `base_dir`).
Scene parse_scene(const nlohmann::json& root, const std::string& source, const std::string& base_dir);

/// A scene built into a world: bodies, instruments and a pose source per instrument.
struct SceneInstance {
  /// The world's executor when the scene asks for more than one thread (null: one). Declared
  /// before the world, so the world is destroyed first.
  std::unique_ptr<TaskExecutor> executor;
  std::unique_ptr<World> world;
  std::vector<BodyId> bodies;             ///< in scene order
  std::vector<Instrument> instruments;    ///< in scene order
  std::vector<std::unique_ptr<PoseSource>> pose_sources;  ///< one per instrument (script or hold)
};

/// "surface" / "penalty" / "none" -> ContactMethod (anything else: surface).
ContactMethod contact_method_from_string(const std::string& name);

/// Builds the world of a loaded scene (with a oneTBB executor when scene.threads > 1).
SceneInstance instantiate_scene(const Scene& scene);

}  // namespace pliant
