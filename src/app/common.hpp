// drivetap command line, what every subcommand shares: the common options (README "Commands"),
// messages and exit codes, refusing to overwrite an input, and the run's pipeline options with the
// drive profiles bound.
#pragma once

#include <cstdio>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "drive/profile.hpp"
#include "pipeline/options.hpp"
#include "sinks/time_format.hpp"
#include "sources/logic/sigrok_file.hpp"

namespace CLI {
class App;
}

namespace drivetap::app {

// The options of every subcommand that decodes (decode, read, diagnose, capture).
struct CommonOptions {
  std::string format = "text";
  bool verbose = false;
  std::string serial;
  std::string t15;
  std::string t35;
  std::string timeout;
  std::string max_hold;
  bool no_summary = false;
  std::string output;
  std::string write;
  bool classic_pcap = false;
  bool plain = false;  // --plain
  std::string dlt = "upper-pdu";
  std::string protocol;               // empty: rtu for captures; decode infers it from the text
  std::vector<std::string> drives;    // "2=e9", "auto", "none"
  std::vector<std::string> profiles;  // user profile files
  std::vector<std::string> profile_dirs;
  bool events_only = false;
  bool stats_only = false;                  // --stats
  std::vector<std::string> statistics;      // -z NAME[,ARG], each checked as it is parsed
  std::vector<std::string> logic_channels;  // --channels RX,TX
  bool invert = false;
  std::uint64_t logic_max = SigrokFile::kDefaultMaxSampleBytes;  // --logic-max
  // tshark's conventions (add_tshark_options()).
  std::uint64_t count = 0;        // -c: stop after N frames (0: no limit)
  bool quiet = false;             // -q: no per-frame output, the summary or statistics alone
  std::string time_format;  // -t: the time column (sinks/time_format.hpp); empty: not given (r)
  std::string color = "auto";     // --color
  bool no_progress = false;       // --no-progress
  bool hex_dump = false;          // -x: each frame's bytes as a hex and ASCII dump
  std::string display_filter;                                    // -Y
  std::vector<std::string> fields;                               // -e, for -T fields
  std::vector<std::string> field_options;                        // -E, for -T fields
};

// The subcommands that take common options: the bits of an option's row in the table of which
// command takes which option (common.cpp, kOptionUse).
enum CommandBit : unsigned {
  kDecodeCommand = 1,
  kReadCommand = 2,
  kDiagnoseCommand = 4,
  kCaptureCommand = 8,
};

// -T, -s, -P, --drive, -o, -w and the others a decoding subcommand takes: those of them that
// `command` (a CommandBit) uses (kOptionUse); the others are unknown to it, refused with exit 2.
void add_common_options(CLI::App* cmd, CommonOptions& o, unsigned command);
// Options that do nothing with the others given (--pcap without -w, -t with -T json): refused,
// one line, exit 2. `command`: a CommandBit.
void refuse_idle_options(const CommonOptions& o, unsigned command);
// --color for text written to `out`: always, never, or auto: when `out` is a terminal and NO_COLOR
// is unset or empty (no-color.org).
bool color_wanted(const CommonOptions& o, std::FILE* out);
// The time format of -t (checked when parsed).
TimeFormat time_format_of(const CommonOptions& o);

// One line on stderr, "drivetap: MESSAGE", with whatever is not printable UTF-8 escaped.
void say(std::string_view message);
// say(), then exit with `code` (2: a usage error, 1: a failed input or output, 130: interrupted).
[[noreturn]] void die(const std::string& message, int code = 2);
// Standard output flushed at the end of any command (a failed write: exit 1; EPIPE: as SIGPIPE).
void finish_stdout();
// Refuses (exit 2) an output that is an input or another output. `files`: {option, path}, the
// inputs first.
void refuse_shared_files(const std::vector<std::pair<std::string, std::string>>& files);

// The drive profiles a run loads (built in, then --profile-dir and --profile), as `read` loads
// them; they live as long as the process.
std::vector<const DriveProfile*> loaded_drive_profiles(const CommonOptions& o);

// Line settings and timing: the capture's own settings first, the command line over them; the
// drive profiles loaded and --drive bound.
PipelineOptions make_pipeline_options(const CommonOptions& o, const RunSettings& capture);

}  // namespace drivetap::app
