// Benchmarks of the decoding stages after the UART: CRC-16, LRC, BCC, the framers on byte
// events, each dissector, pairing, drive profiles, and the text, JSON and pcapng sinks.
// bytes_per_second is bytes of the input buffer (checksums) or bus bytes (everything else);
// `frames` is frames per second. bench/README.md has the command, docs/performance.md the figures.
//
//   BM_Crc16 / BM_Lrc / BM_Bcc       the checksums on 1 KiB .. 1 MiB of random bytes
//   BM_RtuFramer/1, /4096            the Modbus RTU framer on the ByteEvents of polling traffic,
//                                    one event per call or runs of 4096 (push(events))
//   BM_Dissect_<protocol>            each dissector on valid frames (the Frame copy included)
//   BM_Framer_<protocol>             the Modbus ASCII, FC and Easydrive framers on those frames
//   BM_Pairer                        pairing the RTU traffic's dissected requests and replies
//   BM_DriveAnnotate                 read_for_drive with the E-9 profile on the RTU traffic
//   BM_Pipeline_RtuNoDrives          the whole pipeline (framer, dissector, pairing), no profiles
//   BM_Pipeline_RtuAutoDrives        the same with every built-in profile as --drive auto candidate
//   BM_Pipeline_RtuBatched           no profiles, push_runs() on the runs of 16384 events at a time
//                                    (as `read`: a run per frame, whole frames taken at once)
//   BM_Pipeline_RtuBatchedSummaryOnly  the same into a sink that shows no decode but takes records
//   BM_Pipeline_RtuSummaryLane       the same into a sink that takes no records (`read --stats`):
//                                    whole telegrams dissected to their head
//   BM_Pipeline_RtuSummaryLaneAutoDrives  the same with every built-in profile as --drive auto
//                                    candidate (`read --stats`'s default: binding, observations,
//                                    timing rules and the timeline from the heads)
//   BM_TextSink / BM_JsonSink / BM_PcapngSink   the sinks on the pipeline's records, to /dev/null
//
// Every benchmark checks its result once (frames found == frames sent, checksums good, the
// sliced CRC == the bytewise one) and aborts with a message when it is wrong.
// DRIVETAP_BENCH_SMOKE=1 makes every input small.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/checksum.hpp"
#include "core/protocol.hpp"
#include "dissectors/danfoss_fc/fc_dissector.hpp"
#include "dissectors/danfoss_fc/fc_protocol.hpp"
#include "dissectors/easydrive/eds_dissector.hpp"
#include "dissectors/easydrive/eds_protocol.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "drive/annotate.hpp"
#include "drive/profile.hpp"
#include "pipeline/pairer.hpp"
#include "pipeline/pipeline.hpp"
#include "sinks/capture_sink.hpp"
#include "sinks/json_sink.hpp"
#include "sinks/text_sink.hpp"

namespace {

using namespace drivetap;

bool smoke() {
  static const bool on = [] {
    const char* env = std::getenv("DRIVETAP_BENCH_SMOKE");
    return env && std::string(env) == "1";
  }();
  return on;
}

// A benchmark measuring a broken path is worse than none: stop the whole run.
[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "bench_stages: check failed: %s\n", what.c_str());
  std::abort();
}

void count_frames(benchmark::State& state, std::uint64_t frames, std::uint64_t bytes) {
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
  state.counters["frames"] = benchmark::Counter(static_cast<double>(frames),
                                                benchmark::Counter::kIsIterationInvariantRate);
}

std::vector<std::uint8_t> random_bytes(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<std::uint8_t> out(n);
  for (std::uint8_t& b : out) b = static_cast<std::uint8_t>(rng());
  return out;
}

// ---- Checksums --------------------------------------------------------------------------------

std::uint16_t crc16_bytewise(std::span<const std::uint8_t> data) {
  std::uint16_t crc = 0xFFFF;
  for (const std::uint8_t b : data) crc = crc16_modbus_update(crc, b);
  return crc;
}

