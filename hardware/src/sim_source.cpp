// Simulated charge-amplifier front end (docs/hardware.md, "Simulated device").
#include "pvdf/hardware/sim_source.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/json_reader.hpp"
#include "pvdf/core/membrane_scaling.hpp"

#include <algorithm>
#include <cmath>

namespace pvdf::hardware {

namespace {
}

double SimPress::force_at(double t_s) const {
  const double t = t_s - start_s;
  if (t <= 0) return 0.0;
  if (t < rise_s) return force_N * 0.5 * (1 - std::cos(pi * t / rise_s));
  if (t <= rise_s + hold_s) return force_N;
  const double r = t - rise_s - hold_s;
  if (r < rise_s) return force_N * 0.5 * (1 + std::cos(pi * r / rise_s));
  return 0.0;
}

double SimScene::charge_C(int channel, double t_s) const {
  double charge = 0;
  for (const auto& p : presses) {
    const double force = p.force_at(t_s);
    if (!p.charges_C.empty()) {
      // Map-driven: Q(F) = Q(F_press)·(F/F_press)^(2/3), exact for the pure membrane (docs/hardware.md).
      if (force > 0 && p.force_N > 0)
        charge += p.charges_C[static_cast<std::size_t>(channel)] * pvdf::membrane_charge_factor(force / p.force_N);
      continue;
    }
    const double w = p.weights.empty() ? 1.0 : p.weights[static_cast<std::size_t>(channel)];
    charge += w * sensitivity_C_per_N * force;
  }
  return charge;
}

double SimScene::ideal_output_V(int channel, double t_s) const { return gain_V_per_C * charge_C(channel, t_s); }

double largest_press_charge_C(const SimScene& scene) {
  double largest = 0;
  for (const auto& p : scene.presses)
    for (const double q : p.charges_C)
      if (std::abs(q) > largest) largest = std::abs(q);
  return largest;
}

SimScene default_sim_scene() {
  SimScene s;
  SimPress p;
  p.weights = {1.0, 0.45, 0.2};
  s.presses.push_back(p);
  return s;
}

SimScene parse_sim_scene(const nlohmann::json& json, const std::string& source) {
  if (!json.is_object()) throw InputError(source + ": a simulation scene must be a JSON object");
  const JsonObjectReader r(source, "", json);
  SimScene s;
  s.channels = static_cast<int>(r.integer_or("channels", s.channels, 1, protocol::max_channels));
  s.sample_rate_Hz = r.in_range_or("sample_rate_Hz", s.sample_rate_Hz, 1.0, 1.0e6);
  s.duration_s = r.in_range_or("duration_s", s.duration_s, 1e-6, 86400.0);
  s.frame_samples = static_cast<int>(r.integer_or("frame_samples", s.frame_samples, 1, protocol::max_samples_per_frame));
  s.adc_bits = static_cast<int>(r.integer_or("adc_bits", s.adc_bits, 2, 16));
  s.full_scale_V = r.positive_or("full_scale_V", s.full_scale_V);
  s.noise_V = r.non_negative_or("noise_V", s.noise_V);
  s.sensitivity_C_per_N = r.number_or("sensitivity_C_per_N", s.sensitivity_C_per_N);
  s.gain_given = r.has("gain_V_per_C");
  s.gain_V_per_C = r.number_or("gain_V_per_C", s.gain_V_per_C);
  s.time_constant_s = r.non_negative_or("time_constant_s", s.time_constant_s);
  s.seed = static_cast<unsigned>(r.integer_or("seed", 1, 0, 0xFFFFFFFFL));
  if (r.has("presses")) {
    const auto& list = r.json().at("presses");
    if (!list.is_array()) r.fail("presses", "must be an array of press objects");
    (void)r.objects("presses");  // marks the key as read
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string where = "presses[" + std::to_string(i) + "]";
      if (!list[i].is_object()) throw InputError(source + ": " + where + " must be an object");
      // "weights" is a list of numbers, read here; the rest through the strict reader.
      nlohmann::json rest = list[i];
      SimPress p;
      if (rest.contains("weights")) {
        const auto& w = rest.at("weights");
        if (!w.is_array() || w.size() != static_cast<std::size_t>(s.channels))
          throw InputError(source + ": " + where + ".weights = " + json_excerpt(w) + " must be an array of " +
                           std::to_string(s.channels) + " numbers (one per channel)");
        for (const auto& v : w) {
          if (!v.is_number() || !std::isfinite(v.get<double>()))
            throw InputError(source + ": " + where + ".weights = " + json_excerpt(w) + " must hold finite numbers");
          p.weights.push_back(v.get<double>());
        }
        rest.erase("weights");
      }
      const JsonObjectReader pr(source, where, rest);
      if (pr.has("position_m")) p.position_m = pr.pair("position_m");
      p.start_s = pr.non_negative_or("start_s", p.start_s);
      p.rise_s = pr.positive_or("rise_s", p.rise_s);
      p.hold_s = pr.non_negative_or("hold_s", p.hold_s);
      p.force_N = pr.number_or("force_N", p.force_N);
      pr.finish();
      s.presses.push_back(p);
    }
  }
  const auto beside_scene = [&source](std::string path) {
    const auto slash = source.find_last_of('/');
    if (!path.empty() && path.front() != '/' && slash != std::string::npos) path = source.substr(0, slash + 1) + path;
    return path;
  };
  s.map_path = beside_scene(r.string_or("map", ""));
  s.scan_path = beside_scene(r.string_or("scan", ""));
  if (!s.scan_path.empty() && (!s.presses.empty() || !s.map_path.empty()))
    throw InputError(source + ": scan plays recorded signals; remove presses and map (or the scan)");
  for (std::size_t i = 0; i < s.presses.size(); ++i) {
    const auto& p = s.presses[i];
    const std::string where = source + ": presses[" + std::to_string(i) + "]";
    if (!s.map_path.empty() && !p.position_m)
      throw InputError(where + " needs position_m = [x, y] (m) because the scene names a map");
    if (!s.map_path.empty() && !p.weights.empty())
      throw InputError(where + ".weights: with a map the charges come from the map; remove weights");
    if (s.map_path.empty() && p.position_m)
      throw InputError(where + ".position_m needs a charge map: add \"map\": \"FILE.h5\" to the scene, or use weights");
  }
  if (const auto f = r.object_if("faults")) {
    s.faults.drop_every = static_cast<int>(f->integer_or("drop_every", 0, 0, 1000000));
    s.faults.duplicate_every = static_cast<int>(f->integer_or("duplicate_every", 0, 0, 1000000));
    s.faults.corrupt_every = static_cast<int>(f->integer_or("corrupt_every", 0, 0, 1000000));
    s.faults.garbage_every = static_cast<int>(f->integer_or("garbage_every", 0, 0, 1000000));
    f->finish();
  }
  r.finish();
  return s;
}

