#include "sim/check.hpp"

#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "base/input_error.hpp"
#include "mesh/io/xml.hpp"

namespace scalpel {

namespace fs = std::filesystem;

namespace {

// The check file's reader: every error names the file, the line and column and the key path.
class Reader {
 public:
  explicit Reader(fs::path file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const YAML::Node& n, const std::string& key, const std::string& message) const {
    const YAML::Mark m = n.Mark();
    throw InputError(file_.string(), m.line >= 0 ? m.line + 1 : 0, m.line >= 0 ? m.column + 1 : 0, key,
                     message);
  }
  void only(const YAML::Node& map, const std::string& key, std::initializer_list<const char*> keys) const {
    if (!map.IsMap()) fail(map, key, "expected a map");
    for (const auto& kv : map) {
      const std::string k = kv.first.as<std::string>();
      bool known = false;
      std::string list;
      for (const char* allowed : keys) {
        known = known || k == allowed;
        list += (list.empty() ? "" : ", ") + std::string(allowed);
      }
      if (!known) fail(kv.first, key.empty() ? k : key + "." + k, "unknown key, expected one of: " + list);
    }
  }
  double number(const YAML::Node& n, const std::string& key) const {
    try {
      return n.as<double>();
    } catch (const YAML::Exception&) {
      fail(n, key, "expected a number");
    }
  }
  bool boolean(const YAML::Node& n, const std::string& key) const {
    try {
      return n.as<bool>();
    } catch (const YAML::Exception&) {
      fail(n, key, "expected true or false");
    }
  }
  std::string text(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar() || n.Scalar().empty()) fail(n, key, "expected a text");
    return n.Scalar();
  }
  [[nodiscard]] const fs::path& file() const { return file_; }

 private:
  fs::path file_;
};

std::string format(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

}  // namespace

CheckFile load_check_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, 0, "", "cannot open the check file");
  std::stringstream text;
  text << in.rdbuf();
  const Reader r(path);
  YAML::Node root;
  try {
    root = YAML::Load(text.str());
  } catch (const YAML::Exception& e) {
    throw InputError(path.string(), e.mark.line + 1, e.mark.column + 1, "", e.msg);
  }
  if (!root.IsMap()) throw InputError(path.string(), 0, 0, "", "expected a map with `sessions`");
  r.only(root, "", {"sessions"});
  const YAML::Node sessions = root["sessions"];
  if (!sessions || !sessions.IsSequence() || sessions.size() == 0)
    r.fail(sessions ? sessions : root, "sessions", "expected a list of sessions");
  CheckFile out;
  out.file = path;
  const fs::path base = path.parent_path();
  for (std::size_t i = 0; i < sessions.size(); ++i) {
    const YAML::Node s = sessions[i];
    const std::string key = "sessions[" + std::to_string(i) + "]";
    r.only(s, key, {"name", "scenario", "log", "expect"});
    CheckSession cs;
    cs.line = s.Mark().line + 1;
    if (!s["scenario"]) r.fail(s, key + ".scenario", "required: the scenario to replay");
    cs.scenario = (base / r.text(s["scenario"], key + ".scenario")).lexically_normal();
    if (s["log"]) cs.log = (base / r.text(s["log"], key + ".log")).lexically_normal();
    cs.name = s["name"] ? r.text(s["name"], key + ".name") : cs.scenario.stem().string();
    if (const YAML::Node e = s["expect"]) {
      const std::string ek = key + ".expect";
      r.only(e, ek, {"passed", "score", "warnings", "components"});
      if (e["passed"]) cs.expect.passed = r.boolean(e["passed"], ek + ".passed");
      if (e["score"]) cs.expect.score = r.number(e["score"], ek + ".score");
      if (e["warnings"]) {
        const double w = r.number(e["warnings"], ek + ".warnings");
        if (w < 0 || w != static_cast<double>(static_cast<std::size_t>(w)))
          r.fail(e["warnings"], ek + ".warnings", "expected a count >= 0");
        cs.expect.warnings = static_cast<std::size_t>(w);
      }
      if (const YAML::Node c = e["components"]) {
        if (!c.IsMap()) r.fail(c, ek + ".components", "expected a map of component names");
        for (const auto& kv : c) {
          const std::string name = kv.first.as<std::string>();
          const std::string ck = ek + ".components." + name;
          r.only(kv.second, ck, {"min", "max", "passed"});
          ComponentExpectation x;
          if (kv.second["min"]) x.min = r.number(kv.second["min"], ck + ".min");
          if (kv.second["max"]) x.max = r.number(kv.second["max"], ck + ".max");
          if (kv.second["passed"]) x.passed = r.boolean(kv.second["passed"], ck + ".passed");
          cs.expect.components[name] = x;
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