// The sliced CRC against the bytewise one: every length 0..64 at every misalignment 0..15, a
// chained call, and the benchmark's own buffer.
void check_crc16(std::span<const std::uint8_t> buffer) {
  const std::vector<std::uint8_t> data = random_bytes(64 + 16, 99);
  for (std::size_t offset = 0; offset < 16; ++offset)
    for (std::size_t len = 0; len <= 64; ++len) {
      const auto s = std::span(data).subspan(offset, len);
      if (crc16_modbus(s) != crc16_bytewise(s))
        fail(fmt::format("crc16_modbus at offset {} length {}", offset, len));
    }
  const std::uint8_t check[] = {0x01, 0x03, 0x00, 0x00, 0x00, 0x01};
  if (crc16_modbus(check) != 0x0A84) fail("crc16_modbus check value");
  const auto whole = std::span(data);
  if (crc16_modbus(whole.subspan(37), crc16_modbus(whole.first(37))) != crc16_bytewise(whole))
    fail("crc16_modbus chained");
  if (crc16_modbus(buffer) != crc16_bytewise(buffer)) fail("crc16_modbus on the buffer");
}

void BM_Crc16(benchmark::State& state) {
  const std::vector<std::uint8_t> buffer =
      random_bytes(static_cast<std::size_t>(state.range(0)), 1);
  check_crc16(buffer);
  for (auto _ : state) benchmark::DoNotOptimize(crc16_modbus(buffer));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * buffer.size()));
}

// The byte-at-a-time CRC the slicing replaced, for comparison.
void BM_Crc16_Bytewise(benchmark::State& state) {
  const std::vector<std::uint8_t> buffer =
      random_bytes(static_cast<std::size_t>(state.range(0)), 1);
  for (auto _ : state) benchmark::DoNotOptimize(crc16_bytewise(buffer));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * buffer.size()));
}

void BM_Lrc(benchmark::State& state) {
  const std::vector<std::uint8_t> buffer =
      random_bytes(static_cast<std::size_t>(state.range(0)), 2);
  std::uint8_t sum = 0;
  for (const std::uint8_t b : buffer) sum = static_cast<std::uint8_t>(sum + b);
  if (lrc8(buffer) != static_cast<std::uint8_t>(-sum)) fail("lrc8");
  for (auto _ : state) benchmark::DoNotOptimize(lrc8(buffer));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * buffer.size()));
}

void BM_Bcc(benchmark::State& state) {
  const std::vector<std::uint8_t> buffer =
      random_bytes(static_cast<std::size_t>(state.range(0)), 3);
  std::uint8_t x = 0;
  for (const std::uint8_t b : buffer) x ^= b;
  if (danfoss_fc::bcc(buffer) != x) fail("danfoss_fc::bcc");
  for (auto _ : state) benchmark::DoNotOptimize(danfoss_fc::bcc(buffer));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * buffer.size()));
}

// ---- Modbus RTU polling traffic ---------------------------------------------------------------

std::vector<std::uint8_t> with_crc(std::vector<std::uint8_t> b) {
  const std::uint16_t c = crc16_modbus(b);
  b.push_back(static_cast<std::uint8_t>(c & 0xFF));
  b.push_back(static_cast<std::uint8_t>(c >> 8));
  return b;
}

// True when a proper prefix of `frame` ends in its own valid CRC: the RTU framer may then split
// the frame there by content (as it should on a bus), and the traffic would not be what was sent.
bool has_crc_prefix(const std::vector<std::uint8_t>& frame) {
  for (std::size_t n = 4; n < frame.size(); ++n)
    if (check_rtu_crc(std::span(frame).first(n)).verdict == ChecksumVerdict::good) return true;
  return false;
}

struct Traffic {
  SerialConfig serial;
  FramingTiming timing;
  std::vector<std::vector<std::uint8_t>> frames;  // in bus order, request then reply
  std::vector<ByteEvent> events;
  std::uint64_t bytes = 0;
};

