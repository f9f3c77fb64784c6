// A live session's moves of pieces in its recording (sim/piece_events.hpp).
#include <doctest/doctest.h>

#include <cmath>

#include "base/input_error.hpp"
#include "sim/piece_events.hpp"

using namespace scalpel;

TEST_CASE("piece events read back exactly as written, and a bad one names the log, the line and the field") {
  PieceEvent move;
  move.frame = 812;
  move.move.action = PieceAction::Move;
  move.move.point = Vec3(0.1 / 3, -0.004, 1e-17);
  move.move.translation = Vec3(0.0, 0.01, std::sqrt(2.0) * 1e-3);
  move.move.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized()));
  const PieceEvent back = parse_piece_event(format_piece_event(move), "log.csv", 7);
  CHECK(back.frame == 812);
  CHECK(back.move.action == PieceAction::Move);
  CHECK(back.move.point == move.move.point);
  CHECK(back.move.translation == move.move.translation);
  CHECK(back.move.rotation.coeffs() == move.move.rotation.coeffs());

  PieceEvent undo;
  undo.frame = 9;
  undo.move.action = PieceAction::Undo;
  CHECK(format_piece_event(undo) == "frame 9 undo");
  CHECK(parse_piece_event("frame 9 undo", "log.csv", 7).move.action == PieceAction::Undo);
  PieceEvent del;
  del.frame = 10;
  del.move.action = PieceAction::Delete;
  del.move.point = Vec3(0.5, 0.25, -1);
  CHECK(format_piece_event(del) == "frame 10 delete point 0.5 0.25 -1");
  CHECK(parse_piece_event("frame 10 delete point 0.5 0.25 -1", "log.csv", 7).move.point == del.move.point);

  struct Case {
    const char* text;
    const char* field;
    const char* message;
  };
  const Case cases[] = {
      {"frame x undo", "piece.frame", "not a frame number"},
      {"frame 3 jump", "piece", "not move, undo or delete"},
      {"frame 3 undo now", "piece", "more words"},
      {"frame 3 delete point 1 2", "piece", "ends where"},
      {"frame 3 delete point 1 nan 2", "piece.point", "not a finite number"},
      {"frame 3 move point 0 0 0 translate 0 0 0 rotate 2 0 0 0", "piece.rotate", "unit quaternion"},
      {"3 undo", "piece", "expected 'frame'"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.text);
    try {
      (void)parse_piece_event(c.text, "log.csv", 7);
      FAIL("no error");
    } catch (const InputError& e) {
      CHECK(e.file() == "log.csv");
      CHECK(e.line() == 7);
      CHECK(e.field() == c.field);
      CHECK(std::string(e.what()).find(c.message) != std::string::npos);
    }
  }
}
