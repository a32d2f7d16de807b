// The USB protocol of the pvdfkit charge-amplifier front end: constants shared by the host
// (UsbSource), the simulator, the recorder and the mocked device in the tests. docs/hardware.md
// is the normative description for firmware authors; this header must agree with it.
#pragma once

#include <cstddef>
#include <cstdint>

namespace pvdf::hardware::protocol {

/// Default identifiers: 1209:0001 is the pid.codes test VID:PID. A distributed device must
/// use its own pair and be opened with `--device usb:VID:PID`.
inline constexpr std::uint16_t default_vendor_id = 0x1209;
inline constexpr std::uint16_t default_product_id = 0x0001;

/// The device has one vendor-class interface (bInterfaceClass 0xFF) with one bulk-IN endpoint.
inline constexpr int interface_number = 0;
inline constexpr std::uint8_t bulk_in_endpoint = 0x81;

/// Vendor control requests (bmRequestType 0x40 host-to-device, 0xC0 device-to-host,
/// recipient device). Multi-byte fields are little-endian.
enum Request : std::uint8_t {
  request_start = 0x01,            ///< OUT, no data: start streaming (sequence restarts at 0)
  request_stop = 0x02,             ///< OUT, no data: stop streaming after the current frame
  request_set_sample_rate = 0x03,  ///< OUT, 4 bytes: u32 sample rate (Hz), per channel
  request_set_channel_mask = 0x04, ///< OUT, no data: wValue = channel bit mask (bit i = channel i)
  request_set_gain = 0x05,         ///< OUT, 4 bytes: u32 sensitivity (mV/pC); wValue = channel, 0xFFFF = all
  request_get_status = 0x06,       ///< IN, 16 bytes: see Status
  request_get_info = 0x07,         ///< IN, 16 bytes: see DeviceInfo
};

inline constexpr std::uint8_t request_type_out = 0x40;  ///< vendor | host-to-device | device
inline constexpr std::uint8_t request_type_in = 0xC0;   ///< vendor | device-to-host | device
inline constexpr std::uint16_t all_channels = 0xFFFF;

/// GET_STATUS reply (16 bytes, little-endian).
struct Status {
  std::uint8_t protocol_version = 1;  ///< byte 0
  std::uint8_t running = 0;           ///< byte 1: 1 while streaming
  std::uint16_t channel_mask = 0;     ///< bytes 2-3
  std::uint32_t sample_rate_Hz = 0;   ///< bytes 4-7
  std::uint32_t frames_sent = 0;      ///< bytes 8-11: frames queued since START
  std::uint32_t overflow_count = 0;   ///< bytes 12-15: frames the device had to discard since START
};
inline constexpr std::size_t status_size = 16;

/// GET_INFO reply (16 bytes, little-endian).
struct DeviceInfo {
  std::uint8_t protocol_version = 1;  ///< byte 0
  std::uint8_t n_channels = 3;        ///< byte 1: number of ADC channels (1..16)
  std::uint8_t adc_bits = 12;         ///< byte 2: ADC resolution (samples are signed, centred on 0)
  std::uint8_t reserved = 0;          ///< byte 3
  std::uint32_t max_sample_rate_Hz = 10000;  ///< bytes 4-7
  float full_scale_V = 2.5F;          ///< bytes 8-11: IEEE-754 float, amplifier output at code 2^(bits-1)
  std::uint32_t reserved2 = 0;        ///< bytes 12-15
};
inline constexpr std::size_t info_size = 16;

void encode_status(const Status& s, std::uint8_t out[status_size]);
Status decode_status(const std::uint8_t in[status_size]);
void encode_info(const DeviceInfo& info, std::uint8_t out[info_size]);
DeviceInfo decode_info(const std::uint8_t in[info_size]);

/// Bulk-IN frame layout (little-endian):
///   offset 0  u32 magic 0x46445650 (the bytes 'P' 'V' 'D' 'F')
///   offset 4  u8  version (1)
///   offset 5  u8  flags (bit 0: overflow — the device dropped data before this frame)
///   offset 6  u8  n_channels (1..16): channels in this frame, in increasing channel order
///   offset 7  u8  reserved (0)
///   offset 8  u32 sequence number (0 after START, +1 per frame, wraps at 2^32)
///   offset 12 u16 n_samples per channel (1..1024)
///   offset 14 u16 channel mask (bit i = channel i present; popcount = n_channels)
///   offset 16 u64 timestamp of the first sample (µs, device clock)
///   offset 24 i16 samples[n_samples][n_channels] (interleaved, ADC counts)
///   then      u32 CRC-32 (IEEE 802.3) of every byte from offset 0 up to the CRC
inline constexpr std::uint32_t frame_magic = 0x46445650u;
inline constexpr std::uint8_t frame_version = 1;
inline constexpr std::size_t header_size = 24;
inline constexpr std::size_t crc_size = 4;
inline constexpr int max_channels = 16;
inline constexpr int max_samples_per_frame = 1024;
inline constexpr std::uint8_t flag_overflow = 0x01;
/// The largest frame a decoder must accept (bytes).
inline constexpr std::size_t max_frame_size = header_size + 2u * max_channels * max_samples_per_frame + crc_size;

/// Size in bytes of a frame with these counts.
constexpr std::size_t frame_size(int n_channels, int n_samples) {
  return header_size + 2u * static_cast<std::size_t>(n_channels) * static_cast<std::size_t>(n_samples) + crc_size;
}

}  // namespace pvdf::hardware::protocol