// A master polling stations 1..8 at 19200 8E1: read holding registers (request 8 bytes, reply
// 9..39) three times in four, write single register (8 bytes, echoed) otherwise; 4..6 characters
// of silence after every frame (t3.5 is 3.5). Registers 0..5: the E-9 profile's.
Traffic make_rtu_traffic(std::size_t transactions) {
  Traffic t;
  t.serial.baud = 19200;
  t.serial.parity = Parity::even;
  t.timing = FramingTiming::from(t.serial);
  const TimeNs ct = t.timing.character_time;
  std::mt19937 rng(5);
  TimeNs now = 0;
  auto send = [&](const std::vector<std::uint8_t>& frame) {
    for (const std::uint8_t b : frame) {
      t.events.push_back({now, b, 0, 0, 0});
      now += ct;
    }
    now += 4 * ct + static_cast<TimeNs>(rng() % static_cast<std::uint32_t>(2 * ct));
    t.bytes += frame.size();
    t.frames.push_back(frame);
  };
  for (std::size_t i = 0; i < transactions; ++i) {
    const auto station = static_cast<std::uint8_t>(1 + rng() % 8);
    const auto reg = static_cast<std::uint8_t>(rng() % 4);
    if (rng() % 4 != 0) {
      const auto count = static_cast<std::uint8_t>(2 + rng() % 16);
      send(with_crc({station, 0x03, 0x00, reg, 0x00, count}));
      std::vector<std::uint8_t> reply;
      do {
        reply = {station, 0x03, static_cast<std::uint8_t>(2 * count)};
        for (int k = 0; k < 2 * count; ++k) reply.push_back(static_cast<std::uint8_t>(rng() % 4));
        reply = with_crc(reply);
      } while (has_crc_prefix(reply));
      send(reply);
    } else {
      const auto request = with_crc({station, 0x06, 0x00, 0x01, 0x13, 0x88});
      send(request);
      send(request);
    }
  }
  return t;
}

