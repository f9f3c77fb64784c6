#include "sim/piece_events.hpp"

#include <charconv>
#include <cmath>
#include <sstream>
#include <vector>

#include "base/input_error.hpp"

namespace scalpel {

namespace {

void put(std::string& out, double v) {
  char buffer[32];
  const auto end = std::to_chars(buffer, buffer + sizeof buffer, v).ptr;
  out += ' ';
  out.append(buffer, end);
}

void put(std::string& out, const char* word, const Vec3& v) {
  out += ' ';
  out += word;
  for (int i = 0; i < 3; ++i) put(out, v[i]);
}

class Words {
 public:
  Words(const std::string& value, const std::string& file, int line) : file_(file), line_(line) {
    std::istringstream in(value);
    for (std::string w; in >> w;) words_.push_back(w);
  }
  [[noreturn]] void fail(const std::string& field, const std::string& message) const {
    throw InputError(file_, line_, 0, field, message);
  }
  bool done() const { return next_ == words_.size(); }
  std::string word(const char* expected) {
    if (done()) fail("piece", std::string("ends where ") + expected + " was expected");
    return words_[next_++];
  }
  void expect(const char* w) {
    if (word(w) != w) fail("piece", std::string("expected '") + w + "' at word " + std::to_string(next_));
  }
  double number(const std::string& field) {
    const std::string w = word(("a number after " + field).c_str());
    double v = 0.0;
    const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
    if (ec != std::errc() || end != w.data() + w.size() || !std::isfinite(v))
      fail("piece." + field, "'" + w + "' is not a finite number");
    return v;
  }
  Vec3 vec(const char* field) {
    expect(field);
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = number(field);
    return v;
  }

 private:
  std::string file_;
  int line_;
  std::vector<std::string> words_;
  std::size_t next_ = 0;
};

}  // namespace

std::string format_piece_event(const PieceEvent& e) {
  std::string out = "frame " + std::to_string(e.frame);
  const PieceMove& m = e.move;
  switch (m.action) {
    case PieceAction::Move: {
      out += " move";
      put(out, "point", m.point);
      put(out, "translate", m.translation);
      out += " rotate";
      for (const double q : {m.rotation.w(), m.rotation.x(), m.rotation.y(), m.rotation.z()}) put(out, q);
      break;
    }
    case PieceAction::Undo:
      out += " undo";
      break;
    case PieceAction::Delete:
      out += " delete";
      put(out, "point", m.point);
      break;
  }
  return out;
}

PieceEvent parse_piece_event(const std::string& value, const std::string& file, int line) {
  Words w(value, file, line);
  PieceEvent e;
  w.expect("frame");
  const std::string frame = w.word("the frame");
  const auto [end, ec] = std::from_chars(frame.data(), frame.data() + frame.size(), e.frame);
  if (ec != std::errc() || end != frame.data() + frame.size())
    w.fail("piece.frame", "'" + frame + "' is not a frame number");
  const std::string action = w.word("move, undo or delete");
  if (action == "move") {
    e.move.action = PieceAction::Move;
    e.move.point = w.vec("point");
    e.move.translation = w.vec("translate");
    w.expect("rotate");
    Eigen::Quaterniond q;
    q.w() = w.number("rotate");
    q.x() = w.number("rotate");
    q.y() = w.number("rotate");
    q.z() = w.number("rotate");
    if (std::abs(q.norm() - 1.0) > 1e-6) w.fail("piece.rotate", "not a unit quaternion");
    e.move.rotation = q;
  } else if (action == "undo") {
    e.move.action = PieceAction::Undo;
  } else if (action == "delete") {
    e.move.action = PieceAction::Delete;
    e.move.point = w.vec("point");
  } else {
    w.fail("piece", "'" + action + "' is not move, undo or delete");
  }
  if (!w.done()) w.fail("piece", "more words than a " + action + " has");
  return e;
}

}  // namespace scalpel
