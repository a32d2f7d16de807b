// Stream info helpers, counters, and the device-specification parser that opens a Source.
#include "pvdf/hardware/source.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/hardware/recording.hpp"
#include "pvdf/hardware/sim_source.hpp"
#include "pvdf/hardware/usb_source.hpp"

#include <cmath>
#include <sstream>

namespace pvdf::hardware {

double StreamInfo::volts_per_count() const { return full_scale_V / std::ldexp(1.0, adc_bits - 1); }

BlockCharges block_mean_charges(const SampleBlock& block, const StreamInfo& info, double gain_V_per_C) {
  const Frame& f = block.frame;
  const int nc = f.n_channels;
  BlockCharges out;
  out.charge_C.assign(static_cast<std::size_t>(nc), 0.0);
  out.saturated = f.overflow;
  for (int i = 0; i < f.n_samples; ++i) {
    out.saturated = out.saturated || sample_clipped(f, i, info.adc_bits);
    for (int c = 0; c < nc; ++c) out.charge_C[static_cast<std::size_t>(c)] += f.counts[static_cast<std::size_t>(i * nc + c)];
  }
  for (auto& q : out.charge_C) q = q * info.volts_per_count() / f.n_samples / gain_V_per_C;
  return out;
}

double gain_for_peak_charge_V_per_C(double full_scale_V, double peak_charge_C, double fraction) {
  return fraction * full_scale_V / peak_charge_C;
}

std::vector<int> StreamInfo::channels() const {
  std::vector<int> list;
  for (int c = 0; c < protocol::max_channels; ++c)
    if (channel_mask & (1u << c)) list.push_back(c);
  return list;
}

const char* to_string(EndReason reason) {
  switch (reason) {
    case EndReason::running: return "running";
    case EndReason::end_of_data: return "end of data";
    case EndReason::stopped: return "stopped";
    case EndReason::disconnected: return "device disconnected";
    case EndReason::stalled: return "device stalled";
    case EndReason::failed: return "transfer failure";
  }
  return "unknown";
}

std::string StreamCounters::summary() const {
  std::ostringstream s;
  s << decoder.summary() << "; transfers " << transfers << ", timeouts " << transfer_timeouts << ", transfer errors "
    << transfer_errors;
  return s.str();
}

namespace {

/// Applies a gain given on the command line to a source that does not configure hardware.
class GainOverride final : public Source {
 public:
  GainOverride(std::unique_ptr<Source> inner, double gain_V_per_C) : inner_(std::move(inner)), info_(inner_->info()) {
    info_.gain_V_per_C = gain_V_per_C;
  }
  const StreamInfo& info() const override { return info_; }
  bool next(std::vector<SampleBlock>& out, std::chrono::milliseconds timeout) override { return inner_->next(out, timeout); }
  void stop() override { inner_->stop(); }
  EndReason end_reason() const override { return inner_->end_reason(); }
  std::string end_message() const override { return inner_->end_message(); }
  StreamCounters counters() const override { return inner_->counters(); }

 private:
  std::unique_ptr<Source> inner_;
  StreamInfo info_;
};

std::unique_ptr<Source> with_gain(std::unique_ptr<Source> source, double gain_mV_per_pC) {
  if (gain_mV_per_pC <= 0) return source;
  return std::make_unique<GainOverride>(std::move(source), gain_mV_per_pC * 1e9);  // mV/pC = 1e9 V/C
}

}  // namespace

std::unique_ptr<Source> open_source(const std::string& spec, const OpenOptions& options) {
  if (spec == "usb" || spec.rfind("usb:", 0) == 0) {
    std::uint16_t vid = 0, pid = 0;
    parse_usb_spec(spec, vid, pid);
    return std::make_unique<UsbSource>(vid, pid, options);
  }
  const auto not_for = [&](const char* kind) {
    if (options.sample_rate_Hz > 0 || options.channel_mask != 0)
      throw InputError(std::string("OpenOptions::sample_rate_Hz and OpenOptions::channel_mask configure a USB device; ") + kind +
                       " streams are what they are (edit the scene, or record with the settings you need)");
  };
  if (spec.rfind("replay:", 0) == 0) {
    not_for("replay");
    const std::string path = spec.substr(7);
    if (path.empty()) throw InputError("source spec replay:FILE: give the recording file, e.g. replay:run.pvdfrec");
    return with_gain(std::make_unique<ReplaySource>(path, options.realtime), options.gain_mV_per_pC);
  }
  if (spec.rfind("sim:", 0) == 0 || spec == "sim") {
    not_for("simulated");
    const std::string path = spec.size() > 4 ? spec.substr(4) : std::string();
    if (path.empty()) return open_sim(default_sim_scene(), "sim <built-in>", options);
    return open_sim(load_sim_scene(path), "sim " + path, options);
  }
  throw InputError("source spec " + spec + ": expected usb[:VID:PID], replay:FILE or sim:SCENE (sim: for the built-in scene)");
}

std::unique_ptr<Source> open_sim(const SimScene& scene, const std::string& description, const OpenOptions& options) {
  // The simulated device is the hardware: a gain given for it sets its amplifier (like a USB
  // device's), so volts and charges stay consistent.
  if (options.gain_mV_per_pC > 0) {
    SimScene with_gain_set = scene;
    with_gain_set.gain_V_per_C = options.gain_mV_per_pC * 1e9;  // mV/pC = 1e9 V/C
    with_gain_set.gain_given = true;
    return std::make_unique<SimSource>(with_gain_set, options.realtime, description);
  }
  return std::make_unique<SimSource>(scene, options.realtime, description);
}

}  // namespace pvdf::hardware
