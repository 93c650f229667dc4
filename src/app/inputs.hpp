// drivetap command line: opening a capture file of any supported format as a source, and the
// run's options settled from its header and the command line.
#pragma once

#include <memory>
#include <string>

#include "app/common.hpp"
#include "core/byte_event.hpp"
#include "pipeline/options.hpp"
#include "sources/input_file.hpp"
#include "sources/source.hpp"

namespace drivetap::app {

// The source for a capture file of any supported format (the format is read from its first bytes).
// `input_fd`, when given: the descriptor the source reads from (-1 for a logic capture, read by
// name), for the progress line.
std::unique_ptr<ByteSource> open_source(const CommonOptions& o, const std::string& path,
                                        InputFile& in, ChannelTable& channels,
                                        int* input_fd = nullptr);

// Reads the source's header and settles the run's options: the capture's settings, overridden by
// the command line's.
PipelineOptions start_source(const CommonOptions& o, ByteSource& source);

}  // namespace drivetap::app
