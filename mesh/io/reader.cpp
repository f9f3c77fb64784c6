#include "mesh/io/reader.hpp"

#include <charconv>
#include <cmath>
#include <fstream>

#include "base/input_error.hpp"

namespace scalpel::mesh_io {

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, 0, "", "cannot open file");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw InputError(path, 0, 0, "", "cannot read file");
  std::string text(static_cast<std::size_t>(size), '\0');
  in.seekg(0, std::ios::beg);
  in.read(text.data(), size);
  if (!in) throw InputError(path, 0, 0, "", "cannot read file");
  return text;
}

bool parse_int(std::string_view s, long long& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && end == s.data() + s.size() && !s.empty();
}

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && end == s.data() + s.size() && !s.empty() && std::isfinite(out);
}

std::string quoted(std::string_view token) {
  std::string s = "'";
  s.append(token.substr(0, 40));
  if (token.size() > 40) s += "...";
  return s + "'";
}

bool LineReader::next_line() {
  for (;;) {
    if (next_ >= text_.size()) {
      line_ = {};
      cursor_ = 0;
      at_end_ = true;
      return false;
    }
    const std::size_t nl = text_.find('\n', next_);
    const std::size_t end = nl == std::string::npos ? text_.size() : nl;
    line_ = std::string_view(text_).substr(next_, end - next_);
    next_ = end + 1;
    ++line_no_;
    cursor_ = 0;
    if (comments_) {
      const std::size_t hash = line_.find('#');
      if (hash != std::string_view::npos) line_ = line_.substr(0, hash);
    }
    while (!line_.empty() && is_space(line_.back())) line_.remove_suffix(1);
    if (!comments_ || !blank()) return true;
  }
}

void LineReader::require_line(std::string_view field, std::string_view what) {
  if (!next_line()) fail(field, "unexpected end of file, expected " + std::string(what));
}

void LineReader::fail(std::string_view field, const std::string& message) const {
  throw InputError(file_, line_no_, line_.empty() ? 0 : token_column_, std::string(field), message);
}

void LineReader::fail_line(std::string_view field, const std::string& message) const {
  throw InputError(file_, line_no_, 0, std::string(field), message);
}

}  // namespace scalpel::mesh_io
