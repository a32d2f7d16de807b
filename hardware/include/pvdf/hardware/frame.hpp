// Bulk-IN frames of the front end: CRC-32, the encoder (device side, simulator, recorder) and
// the incremental decoder that turns any byte stream into checked frames and counts what it
// had to reject (corrupted, malformed, dropped, duplicated frames, bytes skipped to resync).
#pragma once

#include "pvdf/hardware/protocol.hpp"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace pvdf::hardware {

/// CRC-32 (IEEE 802.3 / zlib: reflected polynomial 0xEDB88320, initial value and final XOR
/// 0xFFFFFFFF) of `n` bytes. crc32("123456789") = 0xCBF43926. Pass a previous result as
/// `crc` to continue over more bytes.
std::uint32_t crc32(const std::uint8_t* data, std::size_t n, std::uint32_t crc = 0);

/// One decoded frame: header fields and ADC counts.
struct Frame {
  std::uint32_t sequence = 0;
  std::uint64_t timestamp_us = 0;     ///< device time of the first sample (µs)
  std::uint16_t channel_mask = 0;     ///< bit i set: channel i present
  int n_channels = 0;                 ///< popcount of channel_mask
  int n_samples = 0;                  ///< samples per channel
  bool overflow = false;              ///< the device dropped data before this frame
  std::vector<std::int16_t> counts;   ///< n_samples × n_channels, interleaved (row = sample)
};

/// True when any channel of sample `sample` sits at the ADC's limits (code ≥ 2^(bits−1) − 1 or
/// ≤ −2^(bits−1)): the amplifier output was clipped and the sample's charges are not known.
bool sample_clipped(const Frame& frame, int sample, int adc_bits);

/// Appends the wire encoding of `frame` (header, samples, CRC) to `out`.
/// Throws InputError if the counts are inconsistent (mask popcount ≠ n_channels, sizes).
void encode_frame(const Frame& frame, std::vector<std::uint8_t>& out);

/// What the decoder saw. All counts are since construction (or reset()).
struct DecoderCounters {
  std::uint64_t bytes_in = 0;          ///< bytes fed
  std::uint64_t frames_ok = 0;         ///< frames delivered (CRC and sequence accepted)
  std::uint64_t crc_errors = 0;        ///< complete frames whose CRC did not match (dropped)
  std::uint64_t bad_headers = 0;       ///< magic found but version/counts/mask invalid
  std::uint64_t bytes_skipped = 0;     ///< bytes discarded while searching for the magic
  std::uint64_t frames_missing = 0;    ///< sequence gaps: frames never received
  std::uint64_t duplicates = 0;        ///< frames with an already-delivered (or older) sequence (dropped)
  std::uint64_t overflow_frames = 0;   ///< delivered frames with the overflow flag
  std::uint64_t trailing_bytes = 0;    ///< bytes still buffered (a partial frame) — see finish()
  /// True when anything was lost or rejected.
  bool any_fault() const {
    return crc_errors + bad_headers + bytes_skipped + frames_missing + duplicates + overflow_frames + trailing_bytes > 0;
  }
  /// One line: "frames 120, missing 2, duplicated 1, CRC errors 3, bad headers 0, skipped 57 B, overflow 0, partial 0 B".
  std::string summary() const;
};

/// Incremental frame decoder: feed it byte chunks as they arrive (a frame may span chunks,
/// a chunk may hold several frames, garbage may sit anywhere). It searches for the magic,
/// checks the header and the CRC, and on any failure drops one byte and searches again, so
/// it resynchronizes on the next good frame. Sequence numbers are checked across frames:
/// gaps are counted as missing frames, repeats and older numbers as duplicates (dropped).
/// Memory is bounded by one maximal frame; no input can make it crash or loop.
class FrameDecoder {
 public:
  /// Feeds `n` bytes and appends every complete, valid, new frame to `out`.
  void feed(const std::uint8_t* data, std::size_t n, std::vector<Frame>& out);
  /// End of stream. The buffered bytes are searched once more for complete frames (a
  /// corrupted length field can hide good frames behind it until more data arrives, which
  /// will not happen now); what remains is counted in trailing_bytes (a torn last frame).
  void finish(std::vector<Frame>& out);
  /// Forgets the sequence history (after a START the device restarts at 0).
  void reset_sequence() { have_sequence_ = false; }
  const DecoderCounters& counters() const { return counters_; }

 private:
  /// Tries to decode at buffer_[start_]; returns bytes consumed (0 = need more data).
  std::size_t try_decode(std::vector<Frame>& out);
  void accept(Frame&& frame, std::vector<Frame>& out);
  void compact();
  bool counting_ = true;  ///< false while finish() rescans: those bytes count as trailing

  std::vector<std::uint8_t> buffer_;
  std::size_t start_ = 0;
  bool have_sequence_ = false;
  std::uint32_t last_sequence_ = 0;
  DecoderCounters counters_;
};

}  // namespace pvdf::hardware
