// The live USB front end through libusb-1.0: opens the device by VID:PID, configures it with
// vendor control requests, and keeps several asynchronous bulk-IN transfers in flight,
// feeding the frame decoder. Disconnects, stalls and transfer errors end the stream with a
// reason; everything received before is still delivered.
#pragma once

#include "pvdf/hardware/source.hpp"

#include <chrono>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

struct libusb_context;
struct libusb_device_handle;
struct libusb_transfer;

namespace pvdf::hardware {

/// Parses "usb" or "usb:VID:PID" (hexadecimal, e.g. usb:1209:0001) into `vid`, `pid`.
/// Throws InputError naming the text and the expected form.
void parse_usb_spec(const std::string& spec, std::uint16_t& vid, std::uint16_t& pid);

class UsbSource final : public Source {
 public:
  /// Opens, configures and starts the device. Throws InputError with a one-line message for:
  /// no USB access, no device with this VID:PID, permission denied, device busy, a device
  /// that does not speak protocol version 1, or a setting it refuses.
  UsbSource(std::uint16_t vendor_id, std::uint16_t product_id, const OpenOptions& options);
  ~UsbSource() override;
  UsbSource(const UsbSource&) = delete;
  UsbSource& operator=(const UsbSource&) = delete;

  const StreamInfo& info() const override { return info_; }
  bool next(std::vector<SampleBlock>& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  EndReason end_reason() const override { return reason_; }
  std::string end_message() const override { return end_message_; }
  StreamCounters counters() const override;

  /// Bytes per bulk transfer.
  static constexpr int transfer_size = 16384;

 private:
  static void transfer_done(libusb_transfer* transfer);
  void on_transfer(libusb_transfer* transfer);
  void end(EndReason reason, const std::string& message);
  void cancel_all();
  void control_out(std::uint8_t request, std::uint16_t value, std::uint16_t index, const std::uint8_t* data,
                   std::uint16_t length, const std::string& what);
  void control_in(std::uint8_t request, std::uint8_t* data, std::uint16_t length, const std::string& what);

  std::string name_;  ///< "usb:1209:0001" for messages
  libusb_context* context_ = nullptr;
  libusb_device_handle* handle_ = nullptr;
  bool claimed_ = false;
  std::vector<libusb_transfer*> transfers_;
  std::vector<std::vector<std::uint8_t>> buffers_;
  int in_flight_ = 0;
  bool finished_ = false;  ///< decoder flushed at the end of the stream
  bool abandoned_ = false;  ///< transfers that never completed after cancel (leaked, not freed)
  int event_errors_ = 0;     ///< consecutive failed libusb event waits (3 in a row end the stream)
  bool stopping_ = false;
  EndReason reason_ = EndReason::running;
  std::string end_message_;
  StreamInfo info_;
  FrameDecoder decoder_;
  std::vector<Frame> decoded_;
  std::deque<SampleBlock> ready_;
  StreamCounters counters_;
  double stall_timeout_s_ = 2.0;
  std::chrono::steady_clock::time_point last_data_;
  std::chrono::steady_clock::time_point stop_requested_;
  int consecutive_errors_ = 0;
};

}  // namespace pvdf::hardware
