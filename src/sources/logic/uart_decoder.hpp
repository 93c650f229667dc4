// UART decoder over sampled logic levels: one channel's level runs -> characters with UART error
// flags (docs/protocols.md §1 line settings; the receiver model of a standard 16550-style UART).
//
// Input is the channel as run-length edges — (level, how many samples) — because a logic analyser
// capture is mostly idle line: the work per run is a few branches, the work per sample is none.
// Consecutive runs of the same level may be pushed separately (a reader's chunk boundaries).
//
//   idle ‾‾‾‾‾‾‾\_____/‾‾‾‾‾\___/‾‾ ... ‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾ idle
//               |start| d0  | d1 ...    parity | stop(s)|
//               ^ start_sample: the first low sample                ^ end_sample
//
// Bits are sampled once, at their centres measured from the start edge; every start edge
// re-synchronises (the transmitter's clock may be a few percent off). A pulse shorter than the
// glitch filter is removed before sampling, so a sampled level is never a single noisy sample.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/byte_event.hpp"
#include "core/serial_config.hpp"
#include "core/time.hpp"

namespace drivetap::phy {

// `length` samples at one logic level, as read from the analyser (before any inversion).
struct LevelRun {
  bool level = true;
  std::uint64_t length = 0;

  friend bool operator==(const LevelRun&, const LevelRun&) = default;
};

// Parity on the wire; mark and space are a fixed 1 or 0 (9-bit multidrop protocols use them).
enum class UartParity : std::uint8_t { none, even, odd, mark, space };

// The parity bit sent after the data bits `value` (false for none, which sends no parity bit):
// what the simulator writes and the decoder expects.
bool parity_bit(UartParity parity, std::uint16_t value);

enum class StopBits : std::uint8_t { one, one_and_half, two };

struct UartSettings {
  // The range `-s` accepts (SerialConfig::parse). Outside it there is no character time the
  // framer and the timing rules can work with (below 0.5 baud it rounds to 0).
  static constexpr double kMinBaud = 50;
  static constexpr double kMaxBaud = 4'000'000;

  double baud = 9600;          // not necessarily a standard rate (10700 occurs)
  std::uint8_t data_bits = 8;  // 5..9
  UartParity parity = UartParity::none;
  StopBits stop_bits = StopBits::one;
  // Idle line low: what a receiver sees with the RS-485 A and B wires swapped (docs/protocols.md
  // §1).
  bool inverted = false;
  // Pulses shorter than this many samples are noise, not edges. Unset: 1/8 of a bit (at least one
  // sample, which filters nothing) — short enough never to eat a bit even with a few percent of
  // baud error, long enough to drop the ringing a long unterminated bus shows at every edge.
  std::optional<std::uint64_t> glitch_filter_samples;

  // Baud rate and format of a byte-level configuration ("19200 8E1").
  static UartSettings from(const SerialConfig& serial);
  // The inverse, for the byte-level pipeline: baud rounded to a whole number, mark/space parity
  // as none, 1.5 stop bits as 1 (SerialConfig has neither).
  [[nodiscard]] SerialConfig serial_config() const;

  // Start bit + data bits + parity bit + stop bits, in bit times (10.5 for 8N1.5).
  [[nodiscard]] double frame_bits() const;
  [[nodiscard]] double samples_per_bit(std::uint64_t sample_rate_hz) const {
    return static_cast<double>(sample_rate_hz) / baud;
  }
  // Why these settings cannot be decoded at `sample_rate_hz` (one line), or "" when they can.
  [[nodiscard]] std::string validate(std::uint64_t sample_rate_hz) const;
};

// One received character. Sample numbers count from the first sample pushed into the decoder.
struct UartCharacter {
  std::uint64_t start_sample = 0;  // first sample of the start bit (the falling edge)
  std::uint64_t end_sample = 0;    // first sample after the stop bit(s); for a character cut
                                   // short (by the next start bit during a second stop bit, or
                                   // by the end of the capture), where it was cut
  std::uint16_t value = 0;         // data bits, LSB first on the wire; 0 for a break
  std::uint8_t flags = 0;          // UartFlag bits (core/byte_event.hpp)
  // Pulses the glitch filter removed since the previous character was reported: noise on the
  // line around this character, even when the character itself decoded cleanly.
  std::uint32_t glitches = 0;

  friend bool operator==(const UartCharacter&, const UartCharacter&) = default;
};

// Running totals over everything pushed, including what no character carries: glitches after the
// last character and false starts (a falling edge whose start bit was gone at its centre).
struct UartDecoderStats : UartCounts {
  // Characters whose first stop bit was good but a later one low or cut short by the next start
  // bit: traffic that does not fit the 2 (or 1.5) stop bits it is decoded with.
  std::uint64_t short_stop_bits = 0;
  // A character the end of the capture cut before its first stop bit: not reported.
  std::uint64_t cut_by_end = 0;
  // Low stretches of kRestCharacters character times or more: the line resting at the space
  // level (a floating, unbiased pair; or an inverted line). Not characters: not reported, not in
  // `characters` or `breaks`.
  std::uint64_t rests_at_space = 0;

