// `pvdfkit acquire`: stream a PVDF charge-amplifier front end (USB, a replayed recording or the
// simulator) as CSV — raw samples, or through a pluggable stage: press locations from a charge
// map (--locate, mapping module) or restored forces (--restore, restore module). Ctrl-C stops
// cleanly: everything received is written out (docs/hardware.md).
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/hardware/recording.hpp"
#include "pvdf/hardware/sim_source.hpp"
#include "pvdf/hardware/source.hpp"

#if __has_include("pvdf/mapping/locator.hpp") && __has_include("pvdf/mapping/map.hpp")
#define PVDF_ACQUIRE_HAVE_MAPPING 1
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/stream.hpp"
#include "pvdf/mapping/tracker.hpp"
#endif
#if __has_include("pvdf/restore/apply.hpp") && __has_include("pvdf/restore/filter.hpp") && \
    __has_include("pvdf/restore/scan_io.hpp")
#define PVDF_ACQUIRE_HAVE_RESTORE 1
#include "pvdf/restore/apply.hpp"
#include "pvdf/restore/filter.hpp"
#include "pvdf/restore/scan_io.hpp"
#endif

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <sstream>

namespace {

using pvdf::hardware::SampleBlock;
using pvdf::hardware::StreamInfo;

volatile std::sig_atomic_t interrupted = 0;
extern "C" void on_acquire_interrupt(int) { interrupted = 1; }  // C linkage: the name is global, keep it unique

struct AcquireOptions {
  std::string device = "sim:";
  std::string record_path;
  std::string locate_map;
  std::string restore_filter;
  std::string output_path;
  std::string channels;
  std::string force_range;
  double rate_Hz = 0;
  double gain_mV_per_pC = 0;
  bool gain_given = false;
  double duration_s = 0;
  double stall_timeout_s = 2.0;
  int transfers = 8;
  bool realtime = false;
  bool quiet = false;
};

/// CSV output: stdout or a file written as the stream goes (flushed per block, so a killed
/// run keeps its rows; deliberately not atomic, like the recording).
class CsvOut {
 public:
  explicit CsvOut(const std::string& path) : path_(path) {
    if (path.empty()) {
      file_ = stdout;
    } else {
      file_ = std::fopen(path.c_str(), "w");
      if (file_ == nullptr) throw pvdf::InputError("--output " + path + ": cannot create the file (" + std::strerror(errno) + ")");
    }
  }
  ~CsvOut() {
    if (file_ != nullptr && file_ != stdout) std::fclose(file_);
  }
  std::FILE* get() { return file_; }
  void flush() {
    if (std::fflush(file_) != 0 && !path_.empty())
      throw pvdf::InputError("--output " + path_ + ": write failed (" + std::strerror(errno) + ")");
  }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
};

/// A processing stage between the source and the CSV: writes its header, then rows per block.
class Stage {
 public:
  virtual ~Stage() = default;
  virtual void header(std::FILE* out) = 0;
  virtual void process(const SampleBlock& block, std::FILE* out) = 0;
  virtual void finish(std::FILE*) {}
};

/// Raw samples: t_s, then one column of volts per streamed channel.
class SamplesStage final : public Stage {
 public:
  explicit SamplesStage(const StreamInfo& info) : info_(info), lsb_V_(info.volts_per_count()) {}
  void header(std::FILE* out) override {
    std::fprintf(out, "t_s");
    for (const int c : info_.channels()) std::fprintf(out, ",ch%d_V", c);
    std::fprintf(out, "\n");
  }
  void process(const SampleBlock& b, std::FILE* out) override {
    const int nc = b.frame.n_channels;
    for (int i = 0; i < b.frame.n_samples; ++i) {
      std::fprintf(out, "%.7f", b.time_s(i, info_.sample_rate_Hz));
      for (int c = 0; c < nc; ++c) std::fprintf(out, ",%.7g", b.frame.counts[static_cast<std::size_t>(i * nc + c)] * lsb_V_);
      std::fputc('\n', out);
    }
  }