const Traffic& rtu_traffic() {
  static const Traffic t = make_rtu_traffic(smoke() ? 200 : 20'000);
  return t;
}

struct Reframed {
  std::uint64_t telegrams = 0, noise = 0, bytes = 0;
};

// A fresh framer from `decoder` re-frames `events`: a push per event with run 1 (what the
// pipeline does), else Framer::push on runs of `run` events (as a reader's buffer would);
// frames are counted as they come out, and the batch is cleared (keeping their storage for the
// next frames), as the pipeline does.
[[gnu::noinline]] Reframed reframe(const ProtocolDecoder& decoder, const FramerSettings& settings,
                                   std::span<const ByteEvent> events, std::size_t run,
                                   FrameBatch& out) {
  Reframed r;
  auto framer = decoder.make_framer(0, settings);
  auto drain = [&] {
    for (Frame& f : out) {
      (f.kind == FrameKind::telegram ? r.telegrams : r.noise) += 1;
      r.bytes += f.size();
    }
    out.clear();
  };
  if (run == 1) {
    for (const ByteEvent& e : events) {
      framer->push(e, out);
      if (!out.empty()) drain();
    }
  } else {
    for (std::size_t i = 0; i < events.size(); i += run) {
      framer->push_all(events.subspan(i, std::min(run, events.size() - i)), out);
      drain();
    }
  }
  framer->finish(out);
  drain();
  return r;
}

// Per iteration: the whole byte log re-framed by reframe(), runs of state.range(0) events.
void BM_RtuFramer(benchmark::State& state) {
  const std::size_t run = static_cast<std::size_t>(state.range(0));
  const Traffic& t = rtu_traffic();
  const ProtocolDecoder* decoder = decoder_for(protocols::modbus_rtu);
  FramerSettings settings;
  settings.timing = t.timing;
  FrameBatch out;
  Reframed r;
  for (auto _ : state) r = reframe(*decoder, settings, t.events, run, out);
  const auto [telegrams, noise, bytes] = r;
  if (telegrams != t.frames.size() || noise != 0 || bytes != t.bytes) {
    // Name the first frame that came out differently.
    auto framer = decoder->make_framer(0, settings);
    for (const ByteEvent& e : t.events) framer->push(e, out);
    framer->finish(out);
    std::size_t k = 0;
    while (k < out.size() && k < t.frames.size() && out[k].bytes() == t.frames[k]) ++k;
    fail(fmt::format(
        "RTU framer: {} telegrams, {} noise, {} bytes of {} frames, {} bytes; frame {} "
        "of {} bytes came out as {} bytes",
        telegrams, noise, bytes, t.frames.size(), t.bytes, k,
        k < t.frames.size() ? t.frames[k].size() : 0, k < out.size() ? out[k].size() : 0));
  }
  count_frames(state, t.frames.size(), t.bytes);
}

// ---- Dissectors -------------------------------------------------------------------------------

struct DissectCase {
  Frame frame;
  Direction direction;
  std::size_t request = SIZE_MAX;  // index of the request a reply answers
};

struct DissectSet {
  std::vector<DissectCase> cases;
  std::uint64_t bytes = 0;
  FramingTiming timing;
};

Frame frame_of(const std::vector<std::uint8_t>& bytes, TimeNs ct) {
  Frame f;
  TimeNs t = 0;
  for (const std::uint8_t b : bytes) f.events.push_back({t += ct, b, 0, 0, 0});
  return f;
}

// Request/reply pairs of `frames` (alternating), as many as `pairs`, repeating the list.
DissectSet make_set(const std::vector<std::vector<std::uint8_t>>& frames, std::size_t pairs) {
  DissectSet s;
  s.timing = FramingTiming::from(SerialConfig{});
  for (std::size_t i = 0; i < 2 * pairs; ++i) {
    const auto& bytes = frames[i % frames.size()];
    const bool reply = i % 2 == 1;
    s.cases.push_back({frame_of(bytes, s.timing.character_time),
                       reply ? Direction::response : Direction::request, reply ? i - 1 : SIZE_MAX});
    s.bytes += bytes.size();
  }
  return s;
}

std::vector<std::uint8_t> text_bytes(const std::string& s) {
  return {s.begin(), s.end()};
}

std::vector<std::uint8_t> ascii_frame(const std::vector<std::uint8_t>& binary) {
  std::string s = ":";
  for (const std::uint8_t b : binary) s += fmt::format("{:02X}", b);
  s += fmt::format("{:02X}\r\n", lrc8(binary));
  return text_bytes(s);
}

std::vector<std::uint8_t> eds_frame(const std::string& body) {
  return text_bytes(fmt::format("~{}{:04X}\r", body, easydrive::ascii_sum(text_bytes(body))));
}

std::size_t dissect_pairs() {
  return smoke() ? 50 : 5'000;
}

const DissectSet& rtu_set() {
  static const DissectSet s = [] {
    const Traffic& t = rtu_traffic();
    return make_set(t.frames, std::min(dissect_pairs(), t.frames.size() / 2));
  }();
  return s;
}

const DissectSet& ascii_set() {
  static const DissectSet s = [] {
    std::vector<std::vector<std::uint8_t>> frames;
    for (const auto& rtu : rtu_traffic().frames) {
      if (frames.size() == 200) break;
      frames.push_back(ascii_frame({rtu.begin(), rtu.end() - 2}));
    }
    return make_set(frames, dissect_pairs());
  }();
  return s;
}

// The telegrams of tests/test_danfoss_fc.cpp: write 4-14 with CTW/REF and its error reply.
const DissectSet& fc_set() {
  static const DissectSet s = make_set(
      {{0x02, 0x0E, 0x81, 0xE1, 0x9E, 0, 0, 0, 0, 0x03, 0xE8, 0x04, 0x7C, 0x20, 0x00, 0x41},
       {0x02, 0x0E, 0x01, 0x71, 0x9E, 0, 0, 0, 0, 0, 0x02, 0x06, 0x07, 0x00, 0x00, 0xE1}},
      dissect_pairs());
  return s;
}

// The exchanges of tests/test_easydrive.cpp: status word, output frequency, run at 40 Hz.
const DissectSet& eds_set() {
  static const DissectSet s =
      make_set({eds_frame("010B000F"), eds_frame("0100030F0015"), eds_frame("010B0001"),
                eds_frame("010000010FA0"), eds_frame("010C00010FA0"), eds_frame("01000001")},
               dissect_pairs());
  return s;
}

void run_dissect(benchmark::State& state, Protocol protocol, const DissectSet& set) {
  const ProtocolDecoder* decoder = decoder_for(protocol);
  std::vector<std::vector<std::uint8_t>> request_bytes(set.cases.size());
  for (std::size_t i = 0; i < set.cases.size(); ++i)
    if (set.cases[i].direction == Direction::request) request_bytes[i] = set.cases[i].frame.bytes();
  std::uint64_t good = 0;
  for (auto _ : state) {
    good = 0;
    for (const DissectCase& c : set.cases) {
      const std::span<const std::uint8_t> request =
          c.request == SIZE_MAX ? std::span<const std::uint8_t>() : request_bytes[c.request];
      Message m = decoder->dissect(c.frame, c.direction, set.timing, request);
      good +=
          m.checksum.verdict == ChecksumVerdict::good && m.protocol == protocol && m.address >= 0;
      benchmark::DoNotOptimize(&m.fields);
    }
  }
  if (good != set.cases.size())
    fail(fmt::format("{}: {} of {} frames with a good checksum and an address",
                     protocol_id(protocol), good, set.cases.size()));
  count_frames(state, set.cases.size(), set.bytes);
}

void BM_Dissect_ModbusRtu(benchmark::State& state) {
  run_dissect(state, protocols::modbus_rtu, rtu_set());
}
void BM_Dissect_ModbusAscii(benchmark::State& state) {
  run_dissect(state, protocols::modbus_ascii, ascii_set());
}
void BM_Dissect_DanfossFc(benchmark::State& state) {
  run_dissect(state, protocols::danfoss_fc, fc_set());
}
void BM_Dissect_Easydrive(benchmark::State& state) {
  run_dissect(state, protocols::easydrive, eds_set());
}

// ---- The other framers and pairing ------------------------------------------------------------

// Per iteration: reframe() with a push per byte, as the pipeline does, on the byte events of a
// DissectSet's frames, each followed by 5 characters of silence.
void run_framer(benchmark::State& state, Protocol protocol, const DissectSet& set) {
  const ProtocolDecoder* decoder = decoder_for(protocol);
  const TimeNs ct = set.timing.character_time;
  std::vector<ByteEvent> events;
  TimeNs now = 0;
  for (const DissectCase& c : set.cases) {
    for (const ByteEvent& e : c.frame.events) {
      events.push_back({now, e.byte, 0, 0, 0});
      now += ct;
    }
    now += 5 * ct;
  }
  FramerSettings settings;
  settings.timing = set.timing;
  FrameBatch out;
  Reframed r;
  for (auto _ : state) r = reframe(*decoder, settings, events, 1, out);
  const auto [telegrams, noise, bytes] = r;
  if (telegrams != set.cases.size() || noise != 0 || bytes != set.bytes)
    fail(fmt::format("{} framer: {} telegrams, {} noise, {} bytes of {} frames, {} bytes",
                     protocol_id(protocol), telegrams, noise, bytes, set.cases.size(), set.bytes));
  count_frames(state, set.cases.size(), set.bytes);
}

void BM_Framer_ModbusAscii(benchmark::State& state) {
  run_framer(state, protocols::modbus_ascii, ascii_set());
}
void BM_Framer_DanfossFc(benchmark::State& state) {
  run_framer(state, protocols::danfoss_fc, fc_set());
}
void BM_Framer_Easydrive(benchmark::State& state) {
  run_framer(state, protocols::easydrive, eds_set());
}

// Per iteration: a fresh Pairer pairs the RTU traffic's messages (framed and dissected once,
// request and reply in turn, as on the bus), draining its transactions as they come.
void BM_Pairer(benchmark::State& state) {
  const Traffic& t = rtu_traffic();
  const ProtocolDecoder* decoder = decoder_for(protocols::modbus_rtu);
  FrameBatch frames;
  {
    FramerSettings settings;
    settings.timing = t.timing;
    auto framer = decoder->make_framer(0, settings);
    framer->push_all(t.events, frames);
    framer->finish(frames);
  }
  std::vector<Message> messages;
  messages.reserve(frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const bool reply = i % 2 == 1;
    Message m = decoder->dissect(std::move(frames[i]),
                                 reply ? Direction::response : Direction::request, t.timing,
                                 reply ? std::span<const std::uint8_t>(messages.back().bytes)
                                       : std::span<const std::uint8_t>());
    m.frame.number = i + 1;
    messages.push_back(std::move(m));
  }
  const PairerOptions options{kNsPerSecond, t.timing.character_time, 64};
  std::vector<Transaction> out;
  std::uint64_t transactions = 0, ok = 0;
  for (auto _ : state) {
    transactions = ok = 0;
    Pairer pairer(options);
    auto drain = [&] {
      for (const Transaction& tr : out) {
        ++transactions;
        ok += tr.outcome == Outcome::ok;
      }
      out.clear();
    };
    for (Message& m : messages) {
      pairer.add(0, m, out);
      if (!out.empty()) drain();
    }
    pairer.finish(out);
    drain();
  }
  if (transactions != t.frames.size() / 2 || ok != transactions)
    fail(fmt::format("pairer: {} transactions ({} ok) of {} request/reply pairs", transactions, ok,
                     t.frames.size() / 2));
  count_frames(state, t.frames.size(), t.bytes);
}

// ---- Pipeline ---------------------------------------------------------------------------------

struct CountingSink final : Sink {
  std::uint64_t frames = 0, noise = 0, anomalies = 0, transactions = 0, ok = 0;
  bool detail = true;  // false: like `read --stats`, no field trees or info lines are built
  // false: no records at all, like `read --stats`' sink (the pipeline dissects telegrams only to
  // their head); the counts then come from the summary.
  bool records = true;
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n;
    n.detail = detail;
    n.records = records;
    return n;
  }
  void on_frame(const Message&) override { ++frames; }
  void on_noise(const Frame&) override { ++noise; }
  void on_anomaly(const Anomaly&) override { ++anomalies; }
  void on_transaction(const Transaction& t) override {
    ++transactions;
    ok += t.outcome == Outcome::ok;
  }
  void on_summary(const Stats& s) override {
    if (records) return;
    frames = s.frames;
    noise = s.noise_records;
    anomalies = s.anomaly_total;
    transactions = s.transactions;
    ok = s.outcomes[static_cast<std::size_t>(Outcome::ok)];
  }
  bool flush() override { return true; }
};

