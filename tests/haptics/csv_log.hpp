// A minimal pose log sink and reader for the recorder tests, in the CSV layout of docs/formats.md
// with force columns. Flush hands complete lines to the kernel with one write(2), so a killed
// process leaves whole lines up to its last flush.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "devices/tool_sample.hpp"

namespace scalpel::test {

class CsvLogSink {
 public:
  explicit CsvLogSink(const std::string& path)
      : fd_(::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644)) {
    if (fd_ < 0) throw std::runtime_error("cannot create " + path);
    buffer_ = "# scalpelsim-log 1\n# device: test\nt,x,y,z,qw,qx,qy,qz,buttons,fx,fy,fz\n";
  }
  ~CsvLogSink() { ::close(fd_); }
  CsvLogSink(const CsvLogSink&) = delete;
  CsvLogSink& operator=(const CsvLogSink&) = delete;

  void write(const ToolSample& s) {
    char line[512];
    const int n = std::snprintf(
        line, sizeof line, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%u,%.17g,%.17g,%.17g\n", s.t,
        s.position.x(), s.position.y(), s.position.z(), s.orientation.w(), s.orientation.x(),
        s.orientation.y(), s.orientation.z(), s.buttons, s.force.x(), s.force.y(), s.force.z());
    buffer_.append(line, static_cast<std::size_t>(n));
  }
  void flush() {
    std::size_t done = 0;
    while (done < buffer_.size()) {
      const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
      if (n <= 0) throw std::runtime_error("write failed");
      done += static_cast<std::size_t>(n);
    }
    buffer_.clear();
  }

 private:
  int fd_;
  std::string buffer_;
};

// Throws on any line that is not a complete, well-formed record.
inline std::vector<ToolSample> read_csv_log(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  if (!text.empty() && text.back() != '\n') throw std::runtime_error("truncated last line");
  std::vector<ToolSample> out;
  std::istringstream lines(text);
  std::string line;
  bool header = false;
  int number = 0;
  while (std::getline(lines, line)) {
    ++number;
    if (line.starts_with("#")) continue;
    if (!header) {
      if (line != "t,x,y,z,qw,qx,qy,qz,buttons,fx,fy,fz") throw std::runtime_error("bad header");
      header = true;
      continue;
    }
    ToolSample s;
    double w, x, y, z;
    unsigned b = 0;
    char end = 0;
    const int n = std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%u,%lf,%lf,%lf%c", &s.t,
                              &s.position.x(), &s.position.y(), &s.position.z(), &w, &x, &y, &z, &b,
                              &s.force.x(), &s.force.y(), &s.force.z(), &end);
    if (n != 12) throw std::runtime_error("line " + std::to_string(number) + ": malformed");
    s.orientation = Eigen::Quaterniond(w, x, y, z);
    s.buttons = b;
    if (!out.empty() && !(s.t > out.back().t))
      throw std::runtime_error("line " + std::to_string(number) + ": t");
    out.push_back(s);
  }
  if (!header) throw std::runtime_error("no header");
  return out;
}

}  // namespace scalpel::test
