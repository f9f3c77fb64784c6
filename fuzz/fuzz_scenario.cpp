// The scenario reader on the bytes as a scenario file in config/scenarios/, so that the bundled
// mesh and log files its relative paths name are found.
#include <cstddef>
#include <cstdint>
#include <string>

#include "base/input_error.hpp"
#include "sim/scenario.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)scalpel::parse_scenario(std::string(reinterpret_cast<const char*>(data), size), "fuzz.yaml",
                                  SCALPEL_SOURCE_DIR "/config/scenarios");
  } catch (const scalpel::InputError&) {
    // a malformed scenario, reported to the user: expected
  }
  return 0;
}
