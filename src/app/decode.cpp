// `drivetap decode`: frames given as hex bytes or as Modbus ASCII / Easydrive text, on the command
// line or one per line of standard input (README "Commands").
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/outputs.hpp"
#include "core/protocol.hpp"
#include "core/protocol_desc.hpp"
#include "pipeline/pipeline.hpp"
#include "sources/file/hex_text.hpp"

namespace drivetap::app {
namespace {

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

// The protocol of frames pasted from a manual, which the user says are telegrams: the one whose
// structure fits them best. A frame whose layout fits one of its directions scores 2, and its
// checksum 2 more when it holds (byte-swapped too: a manual's erratum is still its telegram) or 1
// when it fails; a checksum that holds over a layout nothing predicts (a function the length
// rules do not know) scores 1. Detection's verdict, made for a bus, needs good telegrams: a
// pasted one with a bad checksum would be "random-looking bytes". Unknown when nothing fits;
// `alike`: the others that score as well (the first registered is taken, and the user told).
Protocol protocol_of_pasted(const std::vector<std::vector<std::uint8_t>>& frames,
                            const FramingTiming& timing, std::vector<Protocol>& alike) {
  Protocol best = Protocol::unknown;
  int best_score = 1;  // a checksum alone decides nothing
  alike.clear();
  for (const ProtocolDesc* desc : registered_protocols()) {
    const ProtocolDecoder* decoder = desc->decoder;
    if (!decoder) continue;
    int score = 0;
    for (const std::vector<std::uint8_t>& bytes : frames) {
      const DirectionFit fit = decoder->direction_fit(bytes);
      const bool layout = (fit.request || fit.response) && decoder->recognisable(bytes);
      TelegramView t;
      t.run = ByteRun{bytes, 0, timing.character_time, 0, 0, {}};
      Message m;
      TelegramFindings head;
      const ChecksumVerdict verdict =
          decoder->dissect(t, Direction::unknown, timing, {}, DissectDepth::head, m, &head)
              ? m.checksum.verdict
              : head.verdict;
      const bool holds = verdict == ChecksumVerdict::good || verdict == ChecksumVerdict::swapped;
      score += layout ? 2 + (holds ? 2 : verdict == ChecksumVerdict::bad ? 1 : 0) : holds ? 1 : 0;
    }
    if (score > best_score) {
      best_score = score;
      best = decoder->protocol();
      alike.clear();
    } else if (score == best_score && best != Protocol::unknown) {
      alike.push_back(decoder->protocol());
    }
  }
  return best;
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
  p.max_frames = o.count;  // -c
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
    if (pipeline && o.count > 0 && pipeline->stats().frames >= o.count) return;  // -c reached
    const char kind = decode_text_kind(text);
    if (kind == 0) return;
    const std::string shown = text.size() > 60 ? text.substr(0, 57) + "..." : text;
    if (first_kind != 0 && kind != first_kind)
      stop(fmt::format("{} (\"{}\"): give frames of one kind (hex bytes, {}), not several", where,
                       shown, protocol_text_starts_text()));
    std::string err;
    const auto frames = parse_decode_text(text, kind, &err);
    if (!frames) stop(fmt::format("{} (\"{}\"): {}", where, shown, err));
    if (first_kind == 0) {
      first_kind = kind;
      if (o.protocol.empty() && kind != 'x') p.protocol = protocol_for_text_start(kind);
      if (o.protocol.empty() && kind == 'x') {
        std::vector<Protocol> alike;
        const Protocol pasted = protocol_of_pasted(*frames, p.timing, alike);
        if (pasted != Protocol::unknown) p.protocol = pasted;
        for (const Protocol other : alike)
          say(fmt::format("{} (\"{}\"): fits {} as well as {}: decoded as {}; -P {} for the other",
                          where, shown, protocol_label(other), protocol_label(pasted),
                          protocol_label(pasted), other.desc()->option_names.front()));
      }
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

}  // namespace

Command add_decode_command(CLI::App& app) {
  auto o = std::make_shared<CommonOptions>();
  auto hex_args = std::make_shared<std::vector<std::string>>();
  CLI::App* decode =
      app.add_subcommand("decode", "Decode frames given as hex (from a manual or log)");
  add_common_options(decode, *o, kDecodeCommand);
  decode->add_option("hex", *hex_args,
                     "Hex bytes; '|' ',' ';' separate frames; '-' or none: stdin");
  return {decode, [o, hex_args] {
            refuse_idle_options(*o, kDecodeCommand);
            return run_decode(*o, *hex_args);
          }};
}

}  // namespace drivetap::app
