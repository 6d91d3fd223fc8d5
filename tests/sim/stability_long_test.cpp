// Stability at the extremes, the full matrix (issue 8, item 3; label "long", outside the default
// suite): stiffness ratio 1e-6..1e6, Poisson's ratio up to 0.499, dt 1e-5..2e-2 s, instrument speed
// up to 2 m/s, initial overlap up to 90% of the upper body's thickness, a sliver tet, 1 mg and
// 1000 kg bodies, for both contact methods. Each case checks finiteness, energy against the work
// put in, and bounded residual overlap (tests/sim/stability_harness.h; results in docs/stability.md).
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "sim/stability_harness.h"

namespace pliant::stability {
namespace {

std::vector<Case> full_matrix() {
  std::vector<Case> cases;
  for (ContactMethod m : {ContactMethod::contact_surface, ContactMethod::penalty}) {
    const std::string tag = std::string(to_string(m)) + " ";
    for (double ratio : {1e-6, 1e-3, 1.0, 1e3, 1e6}) {
      Case c{.name = tag + "stiffness ratio " + std::to_string(ratio), .method = m};
      c.stiffness_ratio = ratio;
      cases.push_back(c);
    }
    for (double nu : {0.45, 0.49, 0.499}) {
      Case c{.name = tag + "poisson " + std::to_string(nu), .method = m};
      c.poisson = nu;
      cases.push_back(c);
    }
    for (double dt : {1e-5, 1e-4, 5e-3, 2e-2}) {
      Case c{.name = tag + "dt " + std::to_string(dt), .method = m};
      c.dt = dt;
      cases.push_back(c);
    }
    for (double dt : {1e-5, 1e-3, 2e-2}) {
      for (double speed : {0.01, 0.1, 0.5, 2.0}) {
        Case c{.name = tag + "instrument " + std::to_string(speed) + " m/s dt " + std::to_string(dt), .method = m,
               .partner = Partner::instrument};
        c.dt = dt;
        c.speed = speed;
        cases.push_back(c);
      }
    }
    for (double f : {0.1, 0.5, 0.9}) {
      Case c{.name = tag + "initial overlap " + std::to_string(f), .method = m};
      c.overlap_fraction = f;
      cases.push_back(c);
    }
    {
      Case c{.name = tag + "sliver on block", .method = m};
      c.sliver = true;
      cases.push_back(c);
      Case d{.name = tag + "sliver instrument 0.5 m/s", .method = m, .partner = Partner::instrument};
      d.sliver = true;
      d.speed = 0.5;
      cases.push_back(d);
    }
    for (double mass : {1e-6, 1000.0}) {
      Case c{.name = tag + "upper mass " + std::to_string(mass) + " kg", .method = m};
      c.upper_mass = mass;
      cases.push_back(c);
    }
    // Corners: several extremes at once.
    {
      Case c{.name = tag + "corner ratio 1e6 nu 0.499 dt 2e-2", .method = m};
      c.stiffness_ratio = 1e6;
      c.poisson = 0.499;
      c.dt = 2e-2;
      cases.push_back(c);
      Case d{.name = tag + "corner ratio 1e-6 nu 0.499 overlap 0.5", .method = m};
      d.stiffness_ratio = 1e-6;
      d.poisson = 0.499;
      d.overlap_fraction = 0.5;
      cases.push_back(d);
      Case e{.name = tag + "corner 1000 kg dt 2e-2 ratio 1e3", .method = m};
      e.upper_mass = 1000.0;
      e.dt = 2e-2;
      e.stiffness_ratio = 1e3;
      cases.push_back(e);
      Case f{.name = tag + "corner 1 mg dt 1e-5 sliver", .method = m};
      f.upper_mass = 1e-6;
      f.dt = 1e-5;
      f.sliver = true;
      cases.push_back(f);
    }
    // Session 8, the same extremes with bodies that can carry the load (docs/stability.md M8, M9):
    // at ratio 1e6 about E 1e4 Pa the soft block has E = 10 Pa and cannot carry its own weight
    // (rho g H / E = 39) and 1000 kg presses 6.1 MPa on 1e4 Pa tissue, so those rows mix the
    // model's collapse with the contact. Here the soft side is the nominal 1e4 Pa tissue and the
    // 1000 kg block rests on 1e9 Pa (strain 0.6%): real bodies would rest.
    for (double ratio : {1e-6, 1e6}) {
      Case c{.name = tag + "stiffness ratio " + std::to_string(ratio) + " soft side 1e4 Pa", .method = m};
      c.stiffness_ratio = ratio;
      c.young_mean = 1e7;
      cases.push_back(c);
    }
    {
      Case c{.name = tag + "upper mass 1000 kg on 1e9 Pa", .method = m};
      c.upper_mass = 1000.0;
      c.young_mean = 1e9;
      cases.push_back(c);
    }
  }
  // Opt-in (session 6): PLIANT_STABILITY_IMPLICIT_CORRECTION=1 (or "all") runs the contact-surface
  // cases with ContactSettings::implicit_correction on for every body, =2 (or "stiff_partners") only
  // where the partner is immovable, =3 (or "coupled") with free-free contacts coupled (session 7)
  // (docs/contact-surface.md, "Contact inside the implicit solve").
  if (const char* env = std::getenv("PLIANT_STABILITY_IMPLICIT_CORRECTION"); env != nullptr) {
    const std::string name = env;
    const ImplicitCorrection scope = name == "1" || name == "all"                ? ImplicitCorrection::all
                                     : name == "2" || name == "stiff_partners" ? ImplicitCorrection::stiff_partners
                                     : name == "3" || name == "coupled"        ? ImplicitCorrection::coupled
                                                                                : ImplicitCorrection::off;
    for (Case& c : cases) {
      if (c.method != ContactMethod::contact_surface || scope == ImplicitCorrection::off) continue;
      c.contact_tweak = [tweak = c.contact_tweak, scope](ContactSettings& s) {
        if (tweak) tweak(s);
        s.implicit_correction = scope;
      };
    }
  }
  // Opt-in (session 21): PLIANT_STABILITY_HELD_FINAL_STRAIN=g runs the contact-surface cases with
  // ContactSettings::held_linearised_final_strain = g (the final evaluation linearised under held
  // forces where the moves pass g; docs/contact-surface.md "Response time, session 21").
  if (const char* env = std::getenv("PLIANT_STABILITY_HELD_FINAL_STRAIN"); env != nullptr) {
    char* end = nullptr;
    const double strain = std::strtod(env, &end);
    if (end == env || *end != '\0' || !(strain >= 0.0)) {
      std::fprintf(stderr, "PLIANT_STABILITY_HELD_FINAL_STRAIN: '%s' is not a strain >= 0\n", env);
      std::exit(2);
    }
    for (Case& c : cases) {
      if (c.method != ContactMethod::contact_surface) continue;
      c.contact_tweak = [tweak = c.contact_tweak, strain](ContactSettings& s) {
        if (tweak) tweak(s);
        s.held_linearised_final_strain = strain;
      };
    }
  }
  // Opt-in settings for measuring them on the whole matrix (session 9, docs/stability.md M7, M10):
  // PLIANT_STABILITY_OPT_IN, a comma-separated list of anchored (ContactSettings::
  // anchored_friction_compliance), limit (limit_friction_move), charge_returns (the limit charging
  // returns, session 15), charge_deformable_returns (charging them unless every friction partner of
  // the body is an instrument, session 16), energy_flow (limit_friction_move_energy_flow, session 17),
  // release (release_distant_held_contacts), frictionless (friction off), on
  // the contact-surface cases.
  if (const char* env = std::getenv("PLIANT_STABILITY_OPT_IN"); env != nullptr) {
    bool anchored = false, limit = false, charge_returns = false, release = false, frictionless = false,
         deformable_returns = false, energy_flow = false;
    std::stringstream list(env);
    for (std::string name; std::getline(list, name, ',');) {
      bool* flag = name == "anchored" ? &anchored
                   : name == "limit"  ? &limit
                   : name == "charge_returns" ? &charge_returns
                   : name == "charge_deformable_returns" ? &deformable_returns
                   : name == "energy_flow" ? &energy_flow
                   : name == "release" ? &release
                   : name == "frictionless" ? &frictionless
                                            : nullptr;
      if (flag == nullptr) {
        std::fprintf(stderr,
                     "PLIANT_STABILITY_OPT_IN: unknown '%s' (anchored, limit, charge_returns, charge_deformable_returns, "
                     "energy_flow, release, frictionless)\n",
                     name.c_str());
        std::exit(2);
      }
      *flag = true;
    }
    for (Case& c : cases) {
      if (c.method != ContactMethod::contact_surface) continue;
      c.contact_tweak = [tweak = c.contact_tweak, anchored, limit, charge_returns, deformable_returns, energy_flow,
                         release, frictionless](ContactSettings& s) {
        if (tweak) tweak(s);
        s.anchored_friction_compliance = s.anchored_friction_compliance || anchored;
        s.limit_friction_move = s.limit_friction_move || limit || charge_returns || deformable_returns || energy_flow;
        s.limit_friction_move_energy_flow = s.limit_friction_move_energy_flow || energy_flow;
        s.limit_friction_move_charges_returns =
            s.limit_friction_move_charges_returns || charge_returns || deformable_returns;
        s.limit_friction_move_excuses_instrument_returns =
            s.limit_friction_move_excuses_instrument_returns || deformable_returns;
        s.release_distant_held_contacts = s.release_distant_held_contacts || release;
        s.friction = s.friction && !frictionless;
      };
    }
  }
  return cases;
}

class LongStabilityMatrix : public ::testing::TestWithParam<Case> {};

TEST_P(LongStabilityMatrix, StaysFiniteConservesEnergyAndBoundsOverlap) { expect_stable(GetParam()); }

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  std::string s = std::to_string(info.index) + "_" + info.param.name;
  for (char& ch : s) {
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  }
  return s;
}

INSTANTIATE_TEST_SUITE_P(Long, LongStabilityMatrix, ::testing::ValuesIn(full_matrix()), case_name);

}  // namespace
}  // namespace pliant::stability
