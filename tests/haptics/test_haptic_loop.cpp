#include <doctest/doctest.h>

#include <atomic>
#include <cmath>
#include <thread>
#include <vector>

#include "devices/mock_device.hpp"
#include "haptics/haptic_loop.hpp"

using namespace scalpel;

namespace {

// A smooth, curved stroke sampled at an odd period, so replay interpolates.
std::vector<ToolSample> stroke(double duration, double period = 0.00037) {
  std::vector<ToolSample> log;
  for (int k = 0; k * period <= duration; ++k) {
    ToolSample s;
    s.t = k * period;
    s.position = Eigen::Vector3d(0.05 * std::sin(3.0 * s.t), 0.02 - 0.01 * s.t, 0.05 * std::cos(2.0 * s.t));
    s.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * s.t, Eigen::Vector3d::UnitY()));
    s.buttons = (k / 100) % 2;
    log.push_back(s);
  }
  return log;
}

ForceModel touching_model(std::uint64_t seq) {
  ForceModel m;
  m.sequence = seq;
  m.coupling_stiffness = 100.0;
  m.coupling_damping = 0.5;
  m.constrained_position = Eigen::Vector3d(0.0, 0.02, 0.0);
  m.contact = true;
  m.contact_offset = 0.015;
  m.contact_stiffness = 400.0;
  return m;
}

// A device reporting a fixed pose with a scripted status, recording the forces it is sent.
struct SpyDevice final : Device {
  DeviceStatus status = DeviceStatus::Ok;
  std::vector<Eigen::Vector3d> forces;
  DeviceStatus read(double t, ToolSample& out) noexcept override {
    out.t = t;
    out.position = Eigen::Vector3d(0.0, 0.0, 0.0);
    return status;
  }
  void write_force(const Eigen::Vector3d& f) noexcept override { forces.push_back(f); }
  double max_force() const override { return 4.0; }
  double max_force_rate() const override { return 1e6; }
};

std::vector<ToolSample> drain(ToolQueue& q) {
  std::vector<ToolSample> out;
  ToolSample s;
  while (q.pop(s)) out.push_back(s);
  return out;
}

bool same(const ToolSample& a, const ToolSample& b) {
  return a.t == b.t && a.position == b.position && a.orientation.coeffs() == b.orientation.coeffs() &&
         a.buttons == b.buttons && a.force == b.force;
}

// The replay pattern: rate / visual_rate haptic cycles, then one simulation frame, in one thread.
std::vector<ToolSample> replay(const std::vector<ToolSample>& log, std::size_t frames) {
  MockDevice device(log);
  ToolQueue queue(64);
  ForceChannel forces;
  HapticLoop loop(device, queue, forces, {.max_force = 3.0, .max_force_rate = 500.0});
  std::vector<ToolSample> got;
  for (std::size_t f = 0; f < frames; ++f) {
    std::size_t left = 1000 / 60 + (f % 3 == 0 ? 1 : 0);
    while (left > 0) {
      left -= loop.run_cycles(left);
      for (const ToolSample& s : drain(queue)) got.push_back(s);
    }
    forces.publish(touching_model(f + 1));  // the frame's result
  }
  return got;
}

}  // namespace

TEST_CASE("the virtual clock runs cycles at exact times and replays bit for bit") {
  const std::vector<ToolSample> log = stroke(1.0);
  const std::vector<ToolSample> a = replay(log, 30), b = replay(log, 30);
  REQUIRE(a.size() == 10 * (1000 / 60 + 1) + 20 * (1000 / 60));
  REQUIRE(a.size() == b.size());
  bool identical = true, forces = false;
  for (std::size_t k = 0; k < a.size(); ++k) {
    identical &= same(a[k], b[k]);
    identical &= a[k].t == static_cast<double>(k) / 1000.0;
    forces |= !a[k].force.isZero();
  }
  CHECK(identical);
  CHECK(forces);
}

TEST_CASE("on the virtual clock a full queue stops the loop and no sample is lost") {
  MockDevice device(stroke(0.5));
  ToolQueue queue(8);
  ForceChannel forces;
  HapticLoop loop(device, queue, forces);
  std::vector<ToolSample> got;
  std::size_t cycles = 0, short_runs = 0;
  while (cycles < 300) {
    const std::size_t ran = loop.run_cycles(300 - cycles);
    short_runs += ran < 300 - cycles;
    cycles += ran;
    for (const ToolSample& s : drain(queue)) got.push_back(s);
  }
  CHECK(short_runs > 0);
  CHECK(loop.stats().merged_samples == 0);
  // Every cycle's sample arrives once, in order (the last one may still be held).
  REQUIRE(got.size() >= 299);
  for (std::size_t k = 0; k < got.size(); ++k) CHECK(got[k].t == static_cast<double>(k) / 1000.0);
}

