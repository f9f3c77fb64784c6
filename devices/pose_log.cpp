#include "devices/pose_log.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "base/input_error.hpp"
#include "base/input_file.hpp"

namespace scalpel {

namespace {

constexpr std::array<std::string_view, 13> kColumns = {"t",  "x",       "y",  "z",  "qw", "qx",   "qy",
                                                       "qz", "buttons", "fx", "fy", "fz", "frame"};
constexpr std::size_t kBaseColumns = 9;
constexpr std::size_t kForceColumns = 12;
constexpr std::size_t kFrameColumns = 13;
constexpr std::string_view kHeaderText = "t,x,y,z,qw,qx,qy,qz,buttons";

// "'text' problem", built by appending: GCC 12 warns (-Wrestrict, wrongly) about the inlined
// concatenation of string temporaries here.
std::string quoted(std::string_view text, std::string_view problem) {
  std::string message = "'";
  message.append(text).append("' ").append(problem);
  return message;
}

bool is_blank(char c) {
  return c == ' ' || c == '\t';
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

// One comma-separated field: its text and its 1-based column in the line.
struct FieldText {
  std::string_view text;
  int column = 0;
};

// Splits `line` at commas into at most out.size() fields; returns the number of fields found
// (which may exceed out.size(): the extra ones are counted, not stored).
std::size_t split(std::string_view line, std::array<FieldText, kFrameColumns + 1>& out) {
  std::size_t count = 0, start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    const std::size_t end = comma == std::string_view::npos ? line.size() : comma;
    if (count < out.size()) out[count] = {trim(line.substr(start, end - start)), static_cast<int>(start) + 1};
    ++count;
    if (comma == std::string_view::npos) return count;
    start = comma + 1;
  }
}

enum class Parse { Ok, NotNumber, NotFinite };

Parse parse_double(std::string_view s, double& out) {
  if (s.size() > 1 && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return Parse::NotNumber;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out, std::chars_format::general);
  if (ec != std::errc() || end != s.data() + s.size()) return Parse::NotNumber;
  return std::isfinite(out) ? Parse::Ok : Parse::NotFinite;
}

// "# key: value\n"; std::invalid_argument (naming the log `name`) for an entry the reader would
// not read back.
std::string metadata_line(const std::string& name, const std::string& key, const std::string& value) {
  const bool bad_key =
      key.empty() || key.find_first_of(":\r\n") != std::string::npos || trim(key).size() != key.size();
  if (bad_key || value.find_first_of("\r\n") != std::string::npos)
    throw std::invalid_argument(name + ": bad metadata entry '" + key + "'");
  return "# " + key + ": " + value + '\n';
}

// Appends the shortest text that reads back as exactly `v`.
char* put(char* p, char* end, double v) {
  return std::to_chars(p, end, v).ptr;
}

}  // namespace

// ---- reader ---------------------------------------------------------------------------------------

PoseLogReader::PoseLogReader(const std::string& path) : name_(path) {
  check_input_file(path, "pose log", kPoseLogMaxBytes);
  file_.open(path);
  in_ = &file_;
  if (!file_) throw InputError(path, 0, 0, "", "cannot open pose log");
  read_preamble();
}

PoseLogReader::PoseLogReader(std::istream& in, std::string name) : in_(&in), name_(std::move(name)) {
  read_preamble();
}

void PoseLogReader::fail(int column, std::string_view field, const std::string& message) const {
  throw InputError(name_, line_, column, std::string(field), message);
}

bool PoseLogReader::read_line() {
  if (!std::getline(*in_, line_text_)) {
    if (in_->bad()) throw InputError(name_, line_ + 1, 0, "", "read error");
    return false;
  }
  ++line_;
  // getline stops at the end of the input without a newline only on the last line.
  line_terminated_ = !in_->eof();
  if (!line_text_.empty() && line_text_.back() == '\r') line_text_.pop_back();
  return true;
}

bool PoseLogReader::read_whole_line() {
  if (!read_line()) return false;
  if (line_terminated_ || trim(line_text_).empty()) return true;
  // A writer ends every line with a newline: a last line without one was cut short while it was
  // written, and even one that parses may have lost digits.
  torn_line_ = line_;
  return false;
}

std::string PoseLogReader::torn_warning() const {
  if (torn_line_ == 0) return {};
  return name_ + ":" + std::to_string(torn_line_) +
         ": the last line has no newline (a recording cut short while writing it); skipped";
}

std::optional<std::string> PoseLogReader::metadata(std::string_view key) const {
  for (const auto& [k, v] : metadata_)
    if (k == key) return v;
  return std::nullopt;
}

void PoseLogReader::read_preamble() {
  if (!read_line()) {
    line_ = 1;
    fail(0, "", "empty file, expected '" + std::string(kPoseLogMagic) + "'");
  }
  std::string_view first = line_text_;
  if (first.substr(0, 3) == "\xEF\xBB\xBF") first.remove_prefix(3);  // UTF-8 byte order mark
  constexpr std::string_view kPrefix = "# scalpelsim-log";
  if (first.substr(0, kPrefix.size()) != kPrefix)
    fail(1, "", "missing magic line '" + std::string(kPoseLogMagic) + "'");
  const std::string_view version = trim(first.substr(kPrefix.size()));
  if (version != "1") fail(1, "", "unsupported pose log version '" + std::string(version) + "', expected 1");

  while (true) {
    if (!read_line()) {
      ++line_;
      fail(0, "", "missing header '" + std::string(kHeaderText) + "'");
    }
    const std::string_view line = trim(line_text_);
    if (line.empty()) continue;
    if (line.front() == '#') {
      const std::string_view body = line.substr(1);
      const std::size_t colon = body.find(':');
      if (colon == std::string_view::npos) continue;  // a comment
      const std::string_view key = trim(body.substr(0, colon));
      if (!key.empty()) {
        metadata_.emplace_back(std::string(key), std::string(trim(body.substr(colon + 1))));
        metadata_lines_.push_back(line_);
      }
      continue;
    }
    std::array<FieldText, kFrameColumns + 1> fields;
    const std::size_t count = split(line_text_, fields);
    constexpr std::string_view kOptional = "' optionally followed by ',fx,fy,fz' or ',fx,fy,fz,frame'";
    for (std::size_t i = 0; i < std::min(count, kFrameColumns); ++i)
      if (fields[i].text != kColumns[i])
        fail(fields[i].column, kColumns[i],
             "bad header: column " + std::to_string(i + 1) + " is '" + std::string(fields[i].text) +
                 "', expected '" + std::string(kHeaderText) + std::string(kOptional));
    if (count != kBaseColumns && count != kForceColumns && count != kFrameColumns)
      fail(count > kFrameColumns ? fields[kFrameColumns].column : 0,
           count < kFrameColumns ? kColumns[count] : "",
           "bad header: " + std::to_string(count) + " columns, expected '" + std::string(kHeaderText) +
               std::string(kOptional));
    has_force_ = count >= kForceColumns;
    has_frame_ = count == kFrameColumns;
    return;
  }
}

bool PoseLogReader::next(ToolSample& sample) {
  std::string_view line;
  while (true) {
    if (!read_whole_line()) return false;
    line = trim(line_text_);
    if (line.empty()) continue;
    if (line.front() != '#') break;
    // "# key: value" here is metadata too (a live recording's trailer); other '#' lines are comments.
    const std::string_view body = line.substr(1);
    const std::size_t colon = body.find(':');
    if (colon == std::string_view::npos) continue;
    const std::string_view key = trim(body.substr(0, colon));
    if (!key.empty()) {
      metadata_.emplace_back(std::string(key), std::string(trim(body.substr(colon + 1))));
      metadata_lines_.push_back(line_);
    }
  }

  std::array<FieldText, kFrameColumns + 1> f;
  const std::size_t expected = has_frame_ ? kFrameColumns : has_force_ ? kForceColumns : kBaseColumns;
  const std::size_t count = split(line_text_, f);
  if (count < expected)
    fail(static_cast<int>(line_text_.size()) + 1, kColumns[count],
         "expected " + std::to_string(expected) + " fields, found " + std::to_string(count));
  if (count > expected)
    fail(f[expected].column, "",
         "expected " + std::to_string(expected) + " fields, found " + std::to_string(count));

  std::array<double, kForceColumns> v{};
  for (std::size_t i = 0; i < std::min(expected, kForceColumns); ++i) {
    if (i == 8) continue;  // buttons, below
    switch (parse_double(f[i].text, v[i])) {
      case Parse::Ok:
        break;
      case Parse::NotNumber:
        fail(f[i].column, kColumns[i], quoted(f[i].text, "is not a number"));
      case Parse::NotFinite:
        fail(f[i].column, kColumns[i], quoted(f[i].text, "is not finite"));
    }
  }

  if (!(std::abs(v[0]) <= kPoseLogMaxTime))
    fail(f[0].column, "t", quoted(f[0].text, "is beyond the log's time range of +-1e6 s"));
  if (any_sample_ && !(v[0] > last_t_))
    fail(f[0].column, "t",
         "time must increase strictly (previous sample at t = " + std::to_string(last_t_) + ")");
  if (any_sample_ && !(v[0] - last_t_ >= kPoseLogMinStep))
    fail(f[0].column, "t",
         "samples less than 1 microsecond apart (previous at t = " + std::to_string(last_t_) +
             "); a device samples at 1 MHz at most");
  for (std::size_t i = 1; i <= 3; ++i)
    if (!(std::abs(v[i]) <= kPoseLogMaxCoordinate))
      fail(f[i].column, kColumns[i], quoted(f[i].text, "is more than 100 m from the origin"));
  if (has_force_)
    for (std::size_t i = 9; i <= 11; ++i)
      if (!(std::abs(v[i]) <= kPoseLogMaxForce))
        fail(f[i].column, kColumns[i], quoted(f[i].text, "is beyond the force range of +-1000 N"));

  const double norm = std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
  if (!(std::abs(norm - 1.0) <= kPoseLogUnitTolerance))
    fail(f[4].column, "qw,qx,qy,qz",
         "quaternion is not unit (norm " + std::to_string(norm) + ", tolerance 1e-6)");

  // buttons: a non-negative integer bitmask of 32 bits.
  std::string_view b = f[8].text;
  std::uint64_t buttons = 0;
  const auto [end, ec] = std::from_chars(b.data(), b.data() + b.size(), buttons);
  const auto bad_buttons = [&](std::string_view problem) {
    fail(f[8].column, "buttons", quoted(b, problem));
  };
  if (b.empty() || ec == std::errc::invalid_argument || end != b.data() + b.size()) {
    double d = 0.0;
    if (!b.empty() && b.front() == '-') bad_buttons("is negative, expected a bitmask >= 0");
    if (parse_double(b, d) == Parse::Ok) bad_buttons("is not an integer");
    bad_buttons("is not a number");
  }
  if (ec == std::errc::result_out_of_range || buttons > std::numeric_limits<std::uint32_t>::max())
    bad_buttons("does not fit in 32 bits");

  // frame: the simulation frame that took the sample, a non-negative integer, never decreasing.
  if (has_frame_) {
    const std::string_view text = f[12].text;
    std::uint64_t frame = 0;
    const auto [fend, fec] = std::from_chars(text.data(), text.data() + text.size(), frame);
    if (text.empty() || fec != std::errc() || fend != text.data() + text.size())
      fail(f[12].column, "frame", quoted(text, "is not a frame number (an integer >= 0)"));
    if (any_sample_ && frame < frame_)
      fail(f[12].column, "frame",
           "frame must not decrease (previous sample in frame " + std::to_string(frame_) + ")");
    frame_ = frame;
  }

  sample.t = v[0];
  sample.position = Eigen::Vector3d(v[1], v[2], v[3]);
  sample.orientation = Eigen::Quaterniond(v[4], v[5], v[6], v[7]);
  sample.buttons = static_cast<std::uint32_t>(buttons);
  sample.force = has_force_ ? Eigen::Vector3d(v[9], v[10], v[11]) : Eigen::Vector3d::Zero();
  last_t_ = v[0];
  any_sample_ = true;
  return true;
}

std::vector<ToolSample> read_pose_log(const std::string& path, std::string* torn_warning) {
  PoseLogReader reader(path);
  std::vector<ToolSample> samples;
  ToolSample s;
  while (reader.next(s)) samples.push_back(s);
  if (torn_warning) *torn_warning = reader.torn_warning();
  return samples;
}

// ---- writer ---------------------------------------------------------------------------------------

PoseLogWriter::PoseLogWriter(const std::string& path, const PoseLogMetadata& metadata, bool with_force,
                             bool with_frame)
    : fd_(::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644)),
      name_(path),
      with_force_(with_force || with_frame),
      with_frame_(with_frame) {
  if (fd_ < 0)
    throw InputError(path, 0, 0, "",
                     std::string("cannot open pose log for writing: ") + std::strerror(errno));
  pending_.reserve(kPoseLogBufferBytes);
  try {
    write_preamble(metadata);
    sync();  // a recording killed before its first sample is still a log
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

PoseLogWriter::PoseLogWriter(std::ostream& out, std::string name, const PoseLogMetadata& metadata,
                             bool with_force, bool with_frame)
    : out_(&out), name_(std::move(name)), with_force_(with_force || with_frame), with_frame_(with_frame) {
  pending_.reserve(kPoseLogBufferBytes);
  write_preamble(metadata);
}

PoseLogWriter::~PoseLogWriter() {
  try {
    flush();
  } catch (const std::exception&) {  // NOLINT(bugprone-empty-catch): flush() reports it to callers
  }
  if (fd_ >= 0) ::close(fd_);
}

void PoseLogWriter::append(const char* text, std::size_t size) {
  if (out_) {  // a stream buffers on its own
    out_->write(text, static_cast<std::streamsize>(size));
    return;
  }
  // Only whole lines reach the file: the buffer goes out before a line that would not fit.
  if (!pending_.empty() && pending_.size() + size > pending_.capacity()) write_out();
  pending_.append(text, size);
}

void PoseLogWriter::write_out() {
  if (out_) return;
  std::size_t done = 0;
  while (done < pending_.size()) {
    const ssize_t n = ::write(fd_, pending_.data() + done, pending_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      pending_.erase(0, done);
      throw std::runtime_error(name_ + ": cannot write pose log: " + std::strerror(errno));
    }
    done += static_cast<std::size_t>(n);
  }
  pending_.clear();
}

void PoseLogWriter::write_preamble(const PoseLogMetadata& metadata) {
  std::string text(kPoseLogMagic);
  text += '\n';
  for (const auto& [key, value] : metadata) text += metadata_line(name_, key, value);
  text += std::string(kHeaderText) + (with_force_ ? ",fx,fy,fz" : "") + (with_frame_ ? ",frame" : "") + '\n';
  append(text.data(), text.size());
}

void PoseLogWriter::write(const ToolSample& s, std::uint64_t frame) {
  if (!is_valid(s, kPoseLogUnitTolerance))
    throw std::invalid_argument(name_ + ": sample at t = " + std::to_string(s.t) +
                                " is not finite or its quaternion is not unit");
  if (count_ > 0 && !(s.t - last_t_ >= kPoseLogMinStep))
    throw std::invalid_argument(name_ + ": sample time " + std::to_string(s.t) +
                                " is not at least 1 microsecond after the previous one");
  const bool in_range = std::abs(s.t) <= kPoseLogMaxTime &&
                        s.position.cwiseAbs().maxCoeff() <= kPoseLogMaxCoordinate &&
                        (!with_force_ || s.force.cwiseAbs().maxCoeff() <= kPoseLogMaxForce);
  if (!in_range)
    throw std::invalid_argument(name_ + ": sample at t = " + std::to_string(s.t) +
                                " is beyond the log's bounds (time, position or force)");
  if (with_frame_ && count_ > 0 && frame < last_frame_)
    throw std::invalid_argument(name_ + ": frame " + std::to_string(frame) + " goes back");
  // 12 shortest doubles (at most 24 characters each), two integers and separators.
  std::array<char, 12 * 25 + 40> buffer;
  char* p = buffer.data();
  char* const end = buffer.data() + buffer.size();
  const double values[] = {s.t,
                           s.position.x(),
                           s.position.y(),
                           s.position.z(),
                           s.orientation.w(),
                           s.orientation.x(),
                           s.orientation.y(),
                           s.orientation.z()};
  for (const double v : values) {
    p = put(p, end, v);
    *p++ = ',';
  }
  p = std::to_chars(p, end, s.buttons).ptr;
  if (with_force_)
    for (int a = 0; a < 3; ++a) {
      *p++ = ',';
      p = put(p, end, s.force[a]);
    }
  if (with_frame_) {
    *p++ = ',';
    p = std::to_chars(p, end, frame).ptr;
    last_frame_ = frame;
  }
  *p++ = '\n';
  append(buffer.data(), static_cast<std::size_t>(p - buffer.data()));
  last_t_ = s.t;
  ++count_;
}

void PoseLogWriter::write_trailer(const std::string& key, const std::string& value) {
  const std::string line = metadata_line(name_, key, value);
  append(line.data(), line.size());
}

void PoseLogWriter::flush() {
  write_out();
  if (out_) {
    out_->flush();
    if (!*out_) throw std::runtime_error(name_ + ": cannot write pose log");
    return;
  }
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - last_sync_).count() >= sync_interval_) sync();
}

void PoseLogWriter::sync() {
  write_out();
  if (out_) {
    out_->flush();
    return;
  }
  if (::fsync(fd_) != 0) throw std::runtime_error(name_ + ": cannot sync pose log: " + std::strerror(errno));
  last_sync_ = std::chrono::steady_clock::now();
  ++syncs_;
}

}  // namespace scalpel
