// Recording files (write with a flush per block, replay through the decoder) and real-time pacing.
#include "pvdf/hardware/recording.hpp"

#include "pvdf/core/error.hpp"

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cstring>
#include <thread>

namespace pvdf::hardware {

namespace {

constexpr char file_magic[8] = {'P', 'V', 'D', 'F', 'R', 'E', 'C', '1'};
constexpr std::uint32_t max_header_bytes = 1u << 20;

std::string errno_text() { return std::strerror(errno); }

nlohmann::json info_to_json(const StreamInfo& info) {
  return {{"format", "pvdfkit-recording"},
          {"version", 1},
          {"description", info.description},
          {"sample_rate_Hz", info.sample_rate_Hz},
          {"channel_mask", info.channel_mask},
          {"adc_bits", info.adc_bits},
          {"full_scale_V", info.full_scale_V},
          {"gain_V_per_C", info.gain_V_per_C}};
}

StreamInfo read_header(std::FILE* f, const std::string& path) {
  char magic[8];
  std::uint8_t len_bytes[4];
  if (std::fread(magic, 1, 8, f) != 8 || std::memcmp(magic, file_magic, 8) != 0)
    throw InputError(path + ": not a pvdfkit recording (it must start with PVDFREC1); record one with "
                            "'pvdfkit acquire'");
  if (std::fread(len_bytes, 1, 4, f) != 4)
    throw InputError(path + ": recording header is truncated; the file is damaged");
  const std::uint32_t len = static_cast<std::uint32_t>(len_bytes[0]) | (static_cast<std::uint32_t>(len_bytes[1]) << 8) |
                            (static_cast<std::uint32_t>(len_bytes[2]) << 16) |
                            (static_cast<std::uint32_t>(len_bytes[3]) << 24);
  if (len == 0 || len > max_header_bytes)
    throw InputError(path + ": recording header length " + std::to_string(len) + " must be in 1.." +
                     std::to_string(max_header_bytes) + "; the file is damaged");
  std::string text(len, '\0');
  if (std::fread(text.data(), 1, len, f) != len)
    throw InputError(path + ": recording header is truncated; the file is damaged");
  StreamInfo info;
  try {
    const auto j = nlohmann::json::parse(text);
    if (j.at("format").get<std::string>() != "pvdfkit-recording" || j.at("version").get<int>() != 1)
      throw InputError(path + ": recording format/version must be pvdfkit-recording/1");
    info.description = j.value("description", std::string());
    info.sample_rate_Hz = j.at("sample_rate_Hz").get<double>();
    info.channel_mask = j.at("channel_mask").get<std::uint16_t>();
    info.adc_bits = j.at("adc_bits").get<int>();
    info.full_scale_V = j.at("full_scale_V").get<double>();
    info.gain_V_per_C = j.value("gain_V_per_C", 0.0);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path + ": recording header is not valid (" + std::string(e.what()) + "); the file is damaged");
  }
  if (!(info.sample_rate_Hz > 0) || info.channel_mask == 0 || info.adc_bits < 2 || info.adc_bits > 16 ||
      !(info.full_scale_V > 0) || !(info.gain_V_per_C >= 0))
    throw InputError(path + ": recording header has sample_rate_Hz, channel_mask, adc_bits or full_scale_V out of range");
  return info;
}

}  // namespace

Recorder::Recorder(const std::string& path, const StreamInfo& info) : path_(path) {
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) throw InputError("Recorder path " + path + ": cannot create the file (" + errno_text() + ")");
  const std::string header = info_to_json(info).dump();
  const std::uint32_t len = static_cast<std::uint32_t>(header.size());
  const std::uint8_t len_bytes[4] = {static_cast<std::uint8_t>(len), static_cast<std::uint8_t>(len >> 8),
                                     static_cast<std::uint8_t>(len >> 16), static_cast<std::uint8_t>(len >> 24)};
  const bool ok = std::fwrite(file_magic, 1, 8, file_) == 8 && std::fwrite(len_bytes, 1, 4, file_) == 4 &&
                  std::fwrite(header.data(), 1, header.size(), file_) == header.size() && std::fflush(file_) == 0;
  if (!ok) {
    std::fclose(file_);
    file_ = nullptr;
    throw InputError("Recorder path " + path + ": cannot write the header (" + errno_text() + ")");
  }
}

