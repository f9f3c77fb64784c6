#include <doctest/doctest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "base/input_error.hpp"
#include "devices/pose_log.hpp"

using namespace scalpel;

namespace {

std::vector<ToolSample> tricky_samples(bool with_force) {
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<ToolSample> out;
  double t = 0.0;
  for (int i = 0; i < 200; ++i) {
    ToolSample s;
    t += 0.001 + 1e-7 * (u(rng) + 1.0);
    s.t = t;
    s.position = Eigen::Vector3d(u(rng), u(rng) * 1e-3, u(rng) * 1e-9);
    s.orientation = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
    s.buttons = static_cast<std::uint32_t>(i % 7);
    if (with_force) s.force = Eigen::Vector3d(u(rng), u(rng) * 999.0, u(rng) * 1e-5);
    out.push_back(s);
  }
  // Values whose decimal form is the hard case for round trips.
  out[3].position = Eigen::Vector3d(0.1, 1.0 / 3.0, -0.0);
  out[4].position = Eigen::Vector3d(std::numeric_limits<double>::denorm_min(), 1e-300, -99.99999999999999);
  out[5].position = Eigen::Vector3d(std::nextafter(0.3, 1.0), 5e-324, 12.3456789123456789);
  out[6].buttons = std::numeric_limits<std::uint32_t>::max();
  return out;
}

bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

void check_identical(const ToolSample& a, const ToolSample& b) {
  CHECK(same_bits(a.t, b.t));
  for (int k = 0; k < 3; ++k) {
    CHECK(same_bits(a.position[k], b.position[k]));
    CHECK(same_bits(a.force[k], b.force[k]));
  }
  for (int k = 0; k < 4; ++k) CHECK(same_bits(a.orientation.coeffs()[k], b.orientation.coeffs()[k]));
  CHECK(a.buttons == b.buttons);
}

// The error raised while reading all of `text`.
InputError read_error(const std::string& text) {
  std::istringstream in(text);
  try {
    PoseLogReader reader(in, "bad.csv");
    ToolSample s;
    while (reader.next(s)) {
    }
  } catch (const InputError& e) {
    return e;
  }
  FAIL("no error raised for:\n" << text);
  return InputError("", 0, 0, "", "");
}

const std::string kHead = "# scalpelsim-log 1\n# device: mock\nt,x,y,z,qw,qx,qy,qz,buttons\n";
const std::string kFrameHead = "# scalpelsim-log 1\nt,x,y,z,qw,qx,qy,qz,buttons,fx,fy,fz,frame\n";

std::filesystem::path temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("scalpelsim_test_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace

TEST_CASE("pose log: write then read gives bit-identical samples") {
  for (const bool with_force : {false, true}) {
    CAPTURE(with_force);
    const auto samples = tricky_samples(with_force);
    std::stringstream buffer;
    PoseLogWriter writer(buffer, "memory", {{"device", "mock"}, {"scenario", "skin_incision"}}, with_force);
    for (const auto& s : samples) writer.write(s);
    writer.flush();
    CHECK(writer.samples_written() == samples.size());

    PoseLogReader reader(buffer, "memory");
    CHECK(reader.has_force() == with_force);
    REQUIRE(reader.metadata().size() == 2);
    CHECK(reader.metadata("device") == "mock");
    CHECK(reader.metadata("scenario") == "skin_incision");
    CHECK_FALSE(reader.metadata("units").has_value());
    ToolSample s;
    std::size_t n = 0;
    while (reader.next(s)) {
      REQUIRE(n < samples.size());
      check_identical(samples[n], s);
      CHECK(reader.line() == static_cast<int>(n) + 5);  // magic, 2 metadata, header
      ++n;
    }
    CHECK(n == samples.size());
  }
}

TEST_CASE("pose log: a live recording's frame column round-trips and implies the force columns") {
  const auto samples = tricky_samples(true);
  std::ostringstream out;
  PoseLogWriter w(out, "mem", {{"playback", "verbatim"}}, false, true);
  for (std::size_t i = 0; i < samples.size(); ++i) w.write(samples[i], i / 7);
  w.write_trailer("frames", "40");
  w.flush();
  CHECK_THROWS_AS(w.write(
                      [&] {
                        ToolSample s = samples.back();
                        s.t += 1.0;
                        return s;
                      }(),
                      0),
                  std::invalid_argument);  // a frame going back
  std::istringstream in(out.str());
  PoseLogReader r(in, "mem");
  CHECK(r.has_force());
  CHECK(r.has_frame());
  std::size_t i = 0;
  for (ToolSample s; r.next(s); ++i) {
    check_identical(s, samples[i]);
    CHECK(r.frame() == i / 7);
  }
  CHECK(i == samples.size());
  CHECK(r.metadata("frames") == "40");  // the trailer, read once the reader reached it
}

TEST_CASE("pose log: file round trip through read_pose_log") {
  const auto dir = temp_dir("pose_log_file");
  const std::string path = (dir / "rec.csv").string();
  const auto samples = tricky_samples(true);
  {
    PoseLogWriter writer(path, {{"device", "hid"}}, true);
    for (const auto& s : samples) writer.write(s);
    writer.flush();
  }
  const auto back = read_pose_log(path);
  REQUIRE(back.size() == samples.size());
  for (std::size_t i = 0; i < back.size(); ++i) check_identical(samples[i], back[i]);
  std::filesystem::remove_all(dir);
}

TEST_CASE("pose log: format details the reader accepts") {
  SUBCASE("CRLF line ends, blank lines, comments, spaces around fields and a byte order mark") {
    std::istringstream in(
        "\xEF\xBB\xBF# scalpelsim-log 1\r\n# units: SI\r\n# a free comment\r\n\r\n"
        "t, x, y, z, qw, qx, qy, qz, buttons\r\n0.5, 1, 2, 3, 1, 0, 0, 0, 3\r\n\r\n# note\r\n"
        "0.75,+1e-3,0,0,0,1,0,0,0\r\n");
    PoseLogReader reader(in, "ok.csv");
    CHECK(reader.metadata("units") == "SI");
    ToolSample s;
    REQUIRE(reader.next(s));
    CHECK(s.t == 0.5);
    CHECK(s.position == Eigen::Vector3d(1, 2, 3));
    CHECK(s.buttons == 3u);
    REQUIRE(reader.next(s));
    CHECK(reader.line() == 9);
    CHECK(s.position.x() == 1e-3);
    CHECK(s.orientation.x() == 1.0);
    CHECK_FALSE(reader.next(s));
  }
  SUBCASE("a log with no samples") {
    std::istringstream in(kHead);
    PoseLogReader reader(in, "empty.csv");
    ToolSample s;
    CHECK_FALSE(reader.next(s));
  }
}

TEST_CASE("pose log: every violation names the line and the field") {
  struct Case {
    std::string what;
    std::string text;
    int line;
    std::string field;
    const char* message_part;
  };
  const std::string ok = "0.001,0,0,0,1,0,0,0,0\n";
  const std::vector<Case> cases = {
      {"empty file", "", 1, "", "empty file"},
      {"missing magic", "t,x,y,z,qw,qx,qy,qz,buttons\n" + ok, 1, "", "magic line"},
      {"wrong version", "# scalpelsim-log 2\nt,x,y,z,qw,qx,qy,qz,buttons\n", 1, "", "version"},
      {"no header", "# scalpelsim-log 1\n# device: mock\n", 3, "", "missing header"},
      {"misspelt header", "# scalpelsim-log 1\nt,x,y,z,qw,qx,qy,qz,button\n", 2, "buttons", "bad header"},
      {"short header", "# scalpelsim-log 1\nt,x,y,z\n", 2, "qw", "bad header"},
      {"partial force header", "# scalpelsim-log 1\nt,x,y,z,qw,qx,qy,qz,buttons,fx\n", 2, "fy", "bad header"},
      {"too few fields", kHead + ok + "0.002,0,0,0,1,0,0\n", 5, "qz", "expected 9 fields, found 7"},
      {"too many fields", kHead + ok + "0.002,0,0,0,1,0,0,0,0\n0.003,0,0,0,1,0,0,0,0,9\n", 6, "",
       "expected 9 fields, found 10"},
      {"not a number", kHead + "0.001,0,0,abc,1,0,0,0,0\n", 4, "z", "not a number"},
      {"empty field", kHead + "0.001,0,,0,1,0,0,0,0\n", 4, "y", "not a number"},
      {"trailing garbage", kHead + "0.001,0,0,0,1,0,0,0.5mm,0\n", 4, "qz", "not a number"},
      {"NaN", kHead + "0.001,nan,0,0,1,0,0,0,0\n", 4, "x", "not finite"},
      {"infinity", kHead + ok + "0.002,0,0,0,1,0,0,0,0\n0.003,0,-inf,0,1,0,0,0,0\n", 6, "y", "not finite"},
      {"time repeated", kHead + ok + ok, 5, "t", "increase strictly"},
      {"time decreasing", kHead + "0.002,0,0,0,1,0,0,0,0\n" + ok, 5, "t", "increase strictly"},
      {"quaternion not unit", kHead + ok + "0.002,0,0,0,1,0,0,0.01,0\n", 5, "qw,qx,qy,qz", "not unit"},
      {"zero quaternion", kHead + "0.001,0,0,0,0,0,0,0,0\n", 4, "qw,qx,qy,qz", "not unit"},
      {"negative buttons", kHead + "0.001,0,0,0,1,0,0,0,-1\n", 4, "buttons", "negative"},
      {"fractional buttons", kHead + "0.001,0,0,0,1,0,0,0,1.5\n", 4, "buttons", "not an integer"},
      {"non-numeric buttons", kHead + "0.001,0,0,0,1,0,0,0,left\n", 4, "buttons", "not a number"},
      {"buttons beyond 32 bits", kHead + "0.001,0,0,0,1,0,0,0,4294967296\n", 4, "buttons", "32 bits"},
      {"bad force", "# scalpelsim-log 1\nt,x,y,z,qw,qx,qy,qz,buttons,fx,fy,fz\n0.1,0,0,0,1,0,0,0,0,1,x,2\n",
       3, "fy", "not a number"},
      {"frame without force", "# scalpelsim-log 1\nt,x,y,z,qw,qx,qy,qz,buttons,frame\n", 2, "fx",
       "bad header"},
      {"bad frame", kFrameHead + "0.1,0,0,0,1,0,0,0,0,0,0,0,x\n", 3, "frame", "not a frame number"},
      {"negative frame", kFrameHead + "0.1,0,0,0,1,0,0,0,0,0,0,0,-1\n", 3, "frame", "not a frame number"},
      {"time beyond the log's range", kHead + "1e300,0,0,0,1,0,0,0,0\n", 4, "t", "time range"},
      {"samples a nanosecond apart", kHead + ok + "0.001000001,0,0,0,1,0,0,0,0\n", 5, "t", "1 microsecond"},
      {"a position far off", kHead + ok + "0.002,0,1e300,0,1,0,0,0,0\n", 5, "y", "100 m"},
      {"a force beyond any device",
       "# scalpelsim-log 1\nt,x,y,z,qw,qx,qy,qz,buttons,fx,fy,fz\n0.1,0,0,0,1,0,0,0,0,1,2,-3e4\n", 3, "fz",
       "force range"},
      {"frame going back", kFrameHead + "0.1,0,0,0,1,0,0,0,0,0,0,0,2\n0.2,0,0,0,1,0,0,0,0,0,0,0,1\n", 4,
       "frame", "must not decrease"},
  };
  for (const auto& c : cases) {
    CAPTURE(c.what);
    const InputError e = read_error(c.text);
    CHECK(e.file() == "bad.csv");
    CHECK(e.line() == c.line);
    CHECK(e.field() == c.field);
    CHECK(std::string(e.what()).find(c.message_part) != std::string::npos);
  }
}

TEST_CASE("pose log: a last line without its newline is torn: skipped with a warning, the rest kept") {
  // A recorder killed while writing a line leaves it without its newline, and possibly without
  // digits that still parse ("0.0123" cut to "0.01"): such a line is never taken as a sample.
  for (const std::string tail : {"0.003,0,0,0.1", "0.003,0,0,0,1,0,0,0,0", "# frames: 1"}) {
    CAPTURE(tail);
    std::istringstream in(kHead + "0.001,0,0,0,1,0,0,0,0\n0.002,0,0,0,1,0,0,0,0\n" + tail);
    PoseLogReader reader(in, "killed.csv");
    std::size_t n = 0;
    for (ToolSample s; reader.next(s);) ++n;
    CHECK(n == 2);
    CHECK(reader.torn_line() == 6);
    CHECK(reader.torn_warning() ==
          "killed.csv:6: the last line has no newline (a recording cut short while "
          "writing it); skipped");
    CHECK_FALSE(reader.metadata("frames").has_value());
  }
  std::istringstream whole(kHead + "0.001,0,0,0,1,0,0,0,0\n");
  PoseLogReader reader(whole, "whole.csv");
  for (ToolSample s; reader.next(s);) {
  }
  CHECK(reader.torn_line() == 0);
  CHECK(reader.torn_warning().empty());
}

TEST_CASE("pose log: the column of a bad field is reported") {
  const InputError e = read_error(kHead + "0.001,0,0,abc,1,0,0,0,0\n");
  CHECK(e.column() == 11);  // 1-based character column of "abc"
  CHECK(std::string(e.what()) == "bad.csv:4:11: z: 'abc' is not a number");
}

TEST_CASE("pose log: a missing file is an InputError naming it") {
  CHECK_THROWS_AS(PoseLogReader("/nonexistent/scalpelsim/log.csv"), InputError);
  // /dev/zero would be read forever, a folder reads as nothing.
  CHECK_THROWS_WITH_AS(PoseLogReader("/dev/zero"), doctest::Contains("/dev/zero: is not a regular file"),
                       InputError);
  CHECK_THROWS_WITH_AS(PoseLogReader("/tmp"), doctest::Contains("is a folder"), InputError);
}

TEST_CASE("pose log: the writer refuses samples the reader would reject") {
  std::stringstream buffer;
  PoseLogWriter writer(buffer, "memory", {});
  ToolSample s;
  s.t = 1.0;
  writer.write(s);
  CHECK_THROWS_AS(writer.write(s), std::invalid_argument);  // same t
  s.t = 2.0;
  s.orientation = Eigen::Quaterniond(1.0, 0.1, 0.0, 0.0);
  CHECK_THROWS_AS(writer.write(s), std::invalid_argument);  // not unit
  s.orientation = Eigen::Quaterniond::Identity();
  s.position.x() = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(writer.write(s), std::invalid_argument);
  s.position.x() = 1e300;
  CHECK_THROWS_AS(writer.write(s), std::invalid_argument);  // beyond 100 m
  s.position.x() = 0.0;
  s.t = 1.0 + 1e-9;
  CHECK_THROWS_AS(writer.write(s), std::invalid_argument);  // under a microsecond after the last
  CHECK(writer.samples_written() == 1);
  std::stringstream bad_meta;
  CHECK_THROWS_AS(PoseLogWriter(bad_meta, "memory", {{"a:b", "c"}}), std::invalid_argument);
  CHECK_THROWS_AS(PoseLogWriter(bad_meta, "memory", {{"key", "two\nlines"}}), std::invalid_argument);
}
