// SerialConfig: UART line settings and the Modbus silence intervals they imply (docs/protocols.md
// §1).
//
// A character on the wire is: start bit, 5 to 9 data bits (9 only from a logic capture: a tty
// has none, and a ByteEvent keeps the low 8), optional parity bit, 1 or 2 stop bits.
//   8N1 = 10 bits, 8E1/8O1/8N2 = 11 bits.  character time = bits / baud.
// Modbus serial line spec: frames are separated by >= 3.5 character times of silence (t3.5), and
// a gap of more than 1.5 character times inside a frame makes it invalid (t1.5). Above 19200 baud
// the spec fixes t1.5 = 750 us and t3.5 = 1750 us.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "core/time.hpp"

namespace drivetap {

enum class Parity : std::uint8_t { none, even, odd };

struct SerialConfig {
  std::uint32_t baud = 9600;
  std::uint8_t data_bits = 8;  // 5 to 9
  Parity parity = Parity::none;
  std::uint8_t stop_bits = 1;  // 1 or 2

  [[nodiscard]] std::uint32_t bits_per_character() const {
    return 1u + data_bits + (parity == Parity::none ? 0u : 1u) + stop_bits;
  }
  // Duration of one character on the wire, rounded to the nearest nanosecond.
  [[nodiscard]] TimeNs character_time() const {
    return (static_cast<TimeNs>(bits_per_character()) * kNsPerSecond + baud / 2) / baud;
  }
  // Modbus inter-character limit (t1.5) and inter-frame silence (t3.5), fixed above 19200 baud.
  [[nodiscard]] TimeNs t15() const {
    return baud > 19200 ? 750 * kNsPerUs : character_time() * 3 / 2;
  }
  [[nodiscard]] TimeNs t35() const {
    return baud > 19200 ? 1750 * kNsPerUs : character_time() * 7 / 2;
  }

  // "9600 8N1", the form used on the command line, in byte-log headers and pcapng descriptions.
  [[nodiscard]] std::string to_string() const;

  // Parses "19200 8E1", "19200,8E1", "9600" (8N1 implied) or "8E1" (keeps the baud rate).
  // Returns nullopt and sets *error to a one-line reason when the text is not valid.
  // Settings not named in `text` are taken from `base`.
  static std::optional<SerialConfig> parse(std::string_view text, std::string* error,
                                           const SerialConfig& base);
  static std::optional<SerialConfig> parse(std::string_view text, std::string* error);

  friend bool operator==(const SerialConfig&, const SerialConfig&) = default;
};

// Silence thresholds the framer uses: from the line settings unless the user overrides them
// (--t15 / --t35, given in characters "4c" or microseconds "2000us").
struct FramingTiming {
  TimeNs t15 = 0;
  TimeNs t35 = 0;
  TimeNs character_time = 0;
  // False where the capture's times carry no inter-frame silence (a USB adapter's bursts, found
  // by the source): no silence rule (t1.5, t3.5) is judged and no latency measured.
  bool silences_trusted = true;

  static FramingTiming from(const SerialConfig& serial) {
    return {serial.t15(), serial.t35(), serial.character_time()};
  }
};

// Parses an interval given as "<n>c" / "<n>chars" (characters), "<n>us", "<n>ms" or "<n>s".
// Plain numbers are characters. Returns nullopt and sets *error when the text is not valid.
std::optional<TimeNs> parse_interval(std::string_view text, TimeNs character_time,
                                     std::string* error);

}  // namespace drivetap
