// A skin patch for the contact tests: 20 x 20 mm in 5 x 5 cells, 7 mm thick (epidermis, dermis,
// fat), held at its base and rim, without gravity; the blade presses before it cuts
// (`contact: indent`) and meets no cutting resistance.
#pragma once

#include <string>

#include "sim/scenario.hpp"

namespace scalpel::test {

// The epidermis gives way at `puncture` [N]; `tool` is more of the scenario's tool map (its
// `blade`, `handle`), each line indented by two spaces. Read as "patch.yaml".
inline Scenario press_patch(double puncture, const std::string& tool) {
  const std::string text = R"(
name: press
mesh:
  generator: slab
  size: [0.020, 0.020]
  cells: [5, 5]
  layers:
    - {name: epidermis, thickness: 0.001, cells: 1}
    - {name: dermis, thickness: 0.002, cells: 1}
    - {name: fat, thickness: 0.004, cells: 1}
materials:
  epidermis:
    {young: 1.0e6, poisson: 0.45, density: 1100, damping: {mass: 0.5, stiffness: 0.002}, puncture_force: )" +
                           std::to_string(puncture) + R"(}
  dermis: {young: 1.0e5, poisson: 0.45, density: 1100, damping: {mass: 0.5, stiffness: 0.002}}
  fat: {young: 1.0e4, poisson: 0.45, density: 920, damping: {mass: 0.5, stiffness: 0.002}}
tissue: {rate: 60, solver: {tolerance: 1.0e-3, max_iterations: 200}, gravity: [0, 0, 0]}
fixed:
  - {side: bottom}
  - {side: x_min}
  - {side: x_max}
  - {side: y_min}
  - {side: y_max}
tool:
  contact: indent
  cutting_resistance: 0
)" + tool + "\n";
  return parse_scenario(text, "patch.yaml", ".");
}

}  // namespace scalpel::test
