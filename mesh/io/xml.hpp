// A minimal XML tokenizer for the VTK reader (mesh/io/vtu.cpp), and the escaping of attribute
// values for its writer. Errors are InputErrors naming the file, the line and the field. Not part
// of the public API.
#pragma once

#include <cctype>
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace scalpel::mesh_io {

struct XmlTag {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attributes;
  bool closing = false;
  bool self_closing = false;
  int line = 0;
  const std::string* attribute(const std::string& key) const {
    for (const auto& [k, v] : attributes)
      if (k == key) return &v;
    return nullptr;
  }
};

// `s` with &amp; &lt; &gt; &quot; &apos; replaced by their characters; any other '&' is kept.
[[nodiscard]] std::string xml_unescape(std::string_view s);
// `s` with & < > " written as entities, for an attribute value.
[[nodiscard]] std::string xml_escape(const std::string& s);

// A minimal XML scanner: tags with attributes, and whitespace-separated numbers as text.
class XmlReader {
 public:
  XmlReader(std::string file, std::string text) : file_(std::move(file)), text_(std::move(text)) {}
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  // Bytes of the whole text.
  std::size_t size() const { return text_.size(); }

  // InputError at `line` (no column).
  [[noreturn]] void fail(int line, const std::string& field, const std::string& message) const;

  // Next tag, skipping text, the XML declaration and comments; false at the end of the file.
  bool next_tag(XmlTag& tag);

  // Next whitespace-separated token of the text before the next '<'; empty when the text ends.
  std::string_view token() {
    skip_ws();
    const std::size_t start = pos_;
    token_line_ = line_;
    while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_])) &&
           text_[pos_] != '<')
      ++pos_;
    return std::string_view(text_).substr(start, pos_ - start);
  }
  int token_line() const { return token_line_; }

  // Skips the text content up to the next tag.
  void skip_text() {
    while (pos_ < text_.size() && text_[pos_] != '<') advance();
  }

 private:
  void advance() {
    if (text_[pos_] == '\n') ++line_;
    ++pos_;
  }
  void skip_ws() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) advance();
  }
  bool starts_with(std::string_view s) const { return std::string_view(text_).substr(pos_, s.size()) == s; }
  void skip_past(std::string_view end, const std::string& what);
  std::string name();

  std::string file_;
  std::string text_;
  std::size_t pos_ = 0;
  int line_ = 1;
  int token_line_ = 1;
};

}  // namespace scalpel::mesh_io
