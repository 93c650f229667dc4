// Line settings detection from sampled levels (src/sources/logic/detect.hpp; docs/protocols.md §1).
#include "sources/logic/detect.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bitset>
#include <cmath>
#include <iterator>

#include "core/enum_text.hpp"

namespace drivetap::phy {
namespace {

constexpr std::array<double, 22> kStandardBauds = {
    300,   600,   1200,  2400,  4800,   7200,   9600,   14400,  19200,  28800,  31250,
    38400, 56000, 57600, 76800, 115200, 128000, 187500, 230400, 250000, 460800, 921600};

// Pulses longer than this many bits are idle gaps (mark) or breaks (space), not data.
constexpr double kLongestDataPulse = 12.5;
// Space pulses between that and this many bits are breaks when marks surround them.
constexpr double kLongestBreak = 44;
// A pulse fits a bit width when it is within a quarter bit of a whole multiple.
constexpr double kFitTolerance = 0.25;

struct WidthScore {
  double width = 0;
  double fitting = 0;  // share of the scored pulses that fit
  std::uint64_t scored = 0, single = 0;
  double fit_count = 0;  // pulses that fit
};

WidthScore score_width(const std::vector<std::uint64_t>& widths, double w) {
  WidthScore s;
  s.width = w;
  double fit = 0, sum_len = 0, sum_mult = 0;
  for (std::uint64_t len : widths) {
    const double bits = static_cast<double>(len) / w;
    if (bits > kLongestDataPulse) break;  // sorted: the rest are longer
    ++s.scored;
    const double n = std::round(bits);
    if (n >= 1 && std::abs(bits - n) <= kFitTolerance) {
      ++fit;
      sum_len += static_cast<double>(len);
      sum_mult += n;
      if (n == 1) ++s.single;
    }
  }
  s.fit_count = fit;
  s.fitting = s.scored ? fit / static_cast<double>(s.scored) : 0;
  if (sum_mult > 0) s.width = sum_len / sum_mult;  // refined: the mean width of one bit
  return s;
}

}  // namespace

const char* confidence_name(Confidence c) {
  static constexpr const char* kConfidenceNames[] = {"low", "medium", "high"};
  static_assert(std::size(kConfidenceNames) == static_cast<std::size_t>(Confidence::high) + 1);
  return enum_text(c, kConfidenceNames, static_cast<const char*>("low"));
}

double FormatTrial::error_rate() const {
  if (stats.characters == 0) return 1.0;
  return static_cast<double>(errors()) / static_cast<double>(stats.characters);
}

const FormatTrial* LineDetection::trial(bool inverted, std::uint8_t data_bits, UartParity parity,
                                        StopBits stop_bits) const {
  for (const FormatTrial& t : trials)
    if (t.settings.inverted == inverted && t.settings.data_bits == data_bits &&
        t.settings.parity == parity && t.settings.stop_bits == stop_bits)
      return &t;
  return nullptr;
}

double snap_to_standard_baud(double measured, double tolerance) {
  double nearest = 0;
  for (double standard : kStandardBauds)
    if (std::abs(measured - standard) <= standard * tolerance &&
        (nearest == 0 || std::abs(measured / standard - 1) < std::abs(measured / nearest - 1)))
      nearest = standard;
  return nearest;
}

std::string frame_text(const UartSettings& s) {
  const char parity = "NEOMS"[static_cast<int>(s.parity)];
  const char* stops = s.stop_bits == StopBits::two            ? "2"
                      : s.stop_bits == StopBits::one_and_half ? "1.5"
                                                              : "1";
  return fmt::format("{}{}{}", s.data_bits, parity, stops);
}

std::string settings_text(const UartSettings& s) {
  return fmt::format("{:g} {}{}", s.baud, frame_text(s), s.inverted ? ", inverted" : "");
}

FormatTrial trial_decode(std::span<const std::vector<LevelRun>> channels,
                         std::uint64_t sample_rate_hz, const UartSettings& settings,
                         std::size_t max_runs_per_channel) {
  FormatTrial t;
  t.settings = settings;
  if (!settings.validate(sample_rate_hz).empty()) return t;
  const double per_bit = settings.samples_per_bit(sample_rate_hz);
  const auto frame = static_cast<std::uint64_t>(std::llround(settings.frame_bits() * per_bit));
  const auto top_bit = static_cast<std::uint16_t>(1u << (settings.data_bits - 1));
  std::vector<UartCharacter> out;
  std::bitset<512> values;
  for (const std::vector<LevelRun>& runs : channels) {
    UartDecoder decoder(settings, sample_rate_hz);
    out.clear();
    decoder.push_runs(std::span(runs).first(std::min(runs.size(), max_runs_per_channel)), out);
    decoder.finish(out);
    t.stats += decoder.stats();
    for (std::size_t i = 0; i < out.size(); ++i) {
      if (!(out[i].flags & kUartBreak)) {
        ++t.data_characters;
        if (out[i].value & top_bit) ++t.top_bit_set;
        if (!(out[i].flags & kUartErrorFlags)) values.set(out[i].value & 0x1ff);
      }
      if (i == 0) continue;
      const double idle_bits = (static_cast<double>(out[i].start_sample) -
                                static_cast<double>(out[i - 1].start_sample + frame)) /
                               per_bit;
      if (idle_bits <= 0.5) ++t.back_to_back;
      // A whole bit to within 0.15 bit, or 1.5 samples where a bit has few of them.
      if (std::abs(idle_bits - 1) <= std::min(0.4, std::max(0.15, 1.5 / per_bit)))
        ++t.one_idle_bit_apart;
      else if (idle_bits > 0.25 && idle_bits < 2.5)
        ++t.loosely_apart;
    }
  }
  t.distinct_values = values.count();
  return t;
}

namespace {

struct Pulse {
  bool level;
  std::uint64_t length;
};

// A parity bit that holds on this many characters of this many different values is no
// coincidence (one chance in 2^8: repeats of one value repeat its parity and prove nothing); on
// fewer, a 7-bit format with parity is no better an explanation than 8 bits without (10 bytes
// whose top bit happens to be their even parity read as 7E1; LIN's 0x55, PID and break bytes).
constexpr std::uint64_t kParityProof = 24;
constexpr std::uint64_t kParityProofValues = 8;

bool parity_proven(const FormatTrial& t) {
  return t.settings.parity != UartParity::none && t.stats.characters >= kParityProof &&
         t.distinct_values >= kParityProofValues;
}

// Fewest errors first; among equals (within half a percent) the more specific format: a parity
// bit that checked out on characters enough to prove it (parity_proven); 8 data bits, but never a
// last data bit that is always 1 (two readings tie only when the longer one's last bit is: it is
// the stop bit read as data); 1 stop bit over 2 (settled afterwards, by the spacing).
int specificity(const FormatTrial& t) {
  int score = 0;
  if (parity_proven(t)) score += 4;
  if (t.settings.stop_bits == StopBits::two) score -= 2;
  if (t.top_bit_always_set())
    score -= 3;
  else if (t.settings.data_bits == 8)
    score += 1;
  return score;
}

bool better(const FormatTrial& a, const FormatTrial& b) {
  const double ra = a.error_rate(), rb = b.error_rate();
  if (std::abs(ra - rb) > 0.005) return ra < rb;
  return specificity(a) > specificity(b);
}

// `a` decodes clearly better than `b`: fewer than half its errors per character, and 2 % fewer
// or, over 20 characters or more each, 5 errors fewer than half b's (0 against 7 in 650 is no
// chance, though under 2 %).
bool clearly_better(const FormatTrial& a, const FormatTrial& b) {
  const double ra = a.error_rate(), rb = b.error_rate();
  const bool many = a.stats.characters >= 20 && b.stats.characters >= 20;
  return a.stats.characters > 0 && ra <= rb * 0.5 &&
         (ra + 0.02 < rb || (many && a.errors() * 2 + 5 <= b.errors()));
}

UartSettings format(double baud, bool inverted, std::uint8_t data_bits, UartParity parity,
                    StopBits stop_bits) {
  UartSettings s;
  s.baud = baud;
  s.inverted = inverted;
  s.data_bits = data_bits;
  s.parity = parity;
  s.stop_bits = stop_bits;
  return s;
}

// The rate to decode a measured one at: the standard rate within 3 %, else three significant
// digits (what a device's divisor really is cannot be known).
double decoding_baud(double measured, bool* standard) {
  const double snapped = snap_to_standard_baud(measured);
  *standard = snapped > 0;
  if (*standard) return snapped;
  const double scale = std::pow(10.0, std::floor(std::log10(measured)) - 2);
  return std::round(measured / scale) * scale;
}

// How well a bit width decodes, whatever the format: framing errors, breaks and false starts of
// the best of a few frame lengths (9 to 12 bits) in either polarity. Parity is left to the
// format search, at the chosen rate.
double framing_quality(std::span<const std::vector<LevelRun>> channels, std::uint64_t rate,
                       double baud, std::size_t max_runs) {
  double best = 2;
  for (bool inverted : {false, true})
    for (auto [bits, parity] : {std::pair{7, UartParity::none}, std::pair{8, UartParity::none},
                                std::pair{9, UartParity::none}, std::pair{9, UartParity::mark}}) {
      UartSettings s =
          format(baud, inverted, static_cast<std::uint8_t>(bits), parity, StopBits::one);
      FormatTrial t = trial_decode(channels, rate, s, max_runs);
      // Breaks count here: a fraction of the bit turns runs of zeros into breaks.
      t.stats.parity_errors = 0;
      if (t.stats.characters > 0)
        best = std::min(best, static_cast<double>(t.errors() + t.stats.breaks) /
                                  static_cast<double>(t.stats.characters));
    }
  return best;
}

}  // namespace

LineDetection detect_line(std::span<const std::vector<LevelRun>> channels,
                          std::uint64_t sample_rate_hz, const DetectOptions& options) {
  LineDetection d;
  // Pulse widths: interior runs only (the first and last are cut by the capture), adjacent runs
  // of one level merged (a reader's block boundary is no edge).
  std::vector<std::uint64_t> widths;
  std::vector<std::vector<Pulse>> pulses(channels.size());
  for (std::size_t c = 0; c < channels.size(); ++c) {
    const auto& runs = channels[c];
    const std::size_t n = std::min(runs.size(), options.max_runs_per_channel);
    for (std::size_t i = 0; i < n; ++i) {
      if (!pulses[c].empty() && pulses[c].back().level == runs[i].level)
        pulses[c].back().length += runs[i].length;
      else
        pulses[c].push_back({runs[i].level, runs[i].length});
    }
    for (std::size_t i = 1; i + 1 < pulses[c].size(); ++i) widths.push_back(pulses[c][i].length);
  }
  if (widths.size() < 8) {
    d.why_not = fmt::format("too few edges to measure ({} pulses; need 8)", widths.size());
    return d;
  }
  std::sort(widths.begin(), widths.end());
  d.pulses = widths.size();

  // Candidate bit widths: short pulses at several quantiles and their whole fractions (a whole bit
  // is the greatest width the pulses are multiples of, not the shortest pulse: constant data shows
  // no single-bit pulse, only 2- and 3-bit ones, or 9-bit ones between long marks), each refined
  // around the pulses that fit it.
  std::vector<WidthScore> candidates;
  for (double q : {0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5}) {
    const auto at = static_cast<std::size_t>(q * static_cast<double>(widths.size() - 1));
    for (int bits = 1; bits <= 12; ++bits) {
      const double candidate = static_cast<double>(widths[at]) / bits;
      if (candidate < 2) break;  // fewer than 2 samples a bit cannot be decoded
      WidthScore s = score_width(widths, candidate);
      if (s.scored * 2 < widths.size() || s.fitting == 0)
        continue;                        // most pulses longer: too short
      s = score_width(widths, s.width);  // once more around the refined width
      if (s.scored * 2 < widths.size() || s.fitting == 0) continue;
      // Every pulse one width: a clock, a strobe or a PWM output, not characters (a UART line
      // shows runs of equal bits in all but a stream of 0x55).
      if (bits == 1 && s.single * 100 >= s.scored * 95 && s.scored >= 16) {
        d.why_not = fmt::format(
            "{} of {} pulses are one width ({:.0f} samples): a clock or strobe line, not UART "
            "characters",
            s.single, s.scored, s.width);
        return d;
      }
      const bool seen = std::any_of(candidates.begin(), candidates.end(), [&](const WidthScore& c) {
        return std::abs(c.width / s.width - 1) < 0.03;
      });
      if (!seen) candidates.push_back(s);
    }
  }
  if (candidates.empty()) {
    d.why_not =
        fmt::format("no bit width fits the {} pulses (too few samples per bit?)", widths.size());
    return d;
  }
  // The width that puts the most pulses at whole bit widths (a pulse of more than 12.5 bits is
  // idle to a width, so a fraction of the bit fits fewer of them); on a near tie the wider (every
  // multiple of w is also one of w/2), unless one of the tied, or a whole multiple of the width,
  // decodes clearly better: fewer than half the framing errors. Then a standard rate close by
  // (within a quarter) that decodes as well is preferred to a rate that is none: uniform data
  // decodes at more than one rate (0x00 slots between long marks at 250000 read as 0x80 at 221000).
  std::stable_sort(
      candidates.begin(), candidates.end(), [](const WidthScore& a, const WidthScore& b) {
        if (std::abs(a.fit_count - b.fit_count) > 0.03 * std::max(a.fit_count, b.fit_count))
          return a.fit_count > b.fit_count;
        return a.width > b.width;
      });
  struct Decoded {
    const WidthScore* width;
    bool standard;
    double quality;
  };
  std::vector<Decoded> decoded;
  std::string out_of_range;
  for (const WidthScore& c : candidates) {
    const double measured = static_cast<double>(sample_rate_hz) / c.width;
    bool standard = false;
    const double baud = decoding_baud(measured, &standard);
    if (baud < UartSettings::kMinBaud || baud > UartSettings::kMaxBaud) {
      if (out_of_range.empty())  // the best-fitting width's
        out_of_range = fmt::format(
            "the pulses measure {:g} baud at {} samples/s, outside the UART range {:.0f}..{:.0f} "
            "baud (is the capture's sample rate or timescale right?)",
            measured, sample_rate_hz, UartSettings::kMinBaud, UartSettings::kMaxBaud);
      continue;
    }
    decoded.push_back({&c, standard,
                       candidates.size() == 1 ? 0.0
                                              : framing_quality(channels, sample_rate_hz, baud,
                                                                options.max_runs_per_channel)});
  }
  const Decoded* picked = nullptr;
  for (const Decoded& c : decoded) {
    if (!picked) {
      picked = &c;
      continue;
    }
    // A fraction of the bit fits the odd lengths of idle gaps more often, not better: a width
    // that is a whole multiple of the picked one may overrule it too.
    const double multiple = c.width->width / picked->width->width;
    const bool tied = c.width->fit_count >= picked->width->fit_count * 0.97 ||
                      (multiple > 1.5 && std::abs(multiple - std::round(multiple)) < 0.1);
    if (tied && c.quality + 0.02 < picked->quality && c.quality <= picked->quality * 0.5)
      picked = &c;
  }
  if (picked && !picked->standard)
    for (const Decoded& c : decoded) {
      const double ratio = c.width->width / picked->width->width;
      if (c.standard && c.quality <= picked->quality + 0.005 && ratio > 0.75 && ratio < 4.0 / 3) {
        picked = &c;
        break;
      }
    }
  const WidthScore* best = picked ? picked->width : nullptr;
  if (!best) {
    d.why_not = out_of_range;
    return d;
  }
  d.pulses_fitting = best->fitting;
  d.single_bit_pulses = best->single;
  d.measured_baud = static_cast<double>(sample_rate_hz) / best->width;
  double baud = decoding_baud(d.measured_baud, &d.baud_standard);
  // At few samples a bit the width is known to about half a sample: a standard rate that close,
  // decoding at least as well, is the line's (31250 MIDI at 3.2 samples a bit measures 33333).
  if (!d.baud_standard) {
    const double uncertain = snap_to_standard_baud(d.measured_baud, 0.5 / best->width);
    if (uncertain > 0 &&
        framing_quality(channels, sample_rate_hz, uncertain, options.max_runs_per_channel) <=
            framing_quality(channels, sample_rate_hz, baud, options.max_runs_per_channel) + 0.005) {
      baud = uncertain;
      d.baud_standard = true;
    }
  }
  d.baud_confidence = best->fitting >= 0.95 && best->scored >= 50 && best->single >= 5
                          ? Confidence::high
                      : best->fitting >= 0.85 && best->scored >= 10 && best->single > 0
                          ? Confidence::medium
                          : Confidence::low;  // no one-bit pulse: the width is inferred, not seen
  // Two samples a bit decode (the centre is the sample after the edge's), but one sample of
  // jitter is half a bit.
  if (best->width < 3) d.baud_confidence = Confidence::low;

  // Formats by trial decoding, both polarities.
  for (bool inverted : {false, true})
    for (std::uint8_t data_bits : {8, 7, 9, 6, 5})
      for (UartParity parity : {UartParity::none, UartParity::even, UartParity::odd})
        for (StopBits stop_bits : {StopBits::one, StopBits::two})
          d.trials.push_back(trial_decode(channels, sample_rate_hz,
                                          format(baud, inverted, data_bits, parity, stop_bits),
                                          options.max_runs_per_channel));
  auto best_of = [&](bool inverted) {
    const FormatTrial* found = nullptr;
    for (const FormatTrial& t : d.trials)
      if (t.settings.inverted == inverted && (!found || better(t, *found))) found = &t;
    return *found;
  };
  const FormatTrial upright = best_of(false), upside_down = best_of(true);

  // The rest level: gaps longer than any character, the capture's first and last runs included
  // (a recording usually starts and ends idle). A space between two marks that is shorter than 4
  // characters is a break (DMX and LIN send one before every frame), not the rest level: a DMX
  // packet's only long stretch is its break. (An unbiased pair floats longer: for Modbus at least
  // the 3.5 characters of a frame gap.) Which level is space depends on the polarity, so both
  // levels are counted: all their long stretches, and those that could be breaks.
  const double w = best->width;
  std::array<std::uint64_t, 2> long_time{}, break_time{}, long_gaps{}, break_gaps{};
  for (const std::vector<Pulse>& channel : pulses)
    for (std::size_t i = 0; i < channel.size(); ++i) {
      const Pulse& p = channel[i];
      const double bits = static_cast<double>(p.length) / w;
      if (bits <= kLongestDataPulse) continue;
      long_time[p.level] += p.length;
      ++long_gaps[p.level];
      if (bits < kLongestBreak && i > 0 && i + 1 < channel.size()) {
        break_time[p.level] += p.length;
        ++break_gaps[p.level];
      }
    }
  // The rest evidence if `inverted`: every long stretch at its mark level, and those at its space
  // level that are no break.
  struct Rest {
    std::uint64_t mark = 0, space = 0, gaps = 0, breaks = 0;
    [[nodiscard]] bool any() const { return mark + space > 0; }
    [[nodiscard]] double share() const {
      return static_cast<double>(mark) / static_cast<double>(mark + space);
    }
  };
  auto rest_if = [&](bool inv) {
    const int mark = inv ? 0 : 1, space = 1 - mark;
    return Rest{long_time[mark], long_time[space] - break_time[space],
                long_gaps[mark] + long_gaps[space] - break_gaps[space], break_gaps[space]};
  };

  // Polarity: the reading that decodes clearly better, and well (a handful of characters, most of
  // them damaged either way, prove nothing). When both decode alike (0x00-separated bytes read
  // almost as well upside down), the rest level where it is clear (3 idle gaps or more, 90 % at
  // one level), else the reading with the likelier format (8 data bits over 5: the idle read as
  // stop bits), else the rest level however weak, else upright. On a tie, breaks are lows: the
  // upright reading's space.
  auto decides = [](const FormatTrial& a, const FormatTrial& b) {
    return clearly_better(a, b) && (a.error_rate() <= 0.1 || a.stats.characters >= 20);
  };
  bool inverted = false;
  bool by_quality = true;
  Rest rest;
  enum class Tie { none, rest, format, weak_rest, assumed } tie = Tie::none;
  if (decides(upside_down, upright))
    inverted = true;
  else if (!decides(upright, upside_down)) {
    by_quality = false;
    rest = rest_if(false);
    const bool clear = rest.any() && rest.gaps >= 3 && (rest.share() >= 0.9 || rest.share() <= 0.1);
    if (clear) {
      tie = Tie::rest;
      inverted = rest.share() < 0.5;
    } else if (specificity(upright) != specificity(upside_down)) {
      tie = Tie::format;
      inverted = specificity(upside_down) > specificity(upright);
    } else if (rest.any()) {
      tie = Tie::weak_rest;
      inverted = rest.share() < 0.5;
    } else {
      tie = Tie::assumed;
    }
  }
  if (by_quality) rest = rest_if(inverted);
  const FormatTrial& chosen = inverted ? upside_down : upright;
  d.idle_gaps = rest.gaps;
  d.breaks_not_rest = rest.breaks;
  if (rest.any()) d.idle_share = inverted && !by_quality ? 1 - rest.share() : rest.share();
  d.floats_when_idle = by_quality && rest.any() && d.idle_share < 0.5;
  auto reading = [](const char* name, const FormatTrial& t) {
    return fmt::format("{}: {} errors{} in {} characters", name, t.errors(),
                       t.stats.breaks ? fmt::format(" and {} breaks", t.stats.breaks) : "",
                       t.stats.characters);
  };
  const std::string both =
      fmt::format("{}; {}", reading("upright", upright), reading("inverted", upside_down));
  const std::string rest_text =
      rest.any() ? fmt::format("the line rests at that level {:.0f} % of the time in {} idle gaps",
                               d.idle_share * 100, d.idle_gaps)
                 : "";
  switch (tie) {
    case Tie::none:
      d.polarity_reason = fmt::format("decodes clearly better that way ({})", both);
      break;
    case Tie::rest:
    case Tie::weak_rest:
      d.polarity_reason = fmt::format("both readings decode alike ({}); {}", both, rest_text);
      break;
    case Tie::format:
      d.polarity_reason = fmt::format(
          "both readings decode alike ({}) and no clear idle level shows the rest level; {} reads "
          "as {}, the other way as {}",
          both, inverted ? "inverted" : "upright", frame_text(chosen.settings),
          frame_text((inverted ? upright : upside_down).settings));
      break;
    case Tie::assumed:
      d.polarity_reason = fmt::format(
          "both readings decode alike ({}) and no idle gap shows the rest level: upright assumed",
          both);
      break;
  }
  if (!by_quality && d.breaks_not_rest > 0)
    d.polarity_reason +=
        d.breaks_not_rest == 1
            ? std::string(
                  " (1 low of 12.5 to 44 bits between marks taken as a break, not the "
                  "rest level)")
            : fmt::format(
                  " ({} lows of 12.5 to 44 bits between marks taken as breaks, not the "
                  "rest level)",
                  d.breaks_not_rest);
  if (by_quality && chosen.stats.characters >= 20 && chosen.error_rate() <= 0.05)
    d.polarity_confidence = Confidence::high;
  else if (by_quality || tie == Tie::rest)
    d.polarity_confidence = Confidence::medium;
  else
    d.polarity_confidence = Confidence::low;

  std::stable_sort(d.trials.begin(), d.trials.end(),
                   [&](const FormatTrial& a, const FormatTrial& b) {
                     if (a.settings.inverted != b.settings.inverted)
                       return a.settings.inverted == inverted;
                     return better(a, b);
                   });
  // Two stop bits where characters follow each other exactly 2 stop bits apart, never after 1
  // and seldom a fraction of a bit later, and 2 stop bits decode them as well. A sender with 1
  // stop bit sends back to back from its FIFO, or with gaps of its own that are no whole bit.
  {
    const FormatTrial& top = d.trials.front();
    if (top.settings.stop_bits == StopBits::one) {
      const FormatTrial* two =
          d.trial(inverted, top.settings.data_bits, top.settings.parity, StopBits::two);
      if (two && two->stats.short_stop_bits == 0 && two->errors() <= top.errors() &&
          top.one_idle_bit_apart >= 3 && top.one_idle_bit_apart * 4 >= top.stats.characters &&
          top.loosely_apart * 10 <= top.one_idle_bit_apart) {
        const auto at = std::find_if(d.trials.begin(), d.trials.end(),
                                     [&](const FormatTrial& t) { return &t == two; });
        std::rotate(d.trials.begin(), at, at + 1);
      }
    }
  }
  const FormatTrial& top = d.best();
  if (top.stats.characters == 0) {
    d.why_not = fmt::format("no characters decode at {:g} baud", baud);
    return d;
  }
  d.settings = top.settings;
  d.found = true;

  // Format confidence and reason.
  const double rate = top.error_rate();
  const std::uint64_t chars = top.stats.characters;
  std::vector<std::string> reasons;
  if (top.settings.parity != UartParity::none)
    reasons.push_back(fmt::format("{} parity holds on {} of {} characters",
                                  top.settings.parity == UartParity::even ? "even" : "odd",
                                  chars - top.stats.parity_errors, chars));
  else
    reasons.push_back("no parity fits better");
  const FormatTrial* longer =
      d.trial(inverted, static_cast<std::uint8_t>(top.settings.data_bits + 1), top.settings.parity,
              top.settings.stop_bits);
  if (longer && longer->top_bit_always_set() && longer->errors() <= top.errors())
    reasons.push_back(
        fmt::format("{} data bits: read with {}, the last data bit is 1 in all "
                    "{} characters (it is the stop bit)",
                    top.settings.data_bits, longer->settings.data_bits, longer->data_characters));
  else if (top.settings.data_bits != 8)
    reasons.push_back(
        fmt::format("{} data bits decode with the fewest errors", top.settings.data_bits));
  const FormatTrial* two =
      d.trial(top.settings.inverted, top.settings.data_bits, top.settings.parity, StopBits::two);
  if (top.settings.stop_bits == StopBits::two)
    reasons.push_back(
        fmt::format("{} of {} characters follow the previous one 2 stop bits apart, none after 1",
                    top.back_to_back, chars));
  else if (two && two->stats.short_stop_bits > 0)
    reasons.push_back(fmt::format("{} character{} the previous one after 1 stop bit",
                                  two->stats.short_stop_bits,
                                  two->stats.short_stop_bits == 1 ? " follows" : "s follow"));
  else if (two && two->back_to_back > 0 && two->errors() == top.errors())
    reasons.push_back(fmt::format(
        "characters at least 1 idle bit apart ({} of them back to back that way): 2 stop bits "
        "fit as well",
        two->back_to_back));
  else if (two && two->stats.short_stop_bits == 0 && top.back_to_back == 0 &&
           top.one_idle_bit_apart == 0)
    reasons.push_back(
        "1 stop bit assumed (every character leaves room for 2, none follows the previous one "
        "after exactly 1 or 2 to tell them apart)");
  else
    reasons.push_back("1 stop bit assumed (no characters back to back to tell 1 from 2)");
  d.format_reason = fmt::format("{}", fmt::join(reasons, "; "));
  const bool stops_known = reasons.back().find("assumed") == std::string::npos;
  // Another format of the same length that decodes the same characters as well (7E1 and 8N1
  // over bytes whose top bit is their parity by chance; 8O1 and 8N2 over 0x00 and 0xFF): the bits
  // cannot tell them apart. (A proven parity bit tells it from a reading without.)
  const FormatTrial* alike = nullptr;
  for (const FormatTrial& t : d.trials)
    if (&t != &top && t.settings.inverted == top.settings.inverted &&
        t.settings.frame_bits() == top.settings.frame_bits() &&
        (t.settings.data_bits != top.settings.data_bits ||
         t.settings.parity != top.settings.parity) &&
        t.stats.characters == chars && t.errors() == top.errors() && !t.top_bit_always_set() &&
        ((!parity_proven(top) && !parity_proven(t)) ||
         (t.settings.parity != UartParity::none) == (top.settings.parity != UartParity::none)))
      alike = &t;
  if (alike) {
    const std::string other = settings_text(alike->settings);
    d.format_reason += fmt::format("; {} decodes the same {} characters as well",
                                   other.substr(other.find(' ') + 1), chars);
    d.format_confidence = Confidence::low;
  } else if (chars >= 20 && rate <= 0.01 && stops_known) {
    d.format_confidence = Confidence::high;
  } else if (chars >= 5 && rate <= 0.05) {
    d.format_confidence = Confidence::medium;
  } else {
    d.format_confidence = Confidence::low;
  }
  return d;
}

}  // namespace drivetap::phy
