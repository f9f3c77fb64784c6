// The TetGen reader on the bytes as a .node file and an .ele file: the first line that is exactly
// "# .ele" (a comment to TetGen) ends the .node text; without one, both get the whole input.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz/mesh_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  constexpr std::string_view kSeparator = "# .ele\n";
  std::string node(in), ele(in);
  for (std::size_t at = 0; at < in.size();) {
    if (in.substr(at, kSeparator.size()) == kSeparator) {
      node = in.substr(0, at);
      ele = in.substr(at + kSeparator.size());
      break;
    }
    const std::size_t nl = in.find('\n', at);
    if (nl == std::string_view::npos) break;
    at = nl + 1;
  }
  scalpel::fuzz::inspect_mesh([&] { return scalpel::parse_tetgen(node, "fuzz.node", ele, "fuzz.ele"); });
  return 0;
}
