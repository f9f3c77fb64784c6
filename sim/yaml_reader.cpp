#include "sim/yaml_reader.hpp"

#include <algorithm>
#include <charconv>
#include <sstream>

namespace scalpel {

SourceLocation yaml_location(const YAML::Mark& m) {
  if (m.line < 0) return {};
  return {m.line + 1, m.column + 1};
}

std::string describe(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Map:
      return "a map";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Scalar:
      return "'" + n.Scalar() + "'";
    default:
      return "nothing";
  }
}

std::string join(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& i : items) s += (s.empty() ? "" : ", ") + i;
  return s;
}

std::optional<YamlValue> YamlReader::root(const std::string& text) const {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail(e.mark, "", e.msg);
  }
  if (root.IsNull()) return std::nullopt;
  return YamlValue{root, "", root.Mark(), root.Mark()};
}

void YamlReader::fail(const YAML::Mark& m, const std::string& path, const std::string& message) const {
  const SourceLocation l = yaml_location(m);
  throw InputError(file_, l.line, l.column, path, message);
}

double YamlReader::number(const YamlValue& v) const {
  if (!v.node.IsScalar()) fail(v, "expected a number, found " + describe(v.node));
  std::string_view s = v.node.Scalar();
  if (s.size() > 1 && s.front() == '+') s.remove_prefix(1);
  double x = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x, std::chars_format::general);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size())
    fail(v, "expected a number, found " + describe(v.node));
  if (!std::isfinite(x)) fail(v, "expected a finite number, found " + describe(v.node));
  return x;
}

int YamlReader::integer(const YamlValue& v) const {
  if (!v.node.IsScalar()) fail(v, "expected an integer, found " + describe(v.node));
  std::string_view s = v.node.Scalar();
  if (s.size() > 1 && s.front() == '+') s.remove_prefix(1);
  int x = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size())
    fail(v, "expected an integer, found " + describe(v.node));
  return x;
}

std::string YamlReader::string(const YamlValue& v) const {
  if (!v.node.IsScalar()) fail(v, "expected a text, found " + describe(v.node));
  return v.node.Scalar();
}

bool YamlReader::boolean(const YamlValue& v) const {
  const std::string s = v.node.IsScalar() ? v.node.Scalar() : std::string();
  if (s == "true" || s == "True") return true;
  if (s == "false" || s == "False") return false;
  fail(v, "expected true or false, found " + describe(v.node));
}

int YamlReader::choice(const YamlValue& v, std::initializer_list<std::string_view> choices) const {
  const std::string s = string(v);
  int i = 0;
  std::vector<std::string> names;
  for (const auto c : choices) {
    if (s == c) return i;
    names.emplace_back(c);
    ++i;
  }
  fail(v, "unknown value '" + s + "', expected one of: " + join(names));
}

std::vector<YamlValue> YamlReader::list(const YamlValue& v, const std::string& what) const {
  if (!v.node.IsSequence()) fail(v, "expected " + what + ", found " + describe(v.node));
  std::vector<YamlValue> out;
  int i = 0;
  for (const auto& e : v.node) {
    const std::string path = v.path + "[" + std::to_string(i++) + "]";
    const YAML::Mark m = e.IsNull() || e.Mark().line < 0 ? v.mark : e.Mark();
    out.push_back({e, path, m, m});
  }
  return out;
}

int YamlReader::in_range(const YamlValue& v, int x, int lo, int hi) const {
  if (x < lo || x > hi)
    fail(v, std::to_string(x) + " is out of range, expected " + std::to_string(lo) + " to " +
                std::to_string(hi));
  return x;
}

void YamlReader::check(const YamlValue& v, bool ok, const std::string& expected) const {
  if (!ok)
    fail(v,
         (v.node.IsScalar() ? v.node.Scalar() : describe(v.node)) + " is out of range, expected " + expected);
}

double YamlReader::positive(const YamlValue& v, double max) const {
  const double x = number(v);
  check(v, x > 0.0 && x <= max, std::isinf(max) ? std::string("a value > 0") : "0 < value <= " + format(max));
  return x;
}

std::string YamlReader::format(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

YamlMap::YamlMap(const YamlReader& r, const YamlValue& v) : r_(r), self_(v) {
  if (!v.node.IsMap()) r.fail(v, "expected a map, found " + describe(v.node));
  for (const auto& kv : v.node) {
    const YAML::Mark key_mark = kv.first.Mark();
    if (!kv.first.IsScalar()) r.fail(key_mark, v.path, "expected a plain key, found " + describe(kv.first));
    const std::string key = kv.first.Scalar();
    const std::string path = v.path.empty() ? key : v.path + "." + key;
    if (get(key)) r.fail(key_mark, path, "duplicate key");
    const YAML::Mark mark = kv.second.IsNull() || kv.second.Mark().line < 0 ? key_mark : kv.second.Mark();
    entries_.emplace_back(key, YamlValue{kv.second, path, mark, key_mark});
  }
}

void YamlMap::only(std::initializer_list<std::string_view> allowed) const {
  for (const auto& [key, value] : entries_)
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end())
      r_.fail(
          value.key_mark, value.path,
          "unknown key, expected one of: " + join(std::vector<std::string>(allowed.begin(), allowed.end())));
}

std::optional<YamlValue> YamlMap::get(std::string_view key) const {
  for (const auto& [k, v] : entries_)
    if (k == key) return v;
  return std::nullopt;
}

YamlValue YamlMap::require(std::string_view key) const {
  if (auto v = get(key)) return *v;
  const std::string path = self_.path.empty() ? std::string(key) : self_.path + "." + std::string(key);
  r_.fail(self_.key_mark, path, "missing required key");
}

}  // namespace scalpel
