// A simulated front end: PVDF electrodes behind charge amplifiers and an ADC, driven by a small
// scene of press events, with noise, quantization and optional transport faults. Its frames
// go through the same encoder and decoder as a live device, so the whole chain runs without
// hardware. Scene keys are documented in docs/hardware.md ("Simulated device").
#pragma once

#include "pvdf/hardware/recording.hpp"
#include "pvdf/hardware/source.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace pvdf::hardware {

/// One press of the probe: a raised-cosine ramp to `force_N`, a hold, a raised-cosine release.
struct SimPress {
  double start_s = 0.1;
  double rise_s = 0.02;
  double hold_s = 0.2;
  double force_N = 1.0;
  std::vector<double> weights;  ///< share of the force seen by each channel (default 1 for all)
  /// Map-driven scenes: where the probe presses (m). The charges it produces come from a charge
  /// map, which this module does not read: the caller fills `charges_C` (see SimScene::map_path).
  std::optional<std::array<double, 2>> position_m;
  /// Charge of each channel (C) at the full force_N; when set it replaces weights × sensitivity,
  /// and the charge follows the press as (F(t)/force_N)^(2/3) (the membrane scaling law, docs/hardware.md).
  std::vector<double> charges_C;
  /// Force (N) at time t (s).
  double force_at(double t_s) const;
};

/// Transport faults injected every N frames (0 = never), to exercise the decoder's counters.
struct SimFaults {
  int drop_every = 0;        ///< frame never sent (a sequence gap)
  int duplicate_every = 0;   ///< frame sent twice
  int corrupt_every = 0;     ///< one payload byte flipped (CRC error)
  int garbage_every = 0;     ///< 37 random bytes inserted before the frame
};

/// The simulated device and its scene.
struct SimScene {
  int channels = 3;
  double sample_rate_Hz = 10000.0;   ///< seed 000 Table 1: 12-bit ADC at 10 kHz
  double duration_s = 1.0;
  int frame_samples = 100;           ///< samples per channel per frame
  int adc_bits = 12;
  double full_scale_V = 2.5;
  double noise_V = 0.002;            ///< RMS white noise at the amplifier output
  double sensitivity_C_per_N = 2.0e-11;  ///< film charge per newton (d33-like, 20 pC/N)
  double gain_V_per_C = 5.0e10;      ///< charge amplifier 1/C_f (50 mV/pC)
  /// The scene set gain_V_per_C itself (else an application may pick one that suits the
  /// charges it drives the presses with, e.g. a charge map's range).
  bool gain_given = false;
  double time_constant_s = 0.0;      ///< amplifier R_f·C_f; 0 = ideal (no decay)
  unsigned seed = 1;
  std::vector<SimPress> presses;
  SimFaults faults;
  /// Charge map driving the presses (scene key "map", resolved against the scene's folder);
  /// empty = weights × sensitivity. The application reads the map and fills every press's charges_C.
  std::string map_path;
  /// Recorded or simulated signals to play instead of presses (scene key "scan": a restore scan
  /// CSV `x_m,m1_V,m2_V`, resolved against the scene's folder); the application reads it and
  /// fills waveforms_V[channel][sample] (V at the amplifier output). Noise and the ADC still apply.
  std::string scan_path;
  std::vector<std::vector<double>> waveforms_V;
  /// Ideal amplifier output (V) of channel c at time t, before noise and quantization,
  /// for time_constant_s = 0.
  double ideal_output_V(int channel, double t_s) const;
  /// Charge (C) into channel c at time t.
  double charge_C(int channel, double t_s) const;
};

/// Reads a scene (strict: unknown keys are errors); `source` names it in messages.
SimScene parse_sim_scene(const nlohmann::json& json, const std::string& source);
SimScene load_sim_scene(const std::string& path);
/// The built-in scene: 3 channels at 10 kHz for 1 s, one 1 N press.
SimScene default_sim_scene();
/// Largest |charge| the presses' `charges_C` drive (C; 0 when none is set).
double largest_press_charge_C(const SimScene& scene);

class SimSource final : public Source {
 public:
  SimSource(SimScene scene, bool realtime, const std::string& description = "sim <built-in>");
  const StreamInfo& info() const override { return info_; }
  bool next(std::vector<SampleBlock>& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  EndReason end_reason() const override { return reason_; }
  StreamCounters counters() const override;

 private:
  /// Encodes the next frame (with faults) into bytes for the decoder.
  void produce(std::vector<std::uint8_t>& bytes);

  SimScene scene_;
  StreamInfo info_;
  FrameDecoder decoder_;
  Pacer pacer_;
  EndReason reason_ = EndReason::running;
  std::mt19937_64 rng_;
  std::normal_distribution<double> noise_{0.0, 1.0};
  std::uint32_t sequence_ = 0;
  std::int64_t sample_index_ = 0;
  std::int64_t n_samples_total_ = 0;
  std::vector<double> amp_state_V_;      ///< high-pass state per channel
  std::vector<double> previous_charge_C_;
  std::uint64_t frames_made_ = 0;
};

}  // namespace pvdf::hardware
