// Reading a scenario's `task` section (sim/scenario.cpp reads the rest).
#pragma once

#include "sim/scenario.hpp"
#include "sim/yaml_reader.hpp"

namespace scalpel {

// [m] Bound on lengths in a scenario (mesh extent, layer, incision depth): catches millimetres
// written as metres.
inline constexpr double kMaxScenarioLength = 1.0;
// [s] Bound on a session's duration (simulation.duration): a day.
inline constexpr double kMaxSessionSeconds = 86400.0;

// The task section `v`; fails with the file, position and key path.
Task read_task(const YamlReader& r, const YamlValue& v);

}  // namespace scalpel
