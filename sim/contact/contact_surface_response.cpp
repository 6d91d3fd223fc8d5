#include "sim/contact/contact_surface_response.h"

namespace pliant {

// Placeholder until issue 5 lands: reports the overlap without resolving it.
void ContactSurfaceResponse::respond(std::span<Body* const>, std::span<const VertexContact> contacts, double,
                                     const ContactSettings&, StepReport& report) {
  for (const auto& c : contacts) report.max_residual_overlap = std::max(report.max_residual_overlap, c.penetration_depth);
}

}  // namespace pliant
