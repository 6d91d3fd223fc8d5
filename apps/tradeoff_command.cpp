// `pliant tradeoff`: every combination of binary-search iterations x CG iterations x dt factor is run
// over the same simulated time as `steps` scene steps and compared with a reference run at the
// highest settings (most iterations of both, smallest dt). Runs are deterministic (bit-identical
// reruns), so the reference compared with itself gives zero error: the sweep includes it as a check.
// Errors: residual overlap (absolute), surface-vertex position RMS at the end, instrument force RMS
// over time (reference linearly interpolated to each run's tick times), energy drift. Cost: median
// wall time per tick (SteadyClock around SceneRunner::tick; the ClockStageProfiler's stage sum is
// written too), and per scene step, i.e. scaled by scene dt / dt so that runs at other dt compare
// at equal simulated time. Mesh resolution: the scene's generated box and membrane meshes are
// re-meshed with their cell counts times a factor (JSON rewritten before parsing; fixed regions are
// boxes and planes in world coordinates, so they follow). Those runs use the scene's default
// settings and are compared with a run at the largest factor and the reference's settings; surface
// vertices no longer match by index, so the reference's deformed positions are resampled at each
// run's surface vertices through the reference mesh's rest tetrahedra (barycentric interpolation).
// Sleeping (scene "sleep") is off in every run: bodies falling asleep at different moments would
// add their own differences to the ones being measured.
#include "apps/tradeoff_command.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

#include "interaction/clock.h"
#include "interaction/json_reader.h"
#include "interaction/scene/scene.h"
#include "interaction/scene/scene_runner.h"
#include "interaction/scene/stage_profiler.h"
#include "sim/input_error.h"
#include "sim/io/atomic_file.h"