 private:
  StreamInfo info_;
  double lsb_V_;
};

#ifdef PVDF_ACQUIRE_HAVE_MAPPING
double charge_gain_V_per_C(const StreamInfo& info, const char* flag) {
  if (!(info.gain_V_per_C > 0))
    throw pvdf::InputError(std::string(flag) + " needs the charge-amplifier gain to turn volts into charge; give "
                                               "--gain-mV-per-pC (the amplifier's sensitivity)");
  return info.gain_V_per_C;
}

/// Press locations: one per block, from the block-mean charges (q = V / gain), channel k
/// taken as the map's electrode k. A block with a clipped sample (an ADC code at its limits)
/// or the device's overflow flag is `saturated` and not located: its charges are unknown.
class LocateStage final : public Stage {
 public:
  LocateStage(const StreamInfo& info, const std::string& map_path, const pvdf::mapping::LocatorOptions& options)
      : info_(info), map_(pvdf::mapping::read_map(map_path)), locator_(map_, options),
        gain_V_per_C_(charge_gain_V_per_C(info, "--locate")) {
    if (info.channels().size() != locator_.n_electrodes())
      throw pvdf::InputError("--locate " + map_path + ": the map has " + std::to_string(locator_.n_electrodes()) +
                             " electrodes but the stream has " + std::to_string(info.channels().size()) +
                             " channels; stream one channel per electrode, in the map's order");
    // Front-end sanity: the map's charges (at its highest level) must fit the ADC's range.
    const double peak_V = map_.largest_charge_C() * gain_V_per_C_;
    if (peak_V > info.full_scale_V) {
      char text[320];
      std::snprintf(text, sizeof text,
                    "the map %s reaches %g pC, %g V at the gain of %g mV/pC: beyond the front end's %g V full scale, "
                    "so presses there clip (rows flagged saturated); lower --gain-mV-per-pC to at most %g",
                    map_path.c_str(), map_.largest_charge_C() * 1e12, peak_V, gain_V_per_C_ * 1e-9, info.full_scale_V,
                    gain_V_per_C_ * 1e-9 * info.full_scale_V / peak_V);
      pvdf::app::warn(text);
    }
  }
  void header(std::FILE* out) override { std::fprintf(out, "%s\n", pvdf::mapping::stream_output_header().c_str()); }
  void process(const SampleBlock& b, std::FILE* out) override {
    const pvdf::hardware::BlockCharges q = pvdf::hardware::block_mean_charges(b, info_, gain_V_per_C_);
    pvdf::mapping::Location r;
    if (q.saturated) {
      r.flags = pvdf::mapping::flag::saturated;
      ++n_saturated_;
      tracker_.reset();  // the press is lost while clipped: search afresh after it
    } else {
      r = tracker_.next(q.charge_C.data());
    }
    const double t = b.time_s(0, info_.sample_rate_Hz) + 0.5 * (b.frame.n_samples - 1) / info_.sample_rate_Hz;
    std::fprintf(out, "%.7f,%s\n", t, pvdf::mapping::stream_row_fields(r).c_str());
  }
  void finish(std::FILE*) override {
    if (n_saturated_ > 0) {
      pvdf::app::warn(std::to_string(n_saturated_) + " frame(s) clipped or overflowed: flagged saturated, not located");
    }
  }

