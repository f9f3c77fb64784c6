#pragma once

namespace scalpel {

// The program and report version, "major.minor.patch".
[[nodiscard]] const char* version();

}  // namespace scalpel
