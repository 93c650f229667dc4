// `drivetap report CAPTURE... -o report.html`: one self-contained HTML page with plots of one or
// more captures on one timeline (timing per docs/protocols.md §1; the page: docs/reference.md
// "Report"). One pass of the pipeline per capture feeds the report's sink, the -z stations and
// gaps counters and the diagnosis beside it; the page is written to a temporary file in the
// target's directory and renamed over it at the end, so that no half-written page is left.
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/inputs.hpp"
#include "app/stop_signals.hpp"
#include "diagnose/line_diagnosis.hpp"
#include "filter/display_filter.hpp"
#include "filter/filter_sink.hpp"
#include "pipeline/pipeline.hpp"
#include "sinks/json_sink.hpp"
#include "sinks/report_sink.hpp"
#include "sinks/stats_tables.hpp"

namespace drivetap::app {
namespace {

// The options of `read` that do nothing for a page: removed from `report`'s command line.
constexpr const char* kNotForReport[] = {
    "-T", "-V", "--events", "--no-summary", "--stats", "-w", "--pcap", "--plain", "--dlt",
    "-c", "-q", "-t",       "--color",      "-x",      "-e", "-E",     "-z"};

// The temporary page until it is renamed over the target; removed when the run ends without
// that (die() exits through std::exit, which runs atexit handlers).
std::string g_temporary_page;
void remove_temporary_page() {
  if (!g_temporary_page.empty()) ::unlink(g_temporary_page.c_str());
  g_temporary_page.clear();
}

// The diagnosis sink reads no field tree or info line: it asks for none.
class DiagnosisWithoutDetail final : public ForwardingSink {
 public:
  using ForwardingSink::ForwardingSink;
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n;
    n.detail = n.fields = false;
    return n;
  }
};

// One capture's verdicts as the page shows them.
std::string verdicts_json(std::size_t capture, const LineEvidence& e,
                          const std::vector<Verdict>& verdicts) {
  std::string out = fmt::format(R"({{"capture":{},"line":{},"source":"{}","verdicts":[)", capture,
                                json_quote(e.settings), e.from_samples ? "samples" : "bytes");
  for (std::size_t i = 0; i < verdicts.size(); ++i)
    out += fmt::format(R"({}{{"id":"{}","title":{},"evidence":{},"fix":{},"benign":{}}})",
                       i ? "," : "", verdicts[i].id, json_quote(verdicts[i].title),
                       json_quote(verdicts[i].evidence), json_quote(verdicts[i].fix),
                       verdicts[i].benign);
  out += "]}";
  return out;
}

// Where `-o` puts the page. A regular file, or a name not there yet, gets a temporary file beside
// it renamed over it at the end: all of the page or none of it. A symbolic link is followed to
// the file it names (the link stays a link). A device, a FIFO or a socket (/dev/null, /dev/stdout)
// is written straight, as `-` is: renaming a file over it would replace the device node. A
// directory is refused.
struct PageTarget {
  std::string path;     // the file the page ends up in
  bool direct = false;  // written straight, no temporary file
};
PageTarget page_target(const std::string& target) {
  struct stat st {};
  if (::stat(target.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) die(fmt::format("-o {}: is a directory", target), 1);
    if (!S_ISREG(st.st_mode)) return {target, true};
    std::error_code ec;
    const std::filesystem::path real = std::filesystem::canonical(target, ec);
    return {ec ? target : real.string(), false};
  }
  // Not there, or a link to a file not there yet: the link's target is created (40 links at most,
  // as the kernel follows).
  std::filesystem::path path(target);
  for (int links = 0; links < 40; ++links) {
    std::error_code ec;
    if (!std::filesystem::is_symlink(path, ec)) break;
    const std::filesystem::path to = std::filesystem::read_symlink(path, ec);
    if (ec) break;
    path = to.is_absolute() ? to : path.parent_path() / to;
  }
  return {path.string(), false};
}

// Opens the temporary page beside `target` (same directory: the rename is atomic). Its name is
// short, so that any name the directory allows can be the target.
std::FILE* open_temporary_page(const std::string& target, const std::string& shown) {
  const std::filesystem::path path(target);
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : ".";
  std::string pattern = (dir / ".drivetap-XXXXXX").string();
  const int fd = ::mkstemp(pattern.data());
  if (fd < 0) die(fmt::format("-o {}: cannot create: {}", shown, std::strerror(errno)));
  g_temporary_page = pattern;
  // mkstemp makes it private (0600): a page is as readable as any file the user makes.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);
  std::FILE* file = ::fdopen(fd, "w");
  if (!file) die(fmt::format("-o {}: cannot create: {}", shown, std::strerror(errno)));
  return file;
}

int run_report(const CommonOptions& o, const std::vector<std::string>& paths) {
  if (paths.empty()) die("report: give one or more capture files (drivetap report FILE... -o F)");
  if (o.output.empty()) die("report: give the page's file: -o report.html");
  std::vector<std::pair<std::string, std::string>> files;
  for (const std::string& path : paths) files.emplace_back("input", path);
  files.emplace_back("-o", o.output);
  refuse_shared_files(files);
  // A bad filter stops the run before any file is made.
  if (!o.display_filter.empty()) {
    std::string error;
    if (!DisplayFilter::compile(o.display_filter, &error)) die("-Y: " + error);
  }
  catch_stop_signals();
  std::atexit(remove_temporary_page);
  const bool to_stdout = o.output == "-";
  const PageTarget target = to_stdout ? PageTarget{"-", true} : page_target(o.output);
  std::FILE* page = stdout;
  if (!to_stdout && target.direct) {
    page = std::fopen(target.path.c_str(), "w");
    if (!page) die(fmt::format("-o {}: cannot create: {}", o.output, std::strerror(errno)), 1);
  } else if (!to_stdout) {
    page = open_temporary_page(target.path, o.output);
  }

  ChannelTable channels;  // one for all captures: a channel of the same name is the same line
  ReportSink report(channels);
  // Each capture is diagnosed alone: two files are two lines (or one line on two days), and a
  // verdict over both would blame one for the other's faults.
  std::string diagnoses = "[";
  TimeNs timeline_end = -1;  // the latest byte so far, on the captures' clock
  for (const std::string& path : paths) {
    LineEvidence evidence;
    InputFile in;
    int input_fd = -1;
    std::unique_ptr<ByteSource> source = open_source(o, path, in, channels, &input_fd);
    const PipelineOptions p = start_source(o, *source);
    StatsTablesSink tables(
        channels, p.timing, true,
        {{StatisticKind::stations, kNsPerSecond}, {StatisticKind::gaps, kNsPerSecond}});
    tables.limit_station_rows(ReportSink::kStationRows);
    DiagnosisSink diagnosis(evidence, p.timing);
    DiagnosisWithoutDetail diagnosis_light(diagnosis);
    std::optional<DisplayFilterSink> filtered;
    if (!o.display_filter.empty()) {
      std::string error;
      filtered.emplace(*DisplayFilter::compile(o.display_filter, &error), report, channels,
                       p.timing.character_time, true);
    }
    TeeSink tee;
    tee.add(filtered ? static_cast<Sink*>(&*filtered) : &report);
    tee.add(&tables);
    tee.add(&diagnosis_light);
    bool begun = false;
    const auto begin = [&](TimeNs first) {
      ReportCapture c;
      c.file = in.name;
      c.format = input_format_name(in.format);
      c.line = p.serial.to_string();
      c.timing = p.timing;
      c.wall_clock = first >= 0 && is_wall_clock_time(first);
      // A capture without wall-clock times follows the one before on the timeline, a second on.
      // (held within +-2^62, as the report's times are: hostile times cannot wrap it)
      if (!c.wall_clock && timeline_end >= 0) {
        constexpr TimeNs kEdge = std::numeric_limits<TimeNs>::max() / 2;
        c.shift = static_cast<TimeNs>(std::clamp<__int128>(
            static_cast<__int128>(timeline_end) + kNsPerSecond - first, -kEdge, kEdge));
      }
      report.begin_capture(std::move(c));
      begun = true;
    };
    CaptureReadHooks hooks;
    hooks.first_byte = begin;
    // The UART evidence of the diagnosis: every character and its marks.
    hooks.batch = [&evidence](const RunBatch& batch) {
      for (std::size_t k = 0; k < batch.size(); ++k) {
        const ByteRun run = batch[k];
        for (std::size_t i = 0; i < run.size(); ++i)
          evidence.count_byte(run.bytes[i], run.flags.empty() ? 0 : run.flags[i]);
      }
    };
    bool interrupted = false;
    {
      Pipeline pipeline(p, channels, tee);
      interrupted = read_capture(o, path, in, input_fd, *source, pipeline, hooks);
      if (!begun) begin(-1);
      pipeline.finish();
    }
    timeline_end = std::max(timeline_end, report.timeline_end());
    report.end_capture(tables.tables(true));
    add_capture_evidence(evidence, *source, p, channels, diagnosis);
    if (diagnoses.size() > 1) diagnoses += ',';
    diagnoses += verdicts_json(&path - paths.data(), evidence, diagnose(evidence));
    for (const std::string& note : source->notes()) say(note);
    const std::string error = source->error();
    source.reset();
    close_input(in);
    // A damaged capture or a stop: no page (a page of part of the captures would pass for all).
    if (interrupted) die("interrupted; no page written", 130);
    if (!error.empty()) die(error, 1);
  }
  diagnoses += ']';
  const bool written = report.write_page(page, diagnoses);
  if (to_stdout) {
    // A reader gone (`| head`): the silent exit of a process SIGPIPE ended, as everywhere.
    if (!written || std::fflush(stdout) != 0) {
      if (errno == EPIPE) std::_Exit(128 + SIGPIPE);
      die(fmt::format("standard output: write failed: {}", std::strerror(errno)), 1);
    }
    return 0;
  }
  if (target.direct) {
    const bool flushed = std::fflush(page) == 0;
    const int write_errno = errno;
    if (std::fclose(page) != 0 || !written || !flushed)
      die(fmt::format("-o {}: write failed: {}", o.output, std::strerror(write_errno)), 1);
    return 0;
  }
  const bool closed = std::fflush(page) == 0 && ::fsync(::fileno(page)) == 0;
  const int write_errno = errno;
  if (std::fclose(page) != 0 || !written || !closed)
    die(fmt::format("-o {}: write failed: {}", o.output, std::strerror(write_errno)), 1);
  if (std::rename(g_temporary_page.c_str(), target.path.c_str()) != 0)
    die(fmt::format("-o {}: cannot create: {}", o.output, std::strerror(errno)), 1);
  g_temporary_page.clear();
  return 0;
}

}  // namespace

Command add_report_command(CLI::App& app) {
  auto o = std::make_shared<CommonOptions>();
  auto paths = std::make_shared<std::vector<std::string>>();
  CLI::App* command = app.add_subcommand(
      "report",
      "Draw one or more captures as one self-contained HTML page with plots: drive telemetry, "
      "latency per station, bus load, gaps, findings, the diagnosis");
  add_common_options(command, *o, kReadCommand);
  for (const char* name : kNotForReport)
    for (CLI::Option* option : command->get_options())
      if (option->check_name(name)) {
        command->remove_option(option);
        break;
      }
  if (CLI::Option* output = command->get_option_no_throw("-o"))
    output->description("The page to write (HTML), e.g. report.html; '-' for stdout");
  command->add_option("files", *paths, "Capture files, on one timeline in the order given");
  command->add_option("-r,--read-file", *paths, "A capture file, as tshark -r FILE (repeatable)")
      ->allow_extra_args(false);
  return {command, [o, paths] {
            refuse_idle_options(*o, kReadCommand);
            return run_report(*o, *paths);
          }};
}

}  // namespace drivetap::app
