// The contact-surface method (Spillmann & Teschner), stages 3-5: deformation region, displacement
// vectors (Eq. 1), binary search on the pressure difference (Eq. 2), velocity update and Coulomb
// friction. Design notes and every choice where the paper is silent: docs/contact-surface.md.
#pragma once

#include <vector>

#include "sim/contact/contact_response.h"
#include "sim/contact/contact_velocity_update.h"
#include "sim/contact/deformation_region.h"

namespace pliant {

class ContactSurfaceResponse final : public ContactResponse {
 public:
  void respond(std::span<Body* const> bodies, std::span<const VertexContact> contacts, double dt,
               const ContactSettings& settings, StepReport& report) override;

 private:
  DeformationRegion region_;              ///< stage 3 result, reused across steps
  std::vector<ContactImpulse> impulses_;  ///< stage 5 impulses per contact
};

}  // namespace pliant
