// Where samples come from: the Source interface shared by the USB front end, replayed
// recordings and the simulated device, and the sample blocks they deliver.
#pragma once

#include "pvdf/hardware/frame.hpp"

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace pvdf::hardware {

/// What a stream carries; fixed once the source is open.
struct StreamInfo {
  std::string description;          ///< e.g. "usb 1209:0001 bus 1 address 5", "replay run.pvdfrec"
  double sample_rate_Hz = 10000.0;  ///< per channel
  std::uint16_t channel_mask = 0x7; ///< channels streamed (bit i = channel i)
  int adc_bits = 12;
  double full_scale_V = 2.5;        ///< amplifier output at ADC code 2^(adc_bits-1)
  double gain_V_per_C = 0;          ///< charge-amplifier gain (output V per input C); 0 = unknown
  /// Volts per ADC count: full_scale_V / 2^(adc_bits-1).
  double volts_per_count() const;
  /// Indices of the streamed channels, increasing.
  std::vector<int> channels() const;
};

/// A block of samples: one checked frame, with its place in the stream.
struct SampleBlock {
  Frame frame;                      ///< counts, sequence, device timestamp
  /// Time of sample i (s, device clock): timestamp_us·1e-6 + i / sample_rate_Hz.
  double time_s(int i, double sample_rate_Hz) const {
    return static_cast<double>(frame.timestamp_us) * 1e-6 + i / sample_rate_Hz;
  }
};

/// A block's charges: each streamed channel's mean ADC count over the block's samples, in volts
/// (StreamInfo::volts_per_count) and in charge q = V / gain_V_per_C (C), in channel order.
/// `saturated` when a sample sits at the ADC's limits (sample_clipped) or the device flagged an
/// overflow: the charges are then not known.
struct BlockCharges {
  std::vector<double> charge_C;
  bool saturated = false;
};
/// The charges of `block` at amplifier gain `gain_V_per_C` (V/C, > 0); see BlockCharges.
BlockCharges block_mean_charges(const SampleBlock& block, const StreamInfo& info, double gain_V_per_C);

/// The charge-amplifier gain (V/C) that puts the charge `peak_charge_C` (> 0) at `fraction` of the
/// ADC's full scale `full_scale_V`: the simulated amplifier's default.
double gain_for_peak_charge_V_per_C(double full_scale_V, double peak_charge_C, double fraction = 0.8);

/// Why a stream ended (or that it has not).
enum class EndReason {
  running,          ///< still streaming
  end_of_data,      ///< replay file or simulation finished: a normal end
  stopped,          ///< stop() was called (duration reached, Ctrl-C)
  disconnected,     ///< the device went away mid-stream
  stalled,          ///< no data for longer than the stall timeout
  failed            ///< a transfer error other than the above (message in end_message)
};
const char* to_string(EndReason reason);

/// Counters of a stream: the decoder's, plus the transport's.
struct StreamCounters {
  DecoderCounters decoder;
  std::uint64_t transfers = 0;         ///< USB transfers completed (or file reads)
  std::uint64_t transfer_timeouts = 0; ///< transfers that timed out (data in them is kept)
  std::uint64_t transfer_errors = 0;   ///< transfers that failed otherwise
  std::string summary() const;
};

/// A stream of sample blocks. Not thread-safe: one thread calls next() until it returns false.
class Source {
 public:
  virtual ~Source() = default;
  virtual const StreamInfo& info() const = 0;
  /// Waits up to `timeout` for blocks; appends what arrived to `out` (possibly nothing).
  /// Returns false once the stream has ended and every block received has been delivered.
  virtual bool next(std::vector<SampleBlock>& out, std::chrono::milliseconds timeout) = 0;
  /// Asks the source to stop; blocks already received are still delivered by next().
  virtual void stop() = 0;
  virtual EndReason end_reason() const = 0;
  /// One line explaining the end when it was not normal (empty otherwise).
  virtual std::string end_message() const { return {}; }
  virtual StreamCounters counters() const = 0;
};

/// Opens a source from a device specification:
///   "usb", "usb:VID:PID" (hexadecimal)  — the USB front end (see UsbOptions)
///   "replay:FILE"                        — a recording made with Recorder
///   "sim:SCENE" or "sim:"                — the simulated device (SCENE is a JSON file; empty = built-in)
/// Throws InputError with a one-line message for an unknown form, a missing device or file,
/// permission denied or a busy device.
struct OpenOptions {
  double sample_rate_Hz = 0;        ///< 0 = the device's or file's own
  std::uint16_t channel_mask = 0;   ///< 0 = the device's default (all channels)
  double gain_mV_per_pC = 0;        ///< usb: set the amplifier gain (0 = leave it); any source: the gain used
                                    ///< to convert volts to charge (overrides the file's or scene's)
  bool realtime = false;            ///< replay/sim: pace blocks by their timestamps
  int transfers_in_flight = 8;      ///< usb: bulk transfers queued at once
  double stall_timeout_s = 2.0;     ///< usb: end the stream when nothing arrives for this long
};
std::unique_ptr<Source> open_source(const std::string& spec, const OpenOptions& options = {});

struct SimScene;
/// Opens the simulator on a scene already read (e.g. after the application filled map-driven
/// charges); `description` names it. Applies options.gain_mV_per_pC and options.realtime.
std::unique_ptr<Source> open_sim(const SimScene& scene, const std::string& description, const OpenOptions& options = {});

}  // namespace pvdf::hardware
