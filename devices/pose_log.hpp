// Pose log: the recorded stream of tool samples, read by the mock device and written by the
// recorder (docs/formats.md).
//
//   # scalpelsim-log 1                      magic line, always first
//   # device: hid                           metadata, "# key: value"
//   t,x,y,z,qw,qx,qy,qz,buttons[,fx,fy,fz[,frame]]  header
//   0.001,0.01,0,0.005,1,0,0,0,0            one ToolSample per line
//
// t [s] strictly increasing; x, y, z [m]; (qw, qx, qy, qz) a unit quaternion tool -> world;
// buttons a non-negative integer bitmask; fx, fy, fz [N] the force sent to the device; frame the
// simulation frame that took the sample (a live session's recording), never decreasing. Numbers are
// written in the shortest form that reads back to the same double, so record -> replay is exact.
// After the header, "# key: value" lines are metadata as well (a trailer), other '#' lines are
// comments; empty lines are skipped.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <istream>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "devices/tool_sample.hpp"

namespace scalpel {

inline constexpr std::string_view kPoseLogMagic = "# scalpelsim-log 1";
// Line buffer a writer reserves: a flush interval of 0.1 s at 1 kHz is about 12 KiB.
inline constexpr std::size_t kPoseLogBufferBytes = 64 * 1024;
// Bounds that keep a log physical (docs/formats.md): |t| within kPoseLogMaxTime, consecutive
// samples at least kPoseLogMinStep apart (a device rate of at most 1 MHz), positions within
// kPoseLogMaxCoordinate of the origin, forces within kPoseLogMaxForce.
inline constexpr double kPoseLogMaxTime = 1e6;          // [s], about 11.6 days
inline constexpr double kPoseLogMinStep = 1e-6;         // [s]
inline constexpr double kPoseLogMaxCoordinate = 100.0;  // [m]
inline constexpr double kPoseLogMaxForce = 1e3;         // [N]
// A log of 4 GiB holds about eight hours at 1 kHz.
inline constexpr std::uintmax_t kPoseLogMaxBytes = std::uintmax_t{4} << 30;
// Tolerance on |q| - 1 for the orientation of every sample.
inline constexpr double kPoseLogUnitTolerance = 1e-6;

// Metadata in file order: (key, value).
using PoseLogMetadata = std::vector<std::pair<std::string, std::string>>;

// Streams samples out of a pose log; every violation of the format is an InputError naming the
// file, the line, the column and the field (column name).
class PoseLogReader {
 public:
  // Opens `path` and reads the magic line, the metadata and the header.
  explicit PoseLogReader(const std::string& path);
  // Reads from `in`, which must outlive the reader; `name` names it in errors.
  PoseLogReader(std::istream& in, std::string name);

  // The next sample; false at the end of the input.
  bool next(ToolSample& sample);

  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] const PoseLogMetadata& metadata() const { return metadata_; }
  // The 1-based line of metadata entry i.
  [[nodiscard]] int metadata_line(std::size_t i) const { return metadata_lines_.at(i); }
  // The value of the first metadata entry with `key`, if any. Entries after the header (a trailer)
  // count once the reader has reached them.
  [[nodiscard]] std::optional<std::string> metadata(std::string_view key) const;
  // True when the header has the force columns fx, fy, fz.
  [[nodiscard]] bool has_force() const { return has_force_; }
  // True when it has the frame column; frame() is then the last sample's.
  [[nodiscard]] bool has_frame() const { return has_frame_; }
  [[nodiscard]] std::uint64_t frame() const { return frame_; }
  // 1-based number of the line read last (the last sample after next() returned true).
  [[nodiscard]] int line() const { return line_; }
  // After next() returned false: the number of the last line when it had no newline (a recorder
  // killed while writing it), which was skipped; 0 when the log ended with a whole line.
  [[nodiscard]] int torn_line() const { return torn_line_; }
  // "FILE:LINE: the last line is torn ..." when torn_line() is not 0, else empty.
  [[nodiscard]] std::string torn_warning() const;

