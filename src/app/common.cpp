// drivetap command line: the common options, messages and exit codes, the drive profiles and the
// run's pipeline options (src/app/common.hpp; README "Commands").
#include "app/common.hpp"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <memory>

#include "app/commands.hpp"
#include "core/printable.hpp"
#include "core/protocol.hpp"
#include "dissectors/common/plausibility.hpp"
#include "drive/drive_fields.hpp"
#include "drive/profile.hpp"
#include "sinks/stats_tables.hpp"

namespace drivetap::app {
namespace {

// Profiles loaded for this run (built in and --profile files); bound drives point into it.
std::deque<DriveProfile> g_profiles;

// The built-in profiles (when `builtins_wanted`), then --profile-dir and --profile files (a user
// profile with a built-in id replaces it). A bad file ends the run with its file:line: key error.
void load_profiles(const CommonOptions& o, bool builtins_wanted) {
  auto add = [](DriveProfile profile) {
    for (DriveProfile& known : g_profiles)
      if (known.id == profile.id) {
        known = std::move(profile);
        return;
      }
    g_profiles.push_back(std::move(profile));
  };
  if (builtins_wanted) {
    ProfileError builtin_error;
    auto builtins = load_builtin_profiles(&builtin_error);
    if (!builtins) die(fmt::format("built-in profile {}", builtin_error.text()), 1);
    for (DriveProfile& profile : *builtins) add(std::move(profile));
  }
  std::vector<std::string> files;
  for (const std::string& dir : o.profile_dirs) {
    std::error_code ec;
    std::vector<std::string> found;
    for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
      if (it->path().extension() == ".toml") found.push_back(it->path().string());
    if (ec) die(fmt::format("--profile-dir {}: {}", dir, ec.message()), 1);
    std::sort(found.begin(), found.end());
    files.insert(files.end(), found.begin(), found.end());
  }
  files.insert(files.end(), o.profiles.begin(), o.profiles.end());
  for (const std::string& f : files) {
    ProfileError e;
    auto profile = load_profile_file(f, &e);
    if (!profile) die(fmt::format("profile {}", e.text()), 1);
    add(std::move(*profile));
  }
}
// Which subcommand takes which common option: one row per option, named as on its command line
// (any of its names). An option with no row is taken by every command that adds it.
constexpr unsigned kDecode = kDecodeCommand, kRead = kReadCommand, kDiagnose = kDiagnoseCommand,
                   kCapture = kCaptureCommand;
struct OptionUse {
  std::string_view name;
  unsigned commands;
};
constexpr OptionUse kOptionUse[] = {
    {"-T", kDecode | kRead | kDiagnose | kCapture},
    {"-V", kDecode | kRead | kCapture},
    {"-s", kDecode | kRead | kDiagnose | kCapture},
    {"--t15", kDecode | kRead | kDiagnose | kCapture},
    {"--t35", kDecode | kRead | kDiagnose | kCapture},
    {"--timeout", kRead | kDiagnose | kCapture},  // decode's times are made up: nothing times out
    {"--max-hold", kDecode | kRead | kDiagnose | kCapture},
    {"-P", kDecode | kRead | kDiagnose | kCapture},
    {"--drive", kDecode | kRead | kDiagnose | kCapture},
    {"--profile", kDecode | kRead | kDiagnose | kCapture},
    {"--profile-dir", kDecode | kRead | kDiagnose | kCapture},
    {"--channels", kRead | kDiagnose},  // logic-analyser captures
    {"--invert", kRead | kDiagnose},
    {"--logic-max", kRead | kDiagnose},
    {"--events", kDecode | kRead | kCapture},
    {"--no-summary", kDecode | kRead | kCapture},
    {"--stats", kDecode | kRead | kCapture},
    {"-o", kDecode | kRead | kCapture},
    {"-w", kDecode | kRead | kCapture},
    {"--pcap", kDecode | kRead | kCapture},
    {"--plain", kDecode | kRead | kCapture},
    {"--dlt", kDecode | kRead | kCapture},
    {"-c", kDecode | kRead | kCapture},
    {"-q", kDecode | kRead | kCapture},
    {"-t", kRead | kCapture},  // decode's times are made up: none is shown
    {"--color", kDecode | kRead | kDiagnose | kCapture},
    {"--no-progress", kRead},  // long offline runs
    {"-x", kDecode | kRead | kCapture},
    {"-Y", kDecode | kRead | kCapture},
    {"-e", kDecode | kRead | kCapture},
    {"-E", kDecode | kRead | kCapture},
    {"-z", kDecode | kRead | kCapture},
};

// Removes from `cmd` the options whose row leaves `command` out.
void remove_options_not_taken(CLI::App* cmd, unsigned command) {
  std::vector<CLI::Option*> unused;
  for (CLI::Option* option : cmd->get_options())
    for (const OptionUse& use : kOptionUse)
      if ((use.commands & command) == 0 && option->check_name(std::string(use.name)))
        unused.push_back(option);
  for (CLI::Option* option : unused) cmd->remove_option(option);
}

// tshark's conventions: -c, -q, -t, --color, --no-progress, -x.
void add_tshark_options(CLI::App* cmd, CommonOptions& o) {
  // Digits only, from 1: "-1", "" and 2^64 would otherwise pass for "no limit" (as tshark, 0
  // is refused too).
  cmd->add_option("-c,--count", o.count,
                  "Stop after N frames, N from 1 (as tshark -c; noise records do not count)")
      ->check(CLI::Validator(
          [](const std::string& text) -> std::string {
            constexpr std::string_view kMax = "9223372036854775807";
            const bool digits = !text.empty() && text.find_first_not_of("0123456789") ==
                                                     std::string::npos;
            const std::string_view number =
                digits ? std::string_view(text).substr(std::min(text.find_first_not_of('0'),
                                                                text.size()))
                       : std::string_view();
            if (!digits || number.empty() || number.size() > kMax.size() ||
                (number.size() == kMax.size() && number > kMax))
              return fmt::format("'{}' is not a number of frames from 1 to {}", text, kMax);
            return {};
          },
          "N"));
  cmd->add_flag("-q,--quiet", o.quiet,
                "No line per frame: the closing summary (or the -z statistics) alone");
  cmd->add_option("-t", o.time_format,
                  "Time of the text column and of -T fields' t (as tshark -t): r (default, "
                  "seconds since the capture's start), a / ad (local time / with date), d / dd "
                  "(since the previous record "
                  "captured / shown), e (epoch), u / ud (UTC / with date)")
      ->check(CLI::IsMember({"ad", "a", "r", "d", "dd", "e", "u", "ud"}));
  cmd->add_option("--color", o.color,
                  "Colour findings and verdicts: auto (default: when stdout is a terminal and "
                  "NO_COLOR is unset), always, never")
      ->check(CLI::IsMember({"auto", "always", "never"}));
  cmd->add_flag("--no-progress", o.no_progress,
                "No progress line on stderr (shown for long runs when stderr is a terminal)");
  cmd->add_flag("-x,--hex", o.hex_dump,
                "Text: each frame's bytes in full as a hex and ASCII dump (as tshark -x)");
}

}  // namespace

bool color_wanted(const CommonOptions& o, std::FILE* out) {
  if (o.color == "always") return true;
  if (o.color == "never") return false;
  const char* no_color = std::getenv("NO_COLOR");
  return (!no_color || !*no_color) && ::isatty(::fileno(out)) == 1;
}

TimeFormat time_format_of(const CommonOptions& o) {
  return time_format_from_option(o.time_format).value_or(TimeFormat::relative);
}

void refuse_idle_options(const CommonOptions& o, unsigned command) {
  if (o.write.empty()) {
    if (o.classic_pcap) die("--pcap: only with -w FILE (it is the format of the capture file)");
    if (o.dlt != "upper-pdu") die("--dlt: only with -w FILE (it is the capture file's link type)");
  }
  if (o.format == "json") {
    if (!o.time_format.empty())
      die("-t: only for the text output and -T fields (JSON gives times in seconds as captured)");
    if (o.hex_dump) die("-x: only for the text output (JSON gives each frame's bytes)");
    if (o.verbose) die("-V: only for the text output (JSON gives each frame's fields)");
    if (o.color != "auto") die("--color: only for the text output");
  }
  // Without frame lines, what is shown of each frame does nothing.
  const char* no_frames = o.quiet ? "-q" : o.stats_only ? "--stats" : nullptr;
  if (no_frames && o.events_only)
    die(fmt::format("{} and --events: {} leaves out the events", no_frames, no_frames));
  if (!no_frames && o.events_only) no_frames = "--events";
  if (no_frames && o.hex_dump)
    die(fmt::format("{} and -x: {} leaves out the frames", no_frames, no_frames));
  if (no_frames && o.verbose)
    die(fmt::format("{} and -V: {} leaves out the frames", no_frames, no_frames));
  (void)command;
}

void add_common_options(CLI::App* cmd, CommonOptions& o, unsigned command) {
  cmd->add_option("-T,--format", o.format,
                  "Output format: text, json (JSON lines) or fields (-e, -E: one line per frame)")
      ->check(CLI::IsMember({"text", "json", "fields"}));
  cmd->add_option("-Y,--display-filter", o.display_filter,
                  "Show only the frames this filter selects, in tshark's syntax, e.g. "
                  "'addr == 2 && checksum_bad' (names: JSON keys, field ids, findings)");
  cmd->add_option("-e", o.fields, "With -T fields: a field to print (repeatable), as -Y names it")
      ->allow_extra_args(false);
  cmd->add_option("-E", o.field_options,
                  "With -T fields: separator=,|/t|/s|C header=y|n quote=d|s|n occurrence=f|l|a "
                  "aggregator=,|/s|C (quote=d is for spreadsheets: a cell that starts with = + - "
                  "@ and is no number gets a leading ', so that it is never run as a formula)")
      ->allow_extra_args(false);
  cmd->add_flag("-V,--verbose", o.verbose, "Text: show each frame's field tree with byte offsets");
  cmd->add_option("-s,--serial", o.serial,
                  "Line settings, e.g. \"19200 8E1\" (default: the capture's, else 9600 8N1)");
  cmd->add_option("--t15", o.t15, "Inter-character limit t1.5: 1.5c, 750us, 1ms (default: Modbus)");
  cmd->add_option("--t35", o.t35, "Inter-frame silence t3.5: 3.5c, 1750us, 2ms (default: Modbus)");
  cmd->add_option("--timeout", o.timeout,
                  "Reply timeout before a request counts as unanswered (default 1s)");
  cmd->add_option("--max-hold", o.max_hold,
                  "Longest wait for the rest of a frame split by a silence (default 100ms)");
  std::vector<std::string> protocol_choices{"auto"};
  std::string protocol_help =
      "Protocol on the bus: auto (default: detected per channel from the first frames)";
  for (const ProtocolDesc* d : registered_protocols()) {
    protocol_choices.emplace_back(d->option_names.front());
    protocol_help += fmt::format(", {} ({})", d->option_names.front(), d->help);
  }
  cmd->add_option("-P,--protocol", o.protocol, protocol_help)
      ->check(CLI::IsMember(protocol_choices));
  cmd->add_option("--drive", o.drives,
                  "Bind a station address to a drive profile, e.g. 2=e9 (see `drivetap profiles`); "
                  "auto (default): guess each station's family from its traffic; none: no guessing")
      ->allow_extra_args(false);  // repeatable, one value each: `--drive 2=e9 FILE` keeps FILE
  cmd->add_option("--profile", o.profiles,
                  "Load a drive profile file (TOML) besides the built-in ones; same id replaces")
      ->allow_extra_args(false);
  cmd->add_option("--profile-dir", o.profile_dirs, "Load every *.toml drive profile in DIR")
      ->allow_extra_args(false);
  cmd->add_option("--channels", o.logic_channels,
                  "Logic-analyser captures: the channels to decode as UART, by name or index, "
                  "e.g. RX,TX (default: every channel whose line moves)")
      ->delimiter(',')
      ->allow_extra_args(false);
  cmd->add_flag("--invert", o.invert,
                "Logic-analyser captures, with -s: the line idles low (A/B swapped, RS-232 side); "
                "without -s polarity and settings are detected");
  cmd->add_option("--logic-max", o.logic_max,
                  "sigrok sessions: the most sample data to decompress, e.g. 4G (default 1G; 0: "
                  "no limit), a guard against zip bombs")
      ->transform(CLI::AsSizeValue(false));
  cmd->add_flag("--events", o.events_only,
                "Print only the events: drive-state timeline, drive bindings, protocol detection");
  cmd->add_flag("--no-summary", o.no_summary, "Do not print the closing summary");
  cmd->add_flag("--stats", o.stats_only,
                "Decode everything, print only the closing summary (text or JSON)");
  cmd->add_option("-z", o.statistics,
                  "Statistics printed after the summary (repeatable): stations, functions, gaps, "
                  "load[,SECONDS]; JSON records with -T json")
      ->allow_extra_args(false)
      ->each([](const std::string& spec) {
        std::string error;
        if (!parse_statistic(spec, &error)) die(error);
      });
  cmd->add_option("-o,--output", o.output, "Write the text/JSON output to FILE instead of stdout");
  cmd->add_option("-w,--write", o.write,
                  "Write every frame as a packet to a pcapng FILE ('-' for stdout)");
  cmd->add_flag("--pcap", o.classic_pcap, "With -w: classic pcap instead of pcapng");
  cmd->add_flag("--plain", o.plain,
                "With -w: pcapng of the frames alone (no comments, flags or per-byte times), "
                "packets stamped at their last byte");
  cmd->add_option("--dlt", o.dlt,
                  "With -w: link type upper-pdu (252, Wireshark decodes it as is) or user0 (147)")
      ->check(CLI::IsMember({"upper-pdu", "user0"}));
  add_tshark_options(cmd, o);
  remove_options_not_taken(cmd, command);
}

Command add_file_command(CLI::App& app, const std::string& name, const std::string& description,
                         const std::string& file_help,
                         int (*run)(const CommonOptions& o, const std::string& path)) {
  auto o = std::make_shared<CommonOptions>();
  auto path = std::make_shared<std::string>();
  CLI::App* command = app.add_subcommand(name, description);
  const unsigned bit = name == "read" ? kReadCommand : kDiagnoseCommand;
  add_common_options(command, *o, bit);
  command->add_option("file", *path, file_help);
  command->add_option("-r,--read-file", *path, "The capture file, as tshark -r FILE");
  return {
      command, [o, path, run, bit, name] {
        if (path->empty())
          die(fmt::format("{}: give a capture file (drivetap {} FILE, or -r FILE)", name, name));
        refuse_idle_options(*o, bit);
        return run(*o, *path);
      }};
}

// One line on stderr, "drivetap: MESSAGE": whole (a NUL in a name taken from a file would cut
// a %s), with whatever is not printable UTF-8 escaped (a name may hold a newline or ESC).
void say(std::string_view message) {
  const std::string line = fmt::format("drivetap: {}\n", printable(message, false));
  std::fwrite(line.data(), 1, line.size(), stderr);
}

[[noreturn]] void die(const std::string& message, int code) {
  std::fflush(stdout);
  say(message);
  std::exit(code);
}

// Standard output flushed at the end of any command: a failed write is one line and exit 1 (a full
// disk), or, when the reader went away (EPIPE), the silent exit status of a process that SIGPIPE
// ended, as the shell expects of `drivetap ... | head`.
void finish_stdout() {
  if (std::fflush(stdout) == 0 && !std::ferror(stdout)) return;
  if (errno == EPIPE) std::_Exit(128 + SIGPIPE);
  die(fmt::format("standard output: write failed: {}", std::strerror(errno)), 1);
}

// Refuses (exit 2) an output that is an input or another output: `read Y.pcapng -w Y.pcapng`
// would truncate the capture before reading it, `-o F -w F` would mix two formats in one file.
// Files are compared by device and inode, as tshark does, when they exist, else by their
// normalised path; "-" and devices (/dev/null twice) are not files to protect.
// `files`: {option, path}, the inputs first.
void refuse_shared_files(const std::vector<std::pair<std::string, std::string>>& files) {
  struct Seen {
    std::string option, path;
    bool exists = false;
    dev_t device = 0;
    ino_t inode = 0;
    std::string normalised;
  };
  std::vector<Seen> seen;
  for (const auto& [option, path] : files) {
    if (path.empty() || path == "-") continue;
    Seen f;
    f.option = option;
    f.path = path;
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0) {
      if (!S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode)) continue;
      f.exists = true;
      f.device = st.st_dev;
      f.inode = st.st_ino;
    } else {
      std::error_code ec;
      f.normalised = std::filesystem::weakly_canonical(path, ec).string();
      if (ec) f.normalised = std::filesystem::absolute(path, ec).lexically_normal().string();
    }
    for (const Seen& before : seen) {
      const bool same = f.exists
                            ? before.exists && before.device == f.device && before.inode == f.inode
                            : !before.exists && before.normalised == f.normalised;
      if (same)
        die(fmt::format("{} {}: is the same file as {} {}: refusing to overwrite it", option, path,
                        before.option, before.path));
    }
    seen.push_back(std::move(f));
  }
}

