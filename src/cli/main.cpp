// drivetap command line: `decode` pasted hex, `read` capture files (README "Command reference").
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <sys/stat.h>

#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "core/serial_config.hpp"
#include "pipeline/pipeline.hpp"
#include "sinks/json_sink.hpp"
#include "sinks/text_sink.hpp"
#include "sources/byte_log.hpp"
#include "sources/hex_text.hpp"

namespace {

using namespace drivetap;

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) {
  g_stop = 1;
}

struct CommonOptions {
  std::string format = "text";
  bool verbose = false;
  std::string serial;
  std::string t15;
  std::string t35;
  std::string timeout = "1s";
  std::string max_hold = "100ms";
  bool no_summary = false;
  std::string output;
};

void add_common_options(CLI::App* cmd, CommonOptions& o) {
  cmd->add_option("-T,--format", o.format, "Output format: text or json (JSON lines)")
      ->check(CLI::IsMember({"text", "json"}));
  cmd->add_flag("-V,--verbose", o.verbose, "Text: show each frame's field tree with byte offsets");
  cmd->add_option(
      "-s,--serial", o.serial,
      "Line settings, e.g. \"19200 8E1\" (default: the capture's header, else 9600 8N1)");
  cmd->add_option("--t15", o.t15, "Inter-character limit t1.5: 1.5c, 750us, 1ms (default: Modbus)");
  cmd->add_option("--t35", o.t35, "Inter-frame silence t3.5: 3.5c, 1750us, 2ms (default: Modbus)");
  cmd->add_option("--timeout", o.timeout, "Reply timeout before a request counts as unanswered")
      ->capture_default_str();
  cmd->add_option("--max-hold", o.max_hold,
                  "Longest wait for the rest of a frame split by a silence (adapter latency)")
      ->capture_default_str();
  cmd->add_flag("--no-summary", o.no_summary, "Do not print the closing summary");
  cmd->add_option("-o,--output", o.output, "Write the text/JSON output to FILE instead of stdout");
}

[[noreturn]] void die(const std::string& message, int code = 2) {
  std::fflush(stdout);
  std::fprintf(stderr, "drivetap: %s\n", message.c_str());
  std::exit(code);
}

// Resolves line settings and timing from the options (and a capture header, if any).
PipelineOptions make_pipeline_options(const CommonOptions& o,
                                      const std::optional<SerialConfig>& header) {
  PipelineOptions p;
  std::string err;
  SerialConfig serial = header.value_or(SerialConfig{});
  if (!o.serial.empty()) {
    auto parsed = SerialConfig::parse(o.serial, &err, serial);
    if (!parsed) die(fmt::format("--serial: {}", err));
    serial = *parsed;
  }
  p.serial = serial;
  p.timing = FramingTiming::from(serial);
  auto interval = [&](const std::string& text, const char* option) {
    auto v = parse_interval(text, p.timing.character_time, &err);
    if (!v) die(fmt::format("{}: {}", option, err));
    return *v;
  };
  if (!o.t15.empty()) p.timing.t15 = interval(o.t15, "--t15");
  if (!o.t35.empty()) p.timing.t35 = interval(o.t35, "--t35");
  p.reply_timeout = interval(o.timeout, "--timeout");
  p.max_hold = interval(o.max_hold, "--max-hold");
  if (p.timing.t35 <= 0) die("--t35: must be greater than zero");
  return p;
}

// Owns the output file and the sink chosen by -T.
struct Output {
  std::FILE* file = stdout;
  std::unique_ptr<Sink> sink;

  Output(const CommonOptions& o, const ChannelTable& channels, TimeNs character_time, bool timed) {
    if (!o.output.empty() && o.output != "-") {
      file = std::fopen(o.output.c_str(), "w");
      if (!file) die(fmt::format("-o {}: cannot create: {}", o.output, std::strerror(errno)));
    }
    if (o.format == "json") {
      sink = std::make_unique<JsonSink>(file, channels, character_time, timed);
    } else {
      TextSinkOptions t;
      t.verbose = o.verbose;
      t.show_time = timed;
      t.summary = !o.no_summary;
      t.character_time = character_time;
      sink = std::make_unique<TextSink>(file, channels, t);
    }
  }
  // Flushes and closes; reports a failed write (disk full, closed pipe) as an error.
  int close(const CommonOptions& o) {
    const bool ok = sink->flush();
    if (file != stdout) {
      if (std::fclose(file) != 0 || !ok)
        die(fmt::format("-o {}: write failed: {}", o.output, std::strerror(errno)), 1);
    } else if (!ok) {
      die(fmt::format("writing output failed: {}", std::strerror(errno)), 1);
    }
    return 0;
  }
};

