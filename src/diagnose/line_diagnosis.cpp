// Line diagnosis: evidence -> verdicts (src/diagnose/line_diagnosis.hpp; docs/protocols.md §1, §2).
#include "diagnose/line_diagnosis.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/printable.hpp"
#include "dissectors/modbus/modbus_fields.hpp"
#include "pipeline/pipeline.hpp"
#include "sources/logic/logic_source.hpp"

namespace drivetap {
namespace {

double percent(std::uint64_t part, std::uint64_t whole) {
  return whole ? 100.0 * static_cast<double>(part) / static_cast<double>(whole) : 0.0;
}

std::string trial_errors(const phy::FormatTrial& t) {
  return fmt::format(
      "{} characters, {} framing errors, {} parity errors, {} breaks, {} false start bits",
      t.stats.characters, t.stats.framing_errors, t.stats.parity_errors, t.stats.breaks,
      t.stats.false_starts);
}

// Read without parity, a line that carries a parity bit has it where the stop bit is looked for:
// framing errors on nearly every byte whose parity bit is 0 (even parity: an even number of ones)
// and on nearly none of the others, while the bytes themselves are right (checksums hold). The
// parity it carries, or none.
std::optional<Parity> parity_in_the_stop_bit(const LineEvidence& e) {
  std::string error;
  const std::optional<SerialConfig> read_as = SerialConfig::parse(e.settings, &error);
  if (!read_as || read_as->parity != Parity::none || read_as->data_bits != 8) return std::nullopt;
  if (e.frames_checksum_ok == 0 || e.frames_checksum_ok < e.frames_checksum_bad)
    return std::nullopt;
  for (const int zero_bit_on : {0, 1}) {  // 0: even popcount (even parity's bit is 0)
    const std::uint64_t hit = e.framed_badly_by_ones[zero_bit_on], of = e.by_ones[zero_bit_on];
    const std::uint64_t other = e.framed_badly_by_ones[1 - zero_bit_on];
    const std::uint64_t other_of = e.by_ones[1 - zero_bit_on];
    if (of >= 10 && other_of >= 10 && hit * 10 >= of * 9 && other * 20 <= other_of)
      return zero_bit_on == 0 ? Parity::even : Parity::odd;
  }
  return std::nullopt;
}

// The UART errors on a byte-level capture: which setting is probably wrong.
void byte_level_settings(const LineEvidence& e, std::vector<Verdict>& out) {
  if (e.characters < 20) return;
  const std::uint64_t framing = e.framing_errors + e.breaks;
  const double parity_share = percent(e.parity_errors, e.characters);
  const double framing_share = percent(framing, e.characters);
  if (const std::optional<Parity> parity = parity_in_the_stop_bit(e)) {
    std::string error;
    SerialConfig line = *SerialConfig::parse(e.settings, &error);
    line.parity = *parity;
    const bool even = *parity == Parity::even;
    out.push_back(
        {"parity-mismatch", fmt::format("The line carries a parity bit: use {}", line.to_string()),
         fmt::format("{} of {} bytes with an {} number of one bits have framing errors, {} of "
                     "{} with an {} number: the stop bit read is a{} parity bit; {} of {} frames "
                     "have a good checksum; captured as {}",
                     e.framed_badly_by_ones[even ? 0 : 1], e.by_ones[even ? 0 : 1],
                     even ? "even" : "odd", e.framed_badly_by_ones[even ? 1 : 0],
                     e.by_ones[even ? 1 : 0], even ? "odd" : "even", even ? "n even" : "n odd",
                     e.frames_checksum_ok, e.frames, e.settings),
         fmt::format("capture with -s \"{}\"", line.to_string())});
    return;
  }
  if (parity_share >= 20 && framing_share < 5) {
    out.push_back(
        {"parity-mismatch", "Parity errors on many bytes: the bus uses another parity",
         fmt::format("{} of {} bytes ({:.0f} %) have parity errors, only {} framing errors; "
                     "captured as {}",
                     e.parity_errors, e.characters, parity_share, framing, e.settings),
         "capture again with the parity the drives use (E, O or N: their communication "
         "parameters say which; about half the bytes failing means none vs. even/odd, every "
         "byte failing means even vs. odd)"});
  } else if (framing_share >= 20) {
    out.push_back(
        {"settings-mismatch", "Framing errors on many bytes: baud rate, format or polarity wrong",
         fmt::format("{} of {} bytes ({:.0f} %) have framing errors or breaks; captured as {}",
                     framing, e.characters, framing_share, e.settings),
         "record the line with a logic analyser and run `drivetap diagnose` on it (it measures "
         "the baud rate and the polarity), or check the A/B wiring and the drives' baud "
         "parameter"});
  }
}

// Given settings against what the samples show, and each channel's polarity.
void sampled_settings(const LineEvidence& e, const LineEvidence::Channel& c,
                      std::vector<Verdict>& out) {
  const phy::LineDetection& d = *c.detection;
  if (!d.found) return;
  const phy::UartSettings& found = d.settings;
  const std::string works =
      fmt::format("{} decodes with {} errors in {} characters", phy::settings_text(found),
                  d.best().errors(), d.best().stats.characters);
  const bool inverted_line = found.inverted && d.polarity_confidence != phy::Confidence::low;
  if (inverted_line && (!e.given || !e.given->inverted)) {
    // drivetap sees the same waveform either way: a swapped pair, or a probe on the RS-232 or
    // TTL side of a converter (RS-232 is inverted by definition).
    out.push_back(
        {"inverted-line",
         "The line is inverted: A and B swapped, or the probe is on the RS-232/TTL side of a "
         "converter",
         fmt::format("the polarity {}; {}", d.polarity_reason, works),
         "on an RS-485 pair: swap the A and B wires of the tap (the drives are not affected if "
         "only the tap is swapped; if a drive is, it sees framing errors on every frame); on the "
         "RS-232 side of a converter the inversion is normal; either way decode with --invert"});
  }
  if (d.floats_when_idle)
    out.push_back(
        {"unbiased-bus", "Bus not biased: the line floats when no transmitter drives it",
         fmt::format("between transmissions the line rests at the space level ({:.0f} % of the "
                     "time in {} idle gaps), yet every transmission on it reads {}: {}",
                     (1 - d.idle_share) * 100, d.idle_gaps, found.inverted ? "inverted" : "upright",
                     d.polarity_reason),
         "add fail-safe bias at one point of the bus (about 680 ohm pull-up on B/D+ and "
         "pull-down on A/D-, or the master's or an adapter's bias switch), and check the 120 "
         "ohm terminations: two, one at each end"});
  if (!e.given || !c.given_trial || c.given_trial->error_rate() <= 0.05) return;
  const phy::UartSettings& given = *e.given;
  const std::string given_text = fmt::format(
      "decoding as given ({}): {}", phy::settings_text(given), trial_errors(*c.given_trial));
  if (std::abs(given.baud - found.baud) > found.baud * 0.03) {
    out.push_back(
        {"baud-mismatch",
         fmt::format("Baud rate mismatch: the line runs at {:g}, not {:g}", found.baud, given.baud),
         fmt::format("{}; the pulse widths measure {:.0f} baud and {}", given_text, d.measured_baud,
                     works),
         fmt::format("set {:g} baud (-s \"{:g} {}\"), and check the baud parameter of "
                     "any drive that must talk on this bus",
                     found.baud, found.baud, phy::frame_text(found))});
  } else if (given.parity != found.parity || given.data_bits != found.data_bits) {
    out.push_back({"parity-mismatch",
                   fmt::format("Format mismatch: the line uses {}, not {}", phy::frame_text(found),
                               phy::frame_text(given)),
                   fmt::format("{}; {}", given_text, works),
                   fmt::format("set {} (-s \"{:g} {}\") and the same parity in every drive's "
                               "communication parameters",
                               phy::frame_text(found), found.baud, phy::frame_text(found))});
  } else if (given.inverted != found.inverted && !inverted_line) {
    out.push_back({"settings-mismatch", "Polarity given wrong: the line is not inverted",
                   fmt::format("{}; {}", given_text, works), "decode without --invert"});
  }
}

// Each channel's verdicts: one verdict where every channel has it (a file-level verdict where
// the channels agree), else one per channel, named.
void merge_channel_verdicts(const LineEvidence& e,
                            const std::vector<std::vector<Verdict>>& per_channel,
                            std::vector<Verdict>& out) {
  if (e.channels.size() == 1) {
    out.insert(out.end(), per_channel.front().begin(), per_channel.front().end());
    return;
  }
  std::vector<std::string> ids;
  for (const auto& verdicts : per_channel)
    for (const Verdict& v : verdicts)
      if (std::find(ids.begin(), ids.end(), v.id) == ids.end()) ids.push_back(v.id);
  for (const std::string& id : ids) {
    std::vector<std::pair<std::size_t, const Verdict*>> having;
    for (std::size_t k = 0; k < per_channel.size(); ++k)
      for (const Verdict& v : per_channel[k])
        if (v.id == id) having.emplace_back(k, &v);
    const bool all_agree = having.size() == e.channels.size() &&
                           std::all_of(having.begin(), having.end(), [&](const auto& h) {
                             return h.second->title == having.front().second->title;
                           });
    if (all_agree) {
      Verdict merged = *having.front().second;
      std::vector<std::string> evidence;
      for (const auto& [k, v] : having)
        evidence.push_back(fmt::format("channel {}: {}", e.channels[k].name, v->evidence));
      merged.evidence = fmt::format("{}", fmt::join(evidence, "; "));
      out.push_back(std::move(merged));
      continue;
    }
    for (const auto& [k, v] : having) {
      Verdict named = *v;
      named.title = fmt::format("Channel {}: {}", e.channels[k].name, v->title);
      out.push_back(std::move(named));
    }
  }
}

// "station 2: 5 of 20; station 7: 1 of 3", the stations with a count, by address.
template <typename Count, typename Text>
std::string per_station(const LineEvidence& e, Count count, Text text) {
  std::vector<std::string> parts;
  for (const auto& [address, station] : e.stations)
    if (count(station) > 0)
      parts.push_back(fmt::format(
          "{}: {}", address < 0 ? std::string("no address") : fmt::format("station {}", address),
          text(station)));
  return fmt::format("{}", fmt::join(parts, "; "));
}

using StationCount = std::uint64_t LineEvidence::Station::*;

// per_station() of a count of each station's: "station 2: 1 reply; station 7: 3 replies".
std::string per_station_counted(const LineEvidence& e, StationCount count, std::string_view one,
                                std::string_view many) {
  return per_station(
      e, [count](const LineEvidence::Station& s) { return s.*count; },
      [=](const LineEvidence::Station& s) {
        return fmt::format("{} {}", s.*count, s.*count == 1 ? one : many);
      });
}

// The same as a share of another count: "station 2: 5 of 20 frames".
std::string per_station_share(const LineEvidence& e, StationCount count, StationCount of,
                              std::string_view what) {
  return per_station(
      e, [count](const LineEvidence::Station& s) { return s.*count; },
      [=](const LineEvidence::Station& s) {
        return fmt::format("{} of {} {}", s.*count, s.*of, what);
      });
}

// The fix for a timing rule: each rule has its own.
const char* timing_rule_fix(TimingRule rule) {
  switch (rule) {
    case TimingRule::reply_too_soon:
      return "the drive answers sooner than its manual's minimum delay: check its response-delay "
             "parameter; a master that turns its transmitter around slowly collides with such a "
             "reply";
    case TimingRule::reply_too_late:
      return "the drive answers later than its manual promises (overloaded, or its response "
             "delay set high): lower that parameter, and keep the master's timeout above the "
             "delay";
    case TimingRule::request_after_reply:
      return "the master polls this drive sooner after its reply than the manual allows: add "
             "the required pause before the next request to it";
    case TimingRule::silence_before_request:
    case TimingRule::none:
      break;
  }
  return "the master leaves less silence before its requests than the drive needs: raise the "
         "master's delay between frames to the manual's minimum";
}

// Findings of the conversation (checksums, replies, exceptions, timing rules) and of the capture
// tool: each kind leads to a verdict with evidence per station or drive, or to a benign note.
void bus_findings(const LineEvidence& e, std::vector<Verdict>& out) {
  using S = LineEvidence::Station;
  if (e.findings[static_cast<std::size_t>(AnomalyKind::unanswered_request)] > 0)
    out.push_back(
        {"timeouts", "Requests without a reply",
         per_station_share(e, &S::timeouts, &S::requests, "requests unanswered"),
         "a station that never answers: its address, baud rate and parity, its wiring and power; "
         "one that answers some: noise on its segment, or replies slower than the master's "
         "timeout"});
  if (e.findings[static_cast<std::size_t>(AnomalyKind::checksum_swapped)] > 0)
    out.push_back(
        {"swapped-crc", "CRC sent in the wrong byte order",
         per_station_share(e, &S::swapped_checksum, &S::frames,
                           "frames with the CRC high byte first"),
         "the sender writes its CRC in the wrong byte order (the protocol sends the "
         "low byte first): fix it in the master's Modbus library or the drive's firmware; a "
         "strict receiver drops these frames"});
  std::uint64_t clean_bad = 0;
  for (const auto& [address, station] : e.stations) clean_bad += station.bad_checksum;
  if (clean_bad > 0)
    out.push_back({"bad-checksum", "Bad checksums without a UART error",
                   per_station_share(e, &S::bad_checksum, &S::frames, "frames"),
                   "the bytes arrived without a UART error, so the line is not to blame: the "
                   "sender computes its checksum over other bytes (firmware, a dialect), or the "
                   "capture lost or merged bytes (a loaded USB adapter): compare with a second "
                   "capture"});
  if (e.findings[static_cast<std::size_t>(AnomalyKind::unsolicited_response)] > 0)
    out.push_back({"unsolicited-replies", "Replies without a request",
                   per_station_counted(e, &S::unsolicited, "reply", "replies"),
                   "a second master on the bus, a request the tap missed, or a reply after the "
                   "master had given up (raise the master's timeout)"});
  std::uint64_t malformed = 0;  // on frames without a UART error
  for (const auto& [address, station] : e.stations) malformed += station.malformed;
  if (malformed > 0)
    out.push_back(
        {"malformed-frames", "Frames that break their protocol's rules",
         fmt::format("{} frames without a UART error ({} malformed, {} implausible in "
                     "all); {}",
                     malformed, e.findings[static_cast<std::size_t>(AnomalyKind::malformed)],
                     e.findings[static_cast<std::size_t>(AnomalyKind::implausible)],
                     per_station_counted(e, &S::malformed, "frame", "frames")),
         "a device speaking another protocol or dialect at these settings (see the "
         "protocol detection), or bytes lost or merged by the capture"});
  for (const auto& [channel, carries] : e.foreign_lines)
    out.push_back({"no-drive-protocol", fmt::format("No drive protocol on channel {}", channel),
                   fmt::format("it carries {}: no {} telegram passes its checksum and "
                               "plausibility rules; its bytes are shown as data",
                               carries, protocol_labels_text()),
                   "check that the tap is on the drives' bus (their RS-485 A/B pair) and the line "
                   "settings (`drivetap diagnose` on a logic capture measures them)"});
  const std::uint64_t own_noise = e.noise_records - e.foreign_noise_records;
  const std::uint64_t clean_noise =
      own_noise > e.flagged_noise_records ? own_noise - e.flagged_noise_records : 0;
  if (e.findings[static_cast<std::size_t>(AnomalyKind::noise)] > 0 &&
      clean_noise > e.release_noise_records)
    out.push_back({"stray-bytes", "Bytes that fit no frame",
                   fmt::format("{} noise records ({} bytes), {} without a UART error",
                               e.noise_records, e.noise_bytes, clean_noise),
                   "another device or protocol on the bus, an echo of a transmitter (an adapter's "
                   "echo setting), or reflections on an unterminated line: check the devices on "
                   "the bus and the 120 ohm terminations"});
  std::uint64_t exceptions = 0;
  for (const auto& [address, station] : e.stations)
    for (const auto& [key, count] : station.exceptions) exceptions += count;
  if (exceptions > 0)
    out.push_back({"exception-replies", "Drives refuse requests (exception replies)",
                   per_station(
                       e, [](const S& s) { return s.exceptions.size(); },
                       [](const S& s) {
                         std::vector<std::string> kinds;
                         for (const auto& [key, count] : s.exceptions)
                           kinds.push_back(fmt::format(
                               "function {:02X} exception {} ({}) x{}", key.first, key.second,
                               modbus::exception_meaning(static_cast<std::uint32_t>(key.second)),
                               count));
                         return fmt::format("{}", fmt::join(kinds, ", "));
                       }),
                   "the master asks for what the drive refuses: a function it lacks (1), a "
                   "register it does not have (2: check the register map; PDU addresses count "
                   "from 0), a value out of range (3); busy (6): poll it slower"});
  if (e.findings[static_cast<std::size_t>(AnomalyKind::uart_overrun)] > 0)
    out.push_back({"tap-overrun", "The capturing adapter lost bytes (UART overrun)",
                   fmt::format("{} overruns",
                               e.findings[static_cast<std::size_t>(AnomalyKind::uart_overrun)]),
                   "the tap, not the bus, lost them: a lower latency timer, a less loaded host, "
                   "or a logic analyser"});
  // One verdict per drive and rule: each rule has its own fix.
  for (const auto& [rule, breaks] : e.timing_rules) {
    std::vector<std::string> where;
    for (const auto& [address, at] : breaks.stations)
      where.push_back(fmt::format("station {}: {}", address, at.count));
    const std::uint64_t count = breaks.count();
    out.push_back({"timing-rule", fmt::format("A drive's timing rule is broken: {}", rule),
                   fmt::format("{} {} ({}; first: {})", count, count == 1 ? "time" : "times",
                               fmt::join(where, ", "), breaks.first()),
                   timing_rule_fix(breaks.rule)});
  }
  const std::uint64_t split = e.findings[static_cast<std::size_t>(AnomalyKind::packet_split_frame)];
  const std::uint64_t merged =
      e.findings[static_cast<std::size_t>(AnomalyKind::packet_merged_frames)];
  if (split + merged > 0)
    out.push_back({"capture-packets", "The capture tool's packets do not follow the frames",
                   fmt::format("{} packets held part of a frame, {} held several", split, merged),
                   "", true});
  if (const std::uint64_t back = e.findings[static_cast<std::size_t>(AnomalyKind::time_reversed)];
      back > 0)
    out.push_back({"capture-clock", "The capture's timestamps went backwards",
                   fmt::format("{} {}: the capturing tool's clock, not the bus (timing "
                               "findings next to them are unreliable)",
                               back, back == 1 ? "time" : "times"),
                   "", true});
}

}  // namespace

const std::array<FindingCoverage, kAnomalyKindCount> kFindingCoverage = {{
    {AnomalyKind::checksum_bad, "bad-checksum noise unbiased-bus"},
    {AnomalyKind::checksum_swapped, "swapped-crc"},
    {AnomalyKind::intra_frame_gap, "timing-t15"},
    {AnomalyKind::short_interframe_gap, "timing-t35"},
    {AnomalyKind::noise, "stray-bytes noise unbiased-bus no-drive-protocol"},
    {AnomalyKind::malformed, "malformed-frames noise"},
    {AnomalyKind::implausible, "malformed-frames noise"},
    {AnomalyKind::unanswered_request, "timeouts"},
    {AnomalyKind::unsolicited_response, "unsolicited-replies"},
    {AnomalyKind::uart_framing, "noise unbiased-bus inverted-line"},
    {AnomalyKind::uart_parity, "noise"},
    {AnomalyKind::uart_break, "noise unbiased-bus"},
    {AnomalyKind::uart_overrun, "tap-overrun"},
    {AnomalyKind::time_reversed, "capture-clock"},
    {AnomalyKind::packet_split_frame, "capture-packets"},
    {AnomalyKind::packet_merged_frames, "capture-packets"},
    {AnomalyKind::timing_rule, "timing-rule"},
}};

std::vector<Verdict> diagnose(const LineEvidence& e) {
  std::vector<Verdict> out;
  std::vector<std::vector<Verdict>> per_channel;
  for (const LineEvidence::Channel& c : e.channels) {
    std::vector<Verdict>& mine = per_channel.emplace_back();
    if (!c.detection) continue;
    sampled_settings(e, c, mine);
    if (!c.detection->found || c.detection->baud_standard) continue;
    const phy::LineDetection& d = *c.detection;
    mine.push_back({"non-standard-baud",
                    fmt::format("Non-standard baud rate: {:g} (measured {:.0f})", d.settings.baud,
                                d.measured_baud),
                    fmt::format("the pulse widths measure {:.0f} baud, more than 3 % from every "
                                "standard rate ({} pulses, {:.0f} % at whole bit widths)",
                                d.measured_baud, d.pulses, d.pulses_fitting * 100),
                    "a device at a standard rate will see framing errors: check the sender's "
                    "clock source and baud divisor (an MCU's internal RC oscillator drifts)"});
  }
  if (e.from_samples && !per_channel.empty())
    merge_channel_verdicts(e, per_channel, out);
  else if (!e.from_samples)
    byte_level_settings(e, out);

  auto found = [&](std::initializer_list<std::string_view> wanted) {
    return std::any_of(out.begin(), out.end(), [&](const Verdict& v) {
      return std::find(wanted.begin(), wanted.end(), v.id) != wanted.end();
    });
  };
  // Unbiased bus: the driver releases the line and it floats, read as a 0x00/0xFF byte with a
  // framing error right after the frame (the samples may have said so already).
  if (!found({"unbiased-bus"}) && e.release_artefacts >= 2 && e.release_artefacts * 20 >= e.frames)
    out.push_back(
        {"unbiased-bus", "Bus not biased: the line floats when a transmitter lets go",
         fmt::format("{} of {} frames end in a stray 0x00/0xFF or damaged byte without which "
                     "their checksum is good",
                     e.release_artefacts, e.frames),
         "add fail-safe bias at one point of the bus (about 680 ohm pull-up on B/D+ and "
         "pull-down on A/D-, or the master's or an adapter's bias switch), and check the 120 "
         "ohm terminations: two, one at each end"});

  // Noise: a few damaged characters inside traffic that otherwise decodes. On samples a break is
  // a space through the stop bits and back (LIN and DMX send one before every frame): a line
  // signal, not damage; on bytes a break cannot be told from a 0x00 with a framing error.
  const std::uint64_t bad_chars =
      e.framing_errors + e.parity_errors + (e.from_samples ? 0 : e.breaks);
  const std::uint64_t noise_chars =
      bad_chars > e.release_artefacts ? bad_chars - e.release_artefacts : 0;
  // Decoded with the wrong settings: the errors are theirs, not noise, and the framing and its
  // gaps (measured in their character times) mean nothing until they are fixed.
  const bool decoded_wrong = found({"settings-mismatch", "baud-mismatch", "parity-mismatch"});
  const bool settings_wrong = decoded_wrong || (e.given && found({"inverted-line"}));
  const std::uint64_t noise_events = noise_chars + e.glitches + e.false_starts;
  // On samples the settings are measured: whatever errors remain are the line's. On bytes, many
  // errors are more likely a wrong setting (reported above) than noise.
  if (!settings_wrong && noise_events > 0 &&
      (e.from_samples || percent(noise_chars, e.characters) < 20))
    out.push_back(
        {"noise", "Noise on the line: damaged characters inside valid traffic",
         fmt::format("{} of {} characters damaged ({} framing, {} parity, {} breaks{}){}; {} "
                     "frames with a bad checksum of {}",
                     noise_chars, e.characters, e.framing_errors, e.parity_errors, e.breaks,
                     e.from_samples && e.breaks ? ", not counted: a line signal" : "",
                     e.from_samples ? fmt::format("; {} glitches under 1/8 bit filtered, {} "
                                                  "false start bits",
                                                  e.glitches, e.false_starts)
                                    : std::string(),
                     e.frames_checksum_bad, e.frames),
         "check the cable: twisted pair with its shield grounded at one end, away from motor "
         "and mains cables; terminations (120 ohm at both ends, nowhere else); the common (0 V) "
         "wire between all devices"});

  if (decoded_wrong) return out;
  if (e.intra_frame_gaps > 0)
    out.push_back(
        {"timing-t15", "Pauses inside frames longer than t1.5",
         fmt::format("{} frames have a silence over 1.5 character times between two "
                     "bytes (first: {})",
                     e.intra_frame_gaps, e.first_intra_gap),
         "a receiver that keeps the t1.5 rule drops these frames: check the sender's UART "
         "feeding (a USB adapter or a busy master leaves gaps); if the gaps are the "
         "tap's own (USB latency), set its latency_timer to 1 ms"});
  if (e.short_interframe_gaps > 0)
    out.push_back({"timing-t35", "Silence between frames shorter than t3.5",
                   fmt::format("{} frames start less than 3.5 character times after the "
                               "previous one (first: {})",
                               e.short_interframe_gaps, e.first_short_gap),
                   "receivers may merge the two frames: raise the replying drive's response "
                   "delay parameter or the master's delay between polls"});
  bus_findings(e, out);
  return out;
}

void DiagnosisSink::on_frame(const Message& m) {
  ++evidence_.frames;
  last_frame_ = m.frame.number;
  last_address_ = m.address;
  last_clean_ = !m.frame.events.any_uart_errors();
  LineEvidence::Station& station = evidence_.stations[m.address];
  ++station.frames;
  const ChecksumVerdict verdict = m.checksum.verdict;
  if (verdict == ChecksumVerdict::good) ++evidence_.frames_checksum_ok;
  if (verdict == ChecksumVerdict::swapped) ++station.swapped_checksum;
  if (verdict != ChecksumVerdict::bad) return;
  // Without a UART mark on any byte the line delivered what was sent: not the line's fault.
  const bool clean = !m.frame.events.any_uart_errors();
  if (m.frame.events.size() < 3) {
    if (clean) ++station.bad_checksum;
    return;
  }
  ++evidence_.frames_checksum_bad;
  const ByteEvent& last = m.frame.events.back();
  const bool stray = last.byte == 0x00 || last.byte == 0xFF || (last.flags & kUartErrorFlags) != 0;
  const ProtocolDecoder* decoder = decoder_for(m.protocol);
  if (stray && decoder) {
    Frame trimmed = m.frame;
    trimmed.events.pop_back();
    trimmed.checksum_kind = FrameChecksum::none;  // the framer's CRC was of the untrimmed bytes
    const Message again = decoder->dissect(std::move(trimmed), Direction::unknown, FramingTiming{});
    if (again.checksum.verdict == ChecksumVerdict::good) {
      ++evidence_.release_artefacts;
      return;
    }
  }
  if (clean) ++station.bad_checksum;
}

// A stray byte or two right after a frame (the framer knew the frame's length and left them out):
// the same artefact of a line left floating.
void DiagnosisSink::on_noise(const Frame& noise) {
  evidence_.noise_bytes += noise.events.size();
  ++evidence_.noise_records;
  if (foreign_.contains(noise.channel)) {
    ++evidence_.foreign_noise_records;
    return;
  }
  if (noise.events.any_uart_errors()) ++evidence_.flagged_noise_records;
  const bool right_after = noise.gap_before >= 0 && noise.gap_before < timing_.t15;
  const bool stray = !noise.events.empty() && noise.events.size() <= 2 &&
                     std::all_of(noise.events.begin(), noise.events.end(), [](const ByteEvent& e) {
                       return e.byte == 0x00 || e.byte == 0xFF || (e.flags & kUartErrorFlags) != 0;
                     });
  if (right_after && stray) {
    ++evidence_.release_artefacts;
    if (!noise.events.any_uart_errors()) ++evidence_.release_noise_records;
  }
}

std::uint64_t LineEvidence::RuleBreaks::count() const {
  std::uint64_t n = 0;
  for (const auto& [address, at] : stations) n += at.count;
  return n;
}

const std::string& LineEvidence::RuleBreaks::first() const {
  const AtStation* first = nullptr;
  for (const auto& [address, at] : stations)
    if (!first || at.first_frame < first->first_frame) first = &at;
  static const std::string kNone;
  return first ? first->first : kNone;
}

void DiagnosisSink::on_event(const BusEvent& event) {
  if (event.kind == EventKind::drive_bound && !event.from.empty()) {
    // A binding let go or taken over: the timing rules its family set were never the drive's.
    for (auto rule = evidence_.timing_rules.begin(); rule != evidence_.timing_rules.end();) {
      const auto at = rule->second.stations.find(event.address);
      if (at != rule->second.stations.end()) {
        evidence_.findings[static_cast<std::size_t>(AnomalyKind::timing_rule)] -= at->second.count;
        rule->second.stations.erase(at);
      }
      rule = rule->second.stations.empty() ? evidence_.timing_rules.erase(rule) : std::next(rule);
    }
    return;
  }
  if (event.kind != EventKind::protocol_detected) return;
  if (event.protocol != Protocol::unknown) {
    foreign_.erase(event.channel);
    return;
  }
  foreign_[event.channel] = event.carries;  // "56 bytes of printable ASCII text"
}

void DiagnosisSink::on_transaction(const Transaction& t) {
  LineEvidence::Station& station = evidence_.stations[t.address];
  if (t.request_number > 0) ++station.requests;
  if (t.outcome == Outcome::timeout) ++station.timeouts;
  if (t.outcome == Outcome::unsolicited) ++station.unsolicited;
  if (t.outcome == Outcome::exception) ++station.exceptions[{t.function, t.exception_code}];
}

void DiagnosisSink::on_anomaly(const Anomaly& a) {
  auto example = [&](std::string& slot) {
    if (slot.empty()) slot = fmt::format("frame {}: {}", a.frame_number, a.detail);
  };
  ++evidence_.findings[static_cast<std::size_t>(a.kind)];
  // A frame's findings arrive right after it: its station (a finding handed on later names it).
  const int address = a.address >= 0                                         ? a.address
                      : a.frame_number != 0 && a.frame_number == last_frame_ ? last_address_
                                                                             : -1;
  switch (a.kind) {
    case AnomalyKind::malformed:
    case AnomalyKind::implausible:
      // A frame damaged on the line breaks its rules because of the damage (the noise verdict).
      if (a.frame_number != last_frame_ || last_clean_) ++evidence_.stations[address].malformed;
      break;
    case AnomalyKind::intra_frame_gap:
      ++evidence_.intra_frame_gaps;
      example(evidence_.first_intra_gap);
      break;
    case AnomalyKind::short_interframe_gap:
      ++evidence_.short_interframe_gaps;
      example(evidence_.first_short_gap);
      break;
    case AnomalyKind::timing_rule: {
      // One entry per drive and rule: "the drive keeps at least 10 ms (E5-8200, ...)".
      auto& rule = evidence_.timing_rules[timing_rule_text(a.timing)];
      rule.rule = a.timing.rule;
      LineEvidence::RuleBreaks::AtStation& at = rule.stations[address];
      // (A finding held with its drive's binding comes after later frames' findings.)
      if (at.count++ == 0 || a.frame_number < at.first_frame) {
        at.first_frame = a.frame_number;
        at.first = fmt::format("frame {}: {}", a.frame_number, timing_break_text(a.timing));
      }
      break;
    }
    default:
      break;
  }
}

void add_capture_evidence(LineEvidence& evidence, const ByteSource& source,
                          const PipelineOptions& options, const ChannelTable& channels,
                          const DiagnosisSink& sink) {
  for (const auto& [channel, carries] : sink.foreign())
    evidence.foreign_lines.emplace_back(
        channel < channels.size() ? channels.at(channel).name : fmt::format("{}", channel),
        carries);
  evidence.settings = options.serial.to_string();
  if (const auto* logic = dynamic_cast<const LogicSource*>(&source)) {
    evidence.from_samples = true;
    evidence.settings = phy::settings_text(logic->uart());
    evidence.dropped_channels = logic->dropped();
    const std::vector<phy::UartDecoderStats> decoded = logic->decoder_stats();
    for (std::size_t k = 0; k < logic->lines().size(); ++k) {
      const LogicSource::ChannelLine& line = logic->lines()[k];
      LineEvidence::Channel c;
      c.name = printable_bounded(line.name, ChannelTable::kMaxNameBytes);
      c.settings = phy::settings_text(line.uart);
      c.detection = line.detection;
      c.given_trial = line.given_trial;
      if (k < decoded.size()) c.decoded = decoded[k];
      evidence.glitches += c.decoded.glitches;
      evidence.false_starts += c.decoded.false_starts;
      if (line.given_trial) evidence.given = line.uart;
      evidence.channels.push_back(std::move(c));
    }
    // One file-level line only where every channel agrees.
    for (const LineEvidence::Channel& c : evidence.channels)
      if (c.settings != evidence.channels.front().settings) evidence.settings = "per channel";
  }
}

Diagnosis diagnose_capture(ByteSource& source, const PipelineOptions& options,
                           ChannelTable& channels, const volatile std::sig_atomic_t* stop) {
  Diagnosis result;
  LineEvidence& evidence = result.evidence;
  DiagnosisSink sink(evidence, options.timing);
  {
    Pipeline pipeline(options, channels, sink);
    ByteEvent e;
    while (source.next(e)) {
      for (const Anomaly& a : source.take_findings()) pipeline.report(a);
      pipeline.push(e);
      evidence.count_byte(e.byte, e.flags);
      if (stop && *stop) {
        result.interrupted = true;
        break;
      }
    }
    pipeline.finish();
  }
  result.error = source.error();
  result.stats = sink.stats();
  add_capture_evidence(evidence, source, options, channels, sink);
  result.verdicts = diagnose(evidence);
  return result;
}

}  // namespace drivetap
