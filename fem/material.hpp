// Linear isotropic material parameters of a tissue region (DESIGN section 6).
#pragma once

namespace scalpel {

struct Material {
  double young = 50e3;              // [Pa]
  double poisson = 0.45;            // [-], in (-1, 0.5)
  double density = 1100;            // [kg/m^3]
  double damping_mass = 0.1;        // Rayleigh alpha [1/s]
  double damping_stiffness = 0.01;  // Rayleigh beta [s]
  double prestress = 1.0;           // lambda0 [-]: rest shape scaled by 1/lambda0
};

struct Lame {
  double mu;      // [Pa]
  double lambda;  // [Pa]
};

[[nodiscard]] Lame lame_parameters(const Material& m);

}  // namespace scalpel
