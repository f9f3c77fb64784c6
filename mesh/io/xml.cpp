#include "mesh/io/xml.hpp"

#include <array>

#include "base/input_error.hpp"

namespace scalpel::mesh_io {

std::string xml_unescape(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '&') {
      out += s[i];
      continue;
    }
    static constexpr std::array<std::pair<std::string_view, char>, 5> entities = {
        {{"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}}};
    bool matched = false;
    for (const auto& [e, c] : entities)
      if (s.substr(i, e.size()) == e) {
        out += c;
        i += e.size() - 1;
        matched = true;
        break;
      }
    if (!matched) out += '&';
  }
  return out;
}

std::string xml_escape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

void XmlReader::fail(int line, const std::string& field, const std::string& message) const {
  throw InputError(file_, line, 0, field, message);
}

bool XmlReader::next_tag(XmlTag& tag) {
  for (;;) {
    while (pos_ < text_.size() && text_[pos_] != '<') advance();
    if (pos_ >= text_.size()) return false;
    if (starts_with("<?")) {
      skip_past("?>", "XML declaration");
      continue;
    }
    if (starts_with("<!--")) {
      skip_past("-->", "XML comment");
      continue;
    }
    break;
  }
  tag = XmlTag{};
  tag.line = line_;
  advance();  // '<'
  if (pos_ < text_.size() && text_[pos_] == '/') {
    tag.closing = true;
    advance();
  }
  tag.name = name();
  if (tag.name.empty()) fail(line_, "XML", "expected a tag name after '<'");
  for (;;) {
    skip_ws();
    if (pos_ >= text_.size()) fail(tag.line, "<" + tag.name + ">", "unexpected end of file inside the tag");
    const char c = text_[pos_];
    if (c == '>') {
      advance();
      return true;
    }
    if (c == '/' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '>') {
      advance();
      advance();
      tag.self_closing = true;
      return true;
    }
    std::string key = name();
    if (key.empty()) fail(line_, "<" + tag.name + ">", "malformed attribute");
    skip_ws();
    if (pos_ >= text_.size() || text_[pos_] != '=') fail(line_, key, "expected '=' after the attribute name");
    advance();
    skip_ws();
    if (pos_ >= text_.size() || (text_[pos_] != '"' && text_[pos_] != '\''))
      fail(line_, key, "expected a quoted attribute value");
    const char q = text_[pos_];
    advance();
    const std::size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != q) advance();
    if (pos_ >= text_.size()) fail(tag.line, key, "unterminated attribute value");
    tag.attributes.emplace_back(std::move(key),
                                xml_unescape(std::string_view(text_).substr(start, pos_ - start)));
    advance();
  }
}

void XmlReader::skip_past(std::string_view end, const std::string& what) {
  const int start = line_;
  while (pos_ < text_.size() && !starts_with(end)) advance();
  if (pos_ >= text_.size()) fail(start, "XML", what + " is not terminated");
  for (std::size_t i = 0; i < end.size(); ++i) advance();
}

std::string XmlReader::name() {
  const std::size_t start = pos_;
  while (pos_ < text_.size()) {
    const char c = text_[pos_];
    if (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == ':' || c == '.')
      ++pos_;
    else
      break;
  }
  return text_.substr(start, pos_ - start);
}

}  // namespace scalpel::mesh_io
