// `drivetap generate`: a large, realistic, reproducible capture of the five drive families as a
// byte log and/or a pcapng (src/generate/traffic.hpp; docs/reference.md "Generated captures").
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <cerrno>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/outputs.hpp"
#include "generate/byte_log_writer.hpp"
#include "generate/traffic.hpp"
#include "pipeline/pipeline.hpp"
#include "sinks/capture_sink.hpp"

namespace drivetap::app {
namespace {

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
  if (const auto mix = generate::mix_from_name(g.mix))
    go.mix = *mix;
  else
    die(fmt::format("--mix {}: expected {}", g.mix, generate::kMixNames));
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
    log->comment(
        fmt::format("drivetap generate --frames {} --seed {} --mix {}: a generated capture "
                    "(docs/reference.md \"Generated captures\")\nstations: {}",
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
  const generate::Counts& total = gen.total();
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

}  // namespace

Command add_generate_command(CLI::App& app) {
  auto g = std::make_shared<GenerateOptions>();
  CLI::App* generate = app.add_subcommand(
      "generate",
      "Write a large, realistic, reproducible capture: a master polling drives of the five "
      "families, with errors, noise, exceptions and timeouts");
  generate->add_option("--frames", g->frames,
                       "Records to write: requests, replies and noise records (default 100000)");
  generate->add_option("--seed", g->seed, "Seed: the same seed gives the same bytes (default 1)");
  generate->add_option("--mix", g->mix, generate::kMixHelp);
  generate->add_option("-o,--output", g->output, "Write a byte log to FILE");
  generate->add_option("-w,--write", g->write, "Write a pcapng to FILE");
  generate->add_flag("--plain", g->plain,
                     "With -w: the frames alone, as `read -w FILE --plain` writes them");
  generate->add_option("--truth", g->truth,
                       "Write what was generated (counts per link, JSON) to FILE");
  return {generate, [g] { return run_generate(*g); }};
}

}  // namespace drivetap::app