 private:
  StreamInfo info_;
  pvdf::mapping::ChargeMap map_;
  pvdf::mapping::Locator locator_;
  pvdf::mapping::Tracker tracker_{locator_};
  double gain_V_per_C_;
  std::size_t n_saturated_ = 0;
};
#endif

#ifdef PVDF_ACQUIRE_HAVE_RESTORE
/// Restored forces (f_x, f_z) from the first two streamed channels (m1, m2), block by block
/// with the restore module's streaming overlap-save filter. The filter was designed per scan
/// sample, so the stream's samples must be those scan samples (constant scan speed).
class RestoreStage final : public Stage {
 public:
  RestoreStage(const StreamInfo& info, const std::string& filter_path)
      : info_(info), filter_(pvdf::restore::load_filter(filter_path)) {
    if (info.channels().size() < 2)
      throw pvdf::InputError("--restore " + filter_path + ": needs two channels (m1, m2); the stream has " +
                             std::to_string(info.channels().size()));
    restorer_ = std::make_unique<pvdf::restore::StreamingRestorer>(filter_, 1024);
  }
  void header(std::FILE* out) override { std::fprintf(out, "t_s,fx_N,fz_N\n"); }
  void process(const SampleBlock& b, std::FILE* out) override {
    if (!started_) {
      started_ = true;
      t0_s_ = b.time_s(0, info_.sample_rate_Hz);
    }
    const int nc = b.frame.n_channels;
    m1_.resize(static_cast<std::size_t>(b.frame.n_samples));
    m2_.resize(m1_.size());
    for (int i = 0; i < b.frame.n_samples; ++i) {
      m1_[static_cast<std::size_t>(i)] = b.frame.counts[static_cast<std::size_t>(i * nc)] * info_.volts_per_count();
      m2_[static_cast<std::size_t>(i)] = b.frame.counts[static_cast<std::size_t>(i * nc + 1)] * info_.volts_per_count();
    }
    fx_.clear();
    fz_.clear();
    restorer_->push(m1_.data(), m2_.data(), m1_.size(), fx_, fz_);
    write(out);
  }
  void finish(std::FILE* out) override {
    fx_.clear();
    fz_.clear();
    restorer_->flush(fx_, fz_);
    write(out);
  }

