// The Gmsh reader (ASCII 2.2 and 4.1) on the bytes as a .msh file.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz/mesh_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  scalpel::fuzz::inspect_mesh([&] {
    return scalpel::parse_gmsh(std::string(reinterpret_cast<const char*>(data), size), "fuzz.msh");
  });
  return 0;
}
