// Benchmarks of the UART physical layer (target: UART decoding at >= 100 M samples/s on one
// core). Every benchmark counts items = samples, so items_per_second is samples/s; `chars` is
// UART characters decoded per second. bench/README.md has the command, docs/performance.md the
// figures.
//
//   BM_UartDecoder_Runs      the decoder alone on level runs from the line simulator
//   BM_SigrokRead_Decode     end to end: a sigrok session (.sr) read, scanned into runs and
//                            decoded, one UartDecoder per selected channel (the figure)
//   BM_SigrokRead_Scan       the same without the decoders: reader (inflate + scan) alone
//   BM_SigrokInflate         libzip/zlib inflating the same chunks (and checking their CRC),
//                            nothing else: the floor under the reader
//
// The .sr files are written once per process, with libzip as sigrok writes them (`version`,
// `metadata`, `logic-1-1`, ... deflated at libzip's default level), in 4 MiB chunks (sigrok writes
// one chunk per packet it saves: 20 KiB to 10 MiB in captures/), to a temporary directory that is
// removed at exit.
// DRIVETAP_BENCH_SR_SAMPLES sets their length (default 2^27 samples); DRIVETAP_BENCH_DIR keeps
// them (session_dir); DRIVETAP_BENCH_SMOKE=1 makes every input small.
#include <benchmark/benchmark.h>
#include <zip.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>

#include "sources/logic/line_sim.hpp"
#include "sources/logic/sigrok_file.hpp"
#include "sources/logic/uart_decoder.hpp"

namespace {

using drivetap::RunBlock;
using drivetap::SigrokFile;
using drivetap::phy::LevelRun;
using drivetap::phy::LineSimSettings;
using drivetap::phy::LineSimulator;
using drivetap::phy::UartCharacter;
using drivetap::phy::UartDecoder;
using drivetap::phy::UartParity;
using drivetap::phy::UartSettings;

// DRIVETAP_BENCH_SMOKE=1 (the ctest bench.smoke): every input small, only the checks matter.
bool smoke() {
  static const bool on = [] {
    const char* env = std::getenv("DRIVETAP_BENCH_SMOKE");
    return env && std::string(env) == "1";
  }();
  return on;
}

constexpr double kGapChars = 3.5;  // Modbus RTU's silent interval between frames
constexpr double kCharBits = 11;   // 8E1: start, 8 data, parity, stop

UartSettings uart_8e1(double baud) {
  UartSettings s;
  s.baud = baud;
  s.data_bits = 8;
  s.parity = UartParity::even;
  return s;
}

// 8..40 random bytes, drawn by hand so that every standard library makes the same frames.
std::vector<std::uint8_t> random_frame(std::mt19937& rng) {
  std::vector<std::uint8_t> frame(8 + rng() % 33);
  for (std::uint8_t& b : frame) b = static_cast<std::uint8_t>(rng());
  return frame;
}

// ---- The decoder alone ------------------------------------------------------------------------

struct Line {
  std::vector<LevelRun> runs;
  std::uint64_t samples = 0;
  std::uint64_t characters = 0;  // sent
};

// Modbus-like traffic on one line: frames of 8..40 random bytes, 3.5 character times apart, about
// `characters` of them. Noisy: edge jitter of 5 % of a bit and a pulse every second character,
// half the decoder's glitch filter wide (at least one sample: where the filter is one sample, as at
// 115200 baud sampled at 1 MHz, the pulses pass it and become edges).
Line simulate_line(double baud, std::uint64_t rate, bool noisy, std::uint64_t characters) {
  LineSimSettings settings;
  settings.sample_rate_hz = rate;
  settings.uart = uart_8e1(baud);
  settings.edge_jitter_bits = noisy ? 0.05 : 0;
  settings.seed = 7;
  LineSimulator sim(settings);
  std::mt19937 rng(11);
  Line line;
  sim.idle(10);
  while (line.characters < characters) {
    const std::vector<std::uint8_t> frame = random_frame(rng);
    sim.send(frame);
    sim.idle(kGapChars * kCharBits);
    line.characters += frame.size();
  }
  if (noisy) {
    const UartDecoder probe(settings.uart, rate);
    const std::uint64_t width = std::max<std::uint64_t>(1, probe.glitch_filter_samples() / 2);
    sim.add_random_glitches(baud / kCharBits / 2, width);
  }
  line.runs = sim.runs();
  for (const LevelRun& r : line.runs) line.samples += r.length;
  return line;
}

const Line& cached_line(double baud, std::uint64_t rate, bool noisy) {
  static std::map<std::tuple<double, std::uint64_t, bool>, Line> lines;
  auto [it, added] = lines.try_emplace({baud, rate, noisy});
  if (added) it->second = simulate_line(baud, rate, noisy, smoke() ? 2'000 : 50'000);
  return it->second;
}

// Args: baud, sample rate, noisy (0/1).
void BM_UartDecoder_Runs(benchmark::State& state) {
  const auto baud = static_cast<double>(state.range(0));
  const auto rate = static_cast<std::uint64_t>(state.range(1));
  const bool noisy = state.range(2) != 0;
  const Line& line = cached_line(baud, rate, noisy);
  const UartSettings settings = uart_8e1(baud);
  std::vector<UartCharacter> out;
  out.reserve(line.characters * 2);
  std::uint64_t decoded = 0;
  for (auto _ : state) {
    out.clear();
    UartDecoder decoder(settings, rate);
    decoder.push_runs(line.runs, out);
    decoder.finish(out);
    benchmark::DoNotOptimize(out.data());
    decoded = out.size();
  }
  if (!noisy && decoded != line.characters) {
    state.SkipWithError(
        fmt::format("decoded {} characters of {} sent", decoded, line.characters).c_str());
    return;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * line.samples));
  state.counters["chars"] = benchmark::Counter(static_cast<double>(decoded),
                                               benchmark::Counter::kIsIterationInvariantRate);
  state.counters["runs"] = benchmark::Counter(static_cast<double>(line.runs.size()),
                                              benchmark::Counter::kIsIterationInvariantRate);
}