 private:
  void write(std::FILE* out) {
    for (std::size_t k = 0; k < fx_.size(); ++k, ++emitted_)
      std::fprintf(out, "%.7f,%.9g,%.9g\n", t0_s_ + static_cast<double>(emitted_) / info_.sample_rate_Hz, fx_[k], fz_[k]);
  }
  StreamInfo info_;
  pvdf::restore::InverseFilter filter_;
  std::unique_ptr<pvdf::restore::StreamingRestorer> restorer_;
  std::vector<double> m1_, m2_, fx_, fz_;
  bool started_ = false;
  double t0_s_ = 0;
  std::size_t emitted_ = 0;
};
#endif

std::unique_ptr<Stage> make_stage(const AcquireOptions& o, const StreamInfo& info) {
  if (!o.locate_map.empty() && !o.restore_filter.empty())
    throw pvdf::InputError("--locate and --restore: choose one stage");
  if (!o.locate_map.empty()) {
#ifdef PVDF_ACQUIRE_HAVE_MAPPING
    pvdf::mapping::LocatorOptions options;
    options.valley_sigma_cells = 0;  // a stream: linearised σ's (docs/lookup.md §1.6)
    if (!o.force_range.empty()) {
      const auto range = pvdf::parse_number_list(o.force_range, "--force-range-N", 2);
      if (!(range[0] > 0 && range[1] > range[0]))
        throw pvdf::InputError("--force-range-N " + o.force_range + ": expected MIN,MAX with 0 < MIN < MAX (N)");
      options.min_force_N = range[0];
      options.max_force_N = range[1];
    }
    return std::make_unique<LocateStage>(info, o.locate_map, options);
#else
    throw pvdf::InputError("--locate: not available in this build (the mapping module, pvdf::mapping, was not built)");
#endif
  }
  if (!o.force_range.empty()) throw pvdf::InputError("--force-range-N applies to --locate; add --locate MAP");
  if (!o.restore_filter.empty()) {
#ifdef PVDF_ACQUIRE_HAVE_RESTORE
    return std::make_unique<RestoreStage>(info, o.restore_filter);
#else
    throw pvdf::InputError("--restore: not available in this build (the restore module, pvdf::restore, was not built)");
#endif
  }
  return std::make_unique<SamplesStage>(info);
}

/// Opens the source; a simulated scene that names a charge map gets its press charges from
/// the map here (the hardware module does not read maps): Q at each press's position and force.
std::unique_ptr<pvdf::hardware::Source> open_any_source(const std::string& device, const pvdf::hardware::OpenOptions& open,
                                                        bool quiet) {
  if (device.rfind("sim:", 0) != 0 || device.size() == 4) return pvdf::hardware::open_source(device, open);
  const std::string path = device.substr(4);
  pvdf::hardware::SimScene scene = pvdf::hardware::load_sim_scene(path);
  if (scene.map_path.empty() && scene.scan_path.empty()) return pvdf::hardware::open_source(device, open);
  if (open.sample_rate_Hz > 0 || open.channel_mask != 0)
    throw pvdf::InputError("--rate-Hz and --channels configure a USB device; simulated streams are what the scene says");
  if (!scene.scan_path.empty()) {
#ifdef PVDF_ACQUIRE_HAVE_RESTORE
    // The scanner simulator's (or a measured) scan, played sample by sample as m1, m2.
    const auto scan = pvdf::restore::read_scan_csv(scene.scan_path);
    if (scene.channels != 2)
      throw pvdf::InputError(path + ": channels = " + std::to_string(scene.channels) + " but a scan has two signals (m1, m2); set channels to 2");
    scene.waveforms_V = {scan.m1_V, scan.m2_V};
    return pvdf::hardware::open_sim(scene, "sim " + path + " (scan " + scene.scan_path + ")", open);
#else
    throw pvdf::InputError(path + ": scan playback is not available in this build (the restore module, pvdf::restore, "
                           "was not built)");
#endif
  }
#ifdef PVDF_ACQUIRE_HAVE_MAPPING
  const pvdf::mapping::ChargeMap map = pvdf::mapping::read_map(scene.map_path);
  const pvdf::mapping::Locator model(map);
  if (model.n_electrodes() != static_cast<std::size_t>(scene.channels))
    throw pvdf::InputError(path + ": channels = " + std::to_string(scene.channels) + " but the map " + scene.map_path +
                           " has " + std::to_string(model.n_electrodes()) + " electrodes; make them equal");
  for (std::size_t i = 0; i < scene.presses.size(); ++i) {
    auto& p = scene.presses[i];
    p.charges_C.assign(model.n_electrodes(), 0.0);
    if (!model.predict((*p.position_m)[0], (*p.position_m)[1], p.force_N, p.charges_C.data()))
      throw pvdf::InputError(path + ": presses[" + std::to_string(i) + "].position_m = [" +
                             std::to_string((*p.position_m)[0]) + ", " + std::to_string((*p.position_m)[1]) +
                             "] with force_N = " + std::to_string(p.force_N) + " is outside the map " + scene.map_path +
                             "; move it inside the film (away from the rim)");
  }
  // The simulated amplifier's default gain suits the map: its largest charge (or a press's)
  // at 80 % of the ADC's full scale, unless the scene or --gain-mV-per-pC sets the gain.
  if (!scene.gain_given && !(open.gain_mV_per_pC > 0)) {
    const double peak_C = std::max(map.largest_charge_C(), pvdf::hardware::largest_press_charge_C(scene));
    if (peak_C > 0) {
      scene.gain_V_per_C = pvdf::hardware::gain_for_peak_charge_V_per_C(scene.full_scale_V, peak_C);
      if (!quiet)
        std::fprintf(stderr, "acquire: simulated amplifier gain %.4g mV/pC (the map's largest charge, %.4g pC, at 80 %% of "
                             "the %g V full scale; set gain_V_per_C in the scene or --gain-mV-per-pC to choose)\n",
                     scene.gain_V_per_C * 1e-9, peak_C * 1e12, scene.full_scale_V);
    }
  }
  return pvdf::hardware::open_sim(scene, "sim " + path + " (map " + scene.map_path + ")", open);
#else
  throw pvdf::InputError(path + ": map-driven simulation is not available in this build (the mapping module, "
                         "pvdf::mapping, was not built)");
#endif
}

std::uint16_t parse_channels(const std::string& text) {
  if (text.empty()) return 0;
  std::uint16_t mask = 0;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const long c = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || *end != '\0' || c < 0 || c >= pvdf::hardware::protocol::max_channels)
      throw pvdf::InputError("--channels " + text + ": expected a list of channel numbers 0..15, e.g. 0,1,2");
    mask = static_cast<std::uint16_t>(mask | (1u << c));
  }
  return mask;
}

