// A live session's moves of pieces in its recording (docs/formats.md, "Piece events"): the
// trainee moves, undoes and deletes pieces of rigid tissue in the window, and the recording keeps
// each as a metadata line among the samples, with the frame that applied it, so that a replay
// applies it at the same point and ends with the same mesh, bit for bit:
//
//   # piece: frame 812 move point 0.01 0.02 -0.004 translate 0 0.01 0 rotate 1 0 0 0
//   # piece: frame 840 undo
//   # piece: frame 901 delete point 0.01 0.02 -0.004
//
// point and translate [m]; rotate a unit quaternion w x y z. Numbers are written in the shortest
// form that reads back to the same double.
#pragma once

#include <cstdint>
#include <string>

#include "sim/scenario.hpp"

namespace scalpel {

inline constexpr const char* kPieceEventKey = "piece";

struct PieceEvent {
  std::uint64_t frame = 0;  // the session frame whose end applied it
  PieceMove move;           // `at` unused
};

// The value of the metadata line for `event` (after "# piece: ").
[[nodiscard]] std::string format_piece_event(const PieceEvent& event);
// Reads a value format_piece_event() wrote; InputError naming `file`, `line` and the field
// ("piece", or "piece.<word>" for a bad number after it) otherwise.
[[nodiscard]] PieceEvent parse_piece_event(const std::string& value, const std::string& file, int line);

}  // namespace scalpel
