// Line settings detection from sampled levels (docs/protocols.md §1 line
// settings): baud rate, polarity, data bits, parity and stop bits chosen by decode quality, each
// with its confidence and the evidence behind it. Run it on one channel: the channels of one
// capture may differ (the two sides of an RS-232 converter have opposite polarity).
//
//   pulse widths (samples):  52 52 104 52 156 52 ... 9000 (idle)
//   candidate bit widths: several short pulses and their whole fractions, each refined as the
//   mean of width / multiple of the pulses that fit it; the one that puts the most pulses at
//   whole bit widths wins, unless a tied or a whole multiple of it decodes clearly better
//   polarity: the reading with clearly fewer errors; on a tie the rest level (breaks are not
//   it), then the likelier format (an unbiased pair rests low between transmissions although
//   every character on it is upright)
//
// The measured rate is snapped to a standard one when within 3 % (a UART tolerates about that), or
// within what the measurement can tell at few samples a bit (half a sample of a bit's width: 31250
// measured as 33333 at 3.2 samples a bit) when the standard rate decodes as well; otherwise it is
// reported as measured (10700 occurs: an AVR on its internal oscillator).
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sources/logic/uart_decoder.hpp"

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
  // Characters that began a whole idle bit (within 0.15 bit) after the previous one's end, and
  // those that began a fraction of a bit or more than one but under 2.5 bits after it: a sender
  // with 2 stop bits shows the first, a sender with 1 stop bit and gaps of its own the second.
  std::uint64_t one_idle_bit_apart = 0;
  std::uint64_t loosely_apart = 0;
  // Characters other than breaks, and those whose last data bit read 1: a top data bit that is
  // 1 on (nearly: a damaged character) every character is a stop bit or idle read as data, the
  // sign of too many data bits.
  std::uint64_t data_characters = 0;
  std::uint64_t top_bit_set = 0;
  // Different values among the characters whose parity (if any) held: what a parity bit's holding
  // proves grows with them, not with repeats of one value.
  std::uint64_t distinct_values = 0;

  // Damaged characters. A break (a space through the stop bits, then a mark) is a line signal
  // that LIN and DMX send before every frame, not damage; a rest at the space level is the line,
  // not a character: neither is one.
  [[nodiscard]] std::uint64_t errors() const {
    return stats.framing_errors + stats.parity_errors + stats.false_starts;
  }
  [[nodiscard]] bool top_bit_always_set() const {
    return data_characters >= 4 && top_bit_set * 100 >= data_characters * 97;
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

  double idle_share = 0;  // share of the idle-gap time at the chosen polarity's mark level
  std::uint64_t idle_gaps = 0;
  // Lows of 12.5 to 44 bits between two marks: breaks (DMX, LIN), not the rest level.
  std::uint64_t breaks_not_rest = 0;
  Confidence polarity_confidence = Confidence::low;
  std::string polarity_reason;  // the evidence polarity was chosen by
  // The line decodes clearly better in the chosen polarity, yet rests at its space level for
  // most of the idle time: nobody drives it between transmissions (no fail-safe bias).
  bool floats_when_idle = false;

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

// `channels`: the first runs of one channel (several channels are pooled, as if one line: give
// them only when they are known to share settings).
LineDetection detect_line(std::span<const std::vector<LevelRun>> channels,
                          std::uint64_t sample_rate_hz, const DetectOptions& options = {});

// Trial-decodes the runs with these settings (summed over the channels).
FormatTrial trial_decode(std::span<const std::vector<LevelRun>> channels,
                         std::uint64_t sample_rate_hz, const UartSettings& settings,
                         std::size_t max_runs_per_channel = 40'000);

// "19200 8E1" / "10700 8N2" / "115200 7O1", with ", inverted" when the line idles low.
std::string settings_text(const UartSettings& s);
// "8E1": the frame alone, without rate or polarity.
std::string frame_text(const UartSettings& s);
// The nearest standard baud rate within `tolerance` (3 %), or 0.
double snap_to_standard_baud(double measured, double tolerance = 0.03);

}  // namespace drivetap::phy
