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

// Returns nullopt with *error = "--option: reason" when an override is not valid.
std::optional<PipelineOptions> resolve_pipeline_options(const RunSettings& capture,
                                                        const OptionOverrides& overrides,
                                                        std::string* error);

}  // namespace drivetap
