// drivetap command line: `decode` pasted hex, `read` capture files (README "Command reference").
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <poll.h>
#include <semaphore.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "app/diagnose.hpp"
#include "core/printable.hpp"
#include "core/protocol.hpp"
#include "core/serial_config.hpp"
#include "dissectors/common/plausibility.hpp"
#include "drive/profile.hpp"
#include "formats/shared_libraries.hpp"
#include "generate/byte_log_writer.hpp"
#include "generate/traffic.hpp"
#include "pipeline/options.hpp"
#include "pipeline/pipeline.hpp"
#include "sinks/capture_sink.hpp"
#include "sinks/json_sink.hpp"
#include "sinks/ring_capture_sink.hpp"
#include "sinks/text_sink.hpp"
#include "sinks/threaded_sink.hpp"
#include "sources/file/byte_log.hpp"
#include "sources/file/capture_reader.hpp"
#include "sources/file/hex_text.hpp"
#include "sources/input_file.hpp"
#include "sources/live/serial_port.hpp"
#include "sources/logic/logic_source.hpp"
#include "sources/logic/sigrok_file.hpp"
#include "sources/logic/vcd_file.hpp"
#include "sources/read_ahead.hpp"

namespace {

using namespace drivetap;

volatile std::sig_atomic_t g_stop = 0;
sem_t g_stop_posted;  // posted by on_signal (sem_post is async-signal-safe): wakes the watchdog
void on_signal(int) {
  g_stop = 1;
  ::sem_post(&g_stop_posted);
}

// SIGINT and SIGTERM end a run with its outputs closed (on_signal sets g_stop, which the loops
// check), also a run whose output blocks (a FIFO or pipe whose reader stopped reading), where a
// thread sits in write() and the decoding thread waits for it: a watchdog thread, woken by the
// signal, gives the run a grace second, then sends every other thread SIGUSR1 (a handler that does
// nothing, installed without SA_RESTART) until the run ends. A blocked write() returns EINTR, the
// output counts as failed and is not written to again, and the run closes its other outputs and
// ends as interrupted. Commands that do not catch the signals end at once, as by default.
void start_stop_watchdog() {
  ::sem_init(&g_stop_posted, 0, 0);
  struct sigaction wake {};
  wake.sa_handler = [](int) {};
  sigemptyset(&wake.sa_mask);
  wake.sa_flags = 0;  // no SA_RESTART: the blocked call returns EINTR
  ::sigaction(SIGUSR1, &wake, nullptr);
  std::thread([] {
    while (::sem_wait(&g_stop_posted) != 0) continue;  // EINTR: a signal landed on this thread
    std::this_thread::sleep_for(std::chrono::seconds(1));
    const pid_t self = static_cast<pid_t>(::syscall(SYS_gettid));
    for (;;) {
      std::error_code ec;
      for (const auto& task : std::filesystem::directory_iterator("/proc/self/task", ec)) {
        const long tid = std::strtol(task.path().filename().c_str(), nullptr, 10);
        if (tid > 0 && tid != self) ::syscall(SYS_tgkill, ::getpid(), tid, SIGUSR1);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }).detach();
}

// SIGINT and SIGTERM set g_stop for the rest of this run, with the watchdog behind them.
void catch_stop_signals() {
  static bool watching = false;
  if (!watching) start_stop_watchdog();
  watching = true;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

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
  std::vector<std::string> logic_channels;  // --channels RX,TX
  bool invert = false;
  std::uint64_t logic_max = SigrokFile::kDefaultMaxSampleBytes;  // --logic-max
};

// Profiles loaded for this run (built in and --profile files); bound drives point into it.
std::deque<DriveProfile> g_profiles;

void add_common_options(CLI::App* cmd, CommonOptions& o) {
  cmd->add_option("-T,--format", o.format, "Output format: text or json (JSON lines)")
      ->check(CLI::IsMember({"text", "json"}));
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
}

// One line on stderr, "drivetap: MESSAGE": whole (a NUL in a name taken from a file would cut
// a %s), with whatever is not printable UTF-8 escaped (a name may hold a newline or ESC).
void say(std::string_view message) {
  const std::string line = fmt::format("drivetap: {}\n", printable(message, false));
  std::fwrite(line.data(), 1, line.size(), stderr);
}

[[noreturn]] void die(const std::string& message, int code = 2) {
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

// Said once a run: channel names from the input that were escaped or shortened to print.
void say_rewritten_names(const ChannelTable& channels) {
  if (channels.rewritten_names() == 0) return;
  say(
      fmt::format("{} channel name{} not printable UTF-8 or longer than {} bytes: shown escaped or "
                  "shortened (first: {})",
                  channels.rewritten_names(), channels.rewritten_names() == 1 ? " was" : "s were",
                  ChannelTable::kMaxNameBytes, channels.first_rewritten_name()));
}

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

// The capture file's options for -w (format, link type, the run's settings in each interface).
CaptureSinkOptions capture_options(const CommonOptions& o, const PipelineOptions& p) {
  if (o.plain && o.classic_pcap)
    die("--plain: only with pcapng (classic pcap has no comments or per-byte times to leave out)");
  if (o.classic_pcap && !pcap_library().loaded)
    die(fmt::format("--pcap: {}", pcap_library().error));
  CaptureSinkOptions c;
  c.format = o.classic_pcap ? CaptureFormat::pcap : CaptureFormat::pcapng;
  c.link_type = o.dlt == "user0" ? CaptureLinkType::user0 : CaptureLinkType::upper_pdu;
  c.plain = o.plain;
  c.serial = p.serial;
  c.character_time = p.timing.character_time;
  c.settings = encode_settings(p.timing.t15, p.timing.t35, p.reply_timeout, p.max_hold, p.protocol);
  return c;
}

// Owns the output files and the sinks chosen by -T, -o and -w.
class Outputs {
 public:
  Outputs(const CommonOptions& o, const ChannelTable& channels, const PipelineOptions& p,
          bool timed, const RingOptions* ring = nullptr)
      : options_(o) {
    const bool capture_to_stdout = o.write == "-";
    if (o.plain && o.write.empty()) die("--plain: only with -w FILE (it is a kind of pcapng)");
    if (capture_to_stdout && (o.output.empty() || o.output == "-") && o.format == "json")
      die("-w - and JSON output cannot share stdout: add -o FILE for the JSON");
    if (!o.output.empty() && o.output != "-") {
      text_file_ = open_output_file(o.output);
      if (!text_file_) die(fmt::format("-o {}: cannot create: {}", o.output, std::strerror(errno)));
    } else {
      // With the capture on stdout, the text goes to stderr as a summary only (like tcpdump).
      text_file_ = capture_to_stdout ? stderr : stdout;
    }
    if (ring) {
      if (o.write.empty() || capture_to_stdout) die("-b: needs -w FILE (a file name, not -)");
      ring_ = std::make_unique<RingCaptureSink>(o.write, channels, capture_options(o, p), *ring);
      std::string error;
      if (!ring_->open(&error)) die(error, 1);
      tee_.add(ring_.get());
    } else if (!o.write.empty()) {
      capture_file_ = capture_to_stdout ? stdout : open_output_file(o.write);
      if (!capture_file_)
        die(fmt::format("-w {}: cannot create: {}", o.write, std::strerror(errno)));
      capture_ = std::make_unique<CaptureSink>(capture_file_, channels, capture_options(o, p));
      tee_.add(capture_.get());
    }
    // The text or JSON sink; with no file, one of its helpers (writing into memory).
    const auto make_text = [&](std::FILE* file) -> std::unique_ptr<Sink> {
      if (o.format == "json")
        return std::make_unique<JsonSink>(file, channels, p.timing.character_time, timed);
      TextSinkOptions t;
      t.verbose = o.verbose;
      t.show_time = timed;
      t.summary = !o.no_summary;
      t.frames = !(capture_to_stdout && text_file_ == stderr);
      return std::make_unique<TextSink>(file, channels, t);
    };
    text_ = make_text(text_file_);
    // Text or JSON alone, to a file or a pipe, is formatted a batch at a time by as many threads
    // as there are cores, the decoding thread among them when it is ahead (ThreadedSink helpers),
    // and written in order: formatting is most of a run's work. A terminal gets each line as it
    // comes from the one writer; a capture file has its own order of blocks to keep.
    const unsigned cores = std::thread::hardware_concurrency();
    if (!ring && o.write.empty() && !o.stats_only && !o.events_only && cores >= 2 &&
        ::isatty(::fileno(text_file_)) != 1)
      for (unsigned i = 0; i < std::min(cores, 4u); ++i) helpers_.push_back(make_text(nullptr));
    if (o.stats_only && o.no_summary) die("--stats and --no-summary leave nothing to print");
    if (o.stats_only) {
      summary_only_ = std::make_unique<SummaryOnlySink>(*text_);
      tee_.add(summary_only_.get());
    } else if (o.events_only) {
      events_only_ = std::make_unique<EventsOnlySink>(*text_);
      tee_.add(events_only_.get());
    } else {
      tee_.add(text_.get());
    }
  }
  // From now on the records are formatted and written on a second thread (ThreadedSink) while
  // this one decodes: `read`, when some sink shows or writes every frame (not --stats or
  // --events without -w, whose sinks drop nearly every record: copying them would cost more
  // than it saves).
  void write_on_second_thread() {
    if (!helpers_.empty()) {
      std::vector<Sink*> helpers;
      for (const std::unique_ptr<Sink>& helper : helpers_) helpers.push_back(helper.get());
      threaded_ = std::make_unique<ThreadedSink>(*text_, std::move(helpers));  // (tee_: text_)
    } else if ((!options_.stats_only && !options_.events_only) || capture_) {
      threaded_ = std::make_unique<ThreadedSink>(tee_);
    }
  }
  Sink& sink() { return threaded_ ? static_cast<Sink&>(*threaded_) : tee_; }
  // Whether nothing written from now on reaches anybody: the text output failed (its reader went
  // away, `| head`) and there is no capture file to complete. Reading on would be wasted.
  [[nodiscard]] bool unread() const { return !capture_ && !ring_ && std::ferror(text_file_); }
  // Live capture: everything written so far reaches its file (a text line per frame as it
  // completes; pcapng packets readable while the capture runs). False when a write failed.
  bool flush() {
    const bool ok = threaded_ ? threaded_->flush() : tee_.flush();
    if (!ok && ring_ && !ring_->error().empty()) die(ring_->error(), 1);
    if (capture_file_ && capture_file_ != stdout) {
      if (ok) {
        capture_good_size_ = std::ftell(capture_file_);
      } else if (!capture_failed_) {
        capture_failed_ = true;
        capture_errno_ = errno;
      }
    }
    return ok;
  }

  // Flushes and closes every output; a failed write (disk full, closed pipe) is an error.
  void close() {
    if (threaded_) threaded_->finish();  // every record replayed; the sinks are this thread's
    // Each failure's errno is kept where it happens: cutting the file back and closing it
    // overwrite errno, and the message must give the write's own reason ("No space left").
    const bool text_ok = text_->flush();
    const int text_errno = errno;
    const bool capture_ok = !capture_failed_ && (!capture_ || capture_->flush());
    const int capture_errno = capture_failed_ ? capture_errno_ : errno;
    if (ring_ && !ring_->close()) die(ring_->error(), 1);
    capture_.reset();
    // A failed write (disk full) leaves the file cut back to its last whole block: valid, with
    // every packet that reached the disk.
    if (!capture_ok && capture_file_ && capture_file_ != stdout)
      cut_back_to(capture_file_, capture_good_size_,
                  options_.classic_pcap ? CaptureFormat::pcap : CaptureFormat::pcapng);
    const bool capture_closed =
        !capture_file_ || capture_file_ == stdout || std::fclose(capture_file_) == 0;
    if (!capture_ok)
      die(fmt::format("-w {}: write failed: {}", options_.write, std::strerror(capture_errno)), 1);
    if (!capture_closed)
      die(fmt::format("-w {}: write failed: {}", options_.write, std::strerror(errno)), 1);
    const bool to_file = text_file_ != stdout && text_file_ != stderr;
    const std::string text_name = to_file                ? "-o " + options_.output
                                  : text_file_ == stdout ? std::string("standard output")
                                                         : std::string("standard error");
    if (!text_ok) {
      // Half a line (half a JSON record) would mislead whoever reads the file: cut it off.
      if (to_file) cut_back_to_last_line(text_file_);
      if (!to_file && text_errno == EPIPE) std::_Exit(128 + SIGPIPE);  // `| head`: as SIGPIPE
      if (g_stop && text_errno == EINTR)
        die(fmt::format("interrupted; {} blocked (nobody read it): the rest of its output is lost",
                        text_name),
            130);
      die(fmt::format("{}: write failed: {}", text_name, std::strerror(text_errno)), 1);
    }
    if (to_file && std::fclose(text_file_) != 0)
      die(fmt::format("{}: write failed: {}", text_name, std::strerror(errno)), 1);
  }

 private:
  const CommonOptions& options_;
  std::FILE* text_file_ = stdout;
  std::FILE* capture_file_ = nullptr;
  int capture_errno_ = 0;  // why the first failed flush failed
  std::unique_ptr<Sink> text_;
  std::vector<std::unique_ptr<Sink>> helpers_;  // text_'s kind, writing into memory
  std::unique_ptr<Sink> events_only_;
  std::unique_ptr<Sink> summary_only_;
  std::unique_ptr<CaptureSink> capture_;
  std::unique_ptr<RingCaptureSink> ring_;
  TeeSink tee_;
  long capture_good_size_ = 0;  // the capture file up to its last packet flushed whole
  bool capture_failed_ = false;
  // Last: destroyed first, its thread joined before the sinks it writes to go.
  std::unique_ptr<ThreadedSink> threaded_;
};

// Reads one line of standard input into `line` (without its '\n'), at most kMaxDecodeLine bytes;
// false at the end, or with *error and *code set (a longer line, 2: frames are a few hundred
// characters; a read error, 1).
constexpr std::size_t kMaxDecodeLine = 1u << 20;
bool read_decode_line(std::string& line, std::uint64_t number, std::string* error, int* code) {
  line.clear();
  int c = 0;
  while ((c = std::getchar()) != EOF && c != '\n') {
    if (line.size() == kMaxDecodeLine) {
      *error = fmt::format("standard input: line {}: longer than {} bytes", number, kMaxDecodeLine);
      *code = 2;
      return false;
    }
    line.push_back(static_cast<char>(c));
  }
  if (c == EOF && std::ferror(stdin)) {
    *error = fmt::format("standard input: line {}: read error: {}", number, std::strerror(errno));
    *code = 1;
    return false;
  }
  return c != EOF || !line.empty();
}

// Frames given as arguments, or one text per line of standard input, decoded as they come (a
// long stdin is never held whole).
int run_decode(const CommonOptions& o, const std::vector<std::string>& args) {
  refuse_shared_files({{"-o", o.output}, {"-w", o.write}});
  ChannelTable channels;
  const ChannelId bus = channels.intern("bus");
  PipelineOptions p = make_pipeline_options(o, RunSettings{});
  // The frames are the ones the user typed: one good telegram tells their protocol.
  p.detect_min_good = 1;
  // The times below are made up: no timeout, no unanswered request, no timing rule is reported.
  p.clocked = false;
  // Frames given separately are laid out with a clean silence between them; bytes run together
  // in one frame text are back to back and get split by content.
  const TimeNs gap = std::max<TimeNs>(p.timing.t35 * 4, 20 * kNsPerMs);
  const bool from_stdin = args.empty() || (args.size() == 1 && args[0] == "-");
  // Frames written as text are Modbus ASCII (":0103...") or Easydrive ("~010A..."); hex bytes
  // are left to detection (Modbus RTU, Danfoss FC). The first frame decides, for the whole run.
  char first_kind = 0;  // ':' '~' or 'x' (hex) once a frame was seen
  std::unique_ptr<Outputs> out;
  std::unique_ptr<Pipeline> pipeline;
  std::vector<ByteEvent> events;
  TimeNs clock = 0;
  auto stop = [&](const std::string& message, int code = 2) {
    // What was decoded before the bad text stays written.
    if (pipeline) pipeline->finish();
    if (out) out->close();
    die(message, code);
  };
  auto take = [&](const std::string& text, const std::string& where) {
    const char kind = decode_text_kind(text);
    if (kind == 0) return;
    const std::string shown = text.size() > 60 ? text.substr(0, 57) + "..." : text;
    if (first_kind != 0 && kind != first_kind)
      stop(
          fmt::format("{} (\"{}\"): give frames of one kind (hex bytes, ':' Modbus ASCII or '~' "
                      "Easydrive), not several",
                      where, shown));
    std::string err;
    const auto frames = parse_decode_text(text, kind, &err);
    if (!frames) stop(fmt::format("{} (\"{}\"): {}", where, shown, err));
    if (first_kind == 0) {
      first_kind = kind;
      if (o.protocol.empty() && kind != 'x') p.protocol = protocol_for_text_start(kind);
    }
    events.clear();
    synthesize_events(*frames, bus, p.timing.character_time, gap, &clock, events);
    if (events.empty()) return;
    if (!pipeline) {
      out = std::make_unique<Outputs>(o, channels, p, /*timed=*/false);
      pipeline = std::make_unique<Pipeline>(p, channels, out->sink());
    }
    for (const ByteEvent& e : events) pipeline->push(e);
  };
  if (from_stdin) {
    std::string line, error;
    int code = 0;
    for (std::uint64_t number = 1; read_decode_line(line, number, &error, &code); ++number)
      take(line, fmt::format("standard input: line {}", number));
    if (!error.empty()) stop(error, code);
  } else {
    for (std::size_t i = 0; i < args.size(); ++i) take(args[i], fmt::format("argument {}", i + 1));
  }
  if (!pipeline)
    die("decode: no hex bytes given (e.g. drivetap decode \"01 03 00 00 00 01 84 0A\")");
  pipeline->finish();
  out->close();
  return 0;
}

// -s and --invert for a logic capture: given settings are used as given; without -s the line is
// detected (and --invert alone is refused: detection finds the polarity itself).
LogicSourceOptions logic_source_options(const CommonOptions& o) {
  LogicSourceOptions so;
  so.channels = o.logic_channels;
  if (!o.serial.empty()) {
    const PipelineOptions line = make_pipeline_options(o, RunSettings{});
    so.uart = phy::UartSettings::from(line.serial);
    so.uart->inverted = o.invert;
  } else if (o.invert) {
    die("--invert: give the line settings too (-s \"19200 8E1\"), or neither: both are detected");
  }
  return so;
}

// The source for a capture file of any supported format (the format is read from its first bytes).
std::unique_ptr<ByteSource> open_source(const CommonOptions& o, const std::string& path,
                                        InputFile& in, ChannelTable& channels) {
  std::string err;
  if (!open_input(path, &in, &err)) die(err, 1);
  std::unique_ptr<ByteSource> source;
  switch (in.format) {
    case InputFormat::byte_log:
      source = std::make_unique<ByteLogReader>(in.file, in.name, channels);
      break;
    case InputFormat::pcapng:
      source = std::make_unique<CaptureReader>(in.file, in.name, true, channels);
      break;
    case InputFormat::pcap:
      source = std::make_unique<CaptureReader>(in.file, in.name, false, channels);
      in.file = nullptr;  // libpcap owns and closes it
      break;
    case InputFormat::sigrok:
    case InputFormat::vcd: {
      // Logic captures are read by name: a zip (libzip) cannot come through stdin, and detection
      // reads the start of either twice.
      if (in.name == "<stdin>")
        die(fmt::format("<stdin>: a {} must be read by name", input_format_name(in.format)), 1);
      const InputFormat format = in.format;
      close_input(in);
      std::string error;
      std::unique_ptr<LogicCapture> file;
      if (format == InputFormat::sigrok) {
        auto sigrok = SigrokFile::open(path, &error);
        if (sigrok) sigrok->set_max_sample_bytes(o.logic_max);
        file = std::move(sigrok);
      } else {
        file = VcdFile::open(path, &error);
      }
      if (!file) die(error, 1);
      source =
          std::make_unique<LogicSource>(std::move(file), path, channels, logic_source_options(o));
      break;
    }
    case InputFormat::empty:
      die(fmt::format("{}: empty file", in.name), 1);
    case InputFormat::unknown:
      die(fmt::format("{}: offset 0: not a recognised capture format (first byte 0x{:02X}); "
                      "expected pcapng, pcap, a sigrok session, a VCD or a drivetap byte log",
                      in.name, in.head[0]),
          1);
  }
  return source;
}

// Reads the source's header and settles the run's options: the capture's settings, overridden by
// the command line's.
PipelineOptions start_source(const CommonOptions& o, ByteSource& source) {
  source.set_stop_flag(&g_stop);  // reading ahead for detection may take long (catch_stop_signals)
  if (!source.read_header()) die(source.error(), 1);
  if (g_stop) die("interrupted", 130);
  PipelineOptions p = make_pipeline_options(o, source.settings());
  source.set_character_time(p.timing.character_time);
  return p;
}

// A file named on the command line that is a regular file (not "-", a FIFO or a device).
bool is_regular_file(const std::string& path) {
  struct stat st {};
  return path != "-" && ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

int run_read(const CommonOptions& o, const std::string& path) {
  refuse_shared_files({{"input", path}, {"-o", o.output}, {"-w", o.write}});
  InputFile in;
  ChannelTable channels;
  std::unique_ptr<ByteSource> source = open_source(o, path, in, channels);
  catch_stop_signals();
  const PipelineOptions p = start_source(o, *source);
  Outputs out(o, channels, p, /*timed=*/true);
  out.write_on_second_thread();
  Pipeline pipeline(p, channels, out.sink());

  RunBatch batch;
  bool interrupted = false;
  std::uint64_t batches = 0;
  // pcap/pcapng files are read a few chunks ahead on a second thread (no findings; a regular
  // file cannot block the reader for ever); other sources batch by batch on this one.
  std::optional<ReadAhead> ahead;
  if ((in.format == InputFormat::pcapng || in.format == InputFormat::pcap) && is_regular_file(path))
    ahead.emplace(*source);
  // Each pass decodes one chunk or one batch of the source.
  while (ahead ? ahead->next_chunk(batch) : (batch.clear(), source->append_runs(batch))) {
    if (!ahead)
      for (const Anomaly& a : source->take_findings()) pipeline.report(a);
    pipeline.push_runs(batch);
    // The reader makes the prechecks the pipeline asks for, by the decoders detected so far.
    if (ahead)
      for (std::size_t c = 0; c < pipeline.channel_count(); ++c)
        ahead->precheck_with(static_cast<ChannelId>(c),
                             pipeline.precheck_decoder_of(static_cast<ChannelId>(c)));
    if (g_stop) {
      interrupted = true;
      break;
    }
    if (++batches % 256 == 0 && out.unread()) break;
  }
  interrupted = interrupted || g_stop;  // a source may end early, as at its end, when stopped
  ahead.reset();  // the reader thread has stopped: the source is the caller's alone again
  // Whatever happened, what was read so far is decoded, summarised, written and flushed.
  pipeline.finish();
  out.close();
  for (const std::string& note : source->notes()) say(note);
  say_rewritten_names(channels);
  const std::string error = source->error();
  source.reset();
  close_input(in);
  if (!error.empty()) die(error, 1);
  if (interrupted) die("interrupted; output flushed", 130);
  return 0;
}

// `drivetap diagnose FILE`: runs the capture through the pipeline with nothing printed, then gives
// the line's verdicts (src/app/diagnose.hpp). Any capture: a logic capture gives sample
// evidence (detection, polarity, glitches), the others the UART flags and byte patterns.
int run_diagnose(const CommonOptions& o, const std::string& path) {
  InputFile in;
  ChannelTable channels;
  std::unique_ptr<ByteSource> source = open_source(o, path, in, channels);
  catch_stop_signals();
  const PipelineOptions p = start_source(o, *source);
  const Diagnosis d = diagnose_capture(*source, p, channels, &g_stop);
  if (!d.error.empty()) die(d.error, 1);
  if (d.interrupted) die("interrupted", 130);
  const std::string report = o.format == "json"
                                 ? diagnosis_json(path, d.evidence, d.verdicts, d.stats)
                                 : diagnosis_text(path, d.evidence, d.verdicts, d.stats);
  std::fputs(report.c_str(), stdout);
  std::fflush(stdout);
  close_input(in);
  return 0;
}

// Options of `drivetap capture` besides the common ones.
struct CaptureOptions {
  std::vector<std::string> ports;     // -i
  std::uint64_t max_frames = 0;       // -c
  std::vector<std::string> autostop;  // -a duration:S
  std::vector<std::string> ring;      // -b filesize:MB|duration:S|files:N
  bool reconnect = false;
  bool scan = false;
  double scan_seconds = 2;
};

// One setting of `capture --scan`: what listening `seconds` at `serial` gave.
struct ScanResult {
  SerialConfig serial;
  std::uint64_t bytes = 0, uart_errors = 0, frames = 0, frames_ok = 0;
  std::string error;
};

ScanResult scan_one(const CommonOptions& o, const std::string& path, const SerialConfig& serial,
                    double seconds) {
  ScanResult r;
  r.serial = serial;
  ChannelTable channels;
  SerialPortOptions so;
  so.path = path;
  so.serial = serial;
  auto port = SerialPort::open(so, channels, &r.error);
  if (!port) return r;
  CommonOptions line = o;
  line.serial = serial.to_string();
  PipelineOptions p = make_pipeline_options(line, RunSettings{});
  p.drives.clear();
  p.auto_candidates.clear();
  LineEvidence evidence;
  DiagnosisSink sink(evidence, p.timing);
  Pipeline pipeline(p, channels, sink);
  const TimeNs end = CaptureClock::monotonic() + static_cast<TimeNs>(seconds * 1e9);
  std::vector<ByteEvent> events;
  while (!g_stop && CaptureClock::monotonic() < end) {
    pollfd fd{port->fd(), POLLIN, 0};
    ::poll(&fd, 1, 50);
    events.clear();
    const bool alive = port->read_available(events);
    for (const ByteEvent& e : events) {
      pipeline.push(e);
      ++r.bytes;
      if (e.flags) ++r.uart_errors;
    }
    if (!alive) {
      r.error = port->error();
      break;
    }
  }
  pipeline.finish();
  r.frames = evidence.frames;
  r.frames_ok = evidence.frames_checksum_ok;
  return r;
}

// `drivetap capture --scan -i PORT`: listens at each standard rate and format in turn and says
// which gives frames with good checksums (for a tap on a bus whose settings nobody knows).
int run_scan(const CommonOptions& o, const CaptureOptions& c) {
  if (c.ports.size() != 1) die("--scan: give exactly one port with -i");
  if (!(c.scan_seconds > 0) || c.scan_seconds > 3600)
    die(fmt::format("--scan-time {}: expected seconds between 0 and 3600", c.scan_seconds));
  const std::string path = c.ports.front().substr(0, c.ports.front().find('='));
  catch_stop_signals();
  std::printf("scan %s: %g s per setting (listen only)\n", path.c_str(), c.scan_seconds);
  std::fflush(stdout);
  std::optional<ScanResult> best;
  for (std::uint32_t baud : {9600u, 19200u, 38400u, 57600u, 115200u, 4800u, 2400u, 1200u}) {
    for (Parity parity : {Parity::none, Parity::even, Parity::odd}) {
      if (g_stop) break;
      SerialConfig serial;
      serial.baud = baud;
      serial.parity = parity;
      const ScanResult r = scan_one(o, path, serial, c.scan_seconds);
      if (!r.error.empty() && r.bytes == 0) die(r.error, 1);
      std::printf("  %-11s %6llu bytes, %5llu with UART errors, %4llu frames, %4llu checksum ok\n",
                  serial.to_string().c_str(), static_cast<unsigned long long>(r.bytes),
                  static_cast<unsigned long long>(r.uart_errors),
                  static_cast<unsigned long long>(r.frames),
                  static_cast<unsigned long long>(r.frames_ok));
      std::fflush(stdout);
      // Best: most good frames, then fewest UART errors.
      if (r.frames_ok > 0 &&
          (!best || r.frames_ok > best->frames_ok ||
           (r.frames_ok == best->frames_ok && r.uart_errors < best->uart_errors)))
        best = r;
    }
  }
  if (g_stop) {
    std::printf("interrupted\n");
    return 130;
  }
  if (!best) {
    std::printf(
        "no setting gave a frame with a good checksum (check the wiring: drivetap "
        "diagnose on a logic-analyser capture tells more)\n");
    return 1;
  }
  std::printf(
      "best: %s (%llu frames with a good checksum, %llu UART errors); capture with -s \"%s\"\n",
      best->serial.to_string().c_str(), static_cast<unsigned long long>(best->frames_ok),
      static_cast<unsigned long long>(best->uart_errors), best->serial.to_string().c_str());
  return 0;
}

// `drivetap capture -i PORT...`: live, listen-only capture from serial ports (src/sources/
// serial_port.hpp). Bytes of all ports wait `hold` in a reorder buffer (read latency differs
// between ports), are pushed in time order, and the pipeline is advanced to now - hold, so a frame
// is printed about t3.5 + hold after its last byte. Every output is flushed each round; Ctrl-C,
// SIGTERM, -c, -a, an unplugged adapter (without --reconnect) or a failed write end the run with
// every file closed valid.
int run_capture(const CommonOptions& o, const CaptureOptions& c) {
  if (c.ports.empty()) die("capture: give at least one port with -i (e.g. -i /dev/ttyUSB0)");
  refuse_shared_files({{"-o", o.output}, {"-w", o.write}});
  TimeNs autostop = 0;
  for (const std::string& a : c.autostop) {
    if (!a.starts_with("duration:")) die(fmt::format("-a {}: expected duration:SECONDS", a));
    double seconds = 0;
    std::size_t used = 0;
    try {
      seconds = std::stod(a.substr(9), &used);
    } catch (...) {
      used = 0;
    }
    if (used == 0 || used != a.size() - 9 || !(seconds > 0) || seconds > 1e9)
      die(fmt::format("-a {}: expected duration:SECONDS (e.g. duration:60)", a));
    autostop = static_cast<TimeNs>(seconds * 1e9);
  }
  std::optional<RingOptions> ring;
  for (const std::string& b : c.ring) {
    if (!ring) ring.emplace();
    if (const std::string why = parse_ring_option(b, *ring); !why.empty()) die(why);
  }
  RunSettings given;
  PipelineOptions p = make_pipeline_options(o, given);
  p.max_frames = c.max_frames;
  ChannelTable channels;
  std::vector<std::unique_ptr<SerialPort>> ports(c.ports.size());
  // One clock for the ports and this loop: their byte times and its "now" compare.
  const CaptureClock clock = CaptureClock::take();
  auto open_port = [&](std::size_t k, std::string* error) {
    // -i PATH or -i PATH=NAME: NAME "line.m" / "line.s" puts the two ports of a 4-wire link on
    // one link as master and slave side (src/core/byte_event.hpp channel naming).
    SerialPortOptions so;
    const std::size_t eq = c.ports[k].find('=');
    so.path = c.ports[k].substr(0, eq);
    if (eq != std::string::npos) so.channel_name = c.ports[k].substr(eq + 1);
    so.clock = clock;
    so.serial = p.serial;
    ports[k] = SerialPort::open(so, channels, error);
    return ports[k] != nullptr;
  };
  for (std::size_t k = 0; k < c.ports.size(); ++k) {
    std::string error;
    if (!open_port(k, &error)) die(error, 1);
    for (const std::string& w : ports[k]->warnings()) say("warning: " + w);
  }
  std::fprintf(stderr, "drivetap: capturing on %s at %s (listen only; Ctrl-C stops)\n",
               fmt::format("{}", fmt::join(c.ports, ", ")).c_str(), p.serial.to_string().c_str());
  Outputs out(o, channels, p, /*timed=*/true, ring ? &*ring : nullptr);
  Pipeline pipeline(p, channels, out.sink());
  catch_stop_signals();

  const TimeNs hold = 3 * kNsPerMs;
  const TimeNs started = clock.now();
  std::vector<ByteEvent> pending;  // read, not yet pushed: sorted by time before each push
  std::size_t sorted_pending = 0;  // pending[0, sorted_pending) is in time order
  std::vector<ByteEvent> fresh;
  std::string stop_reason;
  int exit_code = 0;
  while (!g_stop) {
    const TimeNs now = clock.now();
    if (autostop > 0 && now - started >= autostop) {
      stop_reason = "autostop duration reached";
      break;
    }
    if (c.max_frames > 0 && pipeline.stats().frames >= c.max_frames) {
      stop_reason = fmt::format("{} frames captured (-c)", c.max_frames);
      break;
    }
    // Sleep until a port has bytes, the next frame can close, or 100 ms pass.
    TimeNs wake = 100 * kNsPerMs;
    const TimeNs deadline = pipeline.next_deadline();
    if (!pending.empty()) wake = std::min(wake, hold);
    if (deadline != std::numeric_limits<TimeNs>::max())
      wake = std::min(wake, std::max<TimeNs>(0, deadline + hold - now));
    std::vector<pollfd> fds;
    std::vector<std::size_t> which;
    for (std::size_t k = 0; k < ports.size(); ++k)
      if (ports[k]) {
        fds.push_back({ports[k]->fd(), POLLIN, 0});
        which.push_back(k);
      }
    if (fds.empty()) {
      // Every adapter gone, waiting for --reconnect.
      ::usleep(200'000);
    } else {
      const timespec timeout{static_cast<time_t>(wake / kNsPerSecond),
                             static_cast<long>(wake % kNsPerSecond)};
      const int ready = ::ppoll(fds.data(), fds.size(), &timeout, nullptr);
      if (ready < 0 && errno != EINTR) {
        stop_reason = fmt::format("poll: {}", std::strerror(errno));
        exit_code = 1;
        break;
      }
    }
    for (std::size_t f = 0; f < fds.size(); ++f) {
      if (!(fds[f].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const std::size_t k = which[f];
      fresh.clear();
      const bool alive = ports[k]->read_available(fresh);
      pending.insert(pending.end(), fresh.begin(), fresh.end());
      if (!alive) {
        say(ports[k]->error());
        for (const std::string& n : ports[k]->notes()) pipeline.add_source_note(n);
        ports[k].reset();
        if (!c.reconnect) {
          stop_reason = "adapter lost";
          exit_code = 1;
        }
      }
    }
    if (exit_code != 0) break;
    if (c.reconnect)
      for (std::size_t k = 0; k < ports.size(); ++k) {
        if (ports[k] || !std::filesystem::exists(c.ports[k].substr(0, c.ports[k].find('='))))
          continue;
        std::string error;
        if (open_port(k, &error))
          std::fprintf(stderr, "drivetap: %s: reconnected\n", c.ports[k].c_str());
      }
    // Push what is older than the hold, in time order; then let silences close frames.
    const TimeNs settled = clock.now() - hold;
    // What was held is in order already: the new bytes are sorted and merged in (a flooded port
    // would make a full sort of the backlog every round cost more than the bytes).
    const auto by_time = [](const ByteEvent& a, const ByteEvent& b) { return a.time < b.time; };
    const auto fresh_from = pending.begin() + static_cast<std::ptrdiff_t>(sorted_pending);
    std::stable_sort(fresh_from, pending.end(), by_time);
    std::inplace_merge(pending.begin(), fresh_from, pending.end(), by_time);
    std::size_t pushed = 0;
    auto limit_reached = [&] {
      return c.max_frames > 0 && pipeline.stats().frames >= c.max_frames;
    };
    while (pushed < pending.size() && pending[pushed].time <= settled && !limit_reached())
      pipeline.push(pending[pushed++]);
    pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(pushed));
    sorted_pending = pending.size();
    if (!limit_reached()) pipeline.advance(settled);
    if (!out.flush()) {
      stop_reason = "output write failed";
      exit_code = 1;
      break;
    }
  }
  // Whatever stopped the run: what was read is decoded, summarised, written, flushed and closed —
  // except after -c N frames, where the bytes after the Nth frame are not wanted.
  const bool counted_out = c.max_frames > 0 && pipeline.stats().frames >= c.max_frames;
  if (!counted_out)
    for (const ByteEvent& e : pending) pipeline.push(e);
  // The ports' own findings (kernel error counters, USB bursts) go into the summary.
  for (const auto& port : ports)
    if (port)
      for (const std::string& n : port->notes()) pipeline.add_source_note(n);
  pipeline.finish(/*cut_partial=*/!counted_out);
  out.close();
  if (g_stop) {
    std::fprintf(stderr, "drivetap: interrupted; output flushed and closed\n");
    return 130;
  }
  if (!stop_reason.empty()) say("capture stopped: " + stop_reason);
  return exit_code;
}

// Options of `drivetap generate`, kept as text: each is checked here, with one line naming it.
struct GenerateOptions {
  std::string frames = "100000";
  std::string seed = "1";
  std::string mix = "all";
  std::string output;  // -o: byte log
  std::string write;   // -w: pcapng
  std::string truth;   // --truth: what was injected, JSON
  bool plain = false;  // --plain: the pcapng without comments, flags or per-byte times
};

// `drivetap generate`: a large, realistic, reproducible capture (src/generate/traffic.hpp) as a
// byte log (-o) and/or a pcapng (-w). The pcapng is what `drivetap read LOG -w FILE` writes of the
// byte log: the records go through the same pipeline, with read's default options, into the same
// capture sink. Streams: memory stays constant whatever --frames.
int run_generate(const GenerateOptions& g) {
  auto number = [](const char* option, const std::string& text, std::uint64_t lo, std::uint64_t hi,
                   const char* expected) {
    std::uint64_t v = 0;
    const char* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, v);
    if (text.empty() || ec != std::errc() || ptr != end || v < lo || v > hi)
      die(fmt::format("{} {}: expected {}", option, text, expected));
    return v;
  };
  generate::Options go;
  go.frames = number("--frames", g.frames, 1, 10'000'000'000ull, "a number of records, 1 to 10^10");
  go.seed = number("--seed", g.seed, 0, std::numeric_limits<std::uint64_t>::max(),
                   "a whole number, 0 to 2^64-1");
  if (g.mix == "all")
    go.mix = generate::Mix::all;
  else if (g.mix == "modbus-rtu")
    go.mix = generate::Mix::modbus_rtu;
  else
    die(fmt::format("--mix {}: expected all or modbus-rtu", g.mix));
  if (g.output.empty() && g.write.empty())
    die("generate: give -o FILE (byte log), -w FILE (pcapng) or both");
  if (g.plain && g.write.empty()) die("--plain: only with -w FILE (it is a kind of pcapng)");
  if (g.output == "-" && g.write == "-") die("-o - and -w - cannot both be stdout");
  refuse_shared_files({{"-o", g.output}, {"-w", g.write}, {"--truth", g.truth}});
  auto create = [](const char* option, const std::string& path, const char* mode) {
    if (path.empty()) return static_cast<std::FILE*>(nullptr);
    if (path == "-") return stdout;
    std::FILE* f = std::fopen(path.c_str(), mode);
    if (!f) die(fmt::format("{} {}: cannot create: {}", option, path, std::strerror(errno)), 1);
    return f;
  };
  std::FILE* log_file = create("-o", g.output, "w");
  std::FILE* capture_file = create("-w", g.write, "wb");
  std::FILE* truth_file = create("--truth", g.truth, "w");
  const auto started = std::chrono::steady_clock::now();

  generate::Generator gen(go);
  const SerialConfig serial = generate::Generator::serial();
  std::optional<ByteLogWriter> log;
  if (log_file) {
    log.emplace(log_file);
    log->comment(fmt::format(
        "drivetap generate --frames {} --seed {} --mix {}: a generated capture (README \"drivetap "
        "generate\")\nstations: {}",
        go.frames, go.seed, g.mix, gen.drive_bindings()));
    log->header(serial);
  }
  // The pcapng: the pipeline with `drivetap read`'s default options, channels interned as the
  // byte log's reader meets them, so that the file equals `drivetap read LOG -w FILE`'s.
  CommonOptions read_defaults;
  read_defaults.plain = g.plain;
  std::optional<PipelineOptions> p;
  ChannelTable channels;
  std::unique_ptr<CaptureSink> sink;
  std::unique_ptr<Pipeline> pipeline;
  if (capture_file) {
    RunSettings settings;
    settings.serial = serial;
    p = make_pipeline_options(read_defaults, settings);
    sink =
        std::make_unique<CaptureSink>(capture_file, channels, capture_options(read_defaults, *p));
    pipeline = std::make_unique<Pipeline>(*p, channels, *sink);
  }
  std::vector<int> channel_of(gen.links().size(), -1);
  const TimeNs character = serial.character_time();
  generate::Record r;
  TimeNs last = 0;
  std::vector<ByteEvent> events;
  while (gen.next(r)) {
    const std::string& name = gen.links()[r.link].channel;
    if (log) log->line(r.start, name, r.bytes, r.flags, r.note);
    if (pipeline) {
      if (channel_of[r.link] < 0) channel_of[r.link] = channels.intern(name);
      events.clear();
      for (std::size_t i = 0; i < r.bytes.size(); ++i)
        events.push_back({r.start + static_cast<TimeNs>(i) * character, r.bytes[i], r.flags[i],
                          static_cast<ChannelId>(channel_of[r.link]), 0});
      pipeline->push_batch(events);
    }
    last = r.start + static_cast<TimeNs>(r.bytes.size()) * character;
  }
  if (log && (!log->flush() || (log_file != stdout && std::fclose(log_file) != 0)))
    die(fmt::format("-o {}: write failed: {}", g.output, std::strerror(errno)), 1);
  if (pipeline) {
    pipeline->finish();
    const bool ok = sink->flush();
    sink.reset();
    if (!ok || (capture_file != stdout && std::fclose(capture_file) != 0))
      die(fmt::format("-w {}: write failed: {}", g.write, std::strerror(errno)), 1);
  }
  if (truth_file) {
    const std::string truth = gen.truth_json();
    if (std::fputs(truth.c_str(), truth_file) < 0 || std::fclose(truth_file) != 0)
      die(fmt::format("--truth {}: write failed: {}", g.truth, std::strerror(errno)), 1);
  }
  generate::Counts total;
  for (const generate::Counts& c : gen.counts()) total += c;
  const double took =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::fprintf(stderr,
               "drivetap: generated %llu frames and %llu noise records (%llu bytes, %.1f s of bus "
               "time, seed %llu) in %.1f s\n",
               static_cast<unsigned long long>(total.frames),
               static_cast<unsigned long long>(total.noise_records),
               static_cast<unsigned long long>(total.bytes), static_cast<double>(last) / 1e9,
               static_cast<unsigned long long>(go.seed), took);
  return 0;
}

// Lists the built-in drive profiles and checks the given profile files (errors: file:line: key).
int run_profiles(const std::vector<std::string>& files) {
  auto show = [](const DriveProfile& p, std::string_view where) {
    std::printf("%-8s %-44s %3zu registers  %s\n", p.id.c_str(), p.name.c_str(), p.registers.size(),
                std::string(where).c_str());
  };
  for (const BuiltinProfileText& b : builtin_profile_texts()) {
    ProfileError e;
    auto p = parse_profile(b.text, b.file, &e);
    if (!p) die(fmt::format("built-in profile {}", e.text()), 1);
    show(*p, fmt::format("(built in: {})", b.file));
  }
  for (const std::string& f : files) {
    ProfileError e;
    auto p = load_profile_file(f, &e);
    if (!p) die(e.text(), 1);
    show(*p, f);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // A file size limit (ulimit -f) must fail the write (EFBIG) like a full disk, so that outputs
  // are cut back to whole packets and closed, rather than kill the process mid-packet. A reader
  // that went away (`| head`) fails the write too (EPIPE): the -w file is closed whole, then the
  // run ends as SIGPIPE would have ended it (finish_stdout()).
  std::signal(SIGXFSZ, SIG_IGN);
  std::signal(SIGPIPE, SIG_IGN);
  // The short, tcpdump-like form: `drivetap -i /dev/ttyUSB0 -s "19200 8E1"` is a capture.
  std::vector<char*> args(argv, argv + argc);
  static char capture_word[] = "capture";
  if (argc > 1 &&
      (std::string_view(argv[1]) == "-i" || std::string_view(argv[1]) == "--interface" ||
       std::string_view(argv[1]).starts_with("-i/")))
    args.insert(args.begin() + 1, capture_word);
  argc = static_cast<int>(args.size());
  argv = args.data();
  CLI::App app{
      "drivetap: passive RS-485 bus analyser for drive networks (Modbus RTU/ASCII, Danfoss FC, "
      "Easydrive)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "drivetap 0.1.0");

  CommonOptions decode_opts;
  std::vector<std::string> hex_args;
  CLI::App* decode =
      app.add_subcommand("decode", "Decode frames given as hex (from a manual or log)");
  add_common_options(decode, decode_opts);
  decode->add_option("hex", hex_args, "Hex bytes; '|' ',' ';' separate frames; '-' or none: stdin");

  CommonOptions read_opts;
  std::string path;
  CLI::App* read = app.add_subcommand(
      "read", "Decode a capture: pcapng, pcap, byte log, sigrok session or VCD; '-' for stdin");
  add_common_options(read, read_opts);
  read->add_option("file", path, "Capture file")->required();

  CommonOptions diagnose_opts;
  std::string diagnose_path;
  CLI::App* diagnose_cmd = app.add_subcommand(
      "diagnose",
      "Diagnose the line: swapped A/B, wrong baud or parity, noise, missing bias, timing");
  add_common_options(diagnose_cmd, diagnose_opts);
  diagnose_cmd->add_option("file", diagnose_path, "Capture file (a logic capture gives most)")
      ->required();

  CommonOptions capture_opts;
  CaptureOptions capture_args;
  CLI::App* capture_cmd = app.add_subcommand(
      "capture", "Capture live from serial ports (listen only), decode as it comes");
  add_common_options(capture_cmd, capture_opts);
  capture_cmd
      ->add_option("-i,--interface", capture_args.ports,
                   "Serial port to listen on, PATH or PATH=NAME (repeatable; NAME line.m and "
                   "line.s: the master and slave pairs of one 4-wire link)")
      ->allow_extra_args(false);
  capture_cmd->add_option("-c,--count", capture_args.max_frames, "Stop after N frames");
  capture_cmd->add_option("-a,--autostop", capture_args.autostop, "Stop after duration:SECONDS");
  capture_cmd->add_option("-b,--ring-buffer", capture_args.ring,
                          "With -w FILE: a ring of files, filesize:MB, duration:S, files:N");
  capture_cmd->add_flag("--reconnect", capture_args.reconnect,
                        "Wait for an unplugged adapter to come back and go on");
  capture_cmd->add_flag("--scan", capture_args.scan,
                        "Listen at each standard rate and parity in turn, say which gives frames");
  capture_cmd->add_option("--scan-time", capture_args.scan_seconds,
                          "--scan: seconds per setting (default 2)");

  GenerateOptions generate_opts;
  CLI::App* generate_cmd = app.add_subcommand(
      "generate",
      "Write a large, realistic, reproducible capture: a master polling drives of the five "
      "families, with errors, noise, exceptions and timeouts");
  generate_cmd->add_option(
      "--frames", generate_opts.frames,
      "Records to write: requests, replies and noise records (default 100000)");
  generate_cmd->add_option("--seed", generate_opts.seed,
                           "Seed: the same seed gives the same bytes (default 1)");
  generate_cmd->add_option("--mix", generate_opts.mix,
                           "all (default): Modbus RTU, Danfoss FC, Easydrive and Modbus ASCII "
                           "links; modbus-rtu: the Modbus RTU link only");
  generate_cmd->add_option("-o,--output", generate_opts.output, "Write a byte log to FILE");
  generate_cmd->add_option("-w,--write", generate_opts.write, "Write a pcapng to FILE");
  generate_cmd->add_flag("--plain", generate_opts.plain,
                         "With -w: the frames alone, as `read -w FILE --plain` writes them");
  generate_cmd->add_option("--truth", generate_opts.truth,
                           "Write what was generated (counts per link, JSON) to FILE");

  std::vector<std::string> profile_files;
  CLI::App* profiles = app.add_subcommand(
      "profiles", "List the built-in drive profiles and check profile files (TOML)");
  profiles->add_option("file", profile_files, "Profile files to check");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every command-line error exits 2 (CLI11's own codes vary).
    return app.exit(e) == 0 ? 0 : 2;
  }
  int status = 2;
  if (*decode) status = run_decode(decode_opts, hex_args);
  if (*read) status = run_read(read_opts, path);
  if (*capture_cmd)
    status = capture_args.scan ? run_scan(capture_opts, capture_args)
                               : run_capture(capture_opts, capture_args);
  if (*diagnose_cmd) status = run_diagnose(diagnose_opts, diagnose_path);
  if (*profiles) status = run_profiles(profile_files);
  if (*generate_cmd) status = run_generate(generate_opts);
  finish_stdout();
  return status;
}
