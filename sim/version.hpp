#pragma once

namespace scalpel {

// The program and report version, "major.minor.patch".
[[nodiscard]] const char* version();
// The build: "commit <git describe>, <CMake build type>[, invariants checked]".
[[nodiscard]] const char* build_description();

}  // namespace scalpel
