// Linear isotropic material parameters of a tissue region (docs/tissue.md).
#pragma once

#include <optional>
#include <string>

namespace scalpel {

struct Material {
  double young = 50e3;              // [Pa]
  double poisson = 0.45;            // [-], in (-1, 0.5)
  double density = 1100;            // [kg/m^3]
  double damping_mass = 0.1;        // Rayleigh alpha [1/s]
  double damping_stiffness = 0.01;  // Rayleigh beta [s]
  double prestress = 1.0;           // lambda0 [-]: rest shape scaled by 1/lambda0
  // [N] The force under a blade's edge or tip at which the region's surface gives way and the blade
  // cuts in (sim/indentation.hpp); not used by the tissue solve. The default is of the order of
  // the forces at which sharp blades and needles break through skin (docs/contact.md).
  double puncture_force = 1.5;
};

struct Lame {
  double mu;      // [Pa]
  double lambda;  // [Pa]
};

[[nodiscard]] Lame lame_parameters(const Material& m);

// A bad material value: `field` is the Material member (and scenario key) at fault.
struct MaterialError {
  std::string field;    // "young", "poisson", "density", "damping_mass", "damping_stiffness", "prestress",
                        // "puncture_force"
  std::string message;  // e.g. "must be positive [Pa], got -5"
};

// Checks the physical ranges: young > 0, -1 < poisson < 0.5, density > 0, both damping
// coefficients >= 0, prestress > 0, all finite. Returns the first violation, or nothing.
// The scenario loader turns the result into an InputError located at the offending key.
[[nodiscard]] std::optional<MaterialError> validate_material(const Material& m);

}  // namespace scalpel
