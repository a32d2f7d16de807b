// Frame decoder throughput against the design rate of the front end (3 channels × 10 kHz of
// 12-bit samples, seed 000 Table 1; frames of 100 samples per channel = 62.4 kB/s), for a
// clean stream, a damaged one (1 % of frames corrupted plus junk) and the whole simulated chain.
// The CRC-32 is compared with zlib's crc32 (the peer implementation) for speed and agreement.
// Run: ./bench_hardware_decoder   (prints one table; not run by ctest)
#include "pvdf/hardware/frame.hpp"
#include "pvdf/hardware/sim_source.hpp"

#include <zlib.h>

#include <chrono>
#include <cstdio>
#include <random>

using namespace pvdf::hardware;
using clock_type = std::chrono::steady_clock;

namespace {

constexpr double design_bytes_per_s = 100.0 * protocol::frame_size(3, 100);  // 100 frames/s

struct Row {
  const char* name;
  double bytes, seconds;
  std::uint64_t frames_expected, frames_got;
};

void print(const Row& r) {
  const double rate = r.bytes / r.seconds;
  std::printf("%-34s %9.1f %9.4f %10.1f %12.0f %8llu/%-8llu\n", r.name, r.bytes / 1e6, r.seconds, rate / 1e6,
              rate / design_bytes_per_s, static_cast<unsigned long long>(r.frames_got),
              static_cast<unsigned long long>(r.frames_expected));
}

Row decode(const char* name, const std::vector<std::uint8_t>& stream, std::uint64_t expected) {
  FrameDecoder d;
  std::vector<Frame> out;
  std::uint64_t got = 0;
  const auto t0 = clock_type::now();
  for (std::size_t pos = 0; pos < stream.size(); pos += 16384) {
    out.clear();
    d.feed(stream.data() + pos, std::min<std::size_t>(16384, stream.size() - pos), out);
    got += out.size();
  }
  out.clear();
  d.finish(out);
  got += out.size();
  const double s = std::chrono::duration<double>(clock_type::now() - t0).count();
  return {name, static_cast<double>(stream.size()), s, expected, got};
}

}  // namespace

int main() {
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> code(-2048, 2047);
  const std::uint32_t n_frames = 40000;  // 400 s of signal at the design rate, ~25 MB
  std::vector<std::uint8_t> clean, damaged;
  std::uint64_t damaged_good = 0;
  for (std::uint32_t s = 0; s < n_frames; ++s) {
    Frame f;
    f.sequence = s;
    f.n_channels = 3;
    f.n_samples = 100;
    f.channel_mask = 0x7;
    f.timestamp_us = 10000ull * s;
    for (int i = 0; i < 300; ++i) f.counts.push_back(static_cast<std::int16_t>(code(rng)));
    encode_frame(f, clean);
    const std::size_t begin = damaged.size();
    encode_frame(f, damaged);
    if (s % 100 == 50) damaged[begin + 200] ^= 0x08;  // 1 % corrupted
    else ++damaged_good;
    if (s % 100 == 75) for (int k = 0; k < 50; ++k) damaged.push_back(static_cast<std::uint8_t>(rng()));
  }

  std::printf("Frame decoder throughput (design rate: 3 channels x 10 kHz, %.1f kB/s; target >= 100x)\n",
              design_bytes_per_s / 1e3);
  std::printf("%-34s %9s %9s %10s %12s %17s\n", "case", "MB", "wall_s", "MB/s", "x_design", "frames got/exp");
  print(decode("clean stream, 16 KiB transfers", clean, n_frames));
  print(decode("1% corrupted + junk (resync)", damaged, damaged_good));

  // The whole simulated chain (signal model, noise, ADC, encode, decode) for 60 s of signal.
  {
    SimScene scene = default_sim_scene();
    scene.duration_s = 60;
    SimSource sim(scene, false);
    std::vector<SampleBlock> blocks;
    std::uint64_t got = 0;
    const auto t0 = clock_type::now();
    while (sim.next(blocks, std::chrono::milliseconds(0))) {
      got += blocks.size();
      blocks.clear();
    }
    const double s = std::chrono::duration<double>(clock_type::now() - t0).count();
    print({"simulated chain (model+ADC+codec)", 6000.0 * protocol::frame_size(3, 100), s, 6000, got});
  }

  // CRC-32 alone, against zlib.
  {
    auto t0 = clock_type::now();
    const std::uint32_t ours = crc32(clean.data(), clean.size());
    const double s_ours = std::chrono::duration<double>(clock_type::now() - t0).count();
    t0 = clock_type::now();
    const auto theirs = static_cast<std::uint32_t>(::crc32(0L, clean.data(), static_cast<uInt>(clean.size())));
    const double s_zlib = std::chrono::duration<double>(clock_type::now() - t0).count();
    print({"CRC-32 (pvdfkit: zlib crc32)", static_cast<double>(clean.size()), s_ours, 0, 0});
    print({"CRC-32 (zlib, peer)", static_cast<double>(clean.size()), s_zlib, 0, 0});
    std::printf("CRC values agree with zlib: %s (0x%08x)\n", ours == theirs ? "yes" : "NO", ours);
    return ours == theirs ? 0 : 1;
  }
}
