// make_deformation_model: checks the settings once (STYLE.md 5) and builds the chosen model.
#include <cmath>
#include <string>

#include "sim/input_error.h"
#include "sim/model/corotational_fem.h"
#include "sim/model/deformation_model.h"
#include "sim/model/teschner_explicit.h"

namespace pliant {

namespace {

void check_settings(const ModelSettings& s) {
  const std::string where = "model";
  if (s.accuracy.max_solver_iterations < 1) {
    throw InputError(InputErrorKind::bad_value, where,
                     "max_solver_iterations: expected at least 1, got " + std::to_string(s.accuracy.max_solver_iterations));
  }
  if (!(s.accuracy.solver_tolerance > 0.0) || !std::isfinite(s.accuracy.solver_tolerance)) {
    throw InputError(InputErrorKind::bad_value, where, "solver_tolerance: expected a positive number");
  }
  const std::pair<double, const char*> stiffnesses[] = {{s.distance_stiffness, "distance_stiffness"},
                                                        {s.volume_stiffness, "volume_stiffness"},
                                                        {s.area_stiffness, "area_stiffness"},
                                                        {s.distance_damping, "distance_damping"}};
  for (const auto& [value, name] : stiffnesses) {
    if (!(value >= 0.0) || !std::isfinite(value)) {
      throw InputError(InputErrorKind::bad_value, where,
                       std::string(name) + ": expected a non-negative number (0 = derive), got " + std::to_string(value));
    }
  }
}

}  // namespace

std::unique_ptr<DeformationModel> make_deformation_model(ModelKind kind, TetMeshPtr mesh, const Material& material,
                                                         const ModelSettings& settings) {
  if (!mesh) throw InputError(InputErrorKind::bad_value, "model", "no mesh");
  check_settings(settings);
  switch (kind) {
    case ModelKind::corotational_fem: return std::make_unique<CorotationalFem>(std::move(mesh), material, settings);
    case ModelKind::teschner_explicit: return std::make_unique<TeschnerExplicit>(std::move(mesh), material, settings);
  }
  throw InputError(InputErrorKind::unsupported, "model", "unknown model kind");
}

const char* to_string(ModelKind kind) {
  return kind == ModelKind::corotational_fem ? "corotational_fem" : "teschner_explicit";
}

}  // namespace pliant