Recorder::~Recorder() {
  if (file_ != nullptr) std::fclose(file_);
}

void Recorder::write(const std::vector<SampleBlock>& blocks) {
  if (file_ == nullptr || blocks.empty()) return;
  scratch_.clear();
  for (const auto& b : blocks) encode_frame(b.frame, scratch_);
  if (std::fwrite(scratch_.data(), 1, scratch_.size(), file_) != scratch_.size() || std::fflush(file_) != 0)
    throw InputError("Recorder path " + path_ + ": write failed (" + errno_text() + "); the disk may be full");
  frames_written_ += blocks.size();
}

void Recorder::close() {
  if (file_ == nullptr) return;
  const bool ok = std::fflush(file_) == 0;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || !closed) throw InputError("Recorder path " + path_ + ": closing failed (" + errno_text() + ")");
}

void Pacer::push(std::vector<SampleBlock>&& blocks) {
  for (auto& b : blocks) queue_.push_back(std::move(b));
}

void Pacer::pop_due(std::vector<SampleBlock>& out, std::chrono::milliseconds timeout) {
  using clock = std::chrono::steady_clock;
  if (!realtime_) {
    for (auto& b : queue_) out.push_back(std::move(b));
    queue_.clear();
    return;
  }
  if (queue_.empty()) return;
  if (!started_) {
    started_ = true;
    first_timestamp_us_ = queue_.front().frame.timestamp_us;
    start_ = clock::now();
  }
  const auto deadline = clock::now() + timeout;
  const std::size_t before = out.size();
  while (!queue_.empty()) {
    const auto offset = std::chrono::microseconds(
        static_cast<std::int64_t>(queue_.front().frame.timestamp_us - first_timestamp_us_));
    const auto due = start_ + offset;
    const auto now = clock::now();
    if (due > now) {
      if (out.size() > before || due > deadline) break;
      std::this_thread::sleep_until(due);
    }
    out.push_back(std::move(queue_.front()));
    queue_.pop_front();
  }
}

ReplaySource::ReplaySource(const std::string& path, bool realtime) : path_(path), pacer_(realtime), chunk_(1 << 16) {
  file_ = std::fopen(path.c_str(), "rb");
  if (file_ == nullptr) throw InputError("replay:" + path + ": cannot open the recording (" + errno_text() + ")");
  try {
    info_ = read_header(file_, path);
  } catch (...) {
    std::fclose(file_);
    file_ = nullptr;
    throw;
  }
  info_.description = "replay " + path + (info_.description.empty() ? "" : " (" + info_.description + ")");
}

ReplaySource::~ReplaySource() {
  if (file_ != nullptr) std::fclose(file_);
}

bool ReplaySource::next(std::vector<SampleBlock>& out, std::chrono::milliseconds timeout) {
  if (pacer_.empty() && file_ != nullptr && reason_ == EndReason::running) {
    const std::size_t n = std::fread(chunk_.data(), 1, chunk_.size(), file_);
    ++reads_;
    std::vector<Frame> frames;
    decoder_.feed(chunk_.data(), n, frames);
    if (n < chunk_.size()) {
      decoder_.finish(frames);
      reason_ = EndReason::end_of_data;
    }
    std::vector<SampleBlock> blocks;
    blocks.reserve(frames.size());
    for (auto& f : frames) blocks.push_back(SampleBlock{std::move(f)});
    pacer_.push(std::move(blocks));
  }
  const std::size_t before = out.size();
  pacer_.pop_due(out, timeout);
  return !(reason_ != EndReason::running && pacer_.empty() && out.size() == before);
}

void ReplaySource::stop() {
  if (reason_ == EndReason::running) reason_ = EndReason::stopped;
}

StreamCounters ReplaySource::counters() const {
  StreamCounters c;
  c.decoder = decoder_.counters();
  c.transfers = reads_;
  return c;
}

StreamInfo read_recording_info(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw InputError(path + ": cannot open the recording (" + errno_text() + ")");
  try {
    StreamInfo info = read_header(f, path);
    std::fclose(f);
    return info;
  } catch (...) {
    std::fclose(f);
    throw;
  }
}

}  // namespace pvdf::hardware
