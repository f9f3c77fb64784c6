#include "devices/report_device.hpp"

#include <algorithm>
#include <cmath>

namespace scalpel {

namespace {

bool inside(const Eigen::Vector3d& p, const DeviceProfile& prof) {
  return (p.array() >= prof.workspace_min.array()).all() && (p.array() <= prof.workspace_max.array()).all();
}

}  // namespace

ReportDevice::ReportDevice(DeviceProfile profile, std::unique_ptr<ReportTransport> transport)
    : profile_(std::move(profile)), transport_(std::move(transport)), position_(profile_.home) {
  for (const ReportLayout& r : profile_.input_reports)
    for (const ReportField& f : r.fields) has_orientation_ |= f.axis == Axis::QW;
  if (transport_->open()) state_.store(Connected, std::memory_order_release);
}

ReportDevice::~ReportDevice() {
  if (transport_) transport_->close();
}

void ReportDevice::maintain() {
  if (state_.load(std::memory_order_acquire) != Disconnected) return;
  transport_->close();
  if (transport_->open()) state_.store(Reopened, std::memory_order_release);
}

void ReportDevice::apply(const ReportValues& v) noexcept {
  for (std::size_t i = 0; i < axis_.size(); ++i)
    if (v.has[i]) axis_[i] = v.axis[i];
  buttons_ = (buttons_ & ~v.buttons_mask) | (v.buttons & v.buttons_mask);
  fresh_ = true;
  has_joints_ |= v.has[static_cast<std::size_t>(Axis::JA)];
}

void ReportDevice::update_pose(double t) noexcept {
  const auto ax = [&](Axis a) { return axis_[static_cast<std::size_t>(a)]; };
  const double dt = has_last_t_ ? std::clamp(t - last_t_, 0.0, kMaxRateStep) : 0.0;
  last_t_ = t;
  has_last_t_ = true;

  if (profile_.motion == Motion::Rate) {
    // Velocities [m/s] and world-frame angular velocities [rad/s] integrated over one step.
    const Eigen::Vector3d v(ax(Axis::X), ax(Axis::Y), ax(Axis::Z));
    const Eigen::Vector3d w(ax(Axis::RX), ax(Axis::RY), ax(Axis::RZ));
    if (!v.allFinite() || !w.allFinite()) {
      AtomicDeviceCounters::bump(counters_.rejected_poses);
      return;
    }
    const Eigen::Vector3d p =
        (position_ + v * dt).cwiseMax(profile_.workspace_min).cwiseMin(profile_.workspace_max);
    Eigen::Quaterniond q = orientation_;
    const double angle = w.norm() * dt;
    if (angle > 0.0) q = (Eigen::Quaterniond(Eigen::AngleAxisd(angle, w.normalized())) * q).normalized();
    position_ = p;
    orientation_ = q;
    return;
  }

  if (!fresh_) return;
  fresh_ = false;
  // A linkage device's pose is where its arm puts the tip (devices/linkage.hpp).
  const Eigen::Vector3d raw_p = profile_.linkage ? profile_.linkage->position(joints())
                                                 : Eigen::Vector3d(ax(Axis::X), ax(Axis::Y), ax(Axis::Z));
  Eigen::Quaterniond raw_q = Eigen::Quaterniond::Identity();
  if (has_orientation_) raw_q = Eigen::Quaterniond(ax(Axis::QW), ax(Axis::QX), ax(Axis::QY), ax(Axis::QZ));
  const double n = raw_q.norm();
  if (!raw_p.allFinite() || !std::isfinite(n) || std::abs(n - 1.0) > kUnitTolerance ||
      !inside(raw_p, profile_)) {
    AtomicDeviceCounters::bump(counters_.rejected_poses);
    return;
  }
  raw_q.normalize();
  if (reindex_) {
    // Clutch on re-plug: the first pose after it lands on the frozen one.
    offset_orientation_ = orientation_ * raw_q.conjugate();
    offset_position_ = position_ - raw_p;
    reindex_ = false;
  }
  position_ = raw_p + offset_position_;
  orientation_ = (offset_orientation_ * raw_q).normalized();
  has_pose_ = true;
}

DeviceStatus ReportDevice::read(double t, ToolSample& out) noexcept {
  int state = state_.load(std::memory_order_acquire);
  if (state == Reopened) {
    AtomicDeviceCounters::bump(counters_.reconnects);
    axis_.fill(0.0);  // rates from before the unplug are stale
    fresh_ = false;
    has_joints_ = false;
    reindex_ = profile_.motion != Motion::Rate && has_pose_;
    has_last_t_ = false;
    state = Connected;
    state_.store(Connected, std::memory_order_release);
  }
  DeviceStatus status = DeviceStatus::Ok;
  if (state == Connected) {
    for (int i = 0; i < kMaxReportsPerRead; ++i) {
      const int n = transport_->read(in_);
      if (n == 0) break;
      if (n < 0) {
        AtomicDeviceCounters::bump(counters_.disconnects);
        state_.store(Disconnected, std::memory_order_release);
        status = DeviceStatus::Disconnected;
        break;
      }
      ReportValues v;
      switch (
          parse_report(profile_, std::span<const std::uint8_t>(in_.data(), static_cast<std::size_t>(n)), v)) {
        case ParseResult::Ok:
          AtomicDeviceCounters::bump(counters_.reports);
          apply(v);
          break;
        case ParseResult::Short:
          AtomicDeviceCounters::bump(counters_.short_reports);
          break;
        case ParseResult::Malformed:
          AtomicDeviceCounters::bump(counters_.malformed_reports);
          break;
      }
    }
    if (status == DeviceStatus::Ok) update_pose(t);
  } else {
    status = DeviceStatus::Disconnected;
  }
  if (status != DeviceStatus::Ok) has_last_t_ = false;  // a frozen rate device does not integrate
  out.t = t;
  out.position = position_;
  out.orientation = orientation_;
  out.buttons = buttons_;
  return status;
}

void ReportDevice::write_force(const Eigen::Vector3d& force) noexcept {
  if (!profile_.output_report || state_.load(std::memory_order_acquire) != Connected) return;
  // Motor currents for an arm whose angles are not known yet would push it the wrong way: none.
  const Eigen::Vector3d f = profile_.linkage && !has_joints_ ? Eigen::Vector3d::Zero() : force;
  const std::size_t n = encode_force(profile_, f, joints(), out_);
  if (n > 0) (void)transport_->write(std::span<const std::uint8_t>(out_.data(), n));
}

}  // namespace scalpel
