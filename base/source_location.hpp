// Where a value was written in an input file.
#pragma once

namespace scalpel {

// 1-based line and column; 0 when unknown.
struct SourceLocation {
  int line = 0;
  int column = 0;
};

}  // namespace scalpel
