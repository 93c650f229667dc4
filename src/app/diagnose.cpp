// `drivetap diagnose FILE`: the line's health (src/diagnose/line_diagnosis.hpp; docs/protocols.md
// §1, §2) and its report, text for a person or one JSON object (README "Commands").
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/inputs.hpp"
#include "app/stop_signals.hpp"
#include "diagnose/line_diagnosis.hpp"
#include "pipeline/options.hpp"
#include "sinks/color.hpp"
#include "sinks/json_sink.hpp"

namespace drivetap::app {
namespace {

// The report: text for a person, or one JSON object.
std::string diagnosis_text(const std::string& file, const LineEvidence& e,
                           const std::vector<Verdict>& verdicts, const Stats& stats, bool color) {
  // --color: faults red, a healthy line green, benign findings cyan.
  const auto paint = [color](std::string_view on, const std::string& text) {
    return color ? fmt::format("{}{}{}", on, text, color::kReset) : text;
  };
  std::string out = fmt::format("drivetap diagnose: {}\n", file);
  auto detection_text = [&](const phy::LineDetection& d, const char* indent) {
    std::string text;
    text += fmt::format(
        "{}baud     {:g}{} (measured {:.0f}, {:+.1f} %), confidence {}: {:.0f} % of {} pulses "
        "at whole bit widths, {} one bit wide\n",
        indent, d.settings.baud, d.baud_standard ? "" : " (not a standard rate)", d.measured_baud,
        (d.measured_baud / d.settings.baud - 1) * 100, phy::confidence_name(d.baud_confidence),
        d.pulses_fitting * 100, d.pulses, d.single_bit_pulses);
    text += fmt::format("{}polarity {}, confidence {}: {}\n", indent,
                        d.settings.inverted ? "inverted" : "normal",
                        phy::confidence_name(d.polarity_confidence), d.polarity_reason);
    text += fmt::format("{}format   {}, confidence {}: {}\n", indent, phy::frame_text(d.settings),
                        phy::confidence_name(d.format_confidence), d.format_reason);
    return text;
  };
  const char* how = e.given ? " (as given)" : " (detected)";
  if (!e.from_samples) {
    out += fmt::format("line:      {} ({}; byte-level evidence only)\n", e.settings,
                       e.settings_source);
  } else if (e.channels.size() == 1) {
    const LineEvidence::Channel& c = e.channels.front();
    if (c.detection && c.detection->found)
      out +=
          fmt::format("line:      {}{}\n{}", c.settings, how, detection_text(*c.detection, "  "));
    else if (c.detection)
      out += fmt::format("line:      {} (as given; detection failed: {})\n", c.settings,
                         c.detection->why_not);
  } else {
    out += fmt::format("line:      {}{}, {} channels each on its own\n", e.settings, how,
                       e.channels.size());
    for (const LineEvidence::Channel& c : e.channels) {
      out += fmt::format("  channel {}: {}\n", c.name, c.settings);
      if (c.detection && c.detection->found)
        out += detection_text(*c.detection, "    ");
      else if (c.detection)
        out += fmt::format("    detection failed: {}\n", c.detection->why_not);
    }
  }
  for (const std::string& why : e.dropped_channels) out += fmt::format("  {}\n", why);
  out += fmt::format(
      "traffic:   {} characters ({} framing errors, {} parity errors, {} breaks{}); {} frames "
      "(checksum ok {}, bad {}); {} noise bytes; {} transactions\n",
      e.characters, e.framing_errors, e.parity_errors, e.breaks,
      e.from_samples
          ? fmt::format(", {} glitches filtered, {} false starts", e.glitches, e.false_starts)
          : std::string(),
      e.frames, e.frames_checksum_ok, e.frames_checksum_bad, e.noise_bytes, stats.transactions);
  const auto faults = static_cast<std::size_t>(
      std::count_if(verdicts.begin(), verdicts.end(), [](const Verdict& v) { return !v.benign; }));
  if (faults == 0)
    out += "verdict:   " + paint(color::kGreen, "healthy line — no fault found") + "\n";
  else
    out += fmt::format("verdicts:  {}\n", faults);
  for (const Verdict& v : verdicts)
    if (!v.benign)
      out +=
          fmt::format("  {}\n      evidence: {}\n      fix:      {}\n",
                      paint(color::kRed, fmt::format("[{}] {}", v.id, v.title)), v.evidence, v.fix);
  for (const Verdict& v : verdicts)
    if (v.benign)
      out += fmt::format("benign:    {}: {}\n",
                         paint(color::kCyan, fmt::format("[{}] {}", v.id, v.title)), v.evidence);
  return out;
}

std::string diagnosis_json(const std::string& file, const LineEvidence& e,
                           const std::vector<Verdict>& verdicts, const Stats& stats) {
  std::string out = fmt::format("{{\"file\":{},\"line\":{},\"source\":\"{}\"", json_quote(file),
                                json_quote(e.settings), e.from_samples ? "samples" : "bytes");
  if (!e.from_samples) out += fmt::format(",\"line_from\":{}", json_quote(e.settings_source));
  auto detection_json = [](const phy::LineDetection& d) {
    return fmt::format(
        "{{\"baud\":{:g},\"measured_baud\":{:.1f},\"baud_standard\":{},"
        "\"baud_confidence\":\"{}\",\"inverted\":{},\"polarity_confidence\":\"{}\","
        "\"polarity_reason\":{},\"floats_when_idle\":{},\"format\":\"{}\","
        "\"format_confidence\":\"{}\",\"format_reason\":{}}}",
        d.settings.baud, d.measured_baud, d.baud_standard, phy::confidence_name(d.baud_confidence),
        d.settings.inverted, phy::confidence_name(d.polarity_confidence),
        json_quote(d.polarity_reason), d.floats_when_idle, phy::frame_text(d.settings),
        phy::confidence_name(d.format_confidence), json_quote(d.format_reason));
  };
  if (e.channels.size() == 1 && e.channels.front().detection && e.channels.front().detection->found)
    out += ",\"detection\":" + detection_json(*e.channels.front().detection);
  if (e.from_samples) {
    out += ",\"channels\":[";
    for (std::size_t i = 0; i < e.channels.size(); ++i) {
      const LineEvidence::Channel& c = e.channels[i];
      out += fmt::format("{}{{\"name\":{},\"line\":{}", i ? "," : "", json_quote(c.name),
                         json_quote(c.settings));
      if (c.detection && c.detection->found)
        out += ",\"detection\":" + detection_json(*c.detection);
      out += fmt::format(
          ",\"characters\":{},\"framing_errors\":{},\"parity_errors\":{},\"breaks\":{},"
          "\"rests_at_space\":{}}}",
          c.decoded.characters, c.decoded.framing_errors, c.decoded.parity_errors, c.decoded.breaks,
          c.decoded.rests_at_space);
    }
    out += "]";
  }
  out += fmt::format(
      ",\"characters\":{},\"framing_errors\":{},\"parity_errors\":{},\"breaks\":{},"
      "\"glitches\":{},\"false_starts\":{},\"frames\":{},\"checksum_ok\":{},\"checksum_bad\":{},"
      "\"noise_bytes\":{},\"transactions\":{},\"verdicts\":[",
      e.characters, e.framing_errors, e.parity_errors, e.breaks, e.glitches, e.false_starts,
      e.frames, e.frames_checksum_ok, e.frames_checksum_bad, e.noise_bytes, stats.transactions);
  for (std::size_t i = 0; i < verdicts.size(); ++i)
    out += fmt::format("{}{{\"id\":\"{}\",\"title\":{},\"evidence\":{},\"fix\":{},\"benign\":{}}}",
                       i ? "," : "", verdicts[i].id, json_quote(verdicts[i].title),
                       json_quote(verdicts[i].evidence), json_quote(verdicts[i].fix),
                       verdicts[i].benign);
  out += "]}\n";
  return out;
}

// `drivetap diagnose FILE`: runs the capture through the pipeline with nothing printed, then gives
// the line's verdicts (src/diagnose/line_diagnosis.hpp). Any capture: a logic capture gives sample
// evidence (detection, polarity, glitches), the others the UART flags and byte patterns.
int run_diagnose(const CommonOptions& o, const std::string& path) {
  InputFile in;
  ChannelTable channels;
  std::unique_ptr<ByteSource> source = open_source(o, path, in, channels);
  catch_stop_signals();
  const PipelineOptions p = start_source(o, *source);
  Diagnosis d = diagnose_capture(*source, p, channels, &g_stop);
  d.evidence.settings_source = settings_provenance(source->settings(), o.serial).text();
  if (!d.error.empty()) die(d.error, 1);
  if (d.interrupted) die("interrupted", 130);
  const std::string report =
      o.format == "json"
          ? diagnosis_json(path, d.evidence, d.verdicts, d.stats)
          : diagnosis_text(path, d.evidence, d.verdicts, d.stats, color_wanted(o, stdout));
  std::fputs(report.c_str(), stdout);
  std::fflush(stdout);
  close_input(in);
  return 0;
}

}  // namespace

Command add_diagnose_command(CLI::App& app) {
  return add_file_command(
      app, "diagnose",
      "Diagnose the line: swapped A/B, wrong baud or parity, noise, missing bias, timing",
      "Capture file (a logic capture gives most)", run_diagnose);
}

}  // namespace drivetap::app
