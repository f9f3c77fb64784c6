#include "fem/material.hpp"

namespace scalpel {

Lame lame_parameters(const Material& m) {
  const double e = m.young, nu = m.poisson;
  return {e / (2.0 * (1.0 + nu)), e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))};
}

}  // namespace scalpel
