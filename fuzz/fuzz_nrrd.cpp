// The NRRD volume reader (Teem's parser and our checks on what it read) on the bytes as a .nrrd file.
// Teem reads from a path, so the bytes go to a file of this process first.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "base/input_error.hpp"
#include "mesh/volume.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("scalpel_fuzz_" + std::to_string(::getpid()) + ".nrrd");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    const scalpel::ScalarVolume v = scalpel::read_nrrd_volume(path);
    // What a scenario does with it: the range and a sample inside.
    (void)v.range();
    (void)v.sample(v.origin + 0.5 * (v.far_corner() - v.origin));
  } catch (const scalpel::InputError&) {
  }
  return 0;
}
