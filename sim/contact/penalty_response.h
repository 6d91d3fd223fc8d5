// The penalty baseline ([10] in the paper; algorithms.md section 4): f = k d r on the penetrating
// vertex, -f spread over its contact triangle by barycentric weights, optional normal damping and
// Coulomb friction. The stiffness k is the tuning constant the contact-surface method removes.
#pragma once

#include "sim/contact/contact_response.h"

namespace pliant {

class PenaltyResponse final : public ContactResponse {
 public:
  void respond(std::span<Body* const> bodies, std::span<const VertexContact> contacts, double dt,
               const ContactSettings& settings, StepReport& report) override;
};

}  // namespace pliant