SimScene load_sim_scene(const std::string& path) { return parse_sim_scene(read_json_file(path), path); }

SimSource::SimSource(SimScene scene, bool realtime, const std::string& description)
    : scene_(std::move(scene)), pacer_(realtime), rng_(scene_.seed) {
  for (std::size_t i = 0; i < scene_.presses.size(); ++i) {
    const auto& p = scene_.presses[i];
    if (p.position_m && p.charges_C.size() != static_cast<std::size_t>(scene_.channels))
      throw InputError(description + ": presses[" + std::to_string(i) + "] at a position needs its charges from the map " +
                       scene_.map_path + " (" + std::to_string(scene_.channels) + " channels)");
  }
  if (!scene_.scan_path.empty() || !scene_.waveforms_V.empty()) {
    if (scene_.waveforms_V.size() != static_cast<std::size_t>(scene_.channels))
      throw InputError(description + ": the scan " + scene_.scan_path + " must give one signal per channel (" +
                       std::to_string(scene_.channels) + ")");
    for (const auto& w : scene_.waveforms_V)
      if (w.size() != scene_.waveforms_V.front().size())
        throw InputError(description + ": the scan's signals must have equal lengths");
    scene_.duration_s = static_cast<double>(scene_.waveforms_V.front().size()) / scene_.sample_rate_Hz;
  }
  info_.description = description;
  info_.sample_rate_Hz = scene_.sample_rate_Hz;
  info_.channel_mask = static_cast<std::uint16_t>((1u << scene_.channels) - 1u);
  info_.adc_bits = scene_.adc_bits;
  info_.full_scale_V = scene_.full_scale_V;
  info_.gain_V_per_C = scene_.gain_V_per_C;
  n_samples_total_ = static_cast<std::int64_t>(std::llround(scene_.duration_s * scene_.sample_rate_Hz));
  amp_state_V_.assign(static_cast<std::size_t>(scene_.channels), 0.0);
  previous_charge_C_.assign(static_cast<std::size_t>(scene_.channels), 0.0);
}

