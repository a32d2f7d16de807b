// CRC-32, frame encoding and the resynchronizing frame decoder (docs/hardware.md, "Frames").
#include "pvdf/hardware/frame.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/error.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <sstream>

#include <zlib.h>

namespace pvdf::hardware {

namespace {

std::uint16_t get_u16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint32_t get_u32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
std::uint64_t get_u64(const std::uint8_t* p) {
  return static_cast<std::uint64_t>(get_u32(p)) | (static_cast<std::uint64_t>(get_u32(p + 4)) << 32);
}
void put_u16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
}
void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<std::uint8_t>(v >> (8 * k)));
}
void put_u64(std::vector<std::uint8_t>& out, std::uint64_t v) {
  for (int k = 0; k < 8; ++k) out.push_back(static_cast<std::uint8_t>(v >> (8 * k)));
}
int popcount16(std::uint16_t v) {
  int n = 0;
  for (; v != 0; v &= static_cast<std::uint16_t>(v - 1)) ++n;
  return n;
}

}  // namespace

std::uint32_t crc32(const std::uint8_t* data, std::size_t n, std::uint32_t crc) {
  // zlib's crc32 (same polynomial, initial value and final XOR; hardware-assisted where zlib
  // has it), fed in pieces below 4 GiB because its length is a uInt.
  uLong c = crc;
  while (n > 0) {
    const uInt piece = static_cast<uInt>(std::min<std::size_t>(n, 1u << 30));
    c = ::crc32(c, data, piece);
    data += piece;
    n -= piece;
  }
  return static_cast<std::uint32_t>(c);
}

bool sample_clipped(const Frame& frame, int sample, int adc_bits) {
  const int code_max = (1 << (adc_bits - 1)) - 1;
  const int nc = frame.n_channels;
  for (int c = 0; c < nc; ++c) {
    const int v = frame.counts[static_cast<std::size_t>(sample * nc + c)];
    if (v >= code_max || v <= -code_max - 1) return true;
  }
  return false;
}

void encode_frame(const Frame& frame, std::vector<std::uint8_t>& out) {
  using namespace protocol;
  if (frame.n_channels < 1 || frame.n_channels > max_channels || popcount16(frame.channel_mask) != frame.n_channels)
    throw InputError("frame: channel mask 0x" + std::to_string(frame.channel_mask) + " must have n_channels = " +
                     std::to_string(frame.n_channels) + " bits set (1.." + std::to_string(max_channels) + ")");
  if (frame.n_samples < 1 || frame.n_samples > max_samples_per_frame)
    throw InputError("frame: n_samples = " + std::to_string(frame.n_samples) + " must be in 1.." +
                     std::to_string(max_samples_per_frame));
  if (frame.counts.size() != static_cast<std::size_t>(frame.n_channels) * static_cast<std::size_t>(frame.n_samples))
    throw InputError("frame: " + std::to_string(frame.counts.size()) + " counts must equal n_samples × n_channels = " +
                     std::to_string(frame.n_samples * frame.n_channels));
  const std::size_t begin = out.size();
  // Grow geometrically: an exact reserve per frame would copy the whole buffer every time.
  const std::size_t needed = begin + frame_size(frame.n_channels, frame.n_samples);
  if (needed > out.capacity()) out.reserve(std::max(needed, 2 * out.capacity()));
  put_u32(out, frame_magic);
  out.push_back(frame_version);
  out.push_back(frame.overflow ? flag_overflow : 0);
  out.push_back(static_cast<std::uint8_t>(frame.n_channels));
  out.push_back(0);
  put_u32(out, frame.sequence);
  put_u16(out, static_cast<std::uint16_t>(frame.n_samples));
  put_u16(out, frame.channel_mask);
  put_u64(out, frame.timestamp_us);
  for (const std::int16_t c : frame.counts) put_u16(out, static_cast<std::uint16_t>(c));
  put_u32(out, crc32(out.data() + begin, out.size() - begin));
  PVDF_ASSERT(out.size() - begin == frame_size(frame.n_channels, frame.n_samples),
              "an encoded frame must have the size the decoder expects from its header");
}

std::string DecoderCounters::summary() const {
  std::ostringstream s;
  s << "frames " << frames_ok << ", missing " << frames_missing << ", duplicated " << duplicates << ", CRC errors "
    << crc_errors << ", bad headers " << bad_headers << ", skipped " << bytes_skipped << " B, overflow "
    << overflow_frames << ", partial " << trailing_bytes << " B";
  return s.str();
}