const std::vector<DriveProfile>& builtin_profiles() {
  static const std::vector<DriveProfile> profiles = [] {
    ProfileError error;
    auto p = load_builtin_profiles(&error);
    if (!p) fail("built-in profiles: " + error.text());
    return *p;
  }();
  return profiles;
}

PipelineOptions rtu_options(const Traffic& t, bool auto_drives) {
  PipelineOptions p;
  p.serial = t.serial;
  p.timing = t.timing;
  p.protocol = protocols::modbus_rtu;
  if (auto_drives)
    for (const DriveProfile& profile : builtin_profiles()) p.auto_candidates.push_back(&profile);
  return p;
}

// The RTU traffic's events in batches of `batch`, each as the runs of evenly spaced bytes a source
// hands on (RunBatch::add_events: a run per frame here), made once outside the timing: `read`
// makes them on its reader thread.
const std::vector<RunBatch>& rtu_run_batches(std::size_t batch) {
  static const std::vector<RunBatch> batches = [batch] {
    const std::span<const ByteEvent> events(rtu_traffic().events);
    std::vector<RunBatch> out;
    for (std::size_t i = 0; i < events.size(); i += batch)
      out.emplace_back().add_events(events.subspan(i, std::min(batch, events.size() - i)));
    return out;
  }();
  return batches;
}

