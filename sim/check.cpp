#include "sim/check.hpp"

#include <fstream>
#include <sstream>

#include "base/input_error.hpp"
#include "base/input_file.hpp"
#include "mesh/io/xml.hpp"
#include "sim/yaml_reader.hpp"

namespace scalpel {

namespace fs = std::filesystem;

namespace {

std::string format(double x) {
  return YamlReader::format(x);
}

// A count >= 0.
std::size_t count(const YamlReader& r, const YamlValue& v) {
  const int n = r.integer(v);
  r.check(v, n >= 0, "a count >= 0");
  return static_cast<std::size_t>(n);
}

}  // namespace

CheckFile load_check_file(const fs::path& path) {
  const std::string text = read_input_file(path.string(), "check", 16u << 20);
  const YamlReader r(path.string());
  const std::optional<YamlValue> root = r.root(text);
  if (!root || !root->node.IsMap())
    throw InputError(path.string(), 0, 0, "", "expected a map with `sessions`");
  const YamlMap top(r, *root);
  top.only({"sessions"});
  const YamlValue sessions = top.require("sessions");
  const std::vector<YamlValue> items = r.list(sessions, "a list of sessions");
  if (items.empty()) r.fail(sessions, "expected at least one session");
  CheckFile out;
  out.file = path;
  const fs::path base = path.parent_path();
  for (const YamlValue& item : items) {
    const YamlMap s(r, item);
    s.only({"name", "scenario", "log", "expect"});
    CheckSession cs;
    cs.line = yaml_location(item.mark).line;
    const auto file = [&](const YamlValue& v) {
      const std::string name = r.string(v);
      if (name.empty()) r.fail(v, "expected a file path");
      return (base / name).lexically_normal();
    };
    cs.scenario = file(s.require("scenario"));
    if (const auto x = s.get("log")) cs.log = file(*x);
    cs.name = s.has("name") ? r.string(*s.get("name")) : cs.scenario.stem().string();
    if (const auto x = s.get("expect")) {
      const YamlMap e(r, *x);
      e.only({"passed", "score", "warnings", "components"});
      if (const auto y = e.get("passed")) cs.expect.passed = r.boolean(*y);
      if (const auto y = e.get("score")) cs.expect.score = r.number(*y);
      if (const auto y = e.get("warnings")) cs.expect.warnings = count(r, *y);
      if (const auto y = e.get("components")) {
        const YamlMap c(r, *y);
        for (const auto& [name, v] : c.entries()) {
          const YamlMap bounds(r, v);
          bounds.only({"min", "max", "passed"});
          ComponentExpectation want;
          if (const auto z = bounds.get("min")) want.min = r.number(*z);
          if (const auto z = bounds.get("max")) want.max = r.number(*z);
          if (const auto z = bounds.get("passed")) want.passed = r.boolean(*z);
          cs.expect.components[name] = want;
        }
      }
    }
    out.sessions.push_back(std::move(cs));
  }
  return out;
}

std::vector<std::string> unmet_expectations(const CheckFile& file, const CheckSession& session,
                                            const nlohmann::ordered_json& report, bool invariants_ok) {
  std::vector<std::string> out;
  if (!invariants_ok) out.push_back("the mesh invariants are broken after the replay");
  const auto& warnings = report["warnings"];
  if (warnings.size() > session.expect.warnings) {
    std::string all;
    for (const auto& w : warnings) all += (all.empty() ? "" : "; ") + w["message"].get<std::string>();
    out.push_back(std::to_string(warnings.size()) + " warning(s), " +
                  std::to_string(session.expect.warnings) + " allowed: " + all);
  }
  const SessionExpectation& e = session.expect;
  const bool wants_task = e.passed || e.score || !e.components.empty();
  if (!report.contains("task")) {
    if (wants_task) out.push_back("the scenario has no task to score");
    return out;
  }
  const auto& task = report["task"];
  if (e.passed && task["passed"].get<bool>() != *e.passed)
    out.push_back(std::string("the session ") + (*e.passed ? "did not pass" : "passed") + " (score " +
                  format(task["score"].get<double>()) + ")");
  if (e.score && task["score"].get<double>() < *e.score)
    out.push_back("score " + format(task["score"].get<double>()) + ", expected at least " + format(*e.score));
  for (const auto& [name, x] : e.components) {
    const nlohmann::ordered_json* c = nullptr;
    for (const auto& comp : task["components"])
      if (comp["name"] == name) c = &comp;
    if (!c) {
      std::string names;
      for (const auto& comp : task["components"])
        names += (names.empty() ? "" : ", ") + comp["name"].get<std::string>();
      throw InputError(file.file.string(), session.line, 0, "expect.components." + name,
                       "the report has no component '" + name + "'; it has: " + names);
    }
    const double v = (*c)["value"].get<double>();
    const std::string unit = (*c)["unit"].get<std::string>();
    const std::string why = (*c)["why"].get<std::string>();
    if (x.min && v < *x.min)
      out.push_back(name + " " + format(v) + " " + unit + ", expected at least " + format(*x.min) +
                    (why.empty() ? "" : ": " + why));
    if (x.max && v > *x.max)
      out.push_back(name + " " + format(v) + " " + unit + ", expected at most " + format(*x.max) +
                    (why.empty() ? "" : ": " + why));
    if (x.passed && (*c)["passed"].get<bool>() != *x.passed)
      out.push_back(name + (*x.passed ? " did not pass" : " passed") + (why.empty() ? "" : ": " + why));
  }
  return out;
}

std::string junit_xml(const CheckFile& file, const std::vector<CheckOutcome>& outcomes) {
  std::size_t failed = 0;
  double total = 0;
  for (const CheckOutcome& o : outcomes) {
    failed += o.failures.empty() ? 0 : 1;
    total += o.seconds;
  }
  const std::string suite = "scalpelsim check " + file.file.filename().string();
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<testsuites name=\"scalpelsim\" tests=\"" << outcomes.size() << "\" failures=\"" << failed
    << "\" time=\"" << total << "\">\n"
    << "  <testsuite name=\"" << mesh_io::xml_escape(suite) << "\" tests=\"" << outcomes.size()
    << "\" failures=\"" << failed << "\" errors=\"0\" time=\"" << total << "\">\n";
  for (const CheckOutcome& o : outcomes) {
    x << "    <testcase classname=\"scalpelsim." << mesh_io::xml_escape(file.file.stem().string())
      << "\" name=\"" << mesh_io::xml_escape(o.name) << "\" time=\"" << o.seconds << "\">\n";
    if (!o.failures.empty()) {
      std::string all;
      for (const std::string& f : o.failures) all += f + "\n";
      x << "      <failure message=\"" << mesh_io::xml_escape(o.failures.front())
        << "\" type=\"expectation\">" << mesh_io::xml_escape(all) << "</failure>\n";
    }
    x << "      <system-out>" << mesh_io::xml_escape("outputs: " + o.out_dir) << "</system-out>\n"
      << "    </testcase>\n";
  }
  x << "  </testsuite>\n</testsuites>\n";
  return x.str();
}

}  // namespace scalpel
