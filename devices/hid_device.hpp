// The hidapi and libusb back ends of ReportDevice, device enumeration and opening by profile.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "devices/device_profile.hpp"
#include "devices/report_device.hpp"
#include "devices/report_transport.hpp"

struct hid_device_;
struct libusb_context;
struct libusb_device_handle;

namespace scalpel {

// Which of the devices a profile matches to open: empty fields match any.
struct DeviceSelector {
  std::string serial{};  // USB serial number string
  std::string path{};    // platform path (hidapi) or "bus:address" (libusb)
};

// hidapi, non-blocking reads. Opens the first device matching the profile and the selector.
class HidTransport final : public ReportTransport {
 public:
  HidTransport(std::vector<DeviceMatch> match, DeviceSelector selector, bool numbered_reports);
  ~HidTransport() override;
  HidTransport(const HidTransport&) = delete;
  HidTransport& operator=(const HidTransport&) = delete;

  bool open() override;
  void close() override;
  int read(std::span<std::uint8_t> buf) noexcept override;
  bool write(std::span<const std::uint8_t> report) noexcept override;

 private:
  std::vector<DeviceMatch> match_;
  DeviceSelector selector_;
  bool numbered_;
  hid_device_* dev_ = nullptr;
  std::array<std::uint8_t, ReportDevice::kMaxReport + 1> out_{};
};

// libusb, interrupt or bulk endpoints. An I/O thread of its own does the blocking transfers and
// passes reports through two pre-sized SPSC rings, so read() and write() never block.
class UsbTransport final : public ReportTransport {
 public:
  UsbTransport(std::vector<DeviceMatch> match, DeviceSelector selector, UsbEndpoints endpoints,
               std::size_t in_length);
  ~UsbTransport() override;
  UsbTransport(const UsbTransport&) = delete;
  UsbTransport& operator=(const UsbTransport&) = delete;

  bool open() override;
  void close() override;
  int read(std::span<std::uint8_t> buf) noexcept override;
  bool write(std::span<const std::uint8_t> report) noexcept override;

  struct Packet {
    std::array<std::uint8_t, 512> data{};
    int length = 0;
  };

 private:
  void io_loop();

  std::vector<DeviceMatch> match_;
  DeviceSelector selector_;
  UsbEndpoints ep_;
  std::size_t in_length_;
  libusb_context* ctx_ = nullptr;
  libusb_device_handle* handle_ = nullptr;
  struct Queues;
  std::unique_ptr<Queues> queues_;
  Packet scratch_;                    // haptic thread: the popped packet
  std::atomic<bool> running_{false};  // the I/O thread runs while true
  std::atomic<bool> gone_{false};     // set by the I/O thread when the device went away
  std::thread io_;
};

struct FoundDevice {
  Transport transport = Transport::Hid;
  std::uint16_t vendor_id = 0;
  std::uint16_t product_id = 0;
  std::string serial;
  std::string path;
  std::string manufacturer;
  std::string product;
  int profile = -1;  // index into the profiles given, -1 when none matches
};

// Every HID device (hidapi) and every USB device a usb profile matches (libusb), in the order the
// libraries list them; with include_unmatched false only those a profile matches.
[[nodiscard]] std::vector<FoundDevice> enumerate_devices(const std::vector<DeviceProfile>& profiles,
                                                         bool include_unmatched = false);

// A ReportDevice on the profile's transport. It starts disconnected when no device is present and
// connects when maintain() finds one.
[[nodiscard]] std::unique_ptr<ReportDevice> open_device(const DeviceProfile& profile,
                                                        const DeviceSelector& selector = {});

}  // namespace scalpel