// ---- Sigrok sessions --------------------------------------------------------------------------

// A temporary directory for the generated sessions, removed when the process ends.
class TempDir {
 public:
  TempDir() {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "drivetap-bench-XXXXXX").string();
    if (!mkdtemp(pattern.data())) throw std::runtime_error("cannot create a temporary directory");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// DRIVETAP_BENCH_DIR=DIR: the sessions are written there once and kept, and a later run reuses
// them (for profiling the reader without the deflate of the setup). Otherwise a temporary one.
const std::filesystem::path& session_dir() {
  static const std::filesystem::path kept = [] {
    const char* env = std::getenv("DRIVETAP_BENCH_DIR");
    return std::filesystem::path(env ? env : "");
  }();
  if (!kept.empty()) return kept;
  static TempDir dir;
  return dir.path();
}

// Samples in each session: DRIVETAP_BENCH_SR_SAMPLES, else 5 M for the smoke test, else 2^27.
std::uint64_t sr_samples() {
  const char* env = std::getenv("DRIVETAP_BENCH_SR_SAMPLES");
  const std::uint64_t n = env ? std::strtoull(env, nullptr, 10) : 0;
  return n > 0 ? n : smoke() ? 5'000'000 : std::uint64_t{1} << 27;
}

struct Session {
  std::string path;
  std::uint64_t samples = 0;
  // The two lines of a 4-wire link, as in captures/uart-phy: replies on RX, requests on TX.
  std::size_t rx_bit = 3, tx_bit = 4;
  std::uint64_t rx_characters = 0, tx_characters = 0;
  std::string error;  // why it could not be written
};

constexpr std::size_t kChunkBytes = 4 << 20;  // bytes in one logic-1-N

// Clears `bit` over the samples of every space run of `runs`.
void draw_line(std::vector<std::uint8_t>& raw, int unit, std::size_t bit,
               const std::vector<LevelRun>& runs, std::uint64_t samples) {
  const auto byte = bit / 8;
  const auto clear = static_cast<std::uint8_t>(~(1u << (bit % 8)));
  std::uint64_t at = 0;
  for (const LevelRun& r : runs) {
    const std::uint64_t end = std::min(at + r.length, samples);
    if (!r.level)
      for (std::uint64_t i = at; i < end; ++i) raw[i * unit + byte] &= clear;
    at = end;
  }
}

// A polling master on a 4-wire link at `baud` 8E1: a request of 8..40 bytes on TX, 3.5 characters
// of silence, a reply of 8..40 bytes on RX, 3.5 characters, the next request; the bus is never
// idle for longer. The other channels never move. unit: bytes per sample (1: 8 channels with RX
// and TX on bits 3 and 4; 2: 16 channels, TX on bit 12 in the second byte).
Session write_session(std::uint64_t rate, double baud, int unit) {
  Session s;
  s.samples = sr_samples();
  if (unit == 2) s.tx_bit = 12;
  s.path =
      (session_dir() / fmt::format("uart-{}-{}-u{}-{}.sr", rate, baud, unit, s.samples)).string();

  LineSimSettings settings;
  settings.sample_rate_hz = rate;
  settings.uart = uart_8e1(baud);
  settings.edge_jitter_bits = 0.02;
  settings.seed = 3;
  LineSimulator tx(settings);
  settings.seed = 5;
  LineSimulator rx(settings);
  const double bit = tx.samples_per_bit();
  const double gap_bits = kGapChars * kCharBits;
  // Room at the end for a whole transaction: no character is cut by the end of the capture.
  const double last_start =
      static_cast<double>(s.samples) - (2 * 40 + 4 * kGapChars) * kCharBits * bit;
  std::mt19937 rng(13);
  tx.idle(10);
  while (tx.now() < last_start) {
    const auto request = random_frame(rng);
    tx.send(request);
    s.tx_characters += request.size();
    rx.idle((tx.now() - rx.now()) / bit + gap_bits);
    const auto reply = random_frame(rng);
    rx.send(reply);
    s.rx_characters += reply.size();
    tx.idle((rx.now() - tx.now()) / bit + gap_bits);
  }

  if (std::getenv("DRIVETAP_BENCH_DIR") && std::filesystem::exists(s.path)) return s;

  // Idle: RX and TX high, the unused channels at a fixed pattern (bit 0 high, and bit 13 with two
  // bytes per sample).
  const std::uint64_t idle =
      0x2001 | (std::uint64_t{1} << s.rx_bit) | (std::uint64_t{1} << s.tx_bit);
  std::vector<std::uint8_t> raw(s.samples * unit);
  for (std::uint64_t i = 0; i < s.samples; ++i)
    for (int b = 0; b < unit; ++b) raw[i * unit + b] = static_cast<std::uint8_t>(idle >> (8 * b));
  draw_line(raw, unit, s.rx_bit, rx.runs(), s.samples);
  draw_line(raw, unit, s.tx_bit, tx.runs(), s.samples);

  int code = 0;
  zip_t* z = zip_open(s.path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &code);
  if (!z) {
    s.error = fmt::format("{}: cannot create (libzip error {})", s.path, code);
    return s;
  }
  const std::string version = "2";
  std::string metadata = fmt::format(
      "[global]\nsigrok version=0.6.0\n\n[device 1]\ncapturefile=logic-1\ntotal probes={}\n"
      "samplerate={} MHz\ntotal analog=0\n",
      8 * unit, rate / 1'000'000);
  for (int i = 0; i < 8 * unit; ++i) {
    const auto b = static_cast<std::size_t>(i);
    metadata += fmt::format("probe{}={}\n", i + 1,
                            b == s.rx_bit   ? std::string("RX")
                            : b == s.tx_bit ? std::string("TX")
                                            : std::to_string(i));
  }
  metadata += fmt::format("unitsize={}\n", unit);
  auto add = [&](const std::string& name, const void* data, std::size_t size) {
    zip_source_t* src = zip_source_buffer(z, data, size, 0);  // read at zip_close
    if (!src || zip_file_add(z, name.c_str(), src, ZIP_FL_OVERWRITE) < 0) {
      if (src) zip_source_free(src);
      s.error = fmt::format("{}: {}: {}", s.path, name, zip_strerror(z));
      return false;
    }
    return true;
  };
  bool ok = add("version", version.data(), version.size()) &&
            add("metadata", metadata.data(), metadata.size());
  for (std::size_t at = 0, n = 1; ok && at < raw.size(); at += kChunkBytes, ++n)
    ok = add(fmt::format("logic-1-{}", n), raw.data() + at, std::min(kChunkBytes, raw.size() - at));
  if (!ok) {
    zip_discard(z);
    return s;
  }
  if (zip_close(z) != 0) {
    s.error = fmt::format("{}: cannot write: {}", s.path, zip_strerror(z));
    zip_discard(z);
  }
  return s;
}

const Session& cached_session(std::uint64_t rate, double baud, int unit) {
  static std::map<std::tuple<std::uint64_t, double, int>, Session> sessions;
  auto [it, added] = sessions.try_emplace({rate, baud, unit});
  if (added) it->second = write_session(rate, baud, unit);
  return it->second;
}

// Args: sample rate, baud, unit size, channels selected (1: RX only, 2: RX and TX).
struct SessionArgs {
  const Session& session;
  double baud;
  std::vector<std::size_t> channels;
  std::uint64_t characters;  // sent on those channels
};

SessionArgs session_args(const benchmark::State& state) {
  const auto rate = static_cast<std::uint64_t>(state.range(0));
  const auto baud = static_cast<double>(state.range(1));
  const auto unit = static_cast<int>(state.range(2));
  const Session& s = cached_session(rate, baud, unit);
  SessionArgs args{s, baud, {s.rx_bit}, s.rx_characters};
  if (state.range(3) == 2) {
    args.channels.push_back(s.tx_bit);
    args.characters += s.tx_characters;
  }
  return args;
}

void report_samples(benchmark::State& state, const Session& s) {
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * s.samples));
  state.counters["MiB_raw"] =
      static_cast<double>(s.samples * static_cast<std::uint64_t>(state.range(2))) / (1 << 20);
}

