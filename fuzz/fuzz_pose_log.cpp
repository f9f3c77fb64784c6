// The pose log reader on the bytes as a log, read to its end as the mock device does. Every sample
// it gives must be one the format allows: finite, a unit quaternion, times increasing.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "base/input_error.hpp"
#include "devices/pose_log.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    scalpel::PoseLogReader reader(in, "fuzz.csv");
    scalpel::ToolSample s;
    bool first = true;
    double last_t = 0.0;
    while (reader.next(s)) {
      if (!scalpel::is_valid(s, scalpel::kPoseLogUnitTolerance) || (!first && !(s.t > last_t))) {
        std::fprintf(stderr, "pose log: line %d gave a sample the format forbids\n", reader.line());
        std::abort();
      }
      first = false;
      last_t = s.t;
    }
    (void)reader.torn_warning();
    (void)reader.metadata("playback");
  } catch (const scalpel::InputError&) {
    // a malformed log, reported to the user: expected
  }
  return 0;
}
