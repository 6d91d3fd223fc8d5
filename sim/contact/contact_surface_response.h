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
  /// The search's samples of one vertex: (fraction, own minus other pressure).
  struct SearchSamples {
    struct Sample {
      double fraction = 0.0;
      double difference = 0.0;
    };
    Sample last, previous, above, below;  ///< above: difference > 0; below: <= 0
    bool has_last = false, has_previous = false, has_above = false, has_below = false;
    void add(double fraction, double difference);
    /// Secant estimate of the balance (see ContactSettings::secant_refinement).
    double refine(double bisection) const;
  };

  DeformationRegion region_;
  std::vector<SearchSamples> samples_;              ///< stage 3 result, reused across steps
  std::vector<ContactImpulse> impulses_;  ///< stage 5 impulses per contact
};

}  // namespace pliant