// Per iteration: open the session, select the channels, read it block by block, decode each
// channel with its own UartDecoder (what `drivetap read FILE.sr` does before framing).
void BM_SigrokRead_Decode(benchmark::State& state) {
  const SessionArgs args = session_args(state);
  const Session& s = args.session;
  if (!s.error.empty()) {
    state.SkipWithError(s.error.c_str());
    return;
  }
  std::uint64_t decoded = 0;
  std::string error;
  for (auto _ : state) {
    auto file = SigrokFile::open(s.path, &error);
    if (!file || !file->select(args.channels, &error)) break;
    std::vector<UartDecoder> decoders;
    for (std::size_t k = 0; k < args.channels.size(); ++k)
      decoders.emplace_back(uart_8e1(args.baud), file->sample_rate());
    RunBlock block;
    std::vector<UartCharacter> out;
    decoded = 0;
    while (file->next_block(block, &error)) {
      for (std::size_t k = 0; k < decoders.size(); ++k) decoders[k].push_runs(block.runs[k], out);
      decoded += out.size();
      out.clear();  // a pipeline frames them here
    }
    if (!error.empty()) break;
    for (UartDecoder& d : decoders) d.finish(out);
    decoded += out.size();
  }
  if (!error.empty()) {
    state.SkipWithError(error.c_str());
    return;
  }
  if (decoded != args.characters) {
    state.SkipWithError(
        fmt::format("decoded {} characters of {} sent", decoded, args.characters).c_str());
    return;
  }
  report_samples(state, s);
  state.counters["chars"] = benchmark::Counter(static_cast<double>(decoded),
                                               benchmark::Counter::kIsIterationInvariantRate);
}

