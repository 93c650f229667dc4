// Line settings detection from sampled levels (src/phy/detect.hpp; PROTOCOLS.md §1).
#include "phy/detect.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace drivetap::phy {
namespace {

constexpr std::array<double, 22> kStandardBauds = {
    300,   600,   1200,  2400,  4800,   7200,   9600,   14400,  19200,  28800,  31250,
    38400, 56000, 57600, 76800, 115200, 128000, 187500, 230400, 250000, 460800, 921600};

// Pulses longer than this many bits are idle gaps (mark) or breaks (space), not data.
constexpr double kLongestDataPulse = 12.5;
// A pulse fits a bit width when it is within a quarter bit of a whole multiple.
constexpr double kFitTolerance = 0.25;

struct WidthScore {
  double width = 0;
  double fitting = 0;  // share of the scored pulses that fit
  std::uint64_t scored = 0, single = 0;
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
  s.fitting = s.scored ? fit / static_cast<double>(s.scored) : 0;
  if (sum_mult > 0) s.width = sum_len / sum_mult;  // refined: the mean width of one bit
  return s;
}

}  // namespace

const char* confidence_name(Confidence c) {
  switch (c) {
    case Confidence::low:
      return "low";
    case Confidence::medium:
      return "medium";
    case Confidence::high:
      return "high";
  }
  return "low";
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

double snap_to_standard_baud(double measured) {
  double nearest = 0;
  for (double standard : kStandardBauds)
    if (std::abs(measured - standard) <= standard * 0.03 &&
        (nearest == 0 || std::abs(measured / standard - 1) < std::abs(measured / nearest - 1)))
      nearest = standard;
  return nearest;
}

std::string settings_text(const UartSettings& s) {
  const char parity = "NEOMS"[static_cast<int>(s.parity)];
  const char* stops = s.stop_bits == StopBits::two            ? "2"
                      : s.stop_bits == StopBits::one_and_half ? "1.5"
                                                              : "1";
  return fmt::format("{:g} {}{}{}{}", s.baud, s.data_bits, parity, stops,
                     s.inverted ? ", inverted" : "");
}

FormatTrial trial_decode(std::span<const std::vector<LevelRun>> channels,
                         std::uint64_t sample_rate_hz, const UartSettings& settings,
                         std::size_t max_runs_per_channel) {
  FormatTrial t;
  t.settings = settings;
  if (!settings.validate(sample_rate_hz).empty()) return t;
  const double per_bit = settings.samples_per_bit(sample_rate_hz);
  const auto frame = static_cast<std::uint64_t>(std::llround(settings.frame_bits() * per_bit));
  std::vector<UartCharacter> out;
  for (const std::vector<LevelRun>& runs : channels) {
    UartDecoder decoder(settings, sample_rate_hz);
    out.clear();
    decoder.push_runs(std::span(runs).first(std::min(runs.size(), max_runs_per_channel)), out);
    decoder.finish(out);
    t.stats += decoder.stats();
    for (std::size_t i = 1; i < out.size(); ++i)
      if (out[i].start_sample <=
          out[i - 1].start_sample + frame + static_cast<std::uint64_t>(per_bit / 2))
        ++t.back_to_back;
  }
  return t;
}

LineDetection detect_line(std::span<const std::vector<LevelRun>> channels,
                          std::uint64_t sample_rate_hz, const DetectOptions& options) {
  LineDetection d;
  // Pulse widths: interior runs only (the first and last are cut by the capture), adjacent runs
  // of one level merged (a reader's block boundary is no edge).
  std::vector<std::uint64_t> widths;
  struct Pulse {
    bool level;
    std::uint64_t length;
  };
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

  // Bit width: candidates are the short pulses (the shortest that is no glitch is one bit, in any
  // traffic with a 0-1-0 anywhere); the best score wins, the larger width on a near tie (every
  // multiple of w is also one of w/2).
  WidthScore best;
  for (double q : {0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5}) {
    const auto at = static_cast<std::size_t>(q * static_cast<double>(widths.size() - 1));
    const double candidate = static_cast<double>(widths[at]);
    if (candidate < 3) continue;  // fewer than 3 samples a bit cannot be decoded anyway
    WidthScore s = score_width(widths, candidate);
    if (s.scored * 2 < widths.size() || s.single == 0) continue;  // most pulses longer: too short
    s = score_width(widths, s.width);  // once more around the refined width
    if (s.scored * 2 < widths.size() || s.single == 0) continue;
    if (best.scored == 0 || s.fitting > best.fitting + 0.02 ||
        (s.fitting >= best.fitting - 0.02 && s.width > best.width * 1.5))
      best = s;
  }
  if (best.scored == 0) {
    d.why_not =
        fmt::format("no bit width fits the {} pulses (too few samples per bit?)", widths.size());
    return d;
  }
  d.pulses_fitting = best.fitting;
  d.single_bit_pulses = best.single;
  d.measured_baud = static_cast<double>(sample_rate_hz) / best.width;
  const double standard = snap_to_standard_baud(d.measured_baud);
  d.baud_standard = standard > 0;
  double baud = standard;
  if (!d.baud_standard) {
    // Three significant digits: what a device's divisor can really be set to is not knowable.
    const double scale = std::pow(10.0, std::floor(std::log10(d.measured_baud)) - 2);
    baud = std::round(d.measured_baud / scale) * scale;
  }
  if (baud < UartSettings::kMinBaud || baud > UartSettings::kMaxBaud) {
    d.why_not = fmt::format(
        "the pulses measure {:g} baud at {} samples/s, outside the UART range {:.0f}..{:.0f} baud "
        "(is the capture's sample rate or timescale right?)",
        d.measured_baud, sample_rate_hz, UartSettings::kMinBaud, UartSettings::kMaxBaud);
    return d;
  }
  d.baud_confidence = best.fitting >= 0.95 && best.scored >= 50 && best.single >= 5
                          ? Confidence::high
                      : best.fitting >= 0.85 && best.scored >= 10 ? Confidence::medium
                                                                  : Confidence::low;

  // Polarity: the level the line rests at between characters — gaps longer than any character,
  // the capture's first and last runs included (a recording usually starts and ends idle).
  const double w = best.width;
  std::uint64_t high_time = 0, low_time = 0;
  for (std::size_t c = 0; c < pulses.size(); ++c)
    for (const Pulse& p : pulses[c]) {
      if (static_cast<double>(p.length) <= kLongestDataPulse * w) continue;
      ++d.idle_gaps;
      (p.level ? high_time : low_time) += p.length;
    }
  const bool idle_evidence = high_time + low_time > 0;
  bool idle_high = true;
  if (idle_evidence) {
    idle_high = high_time >= low_time;
    d.idle_share = static_cast<double>(std::max(high_time, low_time)) /
                   static_cast<double>(high_time + low_time);
  }
  // Without a gap to judge by, normal polarity unless only the inverted one decodes: a capture
  // that starts and ends inside traffic says nothing about the rest level, and some traffic (as
  // 0x00-separated bytes) reads almost as well upside down.

  // Formats by trial decoding, both polarities.
  for (bool upside : {false, true})
    for (std::uint8_t data_bits : {8, 7})
      for (UartParity parity : {UartParity::none, UartParity::even, UartParity::odd})
        for (StopBits stop_bits : {StopBits::one, StopBits::two}) {
          UartSettings s;
          s.baud = baud;
          s.data_bits = data_bits;
          s.parity = parity;
          s.stop_bits = stop_bits;
          s.inverted = upside ? idle_high : !idle_high;
          d.trials.push_back(
              trial_decode(channels, sample_rate_hz, s, options.max_runs_per_channel));
        }
  // Fewest errors first; among equals (within half a percent) the more specific format: a parity
  // bit that checked out on every character, 8 data bits over 7, and 1 stop bit over 2. Two stop
  // bits cannot be told from one followed by a bit of idle line (a transmitter refilled by an
  // interrupt leaves one); one reads both without error, and its shorter character time is what
  // the sender's own t3.5 is usually measured in.
  auto specificity = [](const FormatTrial& t) {
    int score = 0;
    if (t.settings.parity != UartParity::none) score += 4;
    if (t.settings.stop_bits == StopBits::two) score -= 2;
    if (t.settings.data_bits == 8) score += 1;
    return score;
  };
  auto better = [&](const FormatTrial& a, const FormatTrial& b) {
    const double ra = a.error_rate(), rb = b.error_rate();
    if (std::abs(ra - rb) > 0.005) return ra < rb;
    return specificity(a) > specificity(b);
  };
  // The polarity: the idle level says it, unless only the other one decodes (some traffic, as
  // 0x00-separated bytes, reads almost as well upside down; a rest level is harder to fake).
  auto best_of = [&](bool inverted) {
    const FormatTrial* found = nullptr;
    for (const FormatTrial& t : d.trials)
      if (t.settings.inverted == inverted && (!found || better(t, *found))) found = &t;
    return *found;
  };
  const FormatTrial as_idle = best_of(!idle_high), upside_down = best_of(idle_high);
  bool inverted = !idle_high;
  const double idle_rate = as_idle.error_rate(), upside_rate = upside_down.error_rate();
  if (idle_evidence ? upside_rate < 0.02 && idle_rate > 0.2
                    : upside_rate < idle_rate - 0.3 || (upside_rate < 0.1 && idle_rate > 0.5))
    inverted = idle_high;
  std::stable_sort(d.trials.begin(), d.trials.end(),
                   [&](const FormatTrial& a, const FormatTrial& b) {
                     if (a.settings.inverted != b.settings.inverted)
                       return a.settings.inverted == inverted;
                     return better(a, b);
                   });
  const FormatTrial& top = d.best();
  if (top.stats.characters == 0) {
    d.why_not = fmt::format("no characters decode at {:g} baud", baud);
    return d;
  }
  d.settings = top.settings;
  d.found = true;

  // Polarity confidence: the idle level and the trial decoding agree, with idle gaps to judge by.
  const bool chosen_agrees = (inverted == !idle_high) && !better(upside_down, as_idle);
  if (!idle_evidence || inverted != !idle_high)
    d.polarity_confidence = Confidence::low;
  else if (chosen_agrees && d.idle_gaps >= 3 && d.idle_share >= 0.9)
    d.polarity_confidence = Confidence::high;
  else
    d.polarity_confidence = Confidence::medium;

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
  const FormatTrial* two =
      d.trial(top.settings.inverted, top.settings.data_bits, top.settings.parity, StopBits::two);
  if (top.settings.stop_bits == StopBits::two)
    reasons.push_back(
        fmt::format("{} characters back to back 2 stop bits apart", top.back_to_back));
  else if (two && two->stats.short_stop_bits > 0)
    reasons.push_back(fmt::format("{} characters follow the previous one after 1 stop bit",
                                  two->stats.short_stop_bits));
  else if (two && two->back_to_back > 0 && two->errors() == top.errors())
    reasons.push_back(fmt::format(
        "characters at least 1 idle bit apart ({} of them back to back that way): 2 stop bits "
        "fit as well",
        two->back_to_back));
  else
    reasons.push_back("1 stop bit assumed (no characters back to back to tell 1 from 2)");
  d.format_reason = fmt::format("{}", fmt::join(reasons, "; "));
  const bool stops_known = reasons.back().find("assumed") == std::string::npos;
  if (chars >= 20 && rate <= 0.01 && stops_known)
    d.format_confidence = Confidence::high;
  else if (chars >= 5 && rate <= 0.05)
    d.format_confidence = Confidence::medium;
  else
    d.format_confidence = Confidence::low;
  return d;
}

}  // namespace drivetap::phy
