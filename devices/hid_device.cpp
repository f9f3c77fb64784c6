#include "devices/hid_device.hpp"

#include <algorithm>
#include <cstring>

#include <hidapi/hidapi.h>
#include <libusb-1.0/libusb.h>

#include "base/spsc_ring.hpp"

namespace scalpel {

namespace {

std::string narrow(const wchar_t* w) {
  std::string s;
  if (!w) return s;
  for (; *w; ++w) s.push_back(*w < 128 ? static_cast<char>(*w) : '?');
  return s;
}

bool matches(const std::vector<DeviceMatch>& match, std::uint16_t vid, std::uint16_t pid) {
  return std::any_of(match.begin(), match.end(),
                     [&](const DeviceMatch& m) { return m.vendor_id == vid && m.product_id == pid; });
}

std::string usb_path(libusb_device* d) {
  return std::to_string(libusb_get_bus_number(d)) + ":" + std::to_string(libusb_get_device_address(d));
}

std::string usb_string(libusb_device_handle* h, std::uint8_t index) {
  if (index == 0) return {};
  unsigned char buf[256];
  const int n = libusb_get_string_descriptor_ascii(h, index, buf, sizeof buf);
  return n > 0 ? std::string(reinterpret_cast<const char*>(buf), static_cast<std::size_t>(n)) : std::string();
}

}  // namespace

// ---- hidapi ----

HidTransport::HidTransport(std::vector<DeviceMatch> match, DeviceSelector selector, bool numbered_reports)
    : match_(std::move(match)), selector_(std::move(selector)), numbered_(numbered_reports) {}

HidTransport::~HidTransport() {
  close();
}

bool HidTransport::open() {
  close();
  if (hid_init() != 0) return false;
  hid_device_info* list = hid_enumerate(0, 0);
  std::string path;
  for (hid_device_info* d = list; d; d = d->next) {
    if (!matches(match_, d->vendor_id, d->product_id)) continue;
    if (!selector_.serial.empty() && narrow(d->serial_number) != selector_.serial) continue;
    if (!selector_.path.empty() && selector_.path != d->path) continue;
    path = d->path;
    break;
  }
  hid_free_enumeration(list);
  if (path.empty()) return false;
  dev_ = hid_open_path(path.c_str());
  if (!dev_) return false;
  if (hid_set_nonblocking(dev_, 1) != 0) {
    close();
    return false;
  }
  return true;
}

void HidTransport::close() {
  if (dev_) hid_close(dev_);
  dev_ = nullptr;
}

int HidTransport::read(std::span<std::uint8_t> buf) noexcept {
  if (!dev_) return -1;
  return hid_read(dev_, buf.data(), buf.size());
}

bool HidTransport::write(std::span<const std::uint8_t> report) noexcept {
  if (!dev_ || report.size() + 1 > out_.size()) return false;
  // hidapi wants the report id first; a device without numbered reports takes a 0 there.
  std::size_t n = 0;
  if (!numbered_) out_[n++] = 0;
  std::memcpy(out_.data() + n, report.data(), report.size());
  n += report.size();
  return hid_write(dev_, out_.data(), n) == static_cast<int>(n);
}

// ---- libusb ----

struct UsbTransport::Queues {
  SpscRing<Packet> in{256};  // I/O thread -> haptic thread
  SpscRing<Packet> out{16};  // haptic thread -> I/O thread
};

UsbTransport::UsbTransport(std::vector<DeviceMatch> match, DeviceSelector selector, UsbEndpoints endpoints,
                           std::size_t in_length)
    : match_(std::move(match)),
      selector_(std::move(selector)),
      ep_(endpoints),
      in_length_(std::min<std::size_t>(in_length, sizeof(Packet::data))),
      queues_(std::make_unique<Queues>()) {}

UsbTransport::~UsbTransport() {
  close();
  if (ctx_) libusb_exit(ctx_);
}

bool UsbTransport::open() {
  close();
  if (!ctx_ && libusb_init(&ctx_) != 0) {
    ctx_ = nullptr;
    return false;
  }
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(ctx_, &list);
  for (ssize_t i = 0; i < n && !handle_; ++i) {
    libusb_device_descriptor desc{};
    if (libusb_get_device_descriptor(list[i], &desc) != 0) continue;
    if (!matches(match_, desc.idVendor, desc.idProduct)) continue;
    if (!selector_.path.empty() && usb_path(list[i]) != selector_.path) continue;
    libusb_device_handle* h = nullptr;
    if (libusb_open(list[i], &h) != 0) continue;
    if (!selector_.serial.empty() && usb_string(h, desc.iSerialNumber) != selector_.serial) {
      libusb_close(h);
      continue;
    }
    handle_ = h;
  }
  if (list) libusb_free_device_list(list, 1);
  if (!handle_) return false;
  libusb_set_auto_detach_kernel_driver(handle_, 1);
  if (libusb_claim_interface(handle_, ep_.interface) != 0) {
    libusb_close(handle_);
    handle_ = nullptr;
    return false;
  }
  Packet p;  // the I/O thread is stopped: both ends are ours
  while (queues_->in.pop(p)) {
  }
  while (queues_->out.pop(p)) {
  }
  gone_.store(false, std::memory_order_relaxed);
  running_.store(true, std::memory_order_release);
  io_ = std::thread([this] { io_loop(); });
  return true;
}

void UsbTransport::close() {
  running_.store(false, std::memory_order_release);
  if (io_.joinable()) io_.join();
  if (handle_) {
    libusb_release_interface(handle_, ep_.interface);
    libusb_close(handle_);
  }
  handle_ = nullptr;
}

void UsbTransport::io_loop() {
  const auto transfer = [&](std::uint8_t endpoint, unsigned char* data, int length, int* done,
                            unsigned timeout_ms) {
    return ep_.bulk ? libusb_bulk_transfer(handle_, endpoint, data, length, done, timeout_ms)
                    : libusb_interrupt_transfer(handle_, endpoint, data, length, done, timeout_ms);
  };
  Packet p;
  while (running_.load(std::memory_order_acquire)) {
    Packet o;
    if (ep_.out_endpoint != 0 && queues_->out.pop(o)) {
      // Only the newest force matters: skip those queued behind it.
      while (queues_->out.pop(o)) {
      }
      int done = 0;
      const int r = transfer(ep_.out_endpoint, o.data.data(), o.length, &done, 10);
      if (r == LIBUSB_ERROR_NO_DEVICE || r == LIBUSB_ERROR_IO) break;
    }
    int done = 0;
    const int r = transfer(ep_.in_endpoint, p.data.data(), static_cast<int>(in_length_), &done, 2);
    if (r == 0 || (r == LIBUSB_ERROR_OVERFLOW && done > 0)) {
      p.length = done;
      (void)queues_->in.push(p);  // full: the haptic thread is not reading; newer reports follow
    } else if (r != LIBUSB_ERROR_TIMEOUT) {
      break;
    }
  }
  gone_.store(true, std::memory_order_release);
}

int UsbTransport::read(std::span<std::uint8_t> buf) noexcept {
  const Packet* p = queues_->in.front();
  if (!p) return gone_.load(std::memory_order_acquire) && !queues_->in.front() ? -1 : 0;
  const int n = std::min(p->length, static_cast<int>(buf.size()));
  std::memcpy(buf.data(), p->data.data(), static_cast<std::size_t>(n));
  queues_->in.pop(scratch_);
  return n;
}

bool UsbTransport::write(std::span<const std::uint8_t> report) noexcept {
  if (report.size() > sizeof(Packet::data)) return false;
  Packet p;
  std::memcpy(p.data.data(), report.data(), report.size());
  p.length = static_cast<int>(report.size());
  return queues_->out.push(p);
}

// ---- enumeration ----

std::vector<FoundDevice> enumerate_devices(const std::vector<DeviceProfile>& profiles,
                                           bool include_unmatched) {
  std::vector<FoundDevice> out;
  const auto find_profile = [&](Transport t, std::uint16_t vid, std::uint16_t pid) {
    for (std::size_t i = 0; i < profiles.size(); ++i)
      if (profiles[i].transport == t && profiles[i].matches(vid, pid)) return static_cast<int>(i);
    return -1;
  };
  if (hid_init() == 0) {
    hid_device_info* list = hid_enumerate(0, 0);
    for (hid_device_info* d = list; d; d = d->next) {
      FoundDevice f{Transport::Hid,
                    d->vendor_id,
                    d->product_id,
                    narrow(d->serial_number),
                    d->path ? d->path : "",
                    narrow(d->manufacturer_string),
                    narrow(d->product_string),
                    find_profile(Transport::Hid, d->vendor_id, d->product_id)};
      if (f.profile >= 0 || include_unmatched) out.push_back(std::move(f));
    }
    hid_free_enumeration(list);
  }
  const bool any_usb = std::any_of(profiles.begin(), profiles.end(),
                                   [](const DeviceProfile& p) { return p.transport == Transport::Usb; });
  libusb_context* ctx = nullptr;
  if (any_usb && libusb_init(&ctx) == 0) {
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(ctx, &list);
    for (ssize_t i = 0; i < n; ++i) {
      libusb_device_descriptor desc{};
      if (libusb_get_device_descriptor(list[i], &desc) != 0) continue;
      const int prof = find_profile(Transport::Usb, desc.idVendor, desc.idProduct);
      if (prof < 0) continue;
      FoundDevice f{Transport::Usb, desc.idVendor, desc.idProduct, {}, usb_path(list[i]), {}, {}, prof};
      libusb_device_handle* h = nullptr;
      if (libusb_open(list[i], &h) == 0) {
        f.serial = usb_string(h, desc.iSerialNumber);
        f.manufacturer = usb_string(h, desc.iManufacturer);
        f.product = usb_string(h, desc.iProduct);
        libusb_close(h);
      }
      out.push_back(std::move(f));
    }
    if (list) libusb_free_device_list(list, 1);
    libusb_exit(ctx);
  }
  return out;
}

std::unique_ptr<ReportDevice> open_device(const DeviceProfile& profile, const DeviceSelector& selector) {
  std::unique_ptr<ReportTransport> t;
  if (profile.transport == Transport::Hid)
    t = std::make_unique<HidTransport>(profile.match, selector, profile.numbered_reports());
  else
    t = std::make_unique<UsbTransport>(profile.match, selector, profile.usb, profile.max_input_length());
  return std::make_unique<ReportDevice>(profile, std::move(t));
}

}  // namespace scalpel
