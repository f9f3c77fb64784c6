// Device profiles: how the raw reports of a HID or USB device map to a tool pose, and how a force is
// written back. Profiles are YAML files in config/devices/ (one device family per file):
//
//   name: 3Dconnexion SpaceMouse            # shown by device enumeration
//   transport: hid                          # hid (hidapi) | usb (libusb, interrupt or bulk endpoints)
//   match: [{vendor_id: 0x256f, product_id: 0xc62e}, ...]
//   motion: rate                            # rate: axes are velocities integrated into a pose
//                                           # absolute: axes are the pose itself
//                                           # linkage: axes are the joint angles of an arm
//   workspace: {min: [x, y, z], max: [x, y, z]}   # [m] poses outside are rejected
//   home: [x, y, z]                         # [m] start pose of a rate device (default: centre)
//   input_reports:                          # one layout per report id
//     - id: 1                               # omit for devices without numbered reports
//       length: 13                          # [bytes] including the id byte
//       fields:
//         - {axis: x, offset: 1, type: i16le, scale: 2.9e-4, deadband: 4}
//   output_report: {id: 5, length: 7, fields: [{axis: fx, offset: 1, type: i16le, scale: 1e-3}]}
//   max_force: 3.0                          # [N]
//   max_force_rate: 2000                    # [N/s]
//   usb: {interface: 0, in_endpoint: 0x81, out_endpoint: 0x01, transfer: interrupt}   # usb only
//   linkage:                                # linkage only (devices/linkage.hpp)
//     lengths: [0.08, 0.205, 0.245]         # [m] base, arm, forearm
//     origin: [0.22, 0, 0.08]               # [m] taken off the tip's position
//     ratio: [0.0625, 0.0833, 0.0833]       # joint turn per motor turn, signed
//     torque_constant: [0.0259, 0.0259, 0.0259]   # [N m / A]
//     max_current: 3.0                      # [A]
//
// Axes: x y z (position [m] or velocity [m/s]), rx ry rz (angular velocity [rad/s], rate devices),
// qw qx qy qz (orientation quaternion, absolute devices), ja jb jc (joint angles [rad], linkage
// devices), buttons (bitmask, shifted left by `shift`); output axes fx fy fz [N], or ia ib ic (motor
// currents [A], linkage devices). Value = raw * scale (scale may be negative: it is the axis mapping);
// for output fields raw = round(value / scale) (a force, or a linkage device's motor current),
// saturated to the type's range.
// Types: u8 i8 u16le i16le u16be i16be u32le i32le f32le.
// Fields of a report do not share bytes; an axis comes from one field of one input report (buttons
// from several, each its own bits of the 32-bit mask); keys are names, each given once.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "devices/linkage.hpp"

namespace scalpel {

enum class FieldType : std::uint8_t { U8, I8, U16LE, I16LE, U16BE, I16BE, U32LE, I32LE, F32LE };
enum class Axis : std::uint8_t {
  X,
  Y,
  Z,
  RX,
  RY,
  RZ,
  QW,
  QX,
  QY,
  QZ,
  JA,
  JB,
  JC,
  Buttons,
  FX,
  FY,
  FZ,
  IA,
  IB,
  IC
};
// The axes that carry a value (X..JC), indexing ReportValues::axis.
inline constexpr std::size_t kValueAxes = 13;
enum class Motion : std::uint8_t { Rate, Absolute, Linkage };
enum class Transport : std::uint8_t { Hid, Usb };

[[nodiscard]] std::size_t field_size(FieldType t);

struct ReportField {
  Axis axis = Axis::X;
  std::size_t offset = 0;  // [bytes] from the start of the report (the id byte, when there is one)
  FieldType type = FieldType::U8;
  double scale = 1.0;     // value = raw * scale
  double deadband = 0.0;  // |raw| <= deadband reads as 0 (raw units)
  int shift = 0;          // buttons only: bit position of the field's bit 0
};

struct ReportLayout {
  std::optional<std::uint8_t> id;  // none: the device does not number its reports
  std::size_t length = 0;          // [bytes], id byte included
  std::vector<ReportField> fields;
};

struct UsbEndpoints {
  int interface = 0;
  std::uint8_t in_endpoint = 0x81;
  std::uint8_t out_endpoint = 0;  // 0: none
  bool bulk = false;              // false: interrupt transfers
};

struct DeviceMatch {
  std::uint16_t vendor_id = 0;
  std::uint16_t product_id = 0;
};

struct DeviceProfile {
  std::string name;
  std::string file;  // where it was loaded from
  Transport transport = Transport::Hid;
  std::vector<DeviceMatch> match;
  Motion motion = Motion::Absolute;
  Eigen::Vector3d workspace_min = Eigen::Vector3d::Constant(-1.0);  // [m]
  Eigen::Vector3d workspace_max = Eigen::Vector3d::Constant(1.0);   // [m]
  Eigen::Vector3d home = Eigen::Vector3d::Zero();                   // [m]
  std::vector<ReportLayout> input_reports;
  std::optional<ReportLayout> output_report;
  double max_force = 0.0;       // [N]
  double max_force_rate = 0.0;  // [N/s]
  UsbEndpoints usb;
  std::optional<Linkage> linkage;  // Motion::Linkage

  [[nodiscard]] bool numbered_reports() const { return !input_reports.empty() && input_reports[0].id; }
  [[nodiscard]] bool matches(std::uint16_t vendor_id, std::uint16_t product_id) const;
  [[nodiscard]] const ReportLayout* input_layout(std::uint8_t id) const;
  [[nodiscard]] std::size_t max_input_length() const;
};

// Throw InputError naming the file, line, column and key of the first problem.
[[nodiscard]] DeviceProfile load_device_profile(const std::string& path);
[[nodiscard]] DeviceProfile parse_device_profile(const std::string& yaml_text, const std::string& file);
// Every *.yaml of a folder, in file-name order.
[[nodiscard]] std::vector<DeviceProfile> load_device_profiles(const std::string& dir);

// The values one input report carries. Only the axes present in its layout are set.
struct ReportValues {
  std::array<double, kValueAxes> axis{};  // indexed by Axis X..JC
  std::array<bool, kValueAxes> has{};
  std::uint32_t buttons = 0;
  std::uint32_t buttons_mask = 0;  // bits this report defines
};

enum class ParseResult : std::uint8_t { Ok, Short, Malformed };

// Decodes one raw report (as read: starting with the id byte for numbered reports).
[[nodiscard]] ParseResult parse_report(const DeviceProfile& p, std::span<const std::uint8_t> report,
                                       ReportValues& out) noexcept;

// Encodes a force [N] into the profile's output report; returns its length (0: no output report).
// A linkage device's report carries motor currents, for the arm at joint angles `joints` [rad]
// (the last ones the device reported); other devices ignore them.
std::size_t encode_force(const DeviceProfile& p, const Eigen::Vector3d& force, const Eigen::Vector3d& joints,
                         std::span<std::uint8_t> report) noexcept;

}  // namespace scalpel
