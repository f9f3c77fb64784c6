#include <doctest/doctest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "devices/mock_device.hpp"
#include "haptics/recorder.hpp"
#include "tests/haptics/csv_log.hpp"

using namespace scalpel;

namespace {

std::vector<ToolSample> stroke(double duration, double period) {
  std::vector<ToolSample> log;
  for (int k = 0; k * period <= duration; ++k) {
    ToolSample s;
    s.t = k * period;
    s.position = Eigen::Vector3d(0.04 * std::sin(5.0 * s.t), 0.016 + 0.004 * std::cos(7.0 * s.t), 0.01 * s.t);
    s.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.5 * s.t, Eigen::Vector3d(0.6, 0.0, 0.8)));
    s.buttons = k % 300 < 150 ? 1u : 0u;
    log.push_back(s);
  }
  return log;
}

ForceModel contact_model() {
  ForceModel m;
  m.sequence = 1;
  m.coupling_stiffness = 150.0;
  m.coupling_damping = 0.8;
  m.constrained_position = Eigen::Vector3d(0.0, 0.015, 0.0);
  m.contact = true;
  m.contact_offset = 0.015;
  m.contact_stiffness = 300.0;
  m.cutting_resistance = 0.7;
  return m;
}

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("scalpel_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

RecordingOptions virtual_options(double duration) {
  RecordingOptions o;
  o.virtual_clock = true;
  o.duration = duration;
  o.flush_interval = 0.05;
  o.queue_capacity = 64;
  o.loop.max_force = 3.0;
  o.loop.max_force_rate = 800.0;
  o.loop.stall_timeout = 10.0;  // one model for the whole session
  return o;
}

}  // namespace

TEST_CASE("a recorded session replays to the same samples exactly") {
  const std::string path = temp_path("record.csv");
  const std::atomic<bool> stop{false};
  RecordingResult rec;
  {
    MockDevice source(stroke(0.8, 0.00043));  // an odd period: the recording interpolates
    ForceChannel forces;
    forces.publish(contact_model());
    test::CsvLogSink sink(path);
    rec = record_session(
        source, forces, virtual_options(0.5), [&](const ToolSample& s) { sink.write(s); },
        [&] { sink.flush(); }, stop);
  }
  CHECK(rec.samples == 500);
  CHECK(rec.flushes == 11);  // every 50 ms, and at the end
  const std::vector<ToolSample> recorded = test::read_csv_log(path);
  REQUIRE(recorded.size() == 500);
  bool any_force = false;
  for (const ToolSample& s : recorded) any_force |= !s.force.isZero();
  CHECK(any_force);

  // Replay: the log drives the same loop on the virtual clock.
  std::vector<ToolSample> replayed;
  MockDevice player(recorded);
  ForceChannel forces;
  forces.publish(contact_model());
  const RecordingResult rep = record_session(
      player, forces, virtual_options(0.0), [&](const ToolSample& s) { replayed.push_back(s); }, [] {}, stop);
  CHECK(rep.samples == replayed.size());
  REQUIRE(replayed.size() == recorded.size());
  std::size_t mismatches = 0;
  for (std::size_t k = 0; k < recorded.size(); ++k) {
    const ToolSample &a = recorded[k], &b = replayed[k];
    mismatches +=
        !(a.t == b.t && a.position == b.position && a.orientation.coeffs() == b.orientation.coeffs() &&
          a.buttons == b.buttons && a.force == b.force);
  }
  CHECK(mismatches == 0);
  std::filesystem::remove(path);
}

TEST_CASE("a recorder killed mid-session leaves a log readable up to its last flush") {
  const std::string path = temp_path("killed.csv");
  int pipe_fd[2];
  REQUIRE(::pipe(pipe_fd) == 0);
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    // Records in real time, tells the parent after every flush, and is killed before it ends.
    ::close(pipe_fd[0]);
    MockDevice device(stroke(120.0, 0.001));
    ForceChannel forces;
    forces.publish(contact_model());
    test::CsvLogSink sink(path);
    RecordingOptions o;
    o.duration = 120.0;
    o.flush_interval = 0.01;
    o.loop.realtime_priority = false;
    o.loop.max_force = 3.0;
    o.loop.max_force_rate = 800.0;
    o.loop.stall_timeout = 1e9;
    const std::atomic<bool> stop{false};
    (void)record_session(
        device, forces, o, [&](const ToolSample& s) { sink.write(s); },
        [&] {
          sink.flush();
          const char c = 'f';
          if (::write(pipe_fd[1], &c, 1) != 1) ::_exit(3);
        },
        stop);
    ::_exit(2);  // not reached within the test
  }
  ::close(pipe_fd[1]);
  char c = 0;
  int flushes = 0;
  while (flushes < 5 && ::read(pipe_fd[0], &c, 1) == 1) ++flushes;
  REQUIRE(flushes == 5);
  REQUIRE(::kill(child, SIGKILL) == 0);
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  ::close(pipe_fd[0]);
  CHECK(WIFSIGNALED(status));
  CHECK(WTERMSIG(status) == SIGKILL);

  std::vector<ToolSample> log;
  CHECK_NOTHROW(log = test::read_csv_log(path));
  CHECK(log.size() >= 5);  // at least one sample per flush interval of 10 ms
  for (const ToolSample& s : log) CHECK(is_valid(s));
  std::filesystem::remove(path);
}