TEST_CASE("merging on a full queue keeps the newest pose and counts what it merged") {
  MockDevice device(stroke(0.5));
  ToolQueue queue(4);
  ForceChannel forces;
  HapticLoop loop(device, queue, forces);
  CHECK(loop.run_cycles(100, HapticLoop::OnFullQueue::Merge) == 100);
  std::vector<ToolSample> got = drain(queue);
  const std::size_t cap = got.size();
  CHECK(cap >= 4);
  CHECK(loop.run_cycles(1, HapticLoop::OnFullQueue::Merge) == 1);  // pushes the held, then cycle 100
  got = drain(queue);
  REQUIRE(got.size() == 2);
  CHECK(got[0].t == 99.0 / 1000.0);  // the held sample: the newest pose when the queue had room again
  CHECK(got[1].t == 100.0 / 1000.0);
  const HapticStats st = loop.stats();
  CHECK(st.merged_samples == 100 - cap - 1);  // every cycle that found the queue full, but the held one
  CHECK(st.merged_sweeps == 1);
  CHECK(st.samples_pushed == cap + 2);
}

TEST_CASE("the force goes to zero when the simulation stalls and on a device fault") {
  SpyDevice device;
  ToolQueue queue(4096);
  ForceChannel forces;
  HapticLoop loop(device, queue, forces, {.stall_timeout = 0.0505});
  ForceModel m;
  m.sequence = 1;
  m.coupling_stiffness = 100.0;
  m.constrained_position = Eigen::Vector3d(0.01, 0, 0);
  (void)loop.run_cycles(5);
  CHECK(device.forces.back().isZero());  // nothing published yet
  forces.publish(m);
  (void)loop.run_cycles(1);
  CHECK(device.forces.back().isApprox(Eigen::Vector3d(1.0, 0, 0)));
  (void)loop.run_cycles(50);
  CHECK(device.forces.back().isApprox(Eigen::Vector3d(1.0, 0, 0)));  // 50 ms: not yet stalled
  (void)loop.run_cycles(1);
  CHECK(device.forces.back().isZero());
  CHECK(loop.stats().stalls == 1);
  m.sequence = 2;
  forces.publish(m);
  (void)loop.run_cycles(1);
  CHECK(device.forces.back().isApprox(Eigen::Vector3d(1.0, 0, 0)));
  // Publishing the same model again is not a sign of life.
  forces.publish(m);
  (void)loop.run_cycles(60);
  CHECK(device.forces.back().isZero());
  CHECK(loop.stats().stalls == 2);

  m.sequence = 3;
  forces.publish(m);
  device.status = DeviceStatus::Fault;
  const std::uint64_t pushed = loop.stats().samples_pushed;
  (void)loop.run_cycles(3);
  CHECK(device.forces.back().isZero());
  CHECK(loop.stats().samples_pushed == pushed);  // a frozen tool adds no sweep
  CHECK(loop.stats().device_not_ok == 3);
}

// Under ThreadSanitizer (cmake --preset tsan) this checks the queue and the force channel.
TEST_CASE("a 1 kHz haptic thread and a stalling simulation thread share the queue and force channel") {
  MockDevice device(stroke(30.0, 0.001));
  ToolQueue queue(16);
  ForceChannel forces;
  HapticLoop loop(
      device, queue, forces,
      {.max_force = 3.0, .max_force_rate = 1000.0, .stall_timeout = 0.02, .realtime_priority = false});
  std::vector<ToolSample> got;
  got.reserve(100000);
  std::thread sim([&] {
    ToolSample s;
    std::uint64_t seq = 0;
    const auto frame = [&] {
      while (queue.pop(s)) got.push_back(s);
      forces.publish(touching_model(++seq));
    };
    while (got.size() < 50) frame();
    // Stall: neither drain nor publish until the haptic thread has merged and cut the force.
    while (loop.stats().merged_samples < 30 || loop.stats().stalls < 1) std::this_thread::yield();
    const std::size_t before = got.size();
    while (got.size() < before + 50) frame();
  });
  loop.start();
  sim.join();
  loop.stop();
  ToolSample s;
  while (queue.pop(s)) got.push_back(s);
  const HapticStats st = loop.stats();
  CHECK(st.samples_pushed == got.size());
  CHECK(st.merged_samples >= 30);
  CHECK(st.merged_sweeps >= 1);
  CHECK(st.stalls >= 1);
  bool ordered = true;
  for (std::size_t k = 1; k < got.size(); ++k) ordered &= got[k].t > got[k - 1].t;
  CHECK(ordered);
  // The merged sweep shows as a gap in the sample times: many cycles, though on a loaded machine the
  // merges may spread over more than one sweep.
  double widest = 0.0;
  for (std::size_t k = 1; k < got.size(); ++k) widest = std::max(widest, got[k].t - got[k - 1].t);
  CHECK(widest > 0.01);
}

TEST_CASE("the tool queue holds exactly its capacity and keeps order") {
  ToolQueue q(3);
  CHECK(q.capacity() == 3);
  ToolSample s;
  for (int k = 0; k < 3; ++k) {
    s.t = k;
    CHECK(q.push(s));
  }
  CHECK_FALSE(q.push(s));
  CHECK(q.rejected() == 1);
  CHECK(q.size_approx() == 3);
  for (int k = 0; k < 3; ++k) {
    REQUIRE(q.pop(s));
    CHECK(s.t == k);
  }
  CHECK_FALSE(q.pop(s));
  for (int k = 0; k < 10; ++k) {  // wraps around
    s.t = 10 + k;
    REQUIRE(q.push(s));
    REQUIRE(q.pop(s));
    CHECK(s.t == 10 + k);
  }
}