void FrameDecoder::feed(const std::uint8_t* data, std::size_t n, std::vector<Frame>& out) {
  counters_.bytes_in += n;
  if (n > 0) buffer_.insert(buffer_.end(), data, data + n);
  while (start_ < buffer_.size()) {
    const std::size_t used = try_decode(out);
    if (used == 0) break;
    start_ += used;
  }
  compact();
  counters_.trailing_bytes = buffer_.size() - start_;
}

void FrameDecoder::finish(std::vector<Frame>& out) {
  std::size_t trailing = 0;
  counting_ = false;
  while (start_ < buffer_.size()) {
    const std::size_t frames_before = out.size();
    const std::uint64_t duplicates_before = counters_.duplicates;
    const std::size_t used = try_decode(out);
    if (used == 0) {
      ++trailing;  // an incomplete candidate: drop its first byte and look behind it
      ++start_;
    } else {
      const bool was_frame = out.size() > frames_before || counters_.duplicates > duplicates_before;
      if (!was_frame) trailing += used;
      start_ += used;
    }
  }
  counting_ = true;
  compact();
  counters_.trailing_bytes = trailing;
}

void FrameDecoder::compact() {
  if (start_ == 0) return;
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(start_));
  start_ = 0;
}

std::size_t FrameDecoder::try_decode(std::vector<Frame>& out) {
  using namespace protocol;
  const std::uint8_t* p = buffer_.data() + start_;
  const std::size_t avail = buffer_.size() - start_;
  // 1. Find the magic; everything before it is garbage. Keep up to 3 bytes that may be the
  //    beginning of a magic split across chunks.
  static constexpr std::uint8_t magic[4] = {'P', 'V', 'D', 'F'};
  std::size_t skip = 0;
  while (skip < avail) {
    const std::size_t left = avail - skip;
    const std::size_t k = left < 4 ? left : 4;
    if (std::memcmp(p + skip, magic, k) == 0) break;
    ++skip;
  }
  if (skip > 0) {
    if (counting_) counters_.bytes_skipped += skip;
    return skip;
  }
  if (avail < header_size) return 0;
  // 2. Header checks: a bad header means this was not a real magic (or a corrupted one).
  const int n_channels = p[6];
  const int n_samples = get_u16(p + 12);
  const std::uint16_t mask = get_u16(p + 14);
  if (p[4] != frame_version || p[7] != 0 || (p[5] & ~flag_overflow) != 0 || n_channels < 1 ||
      n_channels > max_channels || n_samples < 1 || n_samples > max_samples_per_frame ||
      popcount16(mask) != n_channels) {
    if (counting_) ++counters_.bad_headers;
    return 1;
  }
  const std::size_t size = frame_size(n_channels, n_samples);
  if (avail < size) return 0;
  // 3. CRC over header and samples.
  if (crc32(p, size - crc_size) != get_u32(p + size - crc_size)) {
    if (counting_) ++counters_.crc_errors;
    return 1;
  }
  Frame f;
  f.overflow = (p[5] & flag_overflow) != 0;
  f.n_channels = n_channels;
  f.n_samples = n_samples;
  f.sequence = get_u32(p + 8);
  f.channel_mask = mask;
  f.timestamp_us = get_u64(p + 16);
  f.counts.resize(static_cast<std::size_t>(n_channels) * static_cast<std::size_t>(n_samples));
  const std::uint8_t* s = p + header_size;
  for (std::size_t i = 0; i < f.counts.size(); ++i) f.counts[i] = static_cast<std::int16_t>(get_u16(s + 2 * i));
  accept(std::move(f), out);
  return size;
}

void FrameDecoder::accept(Frame&& frame, std::vector<Frame>& out) {
  if (have_sequence_) {
    // Distance ahead of the expected number, modulo 2^32: 0 = in order, small = frames lost,
    // "negative" (>= 2^31) = a repeat or an old frame.
    const std::uint32_t ahead = frame.sequence - (last_sequence_ + 1u);
    if (ahead >= 0x80000000u) {
      ++counters_.duplicates;
      return;
    }
    counters_.frames_missing += ahead;
  }
  have_sequence_ = true;
  last_sequence_ = frame.sequence;
  ++counters_.frames_ok;
  if (frame.overflow) ++counters_.overflow_frames;
  out.push_back(std::move(frame));
}

}  // namespace pvdf::hardware
