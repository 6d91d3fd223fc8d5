#include "interaction/scene/scene.h"

#include <filesystem>
#include <set>

#include "interaction/json_reader.h"
#include "interaction/scene/mesh_spec.h"
#include "interaction/script_pose_source.h"
#include "interaction/tbb_task_executor.h"

namespace pliant {
namespace {

// Whether scenes without a "sleep" object let bodies sleep.
constexpr bool kSceneSleepByDefault = true;

Pose read_pose(const JsonReader& j) {
  Pose pose;
  pose.translation = j.vec3_or("position", Vec3::Zero());
  if (auto q = j.find("orientation")) {
    if (!q->is_array() || q->size() != 4) q->fail(InputErrorKind::wrong_type, "expected [qw, qx, qy, qz]");
    Quat rotation(q->at(0).number(), q->at(1).number(), q->at(2).number(), q->at(3).number());
    if (!(rotation.norm() > 1e-12)) q->fail(InputErrorKind::bad_value, "quaternion must not be zero");
    pose.rotation = rotation.normalized();
  }
  if (auto r = j.find("rotation")) {
    r->expect_keys({"axis", "angle_deg"});
    const Vec3 axis = r->at("axis").vec3();
    if (!(axis.norm() > 1e-12)) r->at("axis").fail(InputErrorKind::bad_value, "axis must not be zero");
    pose.rotation = Quat(Eigen::AngleAxisd(r->at("angle_deg").number() * M_PI / 180.0, axis.normalized())) *
                    pose.rotation;
  }
  return pose;
}

Material read_material(const JsonReader& j) {
  j.expect_keys({"young_modulus", "poisson_ratio", "density", "mass_damping", "stiffness_damping", "friction"});
  Material m;
  m.young_modulus = j.positive_number_or("young_modulus", m.young_modulus);
  if (auto nu = j.find("poisson_ratio")) {
    m.poisson_ratio = nu->number();
    if (!(m.poisson_ratio >= 0.0 && m.poisson_ratio < 0.5)) {
      nu->fail(InputErrorKind::bad_value, "expected a number in [0, 0.5), got " + nu->value().dump());
    }
  }
  m.density = j.positive_number_or("density", m.density);
  m.mass_damping = j.non_negative_number_or("mass_damping", m.mass_damping);
  m.stiffness_damping = j.non_negative_number_or("stiffness_damping", m.stiffness_damping);
  m.friction = j.non_negative_number_or("friction", m.friction);
  return m;
}

ModelSettings read_model_settings(const JsonReader& j) {
  j.expect_keys({"max_solver_iterations", "solver_tolerance", "distance_stiffness", "volume_stiffness",
                 "area_stiffness", "distance_damping", "fused_sweeps", "coarse_aggregate_size",
                 "stiffness_rotation_tolerance"});
  ModelSettings s;
  if (auto it = j.find("max_solver_iterations")) {
    s.accuracy.max_solver_iterations = it->integer();
    if (s.accuracy.max_solver_iterations < 1) it->fail(InputErrorKind::bad_value, "expected an integer >= 1");
  }
  s.accuracy.solver_tolerance = j.positive_number_or("solver_tolerance", s.accuracy.solver_tolerance);
  s.distance_stiffness = j.non_negative_number_or("distance_stiffness", s.distance_stiffness);
  s.volume_stiffness = j.non_negative_number_or("volume_stiffness", s.volume_stiffness);
  s.area_stiffness = j.non_negative_number_or("area_stiffness", s.area_stiffness);
  s.distance_damping = j.non_negative_number_or("distance_damping", s.distance_damping);
  s.fused_sweeps = j.boolean_or("fused_sweeps", s.fused_sweeps);
  if (auto it = j.find("coarse_aggregate_size")) {
    s.coarse_aggregate_size = it->integer();
    if (s.coarse_aggregate_size < 0) it->fail(InputErrorKind::bad_value, "expected an integer >= 0 (0: off)");
  }
  s.stiffness_rotation_tolerance =
      j.non_negative_number_or("stiffness_rotation_tolerance", s.stiffness_rotation_tolerance);
  return s;
}

// Fixed regions are given in world coordinates (after the body's pose).
std::vector<int> read_fixed(const JsonReader& j, const TetMesh& mesh, const Pose& pose) {
  std::vector<int> fixed;
  const auto& rest = mesh.rest_positions();
  for (size_t i = 0; i < j.size(); ++i) {
    const JsonReader region = j.at(i);
    region.expect_keys({"box", "plane", "indices"});
    if (auto box = region.find("box")) {
      box->expect_keys({"min", "max"});
      const Vec3 lo = box->at("min").vec3(), hi = box->at("max").vec3();
      for (size_t v = 0; v < rest.size(); ++v) {
        const Vec3 x = pose.apply(rest[v]);
        if ((x.array() >= lo.array()).all() && (x.array() <= hi.array()).all()) fixed.push_back(static_cast<int>(v));
      }
    }
    if (auto plane = region.find("plane")) {
      // Vertices on or behind the plane (opposite to its normal), within a relative tolerance.
      plane->expect_keys({"point", "normal"});
      const Vec3 point = plane->at("point").vec3();
      const Vec3 normal = plane->at("normal").vec3();
      if (!(normal.norm() > 1e-12)) plane->at("normal").fail(InputErrorKind::bad_value, "normal must not be zero");
      const double tolerance = 1e-6 * mesh.rest_bounds().extent().norm();
      for (size_t v = 0; v < rest.size(); ++v) {
        if ((pose.apply(rest[v]) - point).dot(normal.normalized()) <= tolerance) fixed.push_back(static_cast<int>(v));
      }
    }
    if (auto indices = region.find("indices")) {
      for (size_t k = 0; k < indices->size(); ++k) {
        const int v = indices->at(k).integer();
        if (v < 0 || v >= mesh.vertex_count()) {
          indices->at(k).fail(InputErrorKind::index_out_of_range,
                              "vertex " + std::to_string(v) + " out of range (mesh has " +
                                  std::to_string(mesh.vertex_count()) + " vertices)");
        }
        fixed.push_back(v);
      }
    }
  }
  std::sort(fixed.begin(), fixed.end());
  fixed.erase(std::unique(fixed.begin(), fixed.end()), fixed.end());
  return fixed;
}

BodyDef read_body(const JsonReader& j, const std::string& base_dir, size_t index) {
  j.expect_keys({"name", "mesh", "position", "orientation", "rotation", "material", "model", "model_settings",
                 "fixed", "kinematic", "velocity", "self_collision", "collision_group", "collision_mask"});
  BodyDef def;
  def.name = j.string_or("name", "body" + std::to_string(index));
  def.mesh = load_mesh_spec(j.at("mesh"), base_dir);
  def.pose = read_pose(j);
  if (auto m = j.find("material")) def.material = read_material(*m);
  if (auto model = j.find("model")) {
    def.model = model->choice({"corotational_fem", "teschner_explicit"}) == "corotational_fem"
                    ? ModelKind::corotational_fem
                    : ModelKind::teschner_explicit;
  }
  if (auto s = j.find("model_settings")) def.model_settings = read_model_settings(*s);
  if (j.boolean_or("kinematic", false)) def.motion = BodyMotion::kinematic;
  def.initial_velocity = j.vec3_or("velocity", Vec3::Zero());
  if (auto f = j.find("fixed")) def.fixed_vertices = read_fixed(*f, *def.mesh, def.pose);
  def.self_collision = j.boolean_or("self_collision", false);
  if (auto g = j.find("collision_group")) {
    const int group = g->integer();
    if (group < 0) g->fail(InputErrorKind::bad_value, "expected a non-negative bit mask");
    def.collision_group = static_cast<unsigned>(group);
  }
  if (auto m = j.find("collision_mask")) {
    const int mask = m->integer();
    if (mask < -1) m->fail(InputErrorKind::bad_value, "expected a bit mask (or -1 for all)");
    def.collision_mask = static_cast<unsigned>(mask);
  }
  return def;
}

ContactSettings read_contact(const JsonReader& j) {
  j.expect_keys({"method", "binary_search_iterations", "finishing_projection", "penalty_stiffness",
                 "penalty_damping", "friction", "held_force_fraction", "implicit_correction",
                 "linearised_search", "limit_friction_move", "deformable_pair_held_force_fraction",
                 "held_linearised_final_strain"});
  ContactSettings c;
  if (auto m = j.find("method")) c.method = contact_method_from_string(m->choice({"surface", "penalty", "none"}));
  if (auto it = j.find("binary_search_iterations")) {
    c.binary_search_iterations = it->integer();
    if (c.binary_search_iterations < 0 || c.binary_search_iterations > 30) {
      it->fail(InputErrorKind::bad_value, "expected an integer in [0, 30]");
    }
  }
  c.finishing_projection = j.boolean_or("finishing_projection", c.finishing_projection);
  c.penalty_stiffness = j.positive_number_or("penalty_stiffness", c.penalty_stiffness);
  c.penalty_damping = j.non_negative_number_or("penalty_damping", c.penalty_damping);
  c.friction = j.boolean_or("friction", c.friction);
  c.linearised_search = j.boolean_or("linearised_search", c.linearised_search);
  // Session 21, opt-in: the final evaluation linearised under held forces within this strain gate.
  c.held_linearised_final_strain =
      j.non_negative_number_or("held_linearised_final_strain", c.held_linearised_final_strain);
  if (auto it = j.find("limit_friction_move")) {
    // false (the default: no limit) | true (session 10's limit: returns excused) | "charge_returns"
    // (session 15: charged everywhere) | "charge_deformable_returns" (session 16: charged unless every
    // friction partner of the body is an instrument) | "energy_flow" (session 17: returns included,
    // in the model's stiffness, against the impulses' kinetic energy and the step's kinetic dissipation).
    if (it->is_string()) {
      const std::string rule = it->choice({"charge_deformable_returns", "charge_returns", "energy_flow"});
      c.limit_friction_move = true;
      c.limit_friction_move_energy_flow = rule == "energy_flow";
      c.limit_friction_move_charges_returns = rule != "energy_flow";
      c.limit_friction_move_excuses_instrument_returns = rule == "charge_deformable_returns";
    } else {
      c.limit_friction_move = it->boolean();
      c.limit_friction_move_charges_returns = false;
    }
  }
  if (auto it = j.find("implicit_correction")) {
    // "off" | "stiff_partners" | "all" | "coupled"; the session-6 booleans stay valid (true: "all").
    if (it->is_string()) {
      const std::string scope = it->choice({"off", "stiff_partners", "all", "coupled"});
      c.implicit_correction = scope == "off"              ? ImplicitCorrection::off
                              : scope == "stiff_partners" ? ImplicitCorrection::stiff_partners
                              : scope == "all"            ? ImplicitCorrection::all
                                                          : ImplicitCorrection::coupled;
    } else {
      c.implicit_correction = it->boolean() ? ImplicitCorrection::all : ImplicitCorrection::off;
    }
  }
  // Held-force fractions: numbers in [0, 1].
  auto read_fraction = [&](const char* key, double& value) {
    if (auto it = j.find(key)) {
      value = it->number();
      if (value < 0.0 || value > 1.0) it->fail(InputErrorKind::bad_value, "expected a number in [0, 1]");
    }
  };
  read_fraction("held_force_fraction", c.held_force_fraction);
  // Session 10: "derived" instead of a number holds each pair's contact-mode strength
  // (ContactSettings::deformable_pair_held_force_derived).
  if (auto it = j.find("deformable_pair_held_force_fraction"); it && it->is_string()) {
    it->choice({"derived"});
    c.deformable_pair_held_force_derived = true;
  } else {
    read_fraction("deformable_pair_held_force_fraction", c.deformable_pair_held_force_fraction);
  }
  return c;
}

// "sleep": bodies at rest sleep (sim/sleep/sleep_settings.h); on in scenes unless disabled.
SleepSettings read_sleep(const JsonReader& j) {
  j.expect_keys({"enabled", "speed", "time", "wake_margin", "wake_on_centre_motion", "rest_by_centre_when_supported"});
  SleepSettings s;
  s.enabled = j.boolean_or("enabled", true);
  s.speed = j.positive_number_or("speed", s.speed);
  s.time = j.positive_number_or("time", s.time);
  s.wake_margin = j.non_negative_number_or("wake_margin", s.wake_margin);
  s.wake_on_centre_motion = j.boolean_or("wake_on_centre_motion", s.wake_on_centre_motion);
  s.rest_by_centre_when_supported = j.boolean_or("rest_by_centre_when_supported", s.rest_by_centre_when_supported);
  return s;
}

SceneCamera read_camera(const JsonReader& j) {
  j.expect_keys({"position", "target", "up", "fov_deg"});
  SceneCamera c;
  c.position = j.at("position").vec3();
  c.target = j.vec3_or("target", c.target);
  c.up = j.vec3_or("up", c.up);
  c.fov_deg = j.positive_number_or("fov_deg", c.fov_deg);
  if (c.fov_deg >= 179.0) j.at("fov_deg").fail(InputErrorKind::bad_value, "expected a field of view below 179 degrees");
  if ((c.position - c.target).norm() <= 0.0) j.fail(InputErrorKind::bad_value, "camera position equals its target");
  return c;
}

SceneOutput read_output(const JsonReader& j) {
  j.expect_keys({"frames", "frame_rate", "width", "height", "vtu"});
  SceneOutput o;
  o.frames = j.boolean_or("frames", o.frames);
  o.frame_rate = j.positive_number_or("frame_rate", o.frame_rate);
  auto pixels = [&](const char* key, int fallback) {
    auto it = j.find(key);
    if (!it) return fallback;
    const int value = it->integer();
    if (value < 8 || value > 8192) it->fail(InputErrorKind::bad_value, "expected an integer in [8, 8192]");
    return value;
  };
  o.width = pixels("width", o.width);
  o.height = pixels("height", o.height);
  o.vtu = j.boolean_or("vtu", o.vtu);
  return o;
}

}  // namespace

ContactMethod contact_method_from_string(const std::string& name) {
  if (name == "penalty") return ContactMethod::penalty;
  if (name == "none") return ContactMethod::none;
  return ContactMethod::contact_surface;
}

Scene parse_scene(const nlohmann::json& root_json, const std::string& source, const std::string& base_dir) {
  const JsonReader root(root_json, source);
  root.expect_keys({"name", "description", "time_step", "duration", "gravity", "bodies", "instruments", "script",
                    "loop", "contact", "collision", "camera", "output", "sleep", "haptics", "threads"});
  Scene scene;
  scene.file = source;
  scene.name = root.string_or("name", std::filesystem::path(source).stem().string());
  scene.time_step = root.positive_number_or("time_step", scene.time_step);
  scene.duration = root.positive_number_or("duration", scene.duration);
  scene.world.gravity = root.vec3_or("gravity", scene.world.gravity);
  if (auto c = root.find("contact")) scene.world.contact = read_contact(*c);
  scene.world.sleep.enabled = kSceneSleepByDefault;
  if (auto s = root.find("sleep")) scene.world.sleep = read_sleep(*s);
  if (auto t = root.find("threads")) {
    scene.threads = t->integer();
    if (scene.threads < 1) t->fail(InputErrorKind::bad_value, "expected a whole number of threads >= 1");
  }

  const JsonReader bodies = root.at("bodies");
  std::set<std::string> names;
  for (size_t i = 0; i < bodies.size(); ++i) {
    scene.bodies.push_back(read_body(bodies.at(i), base_dir, i));
    if (!names.insert(scene.bodies.back().name).second) {
      bodies.at(i).at("name").fail(InputErrorKind::bad_value, "duplicate body name \"" + scene.bodies.back().name + "\"");
    }
  }

  std::vector<std::string> instrument_names, grasper_names;
  if (auto instruments = root.find("instruments")) {
    for (size_t i = 0; i < instruments->size(); ++i) {
      scene.instruments.push_back(parse_instrument_spec(instruments->at(i)));
      const auto& spec = scene.instruments.back();
      if (names.count(spec.name) != 0) {
        instruments->at(i).fail(InputErrorKind::bad_value, "name \"" + spec.name + "\" is already used");
      }
      names.insert(spec.name);
      instrument_names.push_back(spec.name);
      if (spec.kind == InstrumentKind::grasper) grasper_names.push_back(spec.name);
    }
  }
  if (auto script = root.find("script")) {
    if (script->is_object()) {
      script->expect_keys({"file"});
      std::filesystem::path file = script->at("file").string();
      if (file.is_relative()) file = std::filesystem::path(base_dir) / file;
      scene.script = load_tool_script_file(file.string(), instrument_names, grasper_names);
    } else {
      scene.script = parse_tool_script(*script, instrument_names, grasper_names);
    }
  }
  if (auto collision = root.find("collision")) {
    collision->expect_keys({"disabled_pairs"});
    const JsonReader pairs = collision->at("disabled_pairs");
    for (size_t i = 0; i < pairs.size(); ++i) {
      const JsonReader pair = pairs.at(i);
      if (!pair.is_array() || pair.size() != 2) pair.fail(InputErrorKind::wrong_type, "expected [name, name]");
      const std::string a = pair.at(0).string(), b = pair.at(1).string();
      for (size_t k = 0; k < 2; ++k) {
        const std::string n = pair.at(k).string();
        if (names.count(n) == 0) pair.at(k).fail(InputErrorKind::bad_value, "no body or instrument named \"" + n + "\"");
      }
      scene.disabled_pairs.emplace_back(a, b);
    }
  }
  if (auto loop = root.find("loop")) scene.loop = parse_loop_settings(*loop);
  if (auto haptics = root.find("haptics")) scene.haptics = parse_haptic_settings(*haptics);
  if (auto camera = root.find("camera")) scene.camera = read_camera(*camera);
  if (auto output = root.find("output")) scene.output = read_output(*output);
  return scene;
}

Scene load_scene(const std::string& path) {
  const nlohmann::json root = load_json_file(path);
  const std::string base = std::filesystem::path(path).parent_path().string();
  return parse_scene(root, path, base.empty() ? "." : base);
}

SceneInstance instantiate_scene(const Scene& scene) {
  SceneInstance instance;
  instance.executor = make_task_executor(scene.threads);
  instance.world = std::make_unique<World>(scene.world);
  World& world = *instance.world;
  world.set_executor(instance.executor.get());
  for (const auto& def : scene.bodies) instance.bodies.push_back(world.add_body(def));
  for (const auto& spec : scene.instruments) instance.instruments.push_back(Instrument::create(world, spec));

  // Collision filter by name: bodies, or every body of an instrument.
  auto ids_of = [&](const std::string& name) {
    std::vector<BodyId> ids;
    for (size_t i = 0; i < scene.bodies.size(); ++i) {
      if (scene.bodies[i].name == name) ids.push_back(instance.bodies[i]);
    }
    for (const auto& instrument : instance.instruments) {
      if (instrument.name() == name) {
        for (BodyId id : instrument.bodies()) ids.push_back(id);
      }
    }
    return ids;
  };
  for (const auto& [a, b] : scene.disabled_pairs) {
    for (BodyId ia : ids_of(a)) {
      for (BodyId ib : ids_of(b)) world.disable_collision(ia, ib);
    }
  }
  const ToolScript empty_script;
  const ToolScript& script = scene.script ? *scene.script : empty_script;
  for (const auto& instrument : instance.instruments) {
    instance.pose_sources.push_back(
        std::make_unique<ScriptPoseSource>(script, instrument.name(), instrument.command()));
  }
  return instance;
}

}  // namespace pliant
