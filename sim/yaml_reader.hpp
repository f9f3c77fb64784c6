// Reading the project's YAML files (scenarios, CI check files) so that every error names the file,
// the line and column, and the key path (`file:line:column: field: message`, docs/formats.md): an
// InputError, never a yaml-cpp exception.
#pragma once

#include <array>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <yaml-cpp/yaml.h>
#include <Eigen/Core>

#include "base/input_error.hpp"
#include "base/source_location.hpp"

namespace scalpel {

// Line and column (from 1) of a mark; {0, 0} where yaml-cpp has none.
SourceLocation yaml_location(const YAML::Mark& m);

// A YAML value with its key path ("task.incisions[1].depth"); `mark` is where the value is written
// (its key's position when the value is empty), `key_mark` where its key is.
struct YamlValue {
  YAML::Node node;
  std::string path;
  YAML::Mark mark;
  YAML::Mark key_mark;
};

// "a map", "a list", "'text'" or "nothing": what was found, for a message.
std::string describe(const YAML::Node& n);
// "a, b, c".
std::string join(const std::vector<std::string>& items);

// Typed values of one file, each failing with the file, the position and the key path.
class YamlReader {
 public:
  explicit YamlReader(std::string file) : file_(std::move(file)) {}

  // The document in `text`, at the empty path; none for an empty document. A syntax error fails.
  [[nodiscard]] std::optional<YamlValue> root(const std::string& text) const;

  [[noreturn]] void fail(const YAML::Mark& m, const std::string& path, const std::string& message) const;
  [[noreturn]] void fail(const YamlValue& v, const std::string& message) const {
    fail(v.mark, v.path, message);
  }

  [[nodiscard]] double number(const YamlValue& v) const;  // finite
  [[nodiscard]] int integer(const YamlValue& v) const;
  [[nodiscard]] std::string string(const YamlValue& v) const;
  [[nodiscard]] bool boolean(const YamlValue& v) const;
  // One of `choices`; returns its index.
  [[nodiscard]] int choice(const YamlValue& v, std::initializer_list<std::string_view> choices) const;
  // The items of a list; `what` names what was expected ("a list of points").
  [[nodiscard]] std::vector<YamlValue> list(const YamlValue& v, const std::string& what) const;
  template <int N>
  [[nodiscard]] Eigen::Matrix<double, N, 1> vector(const YamlValue& v) const {
    const std::string what = "a list of " + std::to_string(N) + " numbers";
    const auto items = list(v, what);
    if (static_cast<int>(items.size()) != N)
      fail(v, "expected " + what + ", found " + std::to_string(items.size()));
    Eigen::Matrix<double, N, 1> x;
    for (int i = 0; i < N; ++i) x[i] = number(items[static_cast<std::size_t>(i)]);
    return x;
  }
  template <std::size_t N>
  [[nodiscard]] std::array<int, N> integers(const YamlValue& v, int lo, int hi) const {
    const std::string what = "a list of " + std::to_string(N) + " integers";
    const auto items = list(v, what);
    if (items.size() != N) fail(v, "expected " + what + ", found " + std::to_string(items.size()));
    std::array<int, N> x{};
    for (std::size_t i = 0; i < N; ++i) x[i] = in_range(items[i], integer(items[i]), lo, hi);
    return x;
  }
  int in_range(const YamlValue& v, int x, int lo, int hi) const;
  // Fails with "<value> is out of range, expected <expected>" unless `ok`.
  void check(const YamlValue& v, bool ok, const std::string& expected) const;
  // A number > 0 and <= max.
  [[nodiscard]] double positive(const YamlValue& v,
                                double max = std::numeric_limits<double>::infinity()) const;
  [[nodiscard]] static std::string format(double x);
  [[nodiscard]] const std::string& file() const { return file_; }

 private:
  std::string file_;
};

// The entries of a YAML map, checked for duplicate and (with only()) unknown keys.
class YamlMap {
 public:
  YamlMap(const YamlReader& r, const YamlValue& v);
  // Every key must be one of `allowed`.
  void only(std::initializer_list<std::string_view> allowed) const;
  [[nodiscard]] std::optional<YamlValue> get(std::string_view key) const;
  [[nodiscard]] YamlValue require(std::string_view key) const;
  [[nodiscard]] bool has(std::string_view key) const { return get(key).has_value(); }
  [[nodiscard]] const std::vector<std::pair<std::string, YamlValue>>& entries() const { return entries_; }
  [[nodiscard]] const YamlValue& self() const { return self_; }

 private:
  const YamlReader& r_;
  YamlValue self_;
  std::vector<std::pair<std::string, YamlValue>> entries_;
};

}  // namespace scalpel
