// A USB charge-amplifier front end emulated with umockdev: a testbed holding one USB device
// (sysfs attributes and descriptors) whose usbdevfs node is served by an ioctl handler that
// speaks docs/hardware.md — vendor control requests and bulk-IN URBs fed from a script of
// byte chunks, with optional disconnect, busy interface and refused requests. libusb talks to
// it through its real Linux backend (the test runs under umockdev-wrapper).
#pragma once

#include "pvdf/hardware/protocol.hpp"

#include <umockdev.h>

#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

namespace pvdf_test {

struct MockScript {
  std::uint16_t vendor_id = 0x1209;
  std::uint16_t product_id = 0x0001;
  std::vector<std::vector<std::uint8_t>> chunks;  ///< one per completed bulk-IN URB, after START
  bool disconnect_after_chunks = false;           ///< then: device removed (URBs fail, ioctls ENODEV)
  bool claim_busy = false;                        ///< CLAIMINTERFACE answers EBUSY
  int refuse_request = 0;                         ///< this bRequest is answered with a stall (EPIPE)
  pvdf::hardware::protocol::DeviceInfo info;
};

/// One control request as the device saw it.
struct ControlSeen {
  std::uint8_t request_type, request;
  std::uint16_t value, index;
  std::vector<std::uint8_t> data;
};

class MockFrontEnd {
 public:
  explicit MockFrontEnd(MockScript script);
  ~MockFrontEnd();
  MockFrontEnd(const MockFrontEnd&) = delete;
  MockFrontEnd& operator=(const MockFrontEnd&) = delete;

  /// Path of the emulated device node inside the testbed (for chmod in the permission test).
  std::string node_path() const;
  /// Path of the device's sysfs folder inside the testbed.
  std::string sysfs_path() const;
  std::vector<ControlSeen> controls() const;
  int peak_bulk_in_flight() const;
  std::size_t chunks_sent() const;
  bool disconnected() const;

 private:
  static gboolean on_ioctl(UMockdevIoctlBase* base, UMockdevIoctlClient* client, gpointer self);
  gboolean handle(UMockdevIoctlClient* client);
  void handle_control(UMockdevIoctlData* urb_data, UMockdevIoctlData* buffer);
  void disconnect_locked();

  MockScript script_;
  UMockdevTestbed* testbed_ = nullptr;
  UMockdevIoctlBase* handler_ = nullptr;
  std::string syspath_;
  mutable std::mutex mutex_;
  std::deque<UMockdevIoctlData*> held_;      ///< bulk URBs waiting for data that never comes
  std::deque<UMockdevIoctlData*> reapable_;  ///< completed URBs, in completion order
  std::vector<ControlSeen> controls_;
  std::size_t next_chunk_ = 0;
  bool running_ = false;
  bool disconnected_ = false;
  int bulk_outstanding_ = 0;
  int peak_bulk_outstanding_ = 0;
  std::uint32_t sample_rate_Hz_ = 10000;
  std::uint16_t channel_mask_ = 0x7;
};

/// Drops CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH from this thread's effective set while alive,
/// so that file permissions apply even to root (restored afterwards).
class WithoutFileCapabilities {
 public:
  WithoutFileCapabilities();
  ~WithoutFileCapabilities();

 private:
  std::uint32_t saved_[6] = {};
  bool changed_ = false;
};

}  // namespace pvdf_test
