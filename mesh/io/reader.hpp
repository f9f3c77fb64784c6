// Reading mesh files as text (mesh/io/mesh_io.hpp): the whole file at once, numbers parsed from
// whole tokens, and a line reader whose errors are InputErrors naming the file, the line, the column
// and the field. Shared by the Gmsh, TetGen and VTK readers; not part of the public API.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>

namespace scalpel::mesh_io {

// The largest number a file may give as a count or tag (blocks, entities, physical tags).
constexpr long long kMaxCount = 2'000'000'000;
// The most nodes or elements a file may declare (docs/formats.md). A count is also refused when the
// whole file is too short to hold it, so that nothing is allocated for items that are not there (a
// header declaring 2e9 nodes in a file of a few bytes).
constexpr long long kMaxItems = 100'000'000;

// The whole file; InputError if it cannot be opened or read.
[[nodiscard]] std::string read_file(const std::string& path);

inline bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

// Parses a whole token as a number; false if it is not one (or is out of range).
bool parse_int(std::string_view s, long long& out);
bool parse_double(std::string_view s, double& out);

// A token for an error message: in single quotes, cut after 40 characters.
[[nodiscard]] std::string quoted(std::string_view token);

// Line-by-line reader of a whole file: each record is one line, split into whitespace-separated
// tokens. With `hash_comments`, '#' starts a comment (TetGen) and blank lines are skipped.
class LineReader {
 public:
  LineReader(std::string file, std::string text, bool hash_comments)
      : file_(std::move(file)), text_(std::move(text)), comments_(hash_comments) {}

  const std::string& file() const { return file_; }
  int line_no() const { return line_no_; }
  std::string_view line() const { return line_; }

  // Moves to the next line (next record with hash_comments); false at the end of the file.
  bool next_line();
  // Like next_line, but a missing line is an error about `field`.
  void require_line(std::string_view field, std::string_view what);
  bool at_end() const { return at_end_; }
  bool blank() const {
    return std::all_of(line_.begin(), line_.end(), [](char c) { return is_space(c); });
  }

  // Next token of the current line, empty at the end of the line.
  std::string_view token() {
    while (cursor_ < line_.size() && is_space(line_[cursor_])) ++cursor_;
    const std::size_t start = cursor_;
    while (cursor_ < line_.size() && !is_space(line_[cursor_])) ++cursor_;
    token_column_ = static_cast<int>(start) + 1;
    return line_.substr(start, cursor_ - start);
  }
  std::string_view rest_of_line() {
    while (cursor_ < line_.size() && is_space(line_[cursor_])) ++cursor_;
    token_column_ = static_cast<int>(cursor_) + 1;
    const std::string_view r = line_.substr(cursor_);
    cursor_ = line_.size();
    return r;
  }

  long long read_int(std::string_view field) {
    const std::string_view t = token();
    if (t.empty()) fail(field, "missing value (line ends early)");
    long long v = 0;
    if (!parse_int(t, v)) fail(field, "expected an integer, found " + quoted(t));
    return v;
  }
  long long read_int(std::string_view field, long long lo, long long hi) {
    const long long v = read_int(field);
    if (v < lo || v > hi)
      fail(field,
           std::to_string(v) + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
  }
  // A count of items (nodes, elements) in [lo, kMaxItems], each a line of the file; `items` names
  // them. A count the whole file could not hold (a line is at least a character and a newline) is
  // refused before anything is allocated for it; a file cut short reads up to its end and says
  // where it ends.
  long long read_count(std::string_view field, long long lo, std::string_view items) {
    const long long v = read_int(field);
    if (v < lo) fail(field, std::to_string(v) + " is out of range, expected at least " + std::to_string(lo));
    if (v > kMaxItems)
      fail(field, std::to_string(v) + " " + std::string(items) + " is more than the " +
                      std::to_string(kMaxItems) + " a mesh file may have");
    if (2 * v > static_cast<long long>(text_.size()))
      fail(field, std::to_string(v) + " " + std::string(items) + " declared, more lines than the file's " +
                      std::to_string(text_.size()) + " bytes can hold");
    return v;
  }
  double read_double(std::string_view field) {
    const std::string_view t = token();
    if (t.empty()) fail(field, "missing value (line ends early)");
    double v = 0;
    if (!parse_double(t, v)) fail(field, "expected a finite number, found " + quoted(t));
    return v;
  }
  void expect_line_end(std::string_view field) {
    const std::string_view t = token();
    if (!t.empty()) fail(field, "unexpected extra value " + quoted(t));
  }

  // InputError at the current line, at the column of the last token (fail) or without one.
  [[noreturn]] void fail(std::string_view field, const std::string& message) const;
  [[noreturn]] void fail_line(std::string_view field, const std::string& message) const;

 private:
  std::string file_;
  std::string text_;
  bool comments_;
  std::size_t next_ = 0;
  std::string_view line_;
  std::size_t cursor_ = 0;
  int line_no_ = 0;
  int token_column_ = 0;
  bool at_end_ = false;
};

}  // namespace scalpel::mesh_io