std::vector<const DriveProfile*> loaded_drive_profiles(const CommonOptions& o) {
  load_profiles(o, true);
  std::vector<const DriveProfile*> loaded;
  for (const DriveProfile& profile : g_profiles) loaded.push_back(&profile);
  return loaded;
}

// Line settings and timing: the capture's own settings first, the command line over them.
PipelineOptions make_pipeline_options(const CommonOptions& o, const RunSettings& capture) {
  std::string err;
  auto p = resolve_pipeline_options(capture, {o.serial, o.t15, o.t35, o.timeout, o.max_hold}, &err);
  if (!p) die(err);
  if (!o.protocol.empty()) p->protocol = protocol_from_option(o.protocol);
  // The built-in profiles are parsed even for `--drive none` (a few ms): their vendor exception
  // codes are plausible Modbus exceptions whether or not a drive is bound (before anything
  // decodes).
  load_profiles(o, true);
  // The `drive.*` filter and field names the loaded profiles give (the filter is compiled next).
  static const bool drive_fields_added = [] {
    std::vector<const DriveProfile*> loaded;
    for (const DriveProfile& profile : g_profiles) loaded.push_back(&profile);
    add_drive_field_source(loaded);
    return true;
  }();
  (void)drive_fields_added;
  for (const DriveProfile& profile : g_profiles)
    for (const auto& [code, meaning] : profile.exceptions)
      if (code <= 0xFF) allow_vendor_exception_code(static_cast<std::uint8_t>(code));
  bool guess = true;
  for (const std::string& binding : o.drives) {
    if (binding == "auto") continue;
    if (binding == "none") {
      guess = false;
      continue;
    }
    const std::size_t eq = binding.find('=');
    int address = -1;
    if (eq != std::string::npos) {
      try {
        std::size_t used = 0;
        address = std::stoi(binding.substr(0, eq), &used);
        if (used != eq) address = -1;
      } catch (...) {
        address = -1;
      }
    }
    if (address < 0 || address > 255)
      die(fmt::format("--drive {}: expected ADDRESS=PROFILE (e.g. 2=e9), auto or none", binding));
    const std::string id = binding.substr(eq + 1);
    const DriveProfile* found = nullptr;
    std::string known;
    for (const DriveProfile& profile : g_profiles) {
      if (profile.id == id) found = &profile;
      known += (known.empty() ? "" : ", ") + profile.id;
    }
    if (!found) die(fmt::format("--drive {}: no profile '{}' (known: {})", binding, id, known));
    p->drives[address] = found;
  }
  if (guess)
    for (const DriveProfile& profile : g_profiles) p->auto_candidates.push_back(&profile);
  return *p;
}
}  // namespace drivetap::app
