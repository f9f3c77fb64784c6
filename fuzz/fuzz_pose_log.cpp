// The pose log reader on the bytes as a log, read to its end as the mock device does. Every sample
// it gives must be one the format allows: finite, a unit quaternion, times increasing. Every piece
// event it holds is read as a replay reads it, and one that reads must write back to itself.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "base/input_error.hpp"
#include "devices/pose_log.hpp"
#include "sim/piece_events.hpp"

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
    for (std::size_t i = 0; i < reader.metadata().size(); ++i) {
      const auto& [key, value] = reader.metadata()[i];
      if (key != scalpel::kPieceEventKey) continue;
      try {
        const scalpel::PieceEvent e = scalpel::parse_piece_event(value, "fuzz.csv", reader.metadata_line(i));
        const std::string text = scalpel::format_piece_event(e);
        if (scalpel::format_piece_event(scalpel::parse_piece_event(text, "fuzz.csv", 1)) != text) {
          std::fprintf(stderr, "piece event: '%s' does not read back to itself\n", text.c_str());
          std::abort();
        }
      } catch (const scalpel::InputError&) {
        // a malformed event, reported to the user: expected
      }
    }
  } catch (const scalpel::InputError&) {
    // a malformed log, reported to the user: expected
  }
  return 0;
}
