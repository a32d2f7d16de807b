// Little-endian packing of the GET_STATUS and GET_INFO control replies (docs/hardware.md).
#include "pvdf/hardware/protocol.hpp"

#include <cstring>

namespace pvdf::hardware::protocol {

namespace {
void put32(std::uint8_t* p, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) p[k] = static_cast<std::uint8_t>(v >> (8 * k));
}
std::uint32_t get32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
}  // namespace

void encode_status(const Status& s, std::uint8_t out[status_size]) {
  out[0] = s.protocol_version;
  out[1] = s.running;
  out[2] = static_cast<std::uint8_t>(s.channel_mask);
  out[3] = static_cast<std::uint8_t>(s.channel_mask >> 8);
  put32(out + 4, s.sample_rate_Hz);
  put32(out + 8, s.frames_sent);
  put32(out + 12, s.overflow_count);
}

Status decode_status(const std::uint8_t in[status_size]) {
  Status s;
  s.protocol_version = in[0];
  s.running = in[1];
  s.channel_mask = static_cast<std::uint16_t>(in[2] | (in[3] << 8));
  s.sample_rate_Hz = get32(in + 4);
  s.frames_sent = get32(in + 8);
  s.overflow_count = get32(in + 12);
  return s;
}

void encode_info(const DeviceInfo& info, std::uint8_t out[info_size]) {
  out[0] = info.protocol_version;
  out[1] = info.n_channels;
  out[2] = info.adc_bits;
  out[3] = info.reserved;
  put32(out + 4, info.max_sample_rate_Hz);
  std::uint32_t bits = 0;
  static_assert(sizeof(float) == 4, "IEEE-754 single precision expected");
  std::memcpy(&bits, &info.full_scale_V, 4);
  put32(out + 8, bits);
  put32(out + 12, info.reserved2);
}

DeviceInfo decode_info(const std::uint8_t in[info_size]) {
  DeviceInfo info;
  info.protocol_version = in[0];
  info.n_channels = in[1];
  info.adc_bits = in[2];
  info.reserved = in[3];
  info.max_sample_rate_Hz = get32(in + 4);
  const std::uint32_t bits = get32(in + 8);
  std::memcpy(&info.full_scale_V, &bits, 4);
  info.reserved2 = get32(in + 12);
  return info;
}

}  // namespace pvdf::hardware::protocol