  // Totals of several decoders (the channels of one line).
  UartDecoderStats& operator+=(const UartDecoderStats& o) {
    UartCounts::operator+=(o);
    short_stop_bits += o.short_stop_bits;
    cut_by_end += o.cut_by_end;
    rests_at_space += o.rests_at_space;
    return *this;
  }
};

class UartDecoder {
 public:
  // A low stretch this many character times long is the line at rest (a floating pair between
  // transmitters, an inverted line), not a character: no UART sends one, and the breaks some
  // protocols send (DMX512's, 2 to 4 characters) carry nothing for a drive bus either.
  static constexpr std::uint64_t kRestCharacters = 2;

  // Throws std::invalid_argument with settings.validate()'s reason when they cannot be decoded;
  // callers that take settings from a user call validate() first and report the reason.
  UartDecoder(const UartSettings& settings, std::uint64_t sample_rate_hz);

  // Appends to `out` every character completed by these samples. A character is reported as soon
  // as its last stop bit has been sampled, so a live capture sees it without waiting for the next
  // edge; a break when the line rises again, at most kRestCharacters character times after it
  // began (longer, it is the line at rest, not a break).
  void push_run(bool level, std::uint64_t samples, std::vector<UartCharacter>& out);
  void push_runs(std::span<const LevelRun> runs, std::vector<UartCharacter>& out);
  // End of the capture: a character cut before its first stop bit is dropped (counted in
  // stats().cut_by_end); one cut inside a later stop bit is reported. The decoder then starts
  // over (level unknown) at the same sample count.
  void finish(std::vector<UartCharacter>& out);

  [[nodiscard]] const UartDecoderStats& stats() const { return stats_; }
  [[nodiscard]] std::uint64_t samples_pushed() const { return now_; }
  [[nodiscard]] std::uint64_t glitch_filter_samples() const { return glitch_filter_; }

 private:
  // Sample points of one character: start bit, up to 9 data bits, parity, up to 2 stop bits.
  static constexpr std::size_t kMaxSamplePoints = 13;

  void commit_edge(std::uint64_t at, bool mark, std::vector<UartCharacter>& out);
  void sample_until(std::uint64_t limit, std::vector<UartCharacter>& out);
  void report(std::uint64_t end_sample, bool is_break, std::vector<UartCharacter>& out);
  // The line rose (or the capture ended) at `at` after a whole character of low: a break.
  void end_of_low(std::uint64_t at, std::vector<UartCharacter>& out);

  // Format, fixed at construction.
  std::uint8_t data_bits_;
  UartParity parity_;
  bool inverted_;
  std::uint64_t glitch_filter_;
  std::array<std::uint64_t, kMaxSamplePoints> point_offsets_{};  // from the start edge, samples
  std::uint8_t point_count_ = 0;
  std::uint8_t parity_point_ = 0;
  std::uint8_t first_stop_point_ = 0;
  std::uint64_t frame_samples_ = 0;

  // The line after the glitch filter: `mark_` holds up to the pending edge (or up to now_).
  std::uint64_t now_ = 0;
  bool level_known_ = false;
  bool mark_ = true;
  bool edge_pending_ = false;  // an opposite level began at pending_start_, not yet long enough
  std::uint64_t pending_start_ = 0;
  std::uint32_t glitches_since_report_ = 0;

  // The character being received.
  bool in_character_ = false;
  bool rose_since_start_ = false;  // false while the line has been low since the start edge
  std::uint64_t start_ = 0;
  std::uint8_t next_point_ = 0;
  std::uint32_t sampled_levels_ = 0;  // bit i = level at sample point i
  // Low for a whole character and not risen since: a break or the line at rest, not yet known.
  bool low_after_break_ = false;
  std::uint64_t break_start_ = 0;
  std::uint64_t rest_samples_ = 0;  // kRestCharacters character times

  UartDecoderStats stats_;
};

// Decodes a whole capture held in memory (finish() included).
std::vector<UartCharacter> decode_runs(std::span<const LevelRun> runs, const UartSettings& settings,
                                       std::uint64_t sample_rate_hz);

// Sample numbers -> pipeline time. Exact integer arithmetic (rounded to the nearest ns) for any
// sample rate up to 10 GHz and any capture shorter than the pipeline's time limit (146 years).
struct SampleClock {
  std::uint64_t sample_rate_hz = 1'000'000;
  TimeNs origin = 0;  // time of sample 0

  [[nodiscard]] TimeNs to_ns(std::uint64_t sample) const;
};

// The ByteEvent a framer reads: time = start bit, the low 8 data bits (a 9th data bit has no place
// in a ByteEvent; UartCharacter::value keeps it), the UART flags as they are.
ByteEvent to_byte_event(const UartCharacter& c, const SampleClock& clock, ChannelId channel);

}  // namespace drivetap::phy
