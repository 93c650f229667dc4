// Resolution of the pipeline's settings: a capture's own settings first (byte-log header,
// drivetap pcapng interfaces), command-line overrides over them. Shared by the CLI and the fuzz
// harness so that both run exactly what `drivetap read` runs.
#pragma once

#include <optional>
#include <string>

#include "pipeline/pipeline.hpp"
#include "sources/source.hpp"

namespace drivetap {

// Command-line texts; empty = not given.
struct OptionOverrides {
  std::string serial;  // "19200 8E1"
  std::string t15;     // "1.5c", "750us"
  std::string t35;
  std::string timeout;  // reply timeout
  std::string max_hold;
};

// Where the line settings in force came from, each part in one phrase: "as given" (-s),
// "from the capture" (a byte log's `#! serial`, a drivetap pcapng's interface), or "default"
// (9600 8N1: nothing said). `contradiction`: -s against what the capture says, one line, empty
// when they agree or the capture says nothing.
struct SettingsProvenance {
  const char* baud = "default";
  const char* format = "default";
  std::string contradiction;
  std::string capture_says;  // with a contradiction: the capture's own settings
  // "as given", or "baud as given, format from the capture" when the parts differ; with a
  // contradiction "; the capture says 4800 8N1" after it.
  [[nodiscard]] std::string text() const;
};
// `given`: the -s text (empty: none; a valid one, resolve_pipeline_options() checked it).
SettingsProvenance settings_provenance(const RunSettings& capture, const std::string& given);

// Returns nullopt with *error = "--option: reason" when an override is not valid.
std::optional<PipelineOptions> resolve_pipeline_options(const RunSettings& capture,
                                                        const OptionOverrides& overrides,
                                                        std::string* error);

}  // namespace drivetap
