// A live session (sim/session.hpp): the haptic loop on the real clock, the simulation in its own
// thread, frames published for a renderer; its recording replays headless to the same mesh.
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <tuple>

#include "base/input_error.hpp"
#include "devices/playback_device.hpp"
#include "devices/pose_log.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"
#include "sim/session.hpp"
#include "sim/simulation.hpp"

using namespace scalpel;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

Scenario bundled() {
  return load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/skin_incision.yaml");
}

// Takes the session's frames until `done` holds for one, or the limit passes; false then.
template <class Done>
bool watch(Session& session, Done done, double limit_seconds = 600.0) {
  const auto until = Clock::now() + std::chrono::duration<double>(limit_seconds);
  while (Clock::now() < until && !session.failed()) {
    if (session.update() && done(session.frame())) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));  // a renderer's pace; nothing waits on it
  }
  return false;
}

// Starts `session` and stops it in the middle of the incision, while the device still sends poses;
// false when it did not get there.
bool run_into_incision(Session& session) {
  session.update();
  const std::size_t uncut = session.frame().snapshot.tetrahedra;
  session.start();
  const bool cutting =
      watch(session, [&](const SessionFrame& f) { return f.snapshot.tetrahedra > uncut + 300; });
  session.stop();
  return cutting;
}

// An empty folder of that name in the temporary directory.
fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

}  // namespace

TEST_CASE("a live session's recording replays headless to the same mesh, bit for bit" *
          doctest::test_suite("slow")) {
  const Scenario scenario = bundled();
  const fs::path dir = fresh_dir("scalpelsim_test_session");
  PlaybackDevice device(read_pose_log(scenario.log->string()));  // at real speed
  SessionOptions options;
  options.record = dir / "session.csv";
  options.device_name = "playback";
  Session session(scenario, device, &device, options);
  session.update();
  REQUIRE(session.frame().snapshot.wound_vertices == 0);
  const bool cutting = run_into_incision(session);
  INFO(session.error());
  REQUIRE(cutting);
  REQUIRE_FALSE(session.failed());
  REQUIRE(session.recordings().size() == 1);
  const Simulation& live = session.simulation();

  // The recording: every sample the simulation took, marked for verbatim playback, and the number
  // of frames the session ran.
  PoseLogReader reader(session.recordings()[0].string());
  CHECK(reader.metadata("playback") == "verbatim");
  CHECK(reader.has_force());
  CHECK(reader.has_frame());
  std::size_t samples = 0;
  for (ToolSample s; reader.next(s);) ++samples;
  CHECK(samples == live.samples());
  CHECK(reader.metadata("frames") == std::to_string(live.tissue_steps().size()));

  bool replayed = false;
  std::vector<Vec3> positions;
  std::size_t tets = 0, nodes = 0;
  ReplayOptions ro;
  ro.out_dir = dir / "replay";
  ro.on_frame = [&](const Simulation& sim, std::size_t, bool last) {
    if (!last) return;
    replayed = true;
    positions = sim.mesh().positions();
    tets = sim.mesh().tet_count();
    nodes = sim.mesh().node_count();
  };
  const ReplayResult r = replay(scenario, session.recordings()[0], ro);
  REQUIRE(replayed);
  CHECK(r.report["replay"]["samples"].get<std::size_t>() == live.samples());
  CHECK(tets == live.mesh().tet_count());
  CHECK(nodes == live.mesh().node_count());
  REQUIRE(positions.size() == live.mesh().positions().size());
  std::size_t differing = 0;
  for (std::size_t i = 0; i < positions.size(); ++i)
    differing += positions[i] != live.mesh().positions()[i] ? 1 : 0;
  CHECK(differing == 0);
  CHECK(r.report["replay"]["frames"].get<std::size_t>() == live.tissue_steps().size());
}

