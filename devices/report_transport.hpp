// The byte pipe under a report-based device: hidapi, libusb, or a fake one in tests.
//
// Thread ownership: read() and write() belong to the haptic thread while the transport is open;
// open() and close() belong to the maintenance thread while it is not (ReportDevice hands the
// transport over between the two through an atomic state).
#pragma once

#include <cstdint>
#include <span>

namespace scalpel {

class ReportTransport {
 public:
  virtual ~ReportTransport() = default;

  // Opens (or reopens) the device; false when it is absent. May block and allocate.
  virtual bool open() = 0;
  virtual void close() = 0;

  // Never blocks: copies one pending input report into `buf` (the id byte first for numbered
  // reports) and returns its length, 0 when none is pending, -1 when the device is gone.
  virtual int read(std::span<std::uint8_t> buf) noexcept = 0;
  // Never blocks for long: sends one output report; false on failure.
  virtual bool write(std::span<const std::uint8_t> report) noexcept = 0;
};

}  // namespace scalpel
