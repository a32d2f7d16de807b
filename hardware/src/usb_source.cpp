// libusb-1.0 backend of the front end (docs/hardware.md, "Host behaviour").
#include "pvdf/hardware/usb_source.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

#include <libusb.h>

#include <cmath>
#include <cstdio>
#include <sstream>

namespace pvdf::hardware {

namespace {

std::string hex4(std::uint16_t v) {
  char text[8];
  std::snprintf(text, sizeof text, "%04x", v);
  return text;
}

std::string usb_error(int code) { return libusb_error_name(code); }

constexpr unsigned int control_timeout_ms = 1000;
constexpr unsigned int bulk_timeout_ms = 1000;
constexpr int max_consecutive_errors = 8;

/// Steps 1 and 2 of opening: finds the device VID:PID (the first of `n_found` matches, at `bus` and
/// `address`) and opens it; every failure is an InputError naming the device and the fix.
libusb_device_handle* open_device(libusb_context* context, std::uint16_t vendor_id, std::uint16_t product_id,
                                  const std::string& name, int& bus, int& address, int& n_found) {
  // 1. Find the device.
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(context, &list);
  if (n < 0) throw InputError(name + ": cannot list USB devices (libusb: " + usb_error(static_cast<int>(n)) + ")");
  libusb_device* found = nullptr;
  n_found = 0;
  for (ssize_t i = 0; i < n; ++i) {
    libusb_device_descriptor d{};
    if (libusb_get_device_descriptor(list[i], &d) == 0 && d.idVendor == vendor_id && d.idProduct == product_id) {
      if (found == nullptr) found = list[i];
      ++n_found;
    }
  }
  if (found == nullptr) {
    libusb_free_device_list(list, 1);
    throw InputError(name + ": no device with VID:PID " + hex4(vendor_id) + ":" + hex4(product_id) + " among " +
                     std::to_string(n) + " USB devices; plug the front end in, check 'lsusb', or name the device as usb:VID:PID");
  }
  bus = libusb_get_bus_number(found);
  address = libusb_get_device_address(found);
  // 2. Open and claim.
  libusb_device_handle* handle = nullptr;
  const int r = libusb_open(found, &handle);
  libusb_free_device_list(list, 1);
  if (r != 0) {
    const std::string where = " (bus " + std::to_string(bus) + " address " + std::to_string(address) + ")";
    if (r == LIBUSB_ERROR_ACCESS)
      throw InputError(name + where + ": permission denied opening the device; install the udev rule from "
                                       "docs/hardware.md (/etc/udev/rules.d/70-pvdfkit.rules) and replug it, or run as root");
    if (r == LIBUSB_ERROR_NO_DEVICE)
      throw InputError(name + where + ": the device disappeared while opening it; replug it and retry");
    if (r == LIBUSB_ERROR_BUSY)
      throw InputError(name + where + ": device busy; close the other program using it and retry");
    throw InputError(name + where + ": cannot open the device (libusb: " + usb_error(r) + ")");
  }
  return handle;
}

/// Claims interface 0; a busy, forbidden or vanished device is an InputError saying what to do.
void claim_interface(libusb_device_handle* handle, const std::string& name) {
  const int r = libusb_claim_interface(handle, protocol::interface_number);
  if (r != 0) {
    if (r == LIBUSB_ERROR_BUSY)
      throw InputError(name + ": device busy: interface 0 is claimed by another program (another 'pvdfkit acquire'?); "
                               "close it and retry");
    if (r == LIBUSB_ERROR_ACCESS)
      throw InputError(name + ": permission denied claiming interface 0; install the udev rule from docs/hardware.md");
    if (r == LIBUSB_ERROR_NO_DEVICE) throw InputError(name + ": the device disappeared while opening it; replug it and retry");
    throw InputError(name + ": cannot claim interface 0 (libusb: " + usb_error(r) + ")");
  }
}

}  // namespace

void parse_usb_spec(const std::string& spec, std::uint16_t& vid, std::uint16_t& pid) {
  vid = protocol::default_vendor_id;
  pid = protocol::default_product_id;
  if (spec == "usb") return;
  const auto bad = [&spec]() {
    return InputError("source spec " + spec + ": expected usb or usb:VID:PID with 4-digit hexadecimal ids, e.g. usb:1209:0001");
  };
  if (spec.size() != 13 || spec.compare(0, 4, "usb:") != 0 || spec[8] != ':') throw bad();
  const auto parse = [&](const std::string& text) {
    std::uint16_t v = 0;
    for (const char ch : text) {
      int d;
      if (ch >= '0' && ch <= '9') d = ch - '0';
      else if (ch >= 'a' && ch <= 'f') d = ch - 'a' + 10;
      else if (ch >= 'A' && ch <= 'F') d = ch - 'A' + 10;
      else throw bad();
      v = static_cast<std::uint16_t>(v * 16 + d);
    }
    return v;
  };
  vid = parse(spec.substr(4, 4));
  pid = parse(spec.substr(9, 4));
}

UsbSource::UsbSource(std::uint16_t vendor_id, std::uint16_t product_id, const OpenOptions& options)
    : name_("usb:" + hex4(vendor_id) + ":" + hex4(product_id)), stall_timeout_s_(options.stall_timeout_s) {
  // Any failure below throws; the destructor does not run then, so clean up by hand.
  struct Cleanup {
    UsbSource* self;
    bool armed = true;
    ~Cleanup() {
      if (!armed) return;
      if (self->claimed_) libusb_release_interface(self->handle_, protocol::interface_number);
      if (self->handle_ != nullptr) libusb_close(self->handle_);
      if (self->context_ != nullptr) libusb_exit(self->context_);
    }
  } cleanup{this};

  int r = libusb_init(&context_);
  if (r != 0) {
    context_ = nullptr;
    throw InputError(name_ + ": no USB access on this machine (libusb: " + usb_error(r) +
                     "); is /dev/bus/usb present (in a container, pass the USB bus through)?");
  }
  int bus = 0, address = 0, n_found = 0;
  handle_ = open_device(context_, vendor_id, product_id, name_, bus, address, n_found);  // 1. find, 2. open
  libusb_set_auto_detach_kernel_driver(handle_, 1);  // not supported everywhere; harmless then
  claim_interface(handle_, name_);
  claimed_ = true;
  if (n_found > 1) std::fprintf(stderr, "warning: %d devices match %s; using bus %d address %d\n", n_found, name_.c_str(), bus, address);

  // 3. Identify and configure.
  std::uint8_t reply[protocol::info_size];
  control_in(protocol::request_get_info, reply, protocol::info_size, "GET_INFO");
  const auto dev = protocol::decode_info(reply);
  if (dev.protocol_version != 1)
    throw InputError(name_ + ": the device speaks protocol version " + std::to_string(dev.protocol_version) +
                     ", this pvdfkit speaks version 1; update pvdfkit or the firmware");
  if (dev.n_channels < 1 || dev.n_channels > protocol::max_channels || dev.adc_bits < 2 || dev.adc_bits > 16 ||
      !(dev.full_scale_V > 0) || !std::isfinite(dev.full_scale_V))
    throw InputError(name_ + ": GET_INFO reply is invalid (channels " + std::to_string(dev.n_channels) + ", ADC bits " +
                     std::to_string(dev.adc_bits) + "); check the firmware against docs/hardware.md");
  control_out(protocol::request_stop, 0, 0, nullptr, 0, "STOP");
  if (options.sample_rate_Hz > 0) {
    if (options.sample_rate_Hz > dev.max_sample_rate_Hz || options.sample_rate_Hz != std::floor(options.sample_rate_Hz))
      throw InputError("OpenOptions::sample_rate_Hz " + format_g(options.sample_rate_Hz) + ": must be a whole number <= " +
                       std::to_string(dev.max_sample_rate_Hz) + " Hz (the device's maximum)");
    const auto rate = static_cast<std::uint32_t>(options.sample_rate_Hz);
    const std::uint8_t data[4] = {static_cast<std::uint8_t>(rate), static_cast<std::uint8_t>(rate >> 8),
                                  static_cast<std::uint8_t>(rate >> 16), static_cast<std::uint8_t>(rate >> 24)};
    control_out(protocol::request_set_sample_rate, 0, 0, data, 4, "SET_SAMPLE_RATE");
  }
  if (options.channel_mask != 0) {
    if (options.channel_mask >> dev.n_channels)
      throw InputError("OpenOptions::channel_mask: the device has " + std::to_string(dev.n_channels) + " channels (0.." +
                       std::to_string(dev.n_channels - 1) + ")");
    control_out(protocol::request_set_channel_mask, options.channel_mask, 0, nullptr, 0, "SET_CHANNEL_MASK");
  }
  if (options.gain_mV_per_pC > 0) {
    const auto gain = static_cast<std::uint32_t>(std::lround(options.gain_mV_per_pC));
    const std::uint8_t data[4] = {static_cast<std::uint8_t>(gain), static_cast<std::uint8_t>(gain >> 8),
                                  static_cast<std::uint8_t>(gain >> 16), static_cast<std::uint8_t>(gain >> 24)};
    control_out(protocol::request_set_gain, protocol::all_channels, 0, data, 4, "SET_GAIN");
  }
  control_in(protocol::request_get_status, reply, protocol::status_size, "GET_STATUS");
  const auto status = protocol::decode_status(reply);
  if (status.sample_rate_Hz == 0 || status.channel_mask == 0)
    throw InputError(name_ + ": GET_STATUS reports sample rate " + std::to_string(status.sample_rate_Hz) +
                     " Hz and channel mask " + std::to_string(status.channel_mask) + "; check the firmware");
  info_.description = name_ + " bus " + std::to_string(bus) + " address " + std::to_string(address);
  info_.sample_rate_Hz = status.sample_rate_Hz;
  info_.channel_mask = status.channel_mask;
  info_.adc_bits = dev.adc_bits;
  info_.full_scale_V = dev.full_scale_V;
  info_.gain_V_per_C = options.gain_mV_per_pC > 0 ? options.gain_mV_per_pC * 1e9 : 0.0;  // mV/pC = 1e9 V/C

  // 4. Start and queue the bulk transfers.
  control_out(protocol::request_start, 0, 0, nullptr, 0, "START");
  decoder_.reset_sequence();
  last_data_ = std::chrono::steady_clock::now();
  const int n_transfers = options.transfers_in_flight < 1 ? 1 : options.transfers_in_flight;
  buffers_.assign(static_cast<std::size_t>(n_transfers), std::vector<std::uint8_t>(transfer_size));
  for (int i = 0; i < n_transfers; ++i) {
    libusb_transfer* t = libusb_alloc_transfer(0);
    if (t == nullptr) throw InputError(name_ + ": out of memory allocating a USB transfer");
    transfers_.push_back(t);
    libusb_fill_bulk_transfer(t, handle_, protocol::bulk_in_endpoint, buffers_[static_cast<std::size_t>(i)].data(),
                              transfer_size, &UsbSource::transfer_done, this, bulk_timeout_ms);
    r = libusb_submit_transfer(t);
    if (r != 0) {
      cancel_all();
      throw InputError(name_ + ": cannot queue a bulk transfer (libusb: " + usb_error(r) + ")");
    }
    ++in_flight_;
  }
  cleanup.armed = false;
}

UsbSource::~UsbSource() {
  if (in_flight_ > 0 && !abandoned_) {
    stopping_ = true;
    cancel_all();
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (in_flight_ > 0 && std::chrono::steady_clock::now() < give_up) {
      timeval tv{0, 50000};
      libusb_handle_events_timeout_completed(context_, &tv, nullptr);
    }
  }
  // Transfers still in flight after the grace period are leaked rather than freed under libusb.
  const bool clean = in_flight_ == 0;
  if (clean) {
    for (auto* t : transfers_) libusb_free_transfer(t);
  }
  if (reason_ != EndReason::disconnected) {
    libusb_control_transfer(handle_, protocol::request_type_out, protocol::request_stop, 0, 0, nullptr, 0, 200);
  }
  if (claimed_) libusb_release_interface(handle_, protocol::interface_number);
  if (clean) {
    libusb_close(handle_);
    libusb_exit(context_);
  }
}

void UsbSource::control_out(std::uint8_t request, std::uint16_t value, std::uint16_t index, const std::uint8_t* data,
                            std::uint16_t length, const std::string& what) {
  const int r = libusb_control_transfer(handle_, protocol::request_type_out, request, value, index,
                                        const_cast<std::uint8_t*>(data), length, control_timeout_ms);
  if (r == LIBUSB_ERROR_PIPE)
    throw InputError(name_ + ": the device refused " + what + " (control request stalled); check the requested setting");
  if (r < 0) throw InputError(name_ + ": control request " + what + " failed (libusb: " + usb_error(r) + ")");
}

void UsbSource::control_in(std::uint8_t request, std::uint8_t* data, std::uint16_t length, const std::string& what) {
  const int r = libusb_control_transfer(handle_, protocol::request_type_in, request, 0, 0, data, length, control_timeout_ms);
  if (r < 0) throw InputError(name_ + ": control request " + what + " failed (libusb: " + usb_error(r) + ")");
  if (r != length)
    throw InputError(name_ + ": " + what + " returned " + std::to_string(r) + " bytes, expected " + std::to_string(length) +
                     "; check the firmware against docs/hardware.md");
}

void UsbSource::transfer_done(libusb_transfer* transfer) {
  static_cast<UsbSource*>(transfer->user_data)->on_transfer(transfer);
}

void UsbSource::on_transfer(libusb_transfer* t) {
  // Whatever arrived is decoded first, whatever the status: a timed-out or cancelled
  // transfer may still carry data, and the decoder copes with partial frames.
  if (t->actual_length > 0) {
    decoded_.clear();
    decoder_.feed(t->buffer, static_cast<std::size_t>(t->actual_length), decoded_);
    for (auto& f : decoded_) ready_.push_back(SampleBlock{std::move(f)});
    last_data_ = std::chrono::steady_clock::now();
  }
  bool resubmit = false;
  switch (t->status) {
    case LIBUSB_TRANSFER_COMPLETED:
      ++counters_.transfers;
      consecutive_errors_ = 0;
      resubmit = true;
      break;
    case LIBUSB_TRANSFER_TIMED_OUT:
      ++counters_.transfer_timeouts;
      resubmit = true;
      break;
    case LIBUSB_TRANSFER_CANCELLED:
      break;
    case LIBUSB_TRANSFER_NO_DEVICE:
      end(EndReason::disconnected, name_ + ": device disconnected mid-stream");
      break;
    default:  // STALL, OVERFLOW, ERROR
      ++counters_.transfer_errors;
      if (t->status == LIBUSB_TRANSFER_STALL) libusb_clear_halt(handle_, protocol::bulk_in_endpoint);
      resubmit = ++consecutive_errors_ < max_consecutive_errors;
      if (!resubmit)
        end(EndReason::failed, name_ + ": " + std::to_string(max_consecutive_errors) +
                                   " bulk transfers failed in a row (last: " + libusb_error_name(t->status) + ")");
      break;
  }
  if (resubmit && !stopping_ && reason_ == EndReason::running) {
    const int r = libusb_submit_transfer(t);
    if (r == 0) return;
    if (r == LIBUSB_ERROR_NO_DEVICE) end(EndReason::disconnected, name_ + ": device disconnected mid-stream");
    else end(EndReason::failed, name_ + ": cannot requeue a bulk transfer (libusb: " + usb_error(r) + ")");
  }
  --in_flight_;
}

void UsbSource::end(EndReason reason, const std::string& message) {
  if (reason_ == EndReason::running) {
    reason_ = reason;
    end_message_ = message;
  }
  if (!stopping_) {
    stopping_ = true;
    stop_requested_ = std::chrono::steady_clock::now();
    cancel_all();
  }
}

void UsbSource::cancel_all() {
  for (auto* t : transfers_) libusb_cancel_transfer(t);  // NOT_FOUND for those not in flight: fine
}

bool UsbSource::next(std::vector<SampleBlock>& out, std::chrono::milliseconds timeout) {
  if (ready_.empty() && in_flight_ > 0 && !abandoned_) {
    const auto us = std::chrono::duration_cast<std::chrono::microseconds>(timeout).count();
    timeval tv{static_cast<time_t>(us / 1000000), static_cast<suseconds_t>(us % 1000000)};
    const int r = libusb_handle_events_timeout_completed(context_, &tv, nullptr);
    // A signal (Ctrl-C) that lands inside poll() can surface as INTERRUPTED or, through some
    // preload layers, as IO: one failed wait is not a broken device. Only repeated failures are.
    if (r == 0 || r == LIBUSB_ERROR_INTERRUPTED) {
      event_errors_ = 0;
    } else if (++event_errors_ >= 3) {
      end(EndReason::failed, name_ + ": USB event handling failed (libusb: " + usb_error(r) + ")");
    }
    const auto now = std::chrono::steady_clock::now();
    if (reason_ == EndReason::running && std::chrono::duration<double>(now - last_data_).count() > stall_timeout_s_) {
      std::ostringstream m;
      m << name_ << ": no data for " << stall_timeout_s_ << " s; the device stalled (check its status LED and cable)";
      end(EndReason::stalled, m.str());
    }
    // Transfers that never come back after a stop are abandoned after 2 s.
    if (stopping_ && in_flight_ > 0 && now - stop_requested_ > std::chrono::seconds(2)) {
      end_message_ += (end_message_.empty() ? "" : "; ") + std::to_string(in_flight_) + " transfers did not complete after cancel";
      abandoned_ = true;
    }
  }
  const bool live = in_flight_ > 0 && !abandoned_;
  if (!live && !finished_) {
    finished_ = true;
    decoded_.clear();
    decoder_.finish(decoded_);
    for (auto& f : decoded_) ready_.push_back(SampleBlock{std::move(f)});
  }
  const bool had = !ready_.empty();
  for (auto& b : ready_) out.push_back(std::move(b));
  ready_.clear();
  return had || live;
}

void UsbSource::stop() {
  if (reason_ == EndReason::running) reason_ = EndReason::stopped;
  if (!stopping_) {
    stopping_ = true;
    stop_requested_ = std::chrono::steady_clock::now();
    // Tell the device first, so it stops producing; then cancel what is queued.
    libusb_control_transfer(handle_, protocol::request_type_out, protocol::request_stop, 0, 0, nullptr, 0, 200);
    cancel_all();
  }
}

StreamCounters UsbSource::counters() const {
  StreamCounters c = counters_;
  c.decoder = decoder_.counters();
  return c;
}

}  // namespace pvdf::hardware