namespace {

// The playback device, as one that takes force, keeping every force the haptic loop sends it with the time of
// the sample it answered: what the hand was given. Its store is reserved beforehand: the haptic thread never
// allocates.
class ForceTap final : public Device {
 public:
  struct Sent {
    double t;
    Vec3 position;
    Vec3 force;
  };
  ForceTap(PlaybackDevice& inner, std::size_t capacity) : inner_(inner) { sent_.reserve(capacity); }
  DeviceStatus read(double t, ToolSample& out) noexcept override {
    const DeviceStatus status = inner_.read(t, out);
    read_ = out;
    return status;
  }
  void write_force(const Eigen::Vector3d& force) noexcept override {
    if (sent_.size() < sent_.capacity()) sent_.push_back({read_.t, read_.position, force});
  }
  [[nodiscard]] DeviceCounters counters() const override { return inner_.counters(); }
  // A device with motors, as the generic stylus profile's.
  [[nodiscard]] double max_force() const override { return 3.3; }
  [[nodiscard]] double max_force_rate() const override { return 2000.0; }
  // After the session has stopped.
  [[nodiscard]] const std::vector<Sent>& sent() const { return sent_; }

 private:
  PlaybackDevice& inner_;
  ToolSample read_;
  std::vector<Sent> sent_;
};

}  // namespace

TEST_CASE(
    "a live session's recording holds, for each sample, the force the haptic loop sent the device at "
    "that cycle" *
    doctest::test_suite("slow")) {
  const Scenario scenario = bundled();
  const fs::path dir = fresh_dir("scalpelsim_test_session_forces");
  PlaybackDevice playback(read_pose_log(scenario.log->string()));
  ForceTap tap(playback, 1000 * 600);  // 1 kHz for as long as watch() waits
  SessionOptions options;
  options.record = dir / "forces.csv";
  options.device_name = "playback";
  Session session(scenario, tap, &playback, options);
  const bool cutting = run_into_incision(session);
  INFO(session.error());
  REQUIRE(cutting);
  REQUIRE(session.recordings().size() == 1);
  const std::vector<ForceTap::Sent>& sent = tap.sent();
  REQUIRE(!sent.empty());

  // Every recorded sample is one the device answered, with the force it was sent then, to the bit;
  // the hand was pushed (the blade pressed the skin and cut). The recording's times are session
  // times, from the first sample the simulation took: the device's less a constant, without pauses.
  PoseLogReader reader(session.recordings()[0].string());
  REQUIRE(reader.has_force());
  std::size_t samples = 0, pushed = 0, missing = 0, differing = 0;
  double origin = 0;
  auto at = sent.begin();
  for (ToolSample s; reader.next(s);) {
    if (samples++ == 0) {
      at = std::find_if(sent.begin(), sent.end(),
                        [&](const ForceTap::Sent& e) { return e.position == s.position; });
      REQUIRE(at != sent.end());
      origin = at->t - s.t;
    }
    // The cycle that answered at that time with that pose (on the real clock two cycles may come
    // close together).
    at = std::find_if(at, sent.end(), [&](const ForceTap::Sent& e) { return e.t > s.t + origin - 1e-4; });
    while (at != sent.end() && at->position != s.position && at->t < s.t + origin + 1e-4) ++at;
    if (at == sent.end() || std::abs(at->t - (s.t + origin)) > 1e-4 || at->position != s.position) {
      ++missing;
      continue;
    }
    differing += at->force != s.force ? 1 : 0;
    pushed += s.force.norm() > 0.1 ? 1 : 0;
  }
  CHECK(samples == session.simulation().samples());
  CHECK(missing == 0);
  CHECK(differing == 0);
#if defined(__SANITIZE_THREAD__)
  (void)pushed;  // a frame outlasts the loop's stall timeout (0.1 s): the force goes to zero
#else
  CHECK(pushed > 100);
#endif
}