void SimSource::produce(std::vector<std::uint8_t>& bytes) {
  const int nc = scene_.channels;
  const int ns = static_cast<int>(std::min<std::int64_t>(scene_.frame_samples, n_samples_total_ - sample_index_));
  Frame f;
  f.sequence = sequence_++;
  f.n_channels = nc;
  f.n_samples = ns;
  f.channel_mask = info_.channel_mask;
  f.timestamp_us = static_cast<std::uint64_t>(std::llround(sample_index_ * 1e6 / scene_.sample_rate_Hz));
  f.counts.resize(static_cast<std::size_t>(nc) * static_cast<std::size_t>(ns));
  const double lsb = info_.volts_per_count();
  const double code_max = std::ldexp(1.0, scene_.adc_bits - 1) - 1;
  const double dt = 1.0 / scene_.sample_rate_Hz;
  const double decay = scene_.time_constant_s > 0 ? std::exp(-dt / scene_.time_constant_s) : 1.0;
  for (int i = 0; i < ns; ++i) {
    const double t = static_cast<double>(sample_index_ + i) * dt;
    for (int c = 0; c < nc; ++c) {
      // Charge amplifier: v = -q/C_f ideally (sign kept positive here); with a feedback
      // resistor it is a first-order high-pass, v[n] = a·(v[n-1] + G·(q[n] - q[n-1])), a = exp(-dt/τ).
      const double charge =
          scene_.waveforms_V.empty()
              ? scene_.charge_C(c, t)
              : scene_.waveforms_V[static_cast<std::size_t>(c)][static_cast<std::size_t>(sample_index_ + i)] / scene_.gain_V_per_C;
      double v;
      if (scene_.time_constant_s > 0) {
        const auto k = static_cast<std::size_t>(c);
        amp_state_V_[k] = decay * (amp_state_V_[k] + scene_.gain_V_per_C * (charge - previous_charge_C_[k]));
        previous_charge_C_[k] = charge;
        v = amp_state_V_[k];
      } else {
        v = scene_.gain_V_per_C * charge;
      }
      v += scene_.noise_V * noise_(rng_);
      const double code = std::clamp(std::round(v / lsb), -code_max - 1, code_max);
      f.counts[static_cast<std::size_t>(i * nc + c)] = static_cast<std::int16_t>(code);
    }
  }
  sample_index_ += ns;
  const auto every = [this](int n) { return n > 0 && frames_made_ % static_cast<std::uint64_t>(n) == static_cast<std::uint64_t>(n - 1); };
  const bool drop = every(scene_.faults.drop_every);
  const bool duplicate = every(scene_.faults.duplicate_every);
  const bool corrupt = every(scene_.faults.corrupt_every);
  const bool garbage = every(scene_.faults.garbage_every);
  ++frames_made_;
  if (drop) return;
  if (garbage) {
    // Garbage never containing the magic's first byte, so the count of skipped bytes is exact.
    for (int k = 0; k < 37; ++k) bytes.push_back(static_cast<std::uint8_t>(0x20 + (rng_() % 0x30)));
  }
  const std::size_t begin = bytes.size();
  encode_frame(f, bytes);
  if (corrupt) bytes[begin + protocol::header_size + (rng_() % (bytes.size() - begin - protocol::header_size - 4))] ^= 0x10;
  if (duplicate) {
    const std::vector<std::uint8_t> copy(bytes.begin() + static_cast<std::ptrdiff_t>(begin), bytes.end());
    bytes.insert(bytes.end(), copy.begin(), copy.end());
  }
}

bool SimSource::next(std::vector<SampleBlock>& out, std::chrono::milliseconds timeout) {
  if (pacer_.empty() && reason_ == EndReason::running) {
    // Produce about 50 ms of signal per call.
    const int frames_per_call = std::max(1, static_cast<int>(0.05 * scene_.sample_rate_Hz / scene_.frame_samples));
    std::vector<std::uint8_t> bytes;
    for (int k = 0; k < frames_per_call && sample_index_ < n_samples_total_; ++k) produce(bytes);
    std::vector<Frame> frames;
    decoder_.feed(bytes.data(), bytes.size(), frames);
    if (sample_index_ >= n_samples_total_) {
      decoder_.finish(frames);
      reason_ = EndReason::end_of_data;
    }
    std::vector<SampleBlock> blocks;
    for (auto& f : frames) blocks.push_back(SampleBlock{std::move(f)});
    pacer_.push(std::move(blocks));
  }
  const std::size_t before = out.size();
  pacer_.pop_due(out, timeout);
  return !(reason_ != EndReason::running && pacer_.empty() && out.size() == before);
}

void SimSource::stop() {
  if (reason_ == EndReason::running) reason_ = EndReason::stopped;
}

StreamCounters SimSource::counters() const {
  StreamCounters c;
  c.decoder = decoder_.counters();
  c.transfers = frames_made_;
  return c;
}

}  // namespace pvdf::hardware
