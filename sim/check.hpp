// CI's use of replays (docs/formats.md, "Check files"): a check file lists recorded sessions, each a
// scenario and a pose log with what its replay must show (the score, passing, components,
// warnings allowed). `scalpelsim check` replays each, says which expectation failed, and writes
// JUnit XML so a CI system shows a failing session as a failing test.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace scalpel {

struct ComponentExpectation {
  std::optional<double> min, max;  // on the component's value, in its unit
  std::optional<bool> passed;
};

struct SessionExpectation {
  std::optional<bool> passed;   // the task's verdict
  std::optional<double> score;  // at least
  std::size_t warnings = 0;     // at most
  std::map<std::string, ComponentExpectation> components;
};

struct CheckSession {
  std::string name;
  std::filesystem::path scenario;
  std::optional<std::filesystem::path> log;  // none: the scenario's
  SessionExpectation expect;
  int line = 0;  // in the check file
};

struct CheckFile {
  std::filesystem::path file;
  std::vector<CheckSession> sessions;
};

// Reads a check file; paths in it are resolved against its folder. InputError naming the file,
// line and key for what is malformed.
[[nodiscard]] CheckFile load_check_file(const std::filesystem::path& path);

// What a replay's report fails of its expectations: one sentence each, empty when it meets them.
// InputError (naming the check file) for a component the report does not have.
[[nodiscard]] std::vector<std::string> unmet_expectations(const CheckFile& file, const CheckSession& session,
                                                          const nlohmann::ordered_json& report,
                                                          bool invariants_ok);

struct CheckOutcome {
  std::string name;
  double seconds = 0;  // wall clock of the replay
  std::vector<std::string> failures;
  std::string out_dir;
};

// JUnit XML: one test suite for the file, a test case per session, a failure element per session
// that failed with its sentences.
[[nodiscard]] std::string junit_xml(const CheckFile& file, const std::vector<CheckOutcome>& outcomes);

}  // namespace scalpel
