#include "fem/material.hpp"

#include <cmath>
#include <sstream>

namespace scalpel {

Lame lame_parameters(const Material& m) {
  const double e = m.young, nu = m.poisson;
  return {e / (2.0 * (1.0 + nu)), e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))};
}

namespace {

MaterialError error(const char* field, const char* rule, double got) {
  std::ostringstream s;
  s.precision(17);
  s << rule << ", got " << got;
  return {field, s.str()};
}

}  // namespace

std::optional<MaterialError> validate_material(const Material& m) {
  // Negated comparisons so that NaN fails every check.
  if (!(m.young > 0) || !std::isfinite(m.young))
    return error("young", "must be positive and finite [Pa]", m.young);
  if (!(m.poisson > -1.0 && m.poisson < 0.5))
    return error("poisson", "must lie in (-1, 0.5) [-] (0.5 is incompressible)", m.poisson);
  if (!(m.density > 0) || !std::isfinite(m.density))
    return error("density", "must be positive and finite [kg/m^3]", m.density);
  if (!(m.damping_mass >= 0) || !std::isfinite(m.damping_mass))
    return error("damping_mass", "must be non-negative and finite [1/s]", m.damping_mass);
  if (!(m.damping_stiffness >= 0) || !std::isfinite(m.damping_stiffness))
    return error("damping_stiffness", "must be non-negative and finite [s]", m.damping_stiffness);
  if (!(m.prestress > 0) || !std::isfinite(m.prestress))
    return error("prestress", "must be positive and finite [-] (1 = no prestress)", m.prestress);
  if (!(m.puncture_force > 0) || !std::isfinite(m.puncture_force))
    return error("puncture_force", "must be positive and finite [N]", m.puncture_force);
  return std::nullopt;
}

}  // namespace scalpel
