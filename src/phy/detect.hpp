// Line settings detection from sampled levels (issue 6 §3; PROTOCOLS.md §1 line settings):
// polarity from the idle level, baud rate from the pulse-width distribution, data bits, parity
// and stop bits by trial decoding — each with its confidence and the evidence behind it.
//
//   pulse widths (samples):  52 52 104 52 156 52 ... 9000 (idle)
//   bit width w: the largest w that puts nearly every pulse under 12.5 w at a whole multiple
//   of w, some of them at 1 w; refined as the mean of width / multiple  ->  measured baud
//
// The measured rate is snapped to a standard one when within 3 % (a UART tolerates about that);
// otherwise it is reported as measured (10700 occurs: an AVR on its internal oscillator).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "phy/uart_decoder.hpp"

namespace drivetap::phy {

enum class Confidence : std::uint8_t { low, medium, high };
const char* confidence_name(Confidence c);

// One trial decoding of the detection sample.
struct FormatTrial {
  UartSettings settings;
  UartDecoderStats stats;
  // characters that began within half a bit of the previous one's last stop bit: the spacing
  // that tells 1 stop bit from 2
  std::uint64_t back_to_back = 0;

  [[nodiscard]] std::uint64_t errors() const {
    return stats.framing_errors + stats.parity_errors + stats.breaks + stats.false_starts;
  }
  // errors per character (1 when nothing decodes)
  [[nodiscard]] double error_rate() const;
};

struct LineDetection {
  bool found = false;
  std::string why_not;  // one line, when !found

  UartSettings settings;     // the detected settings (baud snapped when standard)
  double measured_baud = 0;  // from the pulse widths, before snapping
  bool baud_standard = false;

  double idle_share = 0;  // share of the idle-gap time at the idle level
  std::uint64_t idle_gaps = 0;
  Confidence polarity_confidence = Confidence::low;

  std::uint64_t pulses = 0;   // interior pulses measured
  double pulses_fitting = 0;  // share at a whole multiple of the bit width
  std::uint64_t single_bit_pulses = 0;
  Confidence baud_confidence = Confidence::low;

  Confidence format_confidence = Confidence::low;
  std::string format_reason;        // why this format over the others (parity seen, spacing...)
  std::vector<FormatTrial> trials;  // every trial, best first

  [[nodiscard]] const FormatTrial& best() const { return trials.front(); }
  // The trial with these settings' polarity, baud and format, or nullptr.
  [[nodiscard]] const FormatTrial* trial(bool inverted, std::uint8_t data_bits, UartParity parity,
                                         StopBits stop_bits) const;
};

struct DetectOptions {
  // Runs per channel used for trial decoding (the first ones of the capture).
  std::size_t max_runs_per_channel = 40'000;
};

// `channels`: the first runs of each channel that carries traffic; every channel is assumed to
// use the same line settings (the two directions of one link).
LineDetection detect_line(std::span<const std::vector<LevelRun>> channels,
                          std::uint64_t sample_rate_hz, const DetectOptions& options = {});

// Trial-decodes the runs with these settings (summed over the channels).
FormatTrial trial_decode(std::span<const std::vector<LevelRun>> channels,
                         std::uint64_t sample_rate_hz, const UartSettings& settings,
                         std::size_t max_runs_per_channel = 40'000);

// "19200 8E1" / "10700 8N2" / "115200 7O1", with ", inverted" when the line idles low.
std::string settings_text(const UartSettings& s);
// The nearest standard baud rate within 3 %, or 0.
double snap_to_standard_baud(double measured);

}  // namespace drivetap::phy