TEST_CASE("a paused session stands still, and a reset starts a new attempt with its own recording" *
          doctest::test_suite("slow")) {
  // Played at four times its speed the incision outruns a simulation that falls far behind (under
  // ThreadSanitizer), and the press would decide when the first cut comes; this test is of the pause
  // and the reset: the blade cuts on touch.
  Scenario scenario = bundled();
  scenario.tool.contact = ToolContactKind::None;
  const fs::path dir = fresh_dir("scalpelsim_test_session_reset");
  PlaybackDevice device(read_pose_log(scenario.log->string()));
  device.set_speed(4.0);
  SessionOptions options;
  options.record = dir / "attempt.csv";
  Session session(scenario, device, &device, options);
  session.update();
  const std::size_t uncut = session.frame().snapshot.tetrahedra;
  session.start();
  const bool cut = watch(session, [&](const SessionFrame& f) { return f.snapshot.tetrahedra > uncut; });
  INFO(session.error());
  REQUIRE(cut);

  session.set_paused(true);
  REQUIRE(watch(session, [](const SessionFrame& f) { return f.status.paused; }));
  const double paused_at = session.frame().status.time;
  const std::size_t tets = session.frame().snapshot.tetrahedra;
  // Some frames later (published while paused) nothing has moved.
  int frames = 0;
  REQUIRE(watch(session, [&](const SessionFrame&) { return ++frames == 10; }));
  CHECK(session.frame().status.time == paused_at);
  CHECK(session.frame().snapshot.tetrahedra == tets);
  CHECK(device.paused());

  session.set_paused(false);
  session.request_reset();
  REQUIRE(watch(session,
                [&](const SessionFrame& f) { return !f.status.paused && f.snapshot.tetrahedra == uncut; }));
  REQUIRE(watch(session, [&](const SessionFrame& f) { return f.status.time > 0.1; }));
  session.stop();
  REQUIRE_FALSE(session.failed());
  const auto files = session.recordings();
  REQUIRE(files.size() == 2);
  CHECK(files[1] == dir / "attempt.2.csv");
  for (const fs::path& f : files) CHECK(!read_pose_log(f.string()).empty());  // both complete and valid
}

TEST_CASE("a verbatim log without the frame column, or with an unknown playback, is refused by name") {
  const Scenario scenario = bundled();
  const fs::path dir = fresh_dir("scalpelsim_test_session_bad");
  const auto write = [&](const std::string& name, const std::string& playback) {
    PoseLogWriter w((dir / name).string(), {{"playback", playback}}, true);
    ToolSample s;
    s.t = 0.001;
    w.write(s);
    w.flush();
    return dir / name;
  };
  ReplayOptions ro;
  ro.out_dir = dir / "out";
  for (const auto& [name, playback, problem] : {std::tuple{"no_frames.csv", "verbatim", "frame column"},
                                                std::tuple{"unknown.csv", "sometimes", "sometimes"}}) {
    CAPTURE(name);
    try {
      (void)replay(scenario, write(name, playback), ro);
      FAIL("no error");
    } catch (const InputError& e) {
      CHECK(e.field() == "playback");
      CHECK(std::string(e.what()).find(name) != std::string::npos);
      CHECK(std::string(e.what()).find(problem) != std::string::npos);
    }
  }
}

namespace {

// A hand that keeps moving along x at 5 cm/s, 2 cm above the skin, whatever the session does.
class MovingHand final : public Device {
 public:
  DeviceStatus read(double t, ToolSample& out) noexcept override {
    out = ToolSample{};
    out.t = t;
    out.position = Vec3(0.05 * t - 0.01, 0.0, 0.02);
    return DeviceStatus::Ok;
  }
  [[nodiscard]] DeviceCounters counters() const override { return {}; }
};

}  // namespace

TEST_CASE("a tool moved during a pause resumes where it stood: no jump for the cutter" *
          doctest::test_suite("slow")) {
  const Scenario scenario = bundled();
  const fs::path dir = fresh_dir("scalpelsim_test_session_clutch");
  MovingHand hand;
  SessionOptions options;
  options.record = dir / "clutch.csv";
  Session session(scenario, hand, nullptr, options);
  session.start();
  REQUIRE(watch(session, [](const SessionFrame& f) { return f.status.time >= 0.1; }));
  session.set_paused(true);
  REQUIRE(watch(session, [](const SessionFrame& f) { return f.status.paused; }));
  // The hand moves on for a while (5 mm in 0.1 s) while the simulation stands still.
  const auto until = Clock::now() + std::chrono::milliseconds(100);
  REQUIRE(watch(session, [&](const SessionFrame&) { return Clock::now() >= until; }));
  const double paused_at = session.frame().status.time;
  session.set_paused(false);
  REQUIRE(watch(session, [&](const SessionFrame& f) { return f.status.time >= paused_at + 0.1; }));
  session.stop();
  REQUIRE_FALSE(session.failed());
  // Consecutive samples the simulation took are never farther apart than the hand moved between
  // them, across the pause too (where session time goes on by one haptic period). A loaded machine
  // can delay a haptic cycle by milliseconds: the hand's motion over that gap is no jump.
  const std::vector<ToolSample> log = read_pose_log(session.recordings().at(0).string());
  REQUIRE(log.size() > 100);
  double largest = 0.0, beyond_hand = 0.0;
  for (std::size_t i = 1; i < log.size(); ++i) {
    const double step = (log[i].position - log[i - 1].position).norm();
    largest = std::max(largest, step);
    beyond_hand = std::max(beyond_hand, step - 0.05 * (log[i].t - log[i - 1].t));
  }
  MESSAGE("largest step between samples " << largest * 1e3 << " mm over " << log.size() << " samples");
  CHECK(beyond_hand < 1e-6);  // [m] the log's rounding; the pause alone is 5 mm
}

