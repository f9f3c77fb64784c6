// A scripted ReportTransport for tests: reports queued by the test, an unplug switch, and a record
// of what was written. Single-threaded use. Beside it, what device tests read: named raw reports
// from a file, and the error a profile's text gives.
#pragma once

#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/input_error.hpp"
#include "devices/device_profile.hpp"
#include "devices/report_transport.hpp"

namespace scalpel::test {

struct FakeWire {
  std::deque<std::vector<std::uint8_t>> inbox;
  std::vector<std::vector<std::uint8_t>> written;
  bool plugged = true;
  bool open = false;
  int opens = 0;
};

class FakeTransport final : public ReportTransport {
 public:
  explicit FakeTransport(std::shared_ptr<FakeWire> wire) : wire_(std::move(wire)) {}
  bool open() override {
    if (!wire_->plugged) return false;
    wire_->open = true;
    ++wire_->opens;
    return true;
  }
  void close() override { wire_->open = false; }
  int read(std::span<std::uint8_t> buf) noexcept override {
    if (!wire_->plugged || !wire_->open) return -1;
    if (wire_->inbox.empty()) return 0;
    const std::vector<std::uint8_t> r = wire_->inbox.front();
    wire_->inbox.pop_front();
    const std::size_t n = std::min(r.size(), buf.size());
    std::memcpy(buf.data(), r.data(), n);
    return static_cast<int>(n);
  }
  bool write(std::span<const std::uint8_t> report) noexcept override {
    if (!wire_->plugged || !wire_->open) return false;
    wire_->written.emplace_back(report.begin(), report.end());
    return true;
  }

 private:
  std::shared_ptr<FakeWire> wire_;
};

// Named raw reports from tests/data/hid/<name>.txt: lines "name: hex bytes", '#' comments.
inline std::map<std::string, std::vector<std::uint8_t>> load_reports(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error("cannot open " + file);
  std::map<std::string, std::vector<std::uint8_t>> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) throw std::runtime_error(file + ": bad line: " + line);
    std::istringstream ss(line.substr(colon + 1));
    std::vector<std::uint8_t> bytes;
    std::string h;
    while (ss >> h) bytes.push_back(static_cast<std::uint8_t>(std::stoul(h, nullptr, 16)));
    out[line.substr(0, colon)] = bytes;
  }
  return out;
}

// The error a profile's text gives, read as "bad.yaml"; "no error" if it reads.
inline std::string profile_error(const std::string& text) {
  try {
    (void)parse_device_profile(text, "bad.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace scalpel::test
