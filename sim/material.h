// Material parameters of a body, SI units.
#pragma once

#include <cmath>

namespace pliant {

struct Material {
  double young_modulus = 5e3;       ///< E (Pa)
  double poisson_ratio = 0.45;      ///< nu, in [0, 0.5)
  double density = 1000.0;          ///< rho (kg/m^3)
  double mass_damping = 0.0;        ///< Rayleigh alpha (1/s): damping force -alpha M v
  double stiffness_damping = 0.01;  ///< Rayleigh beta (s): damping force -beta K v
  double friction = 0.0;            ///< Coulomb friction coefficient mu (dimensionless)

  /// Lame's first parameter lambda (Pa).
  double lame_lambda() const {
    return young_modulus * poisson_ratio / ((1.0 + poisson_ratio) * (1.0 - 2.0 * poisson_ratio));
  }
  /// Shear modulus mu (Pa).
  double lame_mu() const { return young_modulus / (2.0 * (1.0 + poisson_ratio)); }
  /// Pressure (P-) wave speed c_p = sqrt((lambda + 2 mu) / rho) (m/s).
  double pressure_wave_speed() const { return std::sqrt((lame_lambda() + 2.0 * lame_mu()) / density); }
};

}  // namespace pliant
