// The VTK XML reader on the bytes as a .vtu file.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz/mesh_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  scalpel::fuzz::inspect_mesh(
      [&] { return scalpel::parse_vtu(std::string(reinterpret_cast<const char*>(data), size), "fuzz.vtu"); });
  return 0;
}
