// Settings resolution: capture settings, then command-line overrides (README "Commands").
#include "pipeline/options.hpp"

#include <fmt/format.h>

namespace drivetap {

std::string SettingsProvenance::text() const {
  std::string out = std::string_view(baud) == format
                        ? std::string(baud)
                        : fmt::format("baud {}, format {}", baud, format);
  if (!capture_says.empty()) out += "; the capture says " + capture_says;
  return out;
}

SettingsProvenance settings_provenance(const RunSettings& capture, const std::string& given) {
  SettingsProvenance p;
  if (capture.serial) p.baud = p.format = "from the capture";
  if (given.empty()) return p;
  // Which parts -s sets: those that come out the same over two bases that differ in every part.
  std::string err;
  const SerialConfig a{1200, 7, Parity::odd, 2}, b{4800, 8, Parity::none, 1};
  const std::optional<SerialConfig> over_a = SerialConfig::parse(given, &err, a);
  const std::optional<SerialConfig> over_b = SerialConfig::parse(given, &err, b);
  if (!over_a || !over_b) return p;
  const bool baud_given = over_a->baud == over_b->baud;
  const bool format_given = over_a->data_bits == over_b->data_bits &&
                            over_a->parity == over_b->parity &&
                            over_a->stop_bits == over_b->stop_bits;
  if (baud_given) p.baud = "as given";
  if (format_given) p.format = "as given";
  if (capture.serial) {
    const SerialConfig in_force = *SerialConfig::parse(given, &err, *capture.serial);
    const SerialConfig& said = *capture.serial;
    if (in_force != said) {
      p.capture_says = said.to_string();
      p.contradiction = fmt::format("-s {}: the capture says {}; decoding as {}", given,
                                    said.to_string(), in_force.to_string());
    }
  }
  return p;
}

std::optional<PipelineOptions> resolve_pipeline_options(const RunSettings& capture,
                                                        const OptionOverrides& o,
                                                        std::string* error) {
  PipelineOptions p;
  std::string err;
  SerialConfig serial = capture.serial.value_or(SerialConfig{});
  if (!o.serial.empty()) {
    auto parsed = SerialConfig::parse(o.serial, &err, serial);
    if (!parsed) {
      *error = fmt::format("--serial: {}", err);
      return std::nullopt;
    }
    serial = *parsed;
  }
  p.serial = serial;
  p.timing = FramingTiming::from(serial);
  // Timing stored by a drivetap capture applies only when its line settings are in force.
  if (o.serial.empty()) {
    if (capture.t15) p.timing.t15 = *capture.t15;
    if (capture.t35) p.timing.t35 = *capture.t35;
  }
  if (capture.reply_timeout) p.reply_timeout = *capture.reply_timeout;
  if (capture.max_hold) p.max_hold = *capture.max_hold;
  if (capture.protocol) p.protocol = *capture.protocol;
  struct Override {
    const std::string& text;
    const char* option;
    TimeNs* target;
  };
  const Override overrides[] = {{o.t15, "--t15", &p.timing.t15},
                                {o.t35, "--t35", &p.timing.t35},
                                {o.timeout, "--timeout", &p.reply_timeout},
                                {o.max_hold, "--max-hold", &p.max_hold}};
  for (const Override& ov : overrides) {
    if (ov.text.empty()) continue;
    auto v = parse_interval(ov.text, p.timing.character_time, &err);
    if (!v) {
      *error = fmt::format("{}: {}", ov.option, err);
      return std::nullopt;
    }
    *ov.target = *v;
  }
  if (p.timing.t35 <= 0) {
    *error = "--t35: must be greater than zero";
    return std::nullopt;
  }
  return p;
}

}  // namespace drivetap