TEST_CASE("the trainee's moves of pieces go through the session, into its recording, and replay bit for bit" *
          doctest::test_suite("slow")) {
  // The bracket's V-notch, without the scenario's own moves: the trainee moves the freed wedge,
  // takes the move back, and deletes it.
  Scenario scenario = load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/bracket_sculpt.yaml");
  scenario.moves.clear();
  const fs::path dir = fresh_dir("scalpelsim_test_session_pieces");
  PlaybackDevice device(read_pose_log(scenario.log->string()));
  device.set_speed(4.0);
  SessionOptions options;
  options.record = dir / "session.csv";
  options.device_name = "playback";
  Session session(scenario, device, &device, options);
  session.update();
  REQUIRE(session.frame().snapshot.pieces.size() == 1);
  session.start();
  // The knife is out of the part from about 12.3 s of the log.
  REQUIRE(watch(session, [](const SessionFrame& f) { return f.status.time > 12.45; }));
  REQUIRE(session.frame().snapshot.pieces.size() == 2);
  PieceMove move;
  move.point = Vec3(0.048, 0.012, 0.005);
  move.translation = Vec3(0.010, 0.0, 0.006);
  move.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(-0.4, Vec3::UnitY()));
  REQUIRE(session.request_piece(move));
  REQUIRE(watch(session, [](const SessionFrame& f) { return f.status.pieces_taken == 1; }));
  PieceMove undo;
  undo.action = PieceAction::Undo;
  REQUIRE(session.request_piece(undo));
  PieceMove remove;
  remove.action = PieceAction::Delete;
  remove.point = move.point;  // back where it was
  REQUIRE(session.request_piece(remove));
  REQUIRE(watch(session, [](const SessionFrame& f) { return f.status.pieces_taken == 3; }));
  // One more frame for the recording's trailer, then stop.
  REQUIRE(watch(session, [](const SessionFrame& f) { return f.snapshot.pieces.size() == 1; }));
  session.stop();
  INFO(session.error());
  REQUIRE_FALSE(session.failed());
  const Simulation& live = session.simulation();
  REQUIRE(live.moves().size() == 3);
  for (const Simulation::MoveRecord& m : live.moves()) CHECK(m.refused == "");
  CHECK(live.moves()[2].action == PieceAction::Delete);
  CHECK(live.deleted_volume() == doctest::Approx(360e-9).epsilon(1e-7));

  // In the recording: three piece events among the samples.
  PoseLogReader reader(session.recordings()[0].string());
  for (ToolSample s; reader.next(s);) {
  }
  std::size_t events = 0;
  for (const auto& [key, value] : reader.metadata()) events += key == "piece" ? 1 : 0;
  CHECK(events == 3);

  std::vector<Vec3> positions;
  std::size_t tets = 0;
  ReplayOptions ro;
  ro.out_dir = dir / "replay";
  ro.on_frame = [&](const Simulation& sim, std::size_t, bool last) {
    if (!last) return;
    positions = sim.mesh().positions();
    tets = sim.mesh().tet_count();
  };
  const ReplayResult r = replay(scenario, session.recordings()[0], ro);
  CHECK(r.invariants_ok);
  CHECK(tets == live.mesh().tet_count());
  REQUIRE(positions.size() == live.mesh().positions().size());
  std::size_t differing = 0;
  for (const NodeId n : live.mesh().nodes())
    differing += positions[n.index] != live.mesh().position(n) ? 1 : 0;
  CHECK(differing == 0);
  REQUIRE(r.report["piece_moves"].size() == 3);
  CHECK(r.report["piece_moves"][2]["kind"] == "delete");
  CHECK(r.report["piece_moves"][0]["time"].get<double>() == live.moves()[0].time);
}
