// Recording a stream to a file and replaying it. The file (".pvdfrec") is an 8-byte magic
// "PVDFREC1", a u32 length and a JSON header (stream info), then the frames exactly as on the
// wire (docs/hardware.md, "Recording files"). Each block is flushed as it is written, so a
// run that is killed keeps every block written before; a torn last frame is detected by its
// CRC on replay and counted as partial bytes.
#pragma once

#include "pvdf/hardware/source.hpp"

#include <chrono>
#include <cstdio>
#include <deque>
#include <string>

namespace pvdf::hardware {

/// Appends frames to a recording file. Note: unlike pvdfkit's other outputs this file is
/// written in place (not atomically), on purpose: an interrupted acquisition must keep what
/// it received.
class Recorder {
 public:
  /// Creates (truncates) `path` and writes the header. Throws InputError if it cannot.
  Recorder(const std::string& path, const StreamInfo& info);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;
  /// Writes the blocks' frames and flushes them to the operating system.
  void write(const std::vector<SampleBlock>& blocks);
  /// Flushes and closes (also done by the destructor). Throws InputError on a write error.
  void close();
  std::uint64_t frames_written() const { return frames_written_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  std::vector<std::uint8_t> scratch_;
  std::uint64_t frames_written_ = 0;
};

/// Keeps blocks until their device time is due on the wall clock (real-time replay).
class Pacer {
 public:
  explicit Pacer(bool realtime) : realtime_(realtime) {}
  /// Queues blocks; delivers those due (all of them when not real time), waiting at most `timeout`.
  void push(std::vector<SampleBlock>&& blocks);
  void pop_due(std::vector<SampleBlock>& out, std::chrono::milliseconds timeout);
  bool empty() const { return queue_.empty(); }

 private:
  bool realtime_;
  bool started_ = false;
  std::uint64_t first_timestamp_us_ = 0;
  std::chrono::steady_clock::time_point start_;
  std::deque<SampleBlock> queue_;
};

/// Replays a recording through the frame decoder (so a damaged file is checked like a live stream).
class ReplaySource final : public Source {
 public:
  /// Opens `path`; throws InputError for a missing file or a bad header.
  ReplaySource(const std::string& path, bool realtime);
  ~ReplaySource() override;
  const StreamInfo& info() const override { return info_; }
  bool next(std::vector<SampleBlock>& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  EndReason end_reason() const override { return reason_; }
  StreamCounters counters() const override;

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  StreamInfo info_;
  FrameDecoder decoder_;
  Pacer pacer_;
  EndReason reason_ = EndReason::running;
  std::uint64_t reads_ = 0;
  std::vector<std::uint8_t> chunk_;
};

/// Reads only the header of a recording (for `--help`-style inspection and tests).
StreamInfo read_recording_info(const std::string& path);

}  // namespace pvdf::hardware
