#include <stdexcept>

#include "sim/input_error.h"
#include "sim/model/deformation_model.h"

namespace pliant {

// Placeholder until issue 3 lands.
std::unique_ptr<DeformationModel> make_deformation_model(ModelKind, TetMeshPtr, const Material&,
                                                         const ModelSettings&) {
  throw InputError(InputErrorKind::unsupported, "model", "no deformation model is built yet");
}

const char* to_string(ModelKind kind) {
  return kind == ModelKind::corotational_fem ? "corotational_fem" : "teschner_explicit";
}

}  // namespace pliant