// The reader alone: blocks of runs, nothing decoded.
void BM_SigrokRead_Scan(benchmark::State& state) {
  const SessionArgs args = session_args(state);
  const Session& s = args.session;
  if (!s.error.empty()) {
    state.SkipWithError(s.error.c_str());
    return;
  }
  std::string error;
  std::uint64_t runs = 0;
  for (auto _ : state) {
    auto file = SigrokFile::open(s.path, &error);
    if (!file || !file->select(args.channels, &error)) break;
    RunBlock block;
    runs = 0;
    while (file->next_block(block, &error))
      for (const auto& channel : block.runs) runs += channel.size();
    if (!error.empty()) break;
  }
  if (!error.empty()) {
    state.SkipWithError(error.c_str());
    return;
  }
  report_samples(state, s);
  state.counters["runs"] =
      benchmark::Counter(static_cast<double>(runs), benchmark::Counter::kIsIterationInvariantRate);
}

// libzip and zlib alone: every logic chunk inflated into a buffer of the reader's size (1 MiB).
void BM_SigrokInflate(benchmark::State& state) {
  const SessionArgs args = session_args(state);
  const Session& s = args.session;
  if (!s.error.empty()) {
    state.SkipWithError(s.error.c_str());
    return;
  }
  std::vector<std::uint8_t> buffer(1 << 20);
  std::string error;
  for (auto _ : state) {
    int code = 0;
    zip_t* z = zip_open(s.path.c_str(), ZIP_RDONLY, &code);
    if (!z) {
      error = fmt::format("{}: cannot open (libzip error {})", s.path, code);
      break;
    }
    std::uint64_t bytes = 0;
    for (std::size_t n = 1;; ++n) {
      zip_file_t* f = zip_fopen(z, fmt::format("logic-1-{}", n).c_str(), 0);
      if (!f) break;
      zip_int64_t got;
      while ((got = zip_fread(f, buffer.data(), buffer.size())) > 0)
        bytes += static_cast<std::uint64_t>(got);
      zip_fclose(f);
    }
    zip_discard(z);
    if (bytes != s.samples * static_cast<std::uint64_t>(state.range(2))) {
      error = fmt::format("inflated {} bytes, wrote {}", bytes, s.samples * state.range(2));
      break;
    }
  }
  if (!error.empty()) {
    state.SkipWithError(error.c_str());
    return;
  }
  report_samples(state, s);
}

