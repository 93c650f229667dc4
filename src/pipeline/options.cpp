// Settings resolution: capture settings, then command-line overrides (README "Commands").
#include "pipeline/options.hpp"

#include <fmt/format.h>

namespace drivetap {

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
