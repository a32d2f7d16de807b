// Helpers shared by the USB tests (test_usb.cpp, test_usb_cli.cpp): frames, transfer-sized
// chunks, draining a Source, and paths for test outputs.
#pragma once

#include "pvdf/hardware/frame.hpp"
#include "pvdf/hardware/source.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace pvdf_test {

using pvdf::hardware::Frame;
using pvdf::hardware::SampleBlock;
using pvdf::hardware::Source;

inline Frame make_frame(std::uint32_t sequence, std::mt19937& rng) {
  Frame f;
  f.sequence = sequence;
  f.n_channels = 3;
  f.n_samples = 100;
  f.channel_mask = 0x7;
  f.timestamp_us = 10000ull * sequence;
  std::uniform_int_distribution<int> code(-2048, 2047);
  for (int i = 0; i < 300; ++i) f.counts.push_back(static_cast<std::int16_t>(code(rng)));
  return f;
}

/// Splits a byte stream into chunks of random sizes (1..max), as bulk transfers would carry it.
inline std::vector<std::vector<std::uint8_t>> split(const std::vector<std::uint8_t>& stream, std::mt19937& rng, std::size_t max) {
  std::vector<std::vector<std::uint8_t>> chunks;
  for (std::size_t pos = 0; pos < stream.size();) {
    const std::size_t n = std::min<std::size_t>(stream.size() - pos, 1 + rng() % max);
    chunks.emplace_back(stream.begin() + static_cast<std::ptrdiff_t>(pos), stream.begin() + static_cast<std::ptrdiff_t>(pos + n));
    pos += n;
  }
  return chunks;
}

inline std::vector<SampleBlock> drain(Source& source, std::size_t stop_after = 0) {
  std::vector<SampleBlock> all;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  bool stopped = false;
  while (std::chrono::steady_clock::now() < give_up) {
    if (!source.next(all, std::chrono::milliseconds(50))) break;
    if (stop_after > 0 && !stopped && all.size() >= stop_after) {
      source.stop();
      stopped = true;
    }
  }
  return all;
}

inline std::string temp_path(const char* name) { return std::string(PVDF_BINARY_DIR) + "/tests/hardware/" + name; }

}  // namespace pvdf_test