// `batch` 0: push() per byte event; else push_runs() on batches of runs of `batch` events (what
// `read`'s decoding thread does with the chunks its reader thread hands over).
void run_pipeline(benchmark::State& state, bool auto_drives, std::size_t batch = 0,
                  bool detail = true, bool records = true) {
  const Traffic& t = rtu_traffic();
  ChannelTable channels;
  channels.intern("bus");
  const PipelineOptions options = rtu_options(t, auto_drives);
  const std::vector<RunBatch>* batches = batch == 0 ? nullptr : &rtu_run_batches(batch);
  CountingSink sink;
  for (auto _ : state) {
    sink = CountingSink();
    sink.detail = detail;
    sink.records = records;
    Pipeline pipeline(options, channels, sink);
    if (!batches)
      for (const ByteEvent& e : t.events) pipeline.push(e);
    else
      for (const RunBatch& runs : *batches) pipeline.push_runs(runs);
    pipeline.finish();
  }
  if (sink.frames != t.frames.size() || sink.noise != 0 || sink.ok != t.frames.size() / 2)
    fail(fmt::format("pipeline: {} frames, {} noise, {} ok transactions of {} frames", sink.frames,
                     sink.noise, sink.ok, t.frames.size()));
  count_frames(state, t.frames.size(), t.bytes);
  state.counters["anomalies"] = static_cast<double>(sink.anomalies);
}