int run_decode(const CommonOptions& o, const std::vector<std::string>& args) {
  std::vector<std::string> texts = args;
  if (texts.empty() || (texts.size() == 1 && texts[0] == "-")) {
    texts.clear();
    std::string line;
    while (std::getline(std::cin, line)) texts.push_back(line);
  }
  ChannelTable channels;
  const ChannelId bus = channels.intern("bus");
  PipelineOptions p = make_pipeline_options(o, std::nullopt);
  std::vector<ByteEvent> events;
  TimeNs clock = 0;
  // Frames given separately are laid out with a clean silence between them; bytes run together
  // in one frame text are back to back and get split by content.
  const TimeNs gap = std::max<TimeNs>(p.timing.t35 * 4, 20 * kNsPerMs);
  for (std::size_t i = 0; i < texts.size(); ++i) {
    std::string err;
    auto frames = parse_hex_frames(texts[i], &err);
    if (!frames) {
      if (texts[i].find_first_not_of(" \t\r") == std::string::npos) continue;
      die(fmt::format("argument {} (\"{}\"): {}", i + 1, texts[i], err));
    }
    synthesize_events(*frames, bus, p.timing.character_time, gap, &clock, events);
  }
  if (events.empty())
    die("decode: no hex bytes given (e.g. drivetap decode \"01 03 00 00 00 01 84 0A\")");
  Output out(o, channels, p.timing.character_time, /*timed=*/false);
  Pipeline pipeline(p, channels, *out.sink);
  for (const ByteEvent& e : events) pipeline.push(e);
  pipeline.finish();
  return out.close(o);
}

int run_read(const CommonOptions& o, const std::string& path) {
  struct stat st {};
  if (path != "-" && ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
    die(fmt::format("{}: is a directory, not a capture file", path), 1);
  std::FILE* in = path == "-" ? stdin : std::fopen(path.c_str(), "rb");
  if (!in) die(fmt::format("{}: cannot open: {}", path, std::strerror(errno)), 1);
  const std::string name = path == "-" ? "<stdin>" : path;
  // Recognise the format by content: a byte log starts with a comment, a digit or blank space.
  const int first = std::fgetc(in);
  if (first == EOF && std::ferror(in))
    die(fmt::format("{}: read error: {}", name, std::strerror(errno)), 1);
  if (first != EOF) {
    std::ungetc(first, in);
    const char c = static_cast<char>(first);
    if (!(c == '#' || (c >= '0' && c <= '9') || c == ' ' || c == '\t' || c == '\n' || c == '\r'))
      die(fmt::format("{}: offset 0: not a recognised capture format (first byte 0x{:02X}); "
                      "expected a drivetap byte log",
                      name, static_cast<unsigned char>(c)),
          1);
  }
  ChannelTable channels;
  ByteLogReader reader(in, name, channels);
  if (!reader.read_header()) die(reader.error(), 1);
  PipelineOptions p = make_pipeline_options(o, reader.header_serial());
  reader.set_character_time(p.timing.character_time);
  Output out(o, channels, p.timing.character_time, /*timed=*/true);
  Pipeline pipeline(p, channels, *out.sink);

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  ByteEvent e;
  bool interrupted = false;
  while (reader.next(e)) {
    for (const Anomaly& a : reader.take_findings()) pipeline.report(a);
    pipeline.push(e);
    if (g_stop) {
      interrupted = true;
      break;
    }
  }
  // Whatever happened, what was read so far is decoded, summarised and flushed.
  pipeline.finish();
  out.close(o);
  if (in != stdin) std::fclose(in);
  if (!reader.error().empty()) die(reader.error(), 1);
  if (interrupted) die("interrupted; output flushed", 130);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"drivetap: passive RS-485 bus analyser for drive networks (Modbus RTU)"};
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
  CLI::App* read = app.add_subcommand("read", "Decode a capture file (byte log); '-' for stdin");
  add_common_options(read, read_opts);
  read->add_option("file", path, "Capture file")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (*decode) return run_decode(decode_opts, hex_args);
  if (*read) return run_read(read_opts, path);
  return 2;
}