// The decoder alone: 8E1 at 9600 and 115200 baud, sampled at 1, 8 and 24 MHz, clean and noisy.
void decoder_args(benchmark::internal::Benchmark* b) {
  b->ArgNames({"baud", "rate", "noisy"});
  for (std::int64_t noisy : {0, 1})
    for (std::int64_t baud : {9600, 115200})
      for (std::int64_t rate : {1'000'000, 8'000'000, 24'000'000}) b->Args({baud, rate, noisy});
}

// Sessions: 1 and 8 MHz at 115200 baud (an edge every few dozen samples at 1 MHz: the hard
// case) with one or two bytes per sample, one or both lines selected; 9600 baud at 1 MHz.
void session_args_all(benchmark::internal::Benchmark* b) {
  b->ArgNames({"rate", "baud", "unit", "channels"});
  for (std::int64_t unit : {1, 2})
    for (std::int64_t rate : {1'000'000, 8'000'000})
      for (std::int64_t channels : {1, 2}) b->Args({rate, 115200, unit, channels});
  b->Args({1'000'000, 9600, 1, 2});
  b->Unit(benchmark::kMillisecond);
}

// Breakdown (inflate alone, reader alone): both lines, one and two bytes per sample.
void session_args_breakdown(benchmark::internal::Benchmark* b) {
  b->ArgNames({"rate", "baud", "unit", "channels"});
  for (std::int64_t unit : {1, 2})
    for (std::int64_t rate : {1'000'000, 8'000'000}) b->Args({rate, 115200, unit, 2});
  b->Unit(benchmark::kMillisecond);
}

BENCHMARK(BM_UartDecoder_Runs)->Apply(decoder_args)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SigrokRead_Decode)->Apply(session_args_all);
BENCHMARK(BM_SigrokRead_Scan)->Apply(session_args_breakdown);
BENCHMARK(BM_SigrokInflate)->Apply(session_args_breakdown);

}  // namespace