void BM_Pipeline_RtuNoDrives(benchmark::State& state) {
  run_pipeline(state, false);
}
void BM_Pipeline_RtuAutoDrives(benchmark::State& state) {
  run_pipeline(state, true);
}
void BM_Pipeline_RtuBatched(benchmark::State& state) {
  run_pipeline(state, false, 16384);
}
void BM_Pipeline_RtuBatchedSummaryOnly(benchmark::State& state) {
  run_pipeline(state, false, 16384, false);
}
void BM_Pipeline_RtuSummaryLane(benchmark::State& state) {
  run_pipeline(state, false, 16384, false, false);
}
void BM_Pipeline_RtuSummaryLaneAutoDrives(benchmark::State& state) {
  run_pipeline(state, true, 16384, false, false);
}

// ---- Drive profiles ---------------------------------------------------------------------------

// The pipeline's records of the RTU traffic, in order, replayed into the sinks.
struct Records {
  std::vector<Message> messages;
  std::vector<Transaction> transactions;
  std::vector<std::pair<bool, std::size_t>> order;  // (is transaction, index)
  std::uint64_t bytes = 0;
};

struct RecordingSink final : Sink {
  Records* r;
  explicit RecordingSink(Records* records) : r(records) {}
  void on_frame(const Message& m) override {
    r->order.emplace_back(false, r->messages.size());
    r->messages.push_back(m);
    r->bytes += m.bytes.size();
  }
  void on_noise(const Frame&) override {}
  void on_anomaly(const Anomaly&) override {}
  void on_transaction(const Transaction& t) override {
    r->order.emplace_back(true, r->transactions.size());
    r->transactions.push_back(t);
  }
  void on_summary(const Stats&) override {}
  bool flush() override { return true; }
};

const Records& rtu_records() {
  static const Records records = [] {
    const Traffic& t = rtu_traffic();
    Records r;
    ChannelTable channels;
    channels.intern("bus");
    RecordingSink sink(&r);
    Pipeline pipeline(rtu_options(t, false), channels, sink);
    for (const ByteEvent& e : t.events) pipeline.push(e);
    pipeline.finish();
    if (r.messages.size() != t.frames.size()) fail("records: frames lost");
    return r;
  }();
  return records;
}

// read_for_drive_into (the pipeline's way: one reading reused) with the E-9 profile (registers
// 0..5 are its status, setpoint, frequency...) on every frame of the traffic, replies with their
// request.
void BM_DriveAnnotate(benchmark::State& state) {
  const Records& r = rtu_records();
  const DriveProfile* e9 = nullptr;
  for (const DriveProfile& p : builtin_profiles())
    if (p.id == "e9") e9 = &p;
  if (!e9) fail("no built-in profile e9");
  std::uint64_t annotated = 0;
  DriveReading reading;
  for (auto _ : state) {
    annotated = 0;
    for (std::size_t i = 0; i < r.messages.size(); ++i) {
      const std::span<const std::uint8_t> request =
          i % 2 == 1 ? std::span<const std::uint8_t>(r.messages[i - 1].bytes)
                     : std::span<const std::uint8_t>();
      read_for_drive_into(*e9, r.messages[i], request, DriveReadingWants::text_and_observation,
                          reading);
      annotated += !reading.text.empty();
      benchmark::DoNotOptimize(reading.text.data());
    }
  }
  // Every reply reads registers of the profile; requests may say nothing.
  if (annotated < r.messages.size() / 2)
    fail(fmt::format("E-9 annotated {} of {} frames", annotated, r.messages.size()));
  count_frames(state, r.messages.size(), r.bytes);
  state.counters["annotated"] = static_cast<double>(annotated);
}

// ---- Sinks ------------------------------------------------------------------------------------