namespace pliant {
namespace {

/// One point of the sweep.
struct Setting {
  int binary_search_iterations = 4;
  int solver_iterations = 20;
  double dt_factor = 1.0;
  double resolution_factor = 1.0;  ///< cell counts of generated box/membrane meshes x this
  double held_final_strain = 0.0;  ///< contact.held_linearised_final_strain
};

/// Everything a run records for the comparison.
struct RunRecord {
  bool failed = false;
  std::string fault;
  long steps = 0;
  long retried = 0;
  double dt = 0.0;
  double max_overlap = 0.0;    ///< m
  double mean_overlap = 0.0;   ///< m, over steps
  double energy_drift = 0.0;   ///< J, (kinetic + elastic + gravitational) - work_by_kinematic at the end
  double median_tick_s = 0.0;  ///< wall time per tick
  double median_stage_s = 0.0; ///< sum of the stage times per step (ClockStageProfiler)
  std::vector<double> times;                ///< s, end of each tick
  std::vector<std::vector<Vec3>> forces;    ///< per tick, one force per instrument (N)
  std::vector<std::vector<Vec3>> surfaces;  ///< per deformable body, surface vertex positions at the end
  std::vector<TetMeshPtr> meshes;           ///< per deformable body
  std::vector<std::vector<Vec3>> positions; ///< per deformable body, all vertex positions at the end
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

Scene configured(const Scene& base, const Setting& s) {
  Scene scene = base;
  scene.world.contact.binary_search_iterations = s.binary_search_iterations;
  scene.world.contact.held_linearised_final_strain = s.held_final_strain;
  for (BodyDef& b : scene.bodies) b.model_settings.accuracy.max_solver_iterations = s.solver_iterations;
  scene.time_step = base.time_step * s.dt_factor;
  scene.output.frames = false;
  scene.output.vtu = false;
  scene.world.sleep.enabled = false;
  return scene;
}

/// The scene file with the cell counts of its generated box and membrane meshes times `factor`
/// (at least one cell per axis). `remeshed` counts the bodies changed.
Scene remeshed_scene(const std::string& path, double factor, int* remeshed) {
  nlohmann::json root = load_json_file(path);
  *remeshed = 0;
  if (root.is_object() && root.contains("bodies") && root["bodies"].is_array()) {
    for (auto& body : root["bodies"]) {
      if (!body.is_object() || !body.contains("mesh") || !body["mesh"].is_object()) continue;
      auto& mesh = body["mesh"];
      const std::string shape = mesh.value("shape", std::string());
      if (shape != "box" && shape != "membrane") continue;
      nlohmann::json cells = mesh.contains("cells") ? mesh["cells"] : nlohmann::json::array({8, 8, 1});
      if (!cells.is_array() || cells.size() != 3) continue;  // parse_scene reports it
      for (auto& c : cells) {
        if (c.is_number()) c = std::max(1L, std::lround(c.get<double>() * factor));
      }
      mesh["cells"] = cells;
      ++*remeshed;
    }
  }
  const std::string base = std::filesystem::path(path).parent_path().string();
  return parse_scene(root, path, base.empty() ? "." : base);
}

RunRecord run_setting(const Scene& base, const Setting& s, double end_time) {
  const Scene scene = configured(base, s);
  RunRecord rec;
  rec.dt = scene.time_step;
  SceneRunner runner(scene);
  SteadyClock clock;
  ClockStageProfiler profiler(clock);
  const long steps = std::max(1L, std::lround(end_time / scene.time_step));
  std::vector<double> tick_s, stage_s;
  tick_s.reserve(static_cast<size_t>(steps));
  stage_s.reserve(static_cast<size_t>(steps));
  double overlap_sum = 0.0;
  for (long i = 0; i < steps; ++i) {
    const double t0 = clock.now();
    const bool ok = runner.tick(&profiler);
    tick_s.push_back(clock.now() - t0);
    stage_s.push_back(profiler.total());
    if (!ok) {
      rec.failed = true;
      rec.fault = runner.fault();
      break;
    }
    const StepReport& r = runner.report();
    rec.max_overlap = std::max(rec.max_overlap, r.max_residual_overlap);
    overlap_sum += r.max_residual_overlap;
    rec.times.push_back(runner.time());
    std::vector<Vec3> f;
    for (const InstrumentReading& reading : runner.readings()) f.push_back(reading.force);
    rec.forces.push_back(std::move(f));
    rec.energy_drift = r.energy.total() - r.energy.work_by_kinematic;
    ++rec.steps;
  }
  rec.retried = runner.retried_steps();
  rec.mean_overlap = rec.steps > 0 ? overlap_sum / static_cast<double>(rec.steps) : 0.0;
  rec.median_tick_s = median(tick_s);
  rec.median_stage_s = median(stage_s);
  for (BodyId id : runner.instance().bodies) {
    const Body& b = runner.world().body(id);
    if (b.is_kinematic()) continue;
    std::vector<Vec3> surface;
    for (int v : b.mesh->surface_vertices()) surface.push_back(b.positions[static_cast<size_t>(v)]);
    rec.surfaces.push_back(std::move(surface));
    rec.meshes.push_back(b.mesh);
    rec.positions.push_back(b.positions);
  }
  return rec;
}

/// The reference body's deformed position at rest point `p` (mesh coordinates): barycentric
/// interpolation in the rest tet that contains p (the nearest one by barycentric violation if p
/// lies just outside the mesh).
Vec3 resample(const TetMesh& mesh, const std::vector<Vec3>& deformed, const Vec3& p) {
  const auto& rest = mesh.rest_positions();
  double best_violation = std::numeric_limits<double>::infinity();
  Vec3 best = Vec3::Zero();
  for (const auto& t : mesh.tets()) {
    const Vec3& a = rest[static_cast<size_t>(t[0])];
    Eigen::Matrix3d m;
    m.col(0) = rest[static_cast<size_t>(t[1])] - a;
    m.col(1) = rest[static_cast<size_t>(t[2])] - a;
    m.col(2) = rest[static_cast<size_t>(t[3])] - a;
    const Vec3 l = m.inverse() * (p - a);
    const double b[4] = {1.0 - l.sum(), l.x(), l.y(), l.z()};
    double violation = 0.0;
    for (double w : b) violation = std::max(violation, -w);
    if (violation < best_violation) {
      best_violation = violation;
      best = Vec3::Zero();
      for (int k = 0; k < 4; ++k) best += b[k] * deformed[static_cast<size_t>(t[k])];
      if (violation <= 1e-12) break;
    }
  }
  return best;
}

/// RMS distance at the end between a run's surface vertices and the reference resampled there (m).
double resampled_surface_rms(const RunRecord& run, const RunRecord& ref) {
  double sum = 0.0;
  size_t n = 0;
  for (size_t b = 0; b < run.meshes.size() && b < ref.meshes.size(); ++b) {
    const TetMesh& mesh = *run.meshes[b];
    for (int v : mesh.surface_vertices()) {
      const Vec3 at_ref = resample(*ref.meshes[b], ref.positions[b], mesh.rest_positions()[static_cast<size_t>(v)]);
      sum += (run.positions[b][static_cast<size_t>(v)] - at_ref).squaredNorm();
      ++n;
    }
  }
  return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

/// RMS distance between the surface vertices of a run and the reference at the end (m).
double surface_rms(const RunRecord& run, const RunRecord& ref) {
  double sum = 0.0;
  size_t n = 0;
  for (size_t b = 0; b < run.surfaces.size() && b < ref.surfaces.size(); ++b) {
    for (size_t v = 0; v < run.surfaces[b].size(); ++v) {
      sum += (run.surfaces[b][v] - ref.surfaces[b][v]).squaredNorm();
      ++n;
    }
  }
  return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

/// The reference's instrument forces at time t, linearly interpolated between its ticks.
std::vector<Vec3> reference_force_at(const RunRecord& ref, double t) {
  const auto it = std::lower_bound(ref.times.begin(), ref.times.end(), t - 1e-12);
  if (it == ref.times.end()) return ref.forces.back();
  const auto k = static_cast<size_t>(it - ref.times.begin());
  if (k == 0) return ref.forces.front();
  const double t0 = ref.times[k - 1], t1 = ref.times[k];
  const double w = t1 > t0 ? std::clamp((t - t0) / (t1 - t0), 0.0, 1.0) : 1.0;
  std::vector<Vec3> f(ref.forces[k].size());
  for (size_t i = 0; i < f.size(); ++i) f[i] = (1.0 - w) * ref.forces[k - 1][i] + w * ref.forces[k][i];
  return f;
}

/// RMS over the run's ticks of |F - F_ref| summed over instruments (N).
double force_rms(const RunRecord& run, const RunRecord& ref) {
  if (run.times.empty() || ref.times.empty()) return 0.0;
  double sum = 0.0;
  for (size_t i = 0; i < run.times.size(); ++i) {
    const std::vector<Vec3> f_ref = reference_force_at(ref, run.times[i]);
    for (size_t k = 0; k < f_ref.size() && k < run.forces[i].size(); ++k) sum += (run.forces[i][k] - f_ref[k]).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(run.times.size()));
}

double rms_magnitude(const RunRecord& run) {
  if (run.times.empty()) return 0.0;
  double sum = 0.0;
  for (const auto& fs : run.forces) {
    for (const Vec3& f : fs) sum += f.squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(run.times.size()));
}

/// Marks the points not dominated in (cost, error): no other point is both cheaper and no worse.
std::vector<char> pareto(const std::vector<double>& cost, const std::vector<double>& error, const std::vector<char>& valid) {
  std::vector<char> front(cost.size(), 0);
  for (size_t i = 0; i < cost.size(); ++i) {
    if (!valid[i]) continue;
    bool dominated = false;
    for (size_t j = 0; j < cost.size() && !dominated; ++j) {
      if (j == i || !valid[j]) continue;
      dominated = cost[j] <= cost[i] && error[j] <= error[i] && (cost[j] < cost[i] || error[j] < error[i]);
    }
    front[i] = dominated ? 0 : 1;
  }
  return front;
}

/// scripts/plot_tradeoff.sh next to the working directory or the executable's source tree.
std::filesystem::path find_plot_script() {
  namespace fs = std::filesystem;
  std::vector<fs::path> candidates{fs::path("scripts/plot_tradeoff.sh")};
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    for (fs::path dir = exe.parent_path(); !dir.empty() && dir != dir.root_path(); dir = dir.parent_path()) {
      candidates.push_back(dir / "scripts/plot_tradeoff.sh");
    }
  }
  for (const fs::path& p : candidates) {
    if (fs::exists(p, ec)) return p;
  }
  return {};
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

}  // namespace

int run_tradeoff(const TradeoffOptions& options, std::ostream& log) {
  if (options.steps < 1) throw InputError(InputErrorKind::bad_value, "--steps", "must be at least 1");
  if (options.binary_search_iterations.empty() || options.solver_iterations.empty() || options.dt_factors.empty()) {
    throw InputError(InputErrorKind::bad_value, "--binary-search/--solver/--dt", "each list needs a value");
  }
  const Scene base = load_scene(options.scene);
  const double end_time = static_cast<double>(options.steps) * base.time_step;
  const double scene_gate = base.world.contact.held_linearised_final_strain;
  const std::vector<double> gates =
      options.held_final_strains.empty() ? std::vector<double>{scene_gate} : options.held_final_strains;
  for (double g : gates) {
    if (!(g >= 0.0)) throw InputError(InputErrorKind::bad_value, "--held-final-strain", "expected numbers >= 0");
  }
  const std::filesystem::path out = options.out;
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw InputError(InputErrorKind::io, out.string(), "cannot create output folder: " + ec.message());

  const Setting reference{*std::max_element(options.binary_search_iterations.begin(), options.binary_search_iterations.end()),
                          *std::max_element(options.solver_iterations.begin(), options.solver_iterations.end()),
                          *std::min_element(options.dt_factors.begin(), options.dt_factors.end()), 1.0,
                          *std::min_element(gates.begin(), gates.end())};
  int default_solver = 20;
  for (const BodyDef& b : base.bodies) {
    if (b.motion == BodyMotion::deformable) default_solver = b.model_settings.accuracy.max_solver_iterations;
  }
  const Setting scene_default{base.world.contact.binary_search_iterations, default_solver, 1.0, 1.0, scene_gate};

  if (!options.quiet) {
    log << "tradeoff: " << base.name << ", " << options.steps << " steps of " << base.time_step * 1e3
        << " ms; reference: " << reference.binary_search_iterations << " binary-search iterations, "
        << reference.solver_iterations << " CG iterations, dt x" << reference.dt_factor << ", held final gate "
        << reference.held_final_strain << "\n";
  }
  const RunRecord ref = run_setting(base, reference, end_time);
  if (ref.failed) {
    log << "tradeoff: the reference run failed: " << ref.fault << "\n";
    return 1;
  }
  const double ref_force = rms_magnitude(ref);
  double resolution_reference_energy = 0.0, resolution_reference_force = 0.0;
  std::optional<Setting> resolution_reference;

  std::vector<Setting> settings;
  for (double dt : options.dt_factors) {
    for (int cg : options.solver_iterations) {
      for (int bs : options.binary_search_iterations) {
        for (double g : gates) settings.push_back(Setting{bs, cg, dt, 1.0, g});
      }
    }
  }
  std::vector<RunRecord> runs;
  std::vector<double> cost, pos_err, force_err;
  std::vector<char> valid;
  for (const Setting& s : settings) {
    RunRecord r = run_setting(base, s, end_time);
    const double per_scene_step = base.time_step / r.dt;  // ticks per scene step
    cost.push_back(r.median_tick_s * 1e3 * per_scene_step);
    pos_err.push_back(r.failed ? std::numeric_limits<double>::infinity() : surface_rms(r, ref));
    force_err.push_back(r.failed ? std::numeric_limits<double>::infinity() : force_rms(r, ref));
    valid.push_back(r.failed ? 0 : 1);
    if (!options.quiet) {
      log << "  bs " << s.binary_search_iterations << " cg " << s.solver_iterations << " dt x" << s.dt_factor;
      if (gates.size() > 1) log << " gate " << s.held_final_strain;
      log << ": " << (r.failed ? "FAILED " + r.fault : "") << std::setprecision(3) << " surface " << pos_err.back() * 1e3
          << " mm, force " << force_err.back() << " N, " << cost.back() << " ms/scene step\n";
    }
    runs.push_back(std::move(r));
  }
  std::vector<char> front_pos = pareto(cost, pos_err, valid);
  std::vector<char> front_force = pareto(cost, force_err, valid);
  std::vector<const char*> compared_with(settings.size(), "settings");
  std::vector<long> deformable_vertices(settings.size(), 0);
  auto count_vertices = [](const RunRecord& r) {
    long n = 0;
    for (const auto& p : r.positions) n += static_cast<long>(p.size());
    return n;
  };
  for (size_t i = 0; i < runs.size(); ++i) deformable_vertices[i] = count_vertices(runs[i]);

  // Mesh resolution: the scene's default settings at each factor against the finest factor run
  // at the reference's settings; surfaces compared by resampling (see the design note).
  const bool sweep_resolution =
      options.resolution_factors.size() > 1 ||
      (options.resolution_factors.size() == 1 && options.resolution_factors[0] != 1.0);
  if (sweep_resolution) {
    const double finest = *std::max_element(options.resolution_factors.begin(), options.resolution_factors.end());
    int remeshed = 0;
    const Scene finest_scene = remeshed_scene(options.scene, finest, &remeshed);
    if (remeshed == 0) {
      if (!options.quiet) log << "tradeoff: the scene has no generated box or membrane mesh; no resolution sweep\n";
    } else {
      Setting res_reference = reference;
      res_reference.resolution_factor = finest;
      const RunRecord res_ref = run_setting(finest_scene, res_reference, end_time);
      if (res_ref.failed) {
        log << "tradeoff: the finest-resolution reference failed: " << res_ref.fault << "; no resolution sweep\n";
      } else {
        std::vector<double> rcost, rpos, rforce;
        std::vector<char> rvalid;
        for (double f : options.resolution_factors) {
          Setting s = scene_default;
          s.resolution_factor = f;
          const Scene scene = remeshed_scene(options.scene, f, &remeshed);
          RunRecord r = run_setting(scene, s, end_time);
          rcost.push_back(r.median_tick_s * 1e3 * base.time_step / r.dt);
          rpos.push_back(r.failed ? std::numeric_limits<double>::infinity() : resampled_surface_rms(r, res_ref));
          rforce.push_back(r.failed ? std::numeric_limits<double>::infinity() : force_rms(r, res_ref));
          rvalid.push_back(r.failed ? 0 : 1);
          if (!options.quiet) {
            log << "  mesh x" << f << " (" << count_vertices(r) << " deformable vertices): "
                << (r.failed ? "FAILED " + r.fault : "") << std::setprecision(3) << " surface " << rpos.back() * 1e3
                << " mm, force " << rforce.back() << " N, " << rcost.back() << " ms/scene step\n";
          }
          settings.push_back(s);
          deformable_vertices.push_back(count_vertices(r));
          compared_with.push_back("resolution");
          runs.push_back(std::move(r));
        }
        const std::vector<char> rfront_pos = pareto(rcost, rpos, rvalid);
        const std::vector<char> rfront_force = pareto(rcost, rforce, rvalid);
        for (size_t k = 0; k < rcost.size(); ++k) {
          cost.push_back(rcost[k]);
          pos_err.push_back(rpos[k]);
          force_err.push_back(rforce[k]);
          valid.push_back(rvalid[k]);
          front_pos.push_back(rfront_pos[k]);
          front_force.push_back(rfront_force[k]);
        }
        resolution_reference_energy = res_ref.energy_drift;
        resolution_reference_force = rms_magnitude(res_ref);
        resolution_reference = res_reference;
      }
    }
  }

  std::ostringstream csv;
  csv << std::setprecision(6);
  csv << "binary_search_iterations,solver_iterations,dt_factor,dt_s,steps,failed,retried_steps,"
         "max_residual_overlap_mm,mean_residual_overlap_mm,surface_rms_error_mm,force_rms_error_N,"
         "force_rms_reference_N,energy_drift_J,energy_drift_error_J,median_ms_per_step,median_stage_ms_per_step,"
         "ms_per_scene_step,pareto_surface,pareto_force,is_default,is_reference,resolution_factor,deformable_vertices,"
         "compared_with,held_final_strain\n";
  for (size_t i = 0; i < settings.size(); ++i) {
    const Setting& s = settings[i];
    const RunRecord& r = runs[i];
    const bool by_resolution = std::string(compared_with[i]) == "resolution";
    auto same = [&](const Setting& o) {
      return o.binary_search_iterations == s.binary_search_iterations && o.solver_iterations == s.solver_iterations &&
             o.dt_factor == s.dt_factor && o.resolution_factor == s.resolution_factor &&
             o.held_final_strain == s.held_final_strain;
    };
    const double row_ref_force = by_resolution ? resolution_reference_force : ref_force;
    const double row_ref_energy = by_resolution ? resolution_reference_energy : ref.energy_drift;
    const bool row_is_reference = by_resolution ? (resolution_reference && same(*resolution_reference)) : same(reference);
    csv << s.binary_search_iterations << ',' << s.solver_iterations << ',' << s.dt_factor << ',' << r.dt << ','
        << r.steps << ',' << (r.failed ? 1 : 0) << ',' << r.retried << ',' << r.max_overlap * 1e3 << ','
        << r.mean_overlap * 1e3 << ',' << pos_err[i] * 1e3 << ',' << force_err[i] << ',' << row_ref_force << ','
        << r.energy_drift << ',' << std::abs(r.energy_drift - row_ref_energy) << ',' << r.median_tick_s * 1e3
        << ',' << r.median_stage_s * 1e3 << ',' << cost[i] << ',' << int(front_pos[i]) << ',' << int(front_force[i])
        << ',' << (!by_resolution && same(scene_default) ? 1 : 0) << ',' << (row_is_reference ? 1 : 0) << ','
        << s.resolution_factor << ',' << deformable_vertices[i] << ',' << compared_with[i] << ','
        << s.held_final_strain << '\n';
  }
  const std::filesystem::path csv_path = out / "tradeoff.csv";
  write_file_atomically(csv_path.string(), csv.str());
  if (!options.quiet) log << "tradeoff: wrote " << csv_path.string() << "\n";

  if (options.plot) {
    const std::filesystem::path script = find_plot_script();
    if (script.empty()) {
      log << "tradeoff: scripts/plot_tradeoff.sh not found; no plot\n";
    } else {
      const std::string cmd = "bash " + shell_quote(script.string()) + " " + shell_quote(csv_path.string()) + " " +
                              shell_quote((out / "tradeoff.png").string()) + " " + shell_quote(base.name);
      if (std::system(cmd.c_str()) != 0) {
        log << "tradeoff: plotting failed (is gnuplot installed?)\n";
      } else if (!options.quiet) {
        log << "tradeoff: wrote " << (out / "tradeoff.png").string() << "\n";
      }
    }
  }
  return 0;
}

}  // namespace pliant