 private:
  void read_preamble();
  bool read_line();        // into line_text_; false at the end of the input
  bool read_whole_line();  // read_line(), but a last line without newline ends the input as torn
  [[noreturn]] void fail(int column, std::string_view field, const std::string& message) const;

  std::ifstream file_;
  std::istream* in_;
  std::string name_;
  PoseLogMetadata metadata_;
  std::vector<int> metadata_lines_;
  bool has_force_ = false;
  bool has_frame_ = false;
  std::uint64_t frame_ = 0;
  int line_ = 0;
  int torn_line_ = 0;
  bool line_terminated_ = true;
  std::string line_text_;
  double last_t_ = 0.0;
  bool any_sample_ = false;
};

// Writes a pose log: the magic line, the metadata and the header at construction, then one line per
// write(). Lines collect in a buffer of whole lines; flush() hands them to the file in one write(2),
// so a process killed at any moment leaves a log of whole lines up to its last flush (a log torn
// by a failing disk or a full buffer's partial write ends in at most one torn line, which the
// reader skips with a warning). A writer to a file also fsyncs at flush once `sync_interval` has
// passed since the last fsync, so a power loss costs at most that much. write() formats into a
// fixed buffer and appends to the reserved line buffer, handing it to the file first when full: it
// does not allocate. A writer to a stream writes through to it.
class PoseLogWriter {
 public:
  static constexpr double kDefaultSyncInterval = 1.0;  // [s] between fsyncs at flush

  // Creates (truncates) `path` and writes the preamble to it at once; InputError if it cannot be
  // opened. `with_frame` adds the frame column after the force columns (and so implies them).
  PoseLogWriter(const std::string& path, const PoseLogMetadata& metadata, bool with_force = false,
                bool with_frame = false);
  // Writes into `out`, which must outlive the writer; `name` names it in errors.
  PoseLogWriter(std::ostream& out, std::string name, const PoseLogMetadata& metadata, bool with_force = false,
                bool with_frame = false);
  // Flushes what is left (errors are lost here: call flush() to see them).
  ~PoseLogWriter();
  PoseLogWriter(const PoseLogWriter&) = delete;
  PoseLogWriter& operator=(const PoseLogWriter&) = delete;

  // Throws std::invalid_argument for a sample the reader would reject (non-finite values, t not
  // strictly increasing, quaternion not unit, a frame going back), so a written log always reads
  // back. `frame` is written only with the frame column.
  void write(const ToolSample& sample, std::uint64_t frame = 0);
  // A metadata entry after the samples, "# key: value" (the reader adds it to its metadata once it
  // has read that far). std::invalid_argument for a key or value the reader would not read back.
  void write_trailer(const std::string& key, const std::string& value);
  // Hands the buffered lines to the file (or stream); std::runtime_error when that fails.
  void flush();
  // flush(), then fsync (a file only): the lines are on the disk when it returns.
  void sync();
  // [s] of real time between the fsyncs flush() makes; 0: every flush, infinity: never.
  void set_sync_interval(double seconds) { sync_interval_ = seconds; }

  [[nodiscard]] std::size_t samples_written() const { return count_; }
  [[nodiscard]] std::size_t syncs() const { return syncs_; }

 private:
  void write_preamble(const PoseLogMetadata& metadata);
  void append(const char* text, std::size_t size);
  void write_out();

  int fd_ = -1;
  std::ostream* out_ = nullptr;
  std::string name_;
  std::string pending_;  // whole lines not yet handed to the file
  bool with_force_;
  bool with_frame_ = false;
  std::size_t count_ = 0;
  std::size_t syncs_ = 0;
  double last_t_ = 0.0;
  std::uint64_t last_frame_ = 0;
  double sync_interval_ = kDefaultSyncInterval;
  std::chrono::steady_clock::time_point last_sync_;
};

// Reads the whole log at `path`. A torn last line is skipped; its warning goes to `torn_warning`
// when given (else it is lost).
[[nodiscard]] std::vector<ToolSample> read_pose_log(const std::string& path,
                                                    std::string* torn_warning = nullptr);

}  // namespace scalpel