std::FILE* open_null() {
  std::FILE* f = std::fopen("/dev/null", "wb");
  if (!f) fail("cannot open /dev/null");
  return f;
}

void replay(const Records& r, Sink& sink) {
  for (const auto& [is_transaction, i] : r.order) {
    if (is_transaction)
      sink.on_transaction(r.transactions[i]);
    else
      sink.on_frame(r.messages[i]);
  }
}

// Lines a sink writes for the records (checked once, into a temporary file).
template <typename MakeSink>
std::uint64_t lines_written(const Records& r, MakeSink make) {
  std::FILE* f = std::tmpfile();
  if (!f) fail("cannot create a temporary file");
  {
    auto sink = make(f);
    replay(r, *sink);
    if (!sink->flush()) fail("sink flush");
  }
  std::rewind(f);
  std::uint64_t lines = 0;
  for (int c; (c = std::fgetc(f)) != EOF;) lines += c == '\n';
  std::fclose(f);
  return lines;
}

template <typename MakeSink>
void run_text_sink(benchmark::State& state, const char* name, MakeSink make) {
  const Records& r = rtu_records();
  const std::uint64_t lines = lines_written(r, make);
  if (lines < r.messages.size())
    fail(fmt::format("{}: {} lines for {} frames", name, lines, r.messages.size()));
  std::FILE* out = open_null();
  for (auto _ : state) {
    auto sink = make(out);
    replay(r, *sink);
    if (!sink->flush()) fail(fmt::format("{}: flush", name));
  }
  std::fclose(out);
  count_frames(state, r.messages.size(), r.bytes);
  state.counters["lines"] = static_cast<double>(lines);
}

ChannelTable& bus_channels() {
  static ChannelTable channels;
  if (channels.size() == 0) channels.intern("bus");
  return channels;
}

void BM_TextSink(benchmark::State& state) {
  run_text_sink(state, "text sink", [](std::FILE* f) {
    return std::make_unique<TextSink>(f, bus_channels(), TextSinkOptions{});
  });
}

void BM_JsonSink(benchmark::State& state) {
  run_text_sink(state, "JSON sink", [](std::FILE* f) {
    return std::make_unique<JsonSink>(f, bus_channels(), rtu_traffic().timing.character_time);
  });
}

void BM_PcapngSink(benchmark::State& state) {
  const Records& r = rtu_records();
  CaptureSinkOptions options;
  options.serial = rtu_traffic().serial;
  options.character_time = rtu_traffic().timing.character_time;
  std::FILE* out = open_null();
  std::uint64_t packets = 0;
  for (auto _ : state) {
    CaptureSink sink(out, bus_channels(), options);
    replay(r, sink);
    if (!sink.flush()) fail("pcapng sink: flush");
    packets = sink.packets();
  }
  std::fclose(out);
  if (packets != r.messages.size())
    fail(fmt::format("pcapng sink: {} packets for {} frames", packets, r.messages.size()));
  count_frames(state, r.messages.size(), r.bytes);
}

void buffer_sizes(benchmark::internal::Benchmark* b) {
  b->RangeMultiplier(32)->Range(1 << 10, 1 << 20);
}

BENCHMARK(BM_Crc16)->Apply(buffer_sizes);
BENCHMARK(BM_Crc16_Bytewise)->Apply(buffer_sizes);
BENCHMARK(BM_Lrc)->Apply(buffer_sizes);
BENCHMARK(BM_Bcc)->Apply(buffer_sizes);
BENCHMARK(BM_RtuFramer)->Arg(1)->Arg(64)->Arg(4096)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Dissect_ModbusRtu)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Dissect_ModbusAscii)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Dissect_DanfossFc)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Dissect_Easydrive)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Framer_ModbusAscii)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Framer_DanfossFc)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Framer_Easydrive)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Pairer)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DriveAnnotate)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Pipeline_RtuNoDrives)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Pipeline_RtuAutoDrives)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Pipeline_RtuBatched)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Pipeline_RtuBatchedSummaryOnly)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Pipeline_RtuSummaryLane)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Pipeline_RtuSummaryLaneAutoDrives)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_TextSink)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_JsonSink)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PcapngSink)->Unit(benchmark::kMicrosecond);

}  // namespace