/// The hardware module's messages name its option fields; the user typed flags. Each field the
/// module names is mapped to the flag that sets it.
std::string with_flag_names(std::string message) {
  static const std::pair<const char*, const char*> fields[] = {{"OpenOptions::sample_rate_Hz", "--rate-Hz"},
                                                               {"OpenOptions::channel_mask", "--channels"},
                                                               {"source spec ", "--device "},
                                                               {"Recorder path ", "--record "}};
  for (const auto& [field, flag] : fields) {
    for (std::size_t at = message.find(field); at != std::string::npos; at = message.find(field, at + 1)) {
      message.replace(at, std::strlen(field), flag);
    }
  }
  return message;
}

int run_acquire(const AcquireOptions& o) {
  if (o.duration_s < 0) throw pvdf::InputError("--duration-s " + std::to_string(o.duration_s) + " must be >= 0 (0 = until the stream ends)");
  pvdf::hardware::OpenOptions open;
  open.sample_rate_Hz = o.rate_Hz;
  open.channel_mask = parse_channels(o.channels);
  open.gain_mV_per_pC = o.gain_mV_per_pC;
  open.realtime = o.realtime;
  open.transfers_in_flight = o.transfers;
  open.stall_timeout_s = o.stall_timeout_s;
  if (o.transfers < 1 || o.transfers > 64) throw pvdf::InputError("--transfers " + std::to_string(o.transfers) + " must be in 1..64");

  if (o.gain_given && !(o.gain_mV_per_pC > 0 && std::isfinite(o.gain_mV_per_pC))) {
    char text[160];
    std::snprintf(text, sizeof text, "--gain-mV-per-pC %g: must be finite and > 0 (mV/pC); omit it to use the device's",
                  o.gain_mV_per_pC);
    throw pvdf::InputError(text);
  }
  auto source = open_any_source(o.device, open, o.quiet);
  const StreamInfo info = source->info();
  auto stage = make_stage(o, info);
  std::optional<pvdf::hardware::Recorder> recorder;
  if (!o.record_path.empty()) recorder.emplace(o.record_path, info);
  CsvOut out(o.output_path);
  if (!o.quiet)
    std::fprintf(stderr, "acquire: %s, %g Hz, channels %s, %d-bit ADC, %g V full scale\n", info.description.c_str(),
                 info.sample_rate_Hz, o.channels.empty() ? "all" : o.channels.c_str(), info.adc_bits, info.full_scale_V);

  interrupted = 0;
  auto* previous = std::signal(SIGINT, on_acquire_interrupt);
  bool stop_sent = false, by_user = false;
  std::uint64_t samples = 0;
  double first_t = -1, last_t = 0;
  std::vector<SampleBlock> batch;
  stage->header(out.get());
  try {
    while (true) {
      batch.clear();
      const bool more = source->next(batch, std::chrono::milliseconds(100));
      if (recorder) recorder->write(batch);  // first to disk: the recording is the primary record
      for (const auto& b : batch) {
        stage->process(b, out.get());
        samples += static_cast<std::uint64_t>(b.frame.n_samples);
        if (first_t < 0) first_t = b.time_s(0, info.sample_rate_Hz);
        last_t = b.time_s(b.frame.n_samples, info.sample_rate_Hz);
      }
      if (!batch.empty()) out.flush();
      if (!more) break;
      if (!stop_sent && interrupted) {
        by_user = true;
        stop_sent = true;
        source->stop();
      }
      if (!stop_sent && o.duration_s > 0 && first_t >= 0 && last_t - first_t >= o.duration_s) {
        stop_sent = true;
        source->stop();
      }
    }
    stage->finish(out.get());
    out.flush();
    if (recorder) recorder->close();
  } catch (...) {
    std::signal(SIGINT, previous);
    throw;
  }
  std::signal(SIGINT, previous);

  const auto counters = source->counters();
  const auto reason = source->end_reason();
  const bool broken = reason == pvdf::hardware::EndReason::disconnected || reason == pvdf::hardware::EndReason::stalled ||
                      reason == pvdf::hardware::EndReason::failed;
  if (!o.quiet || broken || counters.decoder.any_fault())
    std::fprintf(stderr, "acquire: %s after %llu samples per channel; %s\n", pvdf::hardware::to_string(reason),
                 static_cast<unsigned long long>(samples), counters.summary().c_str());
  if (counters.decoder.any_fault())
    pvdf::app::warn("the stream had losses or damaged frames (counted above); the data around them is incomplete");
  if (broken) {
    std::string saved = "everything received was written out";
    if (recorder) saved += " (" + std::to_string(recorder->frames_written()) + " frames in " + o.record_path + ")";
    std::fprintf(stderr, "error: %s; %s\n", source->end_message().c_str(), saved.c_str());
    return pvdf::exit_code::bad_input;
  }
  if (by_user) return pvdf::exit_code::interrupted;
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(70, [](CLI::App& root) {
  auto* sub = root.add_subcommand(
      "acquire", "Stream a PVDF charge-amplifier front end (USB, a recording, or the simulator) as CSV: samples, "
                 "press locations (--locate) or restored forces (--restore); see docs/hardware.md");
  auto o = std::make_shared<AcquireOptions>();
  sub->add_option("--device", o->device,
                  "usb | usb:VID:PID (hex) | replay:FILE | sim:SCENE (sim: = built-in 3-channel scene) (default sim:)");
  sub->add_option("--record", o->record_path, "Also record the stream to FILE (.pvdfrec, replay with --device replay:FILE)")
      ->check(pvdf::app::output_file());
  sub->add_option("--locate", o->locate_map, "Locate presses with this charge map (one row per frame)");
  sub->add_option("--restore", o->restore_filter, "Restore forces f_x, f_z with this inverse filter (first two streamed channels = m1, m2)");
  sub->add_option("--force-range-N", o->force_range,
                  "--locate: plausible forces MIN,MAX (N), removes the second solution three electrodes often have");
  sub->add_option("--output", o->output_path, "Write the CSV to FILE instead of stdout (rows flushed per frame)")
      ->check(pvdf::app::output_file());
  sub->add_option("--rate-Hz", o->rate_Hz, "usb: sample rate per channel (Hz) (default the device's)")
      ->check(pvdf::app::number_in(0, 1e7, "Hz (0 = the device's)"));
  sub->add_option("--channels", o->channels, "usb: channels to stream, e.g. 0,1,2 (default the device's)");
  sub->add_option("--gain-mV-per-pC", o->gain_mV_per_pC,
                  "Charge-amplifier sensitivity (mV/pC): set on a usb device (and the simulator), and used to turn volts into "
                  "charge for --locate (default the device's)")
      ->check(pvdf::app::number_in(0, 1e6, "mV/pC", true))
      ->each([o](const std::string&) { o->gain_given = true; });
  sub->add_option("--duration-s", o->duration_s, "Stop after this much signal (s); 0 = until the stream ends or Ctrl-C (default 0)")
      ->check(pvdf::app::number_in(0, 1e7, "s (0 = until the stream ends)"));
  sub->add_option("--stall-timeout-s", o->stall_timeout_s, "usb: give up when no data arrives for this long (s) (default 2)")
      ->check(pvdf::app::number_in(0, 3600, "s", true));
  sub->add_option("--transfers", o->transfers, "usb: bulk transfers kept in flight (default 8)")
      ->check(pvdf::app::integer_in(1, 64, ""));
  sub->add_flag("--realtime", o->realtime, "replay/sim: deliver at the recorded pace instead of as fast as possible");
  sub->add_flag("--quiet", o->quiet, "No progress lines on stderr (faults and errors are still reported)");
  return pvdf::app::Subcommand{sub, [o] {
    try {
      return run_acquire(*o);
    } catch (const pvdf::InputError& e) {
      throw pvdf::InputError(with_flag_names(e.what()));
    }
  }};
});
