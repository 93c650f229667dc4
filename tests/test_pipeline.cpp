// Unit tests: the pipeline stage wiring — direction, pairing outcomes, anomalies, time discipline.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/checksum.hpp"
#include "dissectors/danfoss_fc/fc_protocol.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "generate/traffic.hpp"
#include "sinks/json_sink.hpp"
#include "sinks/text_sink.hpp"
#include "sinks/text_sink.hpp"
#include "sinks/threaded_sink.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::testing;

namespace {

struct Bus {
  ChannelTable channels;
  RecordingSink sink;
  PipelineOptions options;
  std::unique_ptr<Pipeline> pipeline;
  TimeNs clock = 0;
  TimeNs ct;

  explicit Bus(const char* serial = "9600 8N1", Protocol protocol = Protocol::unknown) {
    std::string err;
    options.protocol = protocol;
    options.serial = *SerialConfig::parse(serial, &err);
    options.timing = FramingTiming::from(options.serial);
    ct = options.timing.character_time;
    channels.intern("bus");
    channels.intern("m");
    channels.intern("s");
    pipeline = std::make_unique<Pipeline>(options, channels, sink);
  }
  // Sends a frame at the current clock on `channel`, then waits `then` of silence.
  void send(const std::vector<std::uint8_t>& bytes, TimeNs then = 20 * kNsPerMs,
            ChannelId channel = 0, std::uint8_t flags_on_first = 0) {
    for (std::size_t i = 0; i < bytes.size(); ++i) {
      pipeline->push({clock, bytes[i], i == 0 ? flags_on_first : std::uint8_t{0}, channel});
      clock += ct;
    }
    clock += then;
  }
  void finish() { pipeline->finish(); }
};

const auto kReadReq = with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x01});
const auto kReadRsp = with_crc({0x02, 0x03, 0x02, 0x00, 0x2A});
const auto kWrite = with_crc({0x02, 0x06, 0x00, 0x10, 0x00, 0x01});
const auto kException = with_crc({0x02, 0x83, 0x02});

}  // namespace

TEST(Pipeline, PairsReadWithLatency) {
  Bus b;
  b.send(kReadReq, 5 * kNsPerMs);
  b.send(kReadRsp);
  b.finish();
  ASSERT_EQ(b.sink.frames.size(), 2u);
  EXPECT_EQ(b.sink.frames[0].direction, Direction::request);
  EXPECT_EQ(b.sink.frames[1].direction, Direction::response);
  ASSERT_EQ(b.sink.transactions.size(), 1u);
  EXPECT_EQ(b.sink.transactions[0].outcome, Outcome::ok);
  EXPECT_EQ(b.sink.transactions[0].latency, 5 * kNsPerMs);
  EXPECT_EQ(b.sink.frames[1].latency, 5 * kNsPerMs);
  EXPECT_EQ(b.sink.frames[1].request_number, 1u);
  EXPECT_EQ(b.sink.summaries, 1);
}

// A source that finds its times carry no inter-frame silence (a USB adapter's bursts:
// SerialPort::timing_trusted()) distrusts its channel: from then on no latency is measured, no
// t1.5 or t3.5 finding made, and the summary counts what was not judged. The same traffic with
// trusted times has both (the test's own control).
TEST(Pipeline, DistrustedSilencesMeasureNoLatencyAndJudgeNoSilenceRule) {
  for (const bool distrust : {false, true}) {
    SCOPED_TRACE(distrust ? "distrusted" : "trusted");
    Bus b("19200 8E1");
    if (distrust) b.pipeline->distrust_silences(0);
    b.send(kReadReq, 1 * b.ct);  // t3.5 broken before the reply
    // A reply with a gap of 5 characters inside it (t1.5 broken)
    b.send({kReadRsp.begin(), kReadRsp.begin() + 3}, 5 * b.ct);
    b.send({kReadRsp.begin() + 3, kReadRsp.end()}, 30 * kNsPerMs);
    b.send(kReadReq, 4 * kNsPerMs);
    b.send(kReadRsp);
    b.finish();
    ASSERT_EQ(b.sink.frames.size(), 4u);
    ASSERT_EQ(b.sink.count(Outcome::ok), 2u);
    const std::size_t gaps = distrust ? 0 : 1;
    EXPECT_EQ(b.sink.summary.anomalies[static_cast<int>(AnomalyKind::intra_frame_gap)], gaps);
    EXPECT_EQ(b.sink.summary.anomalies[static_cast<int>(AnomalyKind::short_interframe_gap)], gaps);
    for (const Transaction& t : b.sink.transactions) {
      EXPECT_EQ(t.latency < 0, distrust);
      if (distrust) {
        EXPECT_EQ(t.detail, "latency hidden: timing not trusted");
      }
    }
    EXPECT_EQ(b.sink.frames[3].latency < 0, distrust);
    EXPECT_EQ(b.sink.frames[3].silences_trusted, !distrust);
    EXPECT_EQ(b.sink.summary.latency_count, distrust ? 0u : 2u);
    EXPECT_EQ(b.sink.summary.silences_unjudged, distrust ? 4u : 0u);
    EXPECT_EQ(b.sink.summary.latencies_unjudged, distrust ? 2u : 0u);
    EXPECT_EQ(frame_summary(b.sink.frames[3], true).find("(latency hidden: timing not trusted)") !=
                  std::string::npos,
              distrust);
  }
}

TEST(Pipeline, EchoReplyOfWriteIsTakenAsResponseByOrder) {
  Bus b;
  b.send(kWrite, 5 * kNsPerMs);
  b.send(kWrite, 200 * kNsPerMs);
  b.send(kWrite, 5 * kNsPerMs);  // next request, then its echo
  b.send(kWrite);
  b.finish();
  ASSERT_EQ(b.sink.frames.size(), 4u);
  EXPECT_EQ(b.sink.frames[0].direction, Direction::request);
  EXPECT_EQ(b.sink.frames[1].direction, Direction::response);
  EXPECT_EQ(b.sink.frames[2].direction, Direction::request);
  EXPECT_EQ(b.sink.frames[3].direction, Direction::response);
  EXPECT_EQ(b.sink.count(Outcome::ok), 2u);
}

// Danfoss FC's process-data telegrams fit both directions. A capture that opens on a reply
// takes it for a request, and order alone would then keep every telegram the wrong way round;
// the drive answers in its request's telegram type (002 §7.4.6), so the master's next telegram
// of the other type is a request, and the rest pair the right way.
TEST(Pipeline, FcTelegramOfAnotherTypeIsNotTheAwaitedReply) {
  Bus b("9600 8E1", protocols::danfoss_fc);
  const std::vector<std::uint8_t> poll = {0x02, 0x06, 0x01, 0x04, 0x3C, 0x20, 0x00, 0x1D};
  const std::vector<std::uint8_t> status = {0x02, 0x06, 0x01, 0x06, 0x07, 0x00, 0x00, 0x04};
  const std::vector<std::uint8_t> read_4_14 = {0x02, 0x0E, 0x01, 0x11, 0x9E, 0,    0,    0,
                                               0,    0,    0,    0x04, 0x3C, 0x20, 0x00, 0x9A};
  const std::vector<std::uint8_t> value_4_14 = {0x02, 0x0E, 0x01, 0x11, 0x9E, 0,    0,    0,
                                                0,    0x01, 0xF4, 0x06, 0x07, 0x00, 0x00, 0x76};
  b.send(status, 80 * kNsPerMs);  // the capture opens on a reply
  b.send(poll, 10 * kNsPerMs);
  b.send(status, 80 * kNsPerMs);
  b.send(read_4_14, 10 * kNsPerMs);
  b.send(value_4_14, 80 * kNsPerMs);
  b.send(poll, 10 * kNsPerMs);
  b.send(status);
  b.finish();
  ASSERT_EQ(b.sink.frames.size(), 7u);
  // (frames 0-2 are taken by order, wrongly: nothing tells them apart)
  EXPECT_EQ(b.sink.frames[3].direction, Direction::request);
  EXPECT_EQ(b.sink.frames[4].direction, Direction::response);
  EXPECT_EQ(b.sink.frames[4].request_number, b.sink.frames[3].frame.number);
  EXPECT_EQ(b.sink.frames[5].direction, Direction::request);
  EXPECT_EQ(b.sink.frames[6].direction, Direction::response);
}

TEST(Pipeline, ExceptionTimeoutBroadcastUnsolicited) {
  Bus b;
  b.send(kReadReq, 5 * kNsPerMs);
  b.send(kException);                                      // exception reply
  b.send(kReadReq, 1500 * kNsPerMs);                       // never answered (timeout 1 s)
  b.send(with_crc({0x00, 0x06, 0x00, 0x10, 0x00, 0x01}));  // broadcast write
  b.send(kReadRsp);                                        // nobody asked
  b.finish();
  EXPECT_EQ(b.sink.count(Outcome::exception), 1u);
  EXPECT_EQ(b.sink.count(Outcome::timeout), 1u);
  EXPECT_EQ(b.sink.count(Outcome::broadcast), 1u);
  EXPECT_EQ(b.sink.count(Outcome::unsolicited), 1u);
  EXPECT_EQ(b.sink.count(AnomalyKind::unanswered_request), 1u);
  EXPECT_EQ(b.sink.count(AnomalyKind::unsolicited_response), 1u);
  EXPECT_EQ(b.sink.frames[1].exception_code, 2);
  EXPECT_EQ(b.sink.summary.transactions, 4u);
}

TEST(Pipeline, MasterAndSlaveChannelsPairAcrossChannels) {
  Bus b;
  b.send(kWrite, 3 * kNsPerMs, /*channel m*/ 1);
  b.send(kWrite, 20 * kNsPerMs, /*channel s*/ 2);
  b.finish();
  ASSERT_EQ(b.sink.frames.size(), 2u);
  EXPECT_EQ(b.sink.frames[0].direction, Direction::request);
  EXPECT_EQ(b.sink.frames[1].direction, Direction::response);
  EXPECT_EQ(b.sink.count(Outcome::ok), 1u);
}

TEST(Pipeline, ShortSilenceBeforeReplyIsATimingFinding) {
  Bus b;
  b.send(kReadReq, 2 * b.ct);  // 2 characters < t3.5
  b.send(kReadRsp);
  b.finish();
  ASSERT_EQ(b.sink.frames.size(), 2u);
  EXPECT_EQ(b.sink.count(AnomalyKind::short_interframe_gap), 1u);
  EXPECT_EQ(b.sink.count(Outcome::ok), 1u);
}

TEST(Pipeline, UartFlagsBecomeAnomaliesOfTheFrame) {
  Bus b("9600 8N1", protocols::modbus_rtu);  // (one frame: too little for detection to decide)
  b.send(kReadReq, 20 * kNsPerMs, 0, kUartParityError);
  b.finish();
  EXPECT_EQ(b.sink.count(AnomalyKind::uart_parity), 1u);
  ASSERT_EQ(b.sink.frames.size(), 1u);
  EXPECT_EQ(b.sink.anomalies[0].frame_number, 1u);
}

TEST(Pipeline, OverlappingTimestampsAreMovedAfterThePreviousByte) {
  Bus b;
  // Whole request and reply stamped with one time: the second byte onwards would overlap.
  for (std::uint8_t v : kReadReq) b.pipeline->push({1000, v, 0, 0});
  for (std::uint8_t v : kReadRsp) b.pipeline->push({1000, v, 0, 0});
  b.finish();
  ASSERT_EQ(b.sink.frames.size(), 2u);
  EXPECT_EQ(b.sink.frames[1].frame.start(), 1000 + 8 * b.ct);
  EXPECT_EQ(b.sink.frames[1].latency, -1) << "no silence visible: latency is not measurable";
  EXPECT_EQ(b.sink.count(Outcome::ok), 1u);
}

TEST(Pipeline, SummaryCountsVerdictsAndNoise) {
  Bus b("9600 8N1", protocols::modbus_rtu);  // (no good telegram: detection would find nothing)
  auto bad = kReadReq;
  bad[7] ^= 0xFF;
  auto swapped = kReadReq;
  std::swap(swapped[6], swapped[7]);
  b.send(bad);
  b.send(swapped);
  b.send({0xFF});
  b.finish();
  const Stats& s = b.sink.summary;
  EXPECT_EQ(s.frames, 2u);
  EXPECT_EQ(s.checksum[static_cast<int>(ChecksumVerdict::bad)], 1u);
  EXPECT_EQ(s.checksum[static_cast<int>(ChecksumVerdict::swapped)], 1u);
  EXPECT_EQ(s.noise_records, 1u);
  EXPECT_EQ(s.noise_bytes, 1u);
  EXPECT_EQ(s.bytes, 17u);
  EXPECT_EQ(s.anomalies[static_cast<int>(AnomalyKind::checksum_bad)], 1u);
  EXPECT_EQ(s.anomalies[static_cast<int>(AnomalyKind::checksum_swapped)], 1u);
}

namespace {

// Writes down everything a sink is told, fields and info lines apart, as text lines.
struct TranscriptSink final : Sink {
  explicit TranscriptSink(bool detail) : detail(detail), fields(detail) {}
  TranscriptSink(bool detail, bool fields) : detail(detail), fields(fields) {}
  bool detail, fields;
  std::vector<std::string> records;
  std::vector<std::string> infos;  // each message's info line
  std::size_t with_fields = 0, with_info = 0, messages = 0;
  std::set<const FieldDesc*> descriptors;  // of every field node seen
  void on_frame(const Message& m) override {
    ++messages;
    for (const FieldNode& node : m.fields) descriptors.insert(node.desc);
    with_fields += !m.fields.empty();
    with_info += !m.info.empty();
    infos.push_back(m.info);
    records.push_back(fmt::format(
        "frame #{} t {} gap {} {} {} addr {} fc {} exc {} code {} crc {} lat {} req #{} drive '{}' "
        "anomalies {}",
        m.frame.number, m.frame.start(), m.frame.gap_before, protocol_id(m.protocol),
        direction_id(m.direction), m.address, m.function, m.is_exception, m.exception_code,
        static_cast<int>(m.checksum.verdict), m.latency, m.request_number, m.drive_info,
        m.anomalies.size()));
  }
  void on_noise(const Frame& f) override {
    records.push_back(fmt::format("noise #{} {} bytes", f.number, f.size()));
  }
  void on_anomaly(const Anomaly& a) override {
    records.push_back(
        fmt::format("anomaly {} #{} {}", static_cast<int>(a.kind), a.frame_number, a.detail));
  }
  void on_transaction(const Transaction& t) override {
    records.push_back(fmt::format("transaction {} #{} #{} {} {}", outcome_id(t.outcome),
                                  t.request_number, t.response_number, t.latency, t.detail));
  }
  void on_event(const BusEvent& e) override {
    records.push_back(fmt::format("event {} {}", event_kind_id(e.kind), e.detail));
  }
  void on_summary(const Stats& s) override {
    records.push_back(fmt::format(
        "summary {} frames {} bytes {} noise ({} bytes) checksums {} {} transactions {} "
        "latencies {} sum {} min {} max {} anomalies {} {} window {}..{} drives {}",
        s.frames, s.bytes, s.noise_records, s.noise_bytes, fmt::join(s.checksum, " "),
        s.transactions, fmt::join(s.outcomes, " "), s.latency_count, s.latency_sum, s.latency_min,
        s.latency_max, s.anomaly_total, fmt::join(s.anomalies, " "), s.first_time, s.last_time,
        s.drives.size()));
    for (const DriveSummary& d : s.drives)
      records.back() +=
          fmt::format(" | drive {} {} '{}' {} events", d.address, d.profile, d.state, d.events);
  }
  bool flush() override { return true; }
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n;
    n.detail = detail;
    n.fields = fields;
    n.transactions = transactions;
    n.records = records_wanted;
    n.deferred_decode = decodes;
    n.events = events_wanted;
    return n;
  }
  // With `decodes`: also writes down each undecoded telegram's head (DeferredTelegram::head)
  // before decoding it.
  void on_deferred_frame(const DeferredTelegram& telegram) override {
    if (telegram.head) {
      const TelegramFindings& h = *telegram.head;
      records.push_back(fmt::format("head #{} addr {} fc {} crc {} malformed {} kinds {:x} lat {}",
                                    telegram.number, h.address, h.function,
                                    static_cast<int>(h.verdict), h.malformed, h.other_kinds,
                                    telegram.latency));
    }
    Sink::on_deferred_frame(telegram);
  }
  bool transactions = true;
  bool records_wanted = true;
  bool events_wanted = true;
  bool decodes = false;  // takes telegrams undecoded (decoded by Sink::on_deferred_frame())
};

// What the pipeline must adjust before framing (Pipeline::as_on_the_wire): bytes stamped inside
// their predecessor (an adapter that stamps a whole read at once: every third record's bytes get
// the record's start time), or an 8th bit that is not data (the run set to 7 data bits).
// (run_generated_runs() only: early_starts, every fourth record starting half a character before
// the end of its channel's previous one; slow_bytes, every fifth record's bytes a silence longer
// than t1.5 apart; zero_quantities, every seventh 8-byte telegram of function 01-04 asking for 0
// items, its CRC made good again: a malformed telegram framed like a good one.)
// split_directions (run_generated_runs): a link's requests and replies on two channels, `.tx` and
// `.rx`, as a tap that flags each packet's direction gives them.
enum class Adjust {
  none,
  one_stamp_reads,
  seven_bits,
  early_starts,
  slow_bytes,
  zero_quantities,
  split_directions
};

// The generator's mixed bus (four protocols, errors, noise, timeouts) through one pipeline:
// byte by byte (`chunk` 0) or with push_batch() over runs of `chunk` bytes that cut across
// records and channels.
// The generator's traffic (seed 7) and what a pipeline over it needs: the channel table its
// links are interned in on first use, and the options (7 data bits for Adjust::seven_bits).
struct GeneratedBus {
  // The links are interned into `table` when given (a sink's), else into the bus's own.
  // `drives`: every built-in profile a candidate for binding by guess (`read`'s default).
  GeneratedBus(std::uint64_t frames, generate::Mix mix, Adjust adjust,
               ChannelTable* table = nullptr, bool drives = false)
      : gen(generate::Options{frames, 7, mix}),
        channel_of(gen.links().size(), -1),
        channels(table ? *table : own_channels) {
    options.serial = generate::Generator::serial();
    options.timing = FramingTiming::from(options.serial);
    if (adjust == Adjust::seven_bits) options.serial.data_bits = 7;
    if (drives)
      for (const DriveProfile& p : drivetap::testing::builtin_profiles())
        options.auto_candidates.push_back(&p);
  }
  ChannelId channel(std::size_t link) {
    if (channel_of[link] < 0) channel_of[link] = channels.intern(gen.links()[link].channel);
    return static_cast<ChannelId>(channel_of[link]);
  }

  generate::Generator gen;
  std::vector<int> channel_of;
  ChannelTable own_channels;
  ChannelTable& channels;
  PipelineOptions options;
};

void run_generated(TranscriptSink& sink, std::size_t chunk = 0, Adjust adjust = Adjust::none) {
  GeneratedBus bus(20000, generate::Mix::all, adjust);
  Pipeline pipeline(bus.options, bus.channels, sink);
  const TimeNs character_time = bus.options.timing.character_time;
  generate::Record r;
  std::vector<ByteEvent> pending;
  for (std::size_t record = 0; bus.gen.next(r); ++record) {
    const ChannelId channel = bus.channel(r.link);
    const bool one_stamp = adjust == Adjust::one_stamp_reads && record % 3 == 0;
    for (std::size_t i = 0; i < r.bytes.size(); ++i) {
      const TimeNs offset = one_stamp ? 0 : static_cast<TimeNs>(i) * character_time;
      const ByteEvent e{r.start + offset, r.bytes[i], r.flags[i], channel, 0};
      if (chunk == 0) {
        pipeline.push(e);
        continue;
      }
      pending.push_back(e);
      if (pending.size() == chunk) {
        pipeline.push_batch(pending);
        pending.clear();
      }
    }
  }
  pipeline.push_batch(pending);
  pipeline.finish();
}

// Prechecks a batch's runs carry (TelegramPrecheck), as ReadAhead makes them: none; made by the
// decoder the pipeline names (Pipeline::precheck_decoder_of); or made by it, then falsified, and
// credited to another decoder (the pipeline must not use them) or to the right one (it must).
enum class Prechecks { none, made, foreign_falsified, own_falsified };

void set_prechecks(RunBatch& runs, const Pipeline& pipeline, Prechecks kind) {
  if (kind == Prechecks::none) return;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const ByteRun run = runs[k];
    const ProtocolDecoder* decoder = pipeline.precheck_decoder_of(run.channel);
    TelegramPrecheck made;
    if (!decoder || !run.flags.empty() || !decoder->precheck(run.bytes, &made)) continue;
    made.decoder = decoder;
    if (kind != Prechecks::made) {  // every answer turned round
      made.whole_frame = !made.whole_frame;
      made.checksum ^= 0xFFFF;
      made.fit = {!made.fit.request, !made.fit.response};
      made.always_response = !made.always_response;
      made.exception_code[0] = made.exception_code[1] = 7;
      made.malformed[0] = made.malformed[1] = 1;
    }
    if (kind == Prechecks::foreign_falsified)
      made.decoder =
          decoder_for(decoder->protocol() == protocols::modbus_rtu ? protocols::danfoss_fc
                                                                   : protocols::modbus_rtu);
    runs.set_precheck(k, made);
  }
}

// The same traffic as runs, one per record (a pcapng's packets), through push_runs() in batches
// of `batch` runs (0: each byte pushed on its own): a whole frame between two silences goes to the
// framer at once when the next run of the batch shows the silence after it (Pipeline::push_whole).
// One-stamp reads, 7 data bits and early starts give runs that need the byte-by-byte way.
// `prechecks`: what the batches carry; *prechecked counts the runs that carried one.
// `drives`: with every built-in profile a candidate for binding (GeneratedBus).
void run_generated_runs(Sink& sink, std::size_t batch, Adjust adjust, generate::Mix mix,
                        ChannelTable* channels = nullptr, Prechecks prechecks = Prechecks::none,
                        std::size_t* prechecked = nullptr, bool drives = false) {
  // Fewer records than run_generated(): the test makes 32 runs of it (slow under the sanitizers).
  GeneratedBus bus(6000, mix, adjust, channels, drives);
  Pipeline pipeline(bus.options, bus.channels, sink);
  const TimeNs character_time = bus.options.timing.character_time;
  generate::Record r;
  RunBatch runs;
  std::vector<TimeNs> end_of(bus.gen.links().size(), -1);  // each link's previous record's end
  for (std::size_t record = 0; bus.gen.next(r); ++record) {
    const ChannelId channel =
        adjust == Adjust::split_directions
            ? bus.channels.intern(bus.gen.links()[r.link].channel +
                                  (r.kind == generate::RecordKind::request ? ".tx" : ".rx"))
            : bus.channel(r.link);
    const bool one_stamp = adjust == Adjust::one_stamp_reads && record % 3 == 0;
    const bool marked = std::any_of(r.flags.begin(), r.flags.end(), [](auto f) { return f != 0; });
    TimeNs start = r.start;
    if (adjust == Adjust::early_starts && record % 4 == 0 && end_of[r.link] >= 0)
      start = end_of[r.link] - character_time / 2;
    const TimeNs slow = adjust == Adjust::slow_bytes && record % 5 == 0
                            ? character_time + bus.options.timing.t15 + 1
                            : character_time;
    end_of[r.link] = start + static_cast<TimeNs>(r.bytes.size()) * slow;
    std::vector<std::uint8_t> bytes = r.bytes;
    if (adjust == Adjust::zero_quantities && record % 7 == 0 && bytes.size() == 8 &&
        bytes[1] >= 1 && bytes[1] <= 4) {
      bytes = drivetap::testing::with_crc({bytes[0], bytes[1], bytes[2], bytes[3], 0, 0});
    }
    const ByteRun run{
        bytes,
        start,
        one_stamp ? 0 : slow,
        channel,
        0,
        marked ? std::span<const std::uint8_t>(r.flags) : std::span<const std::uint8_t>()};
    if (batch == 0) {
      for (std::size_t i = 0; i < run.size(); ++i) pipeline.push(run.event(i));
      continue;
    }
    runs.add(run);
    if (runs.size() == batch) {
      set_prechecks(runs, pipeline, prechecks);
      for (std::size_t k = 0; prechecked && k < runs.size(); ++k)
        *prechecked += runs.precheck(k) ? 1 : 0;
      pipeline.push_runs(runs);
      runs.clear();
    }
  }
  set_prechecks(runs, pipeline, prechecks);
  pipeline.push_runs(runs);
  pipeline.finish();
}

}  // namespace

// push_runs() takes whole frames at once where it can; what comes out must be exactly what push()
// of each byte gives: on one channel (nearly every frame taken whole), on four polled at the
// same time (whole only while no other channel holds bytes), with each link's requests and
// replies on two channels (the silence after a run shown by its channel's next run, a few runs
// on), and with bytes that need adjusting.
// (The test of the pipeline's look ahead: tests/test_rtu_framer.cpp holds the framer's own.)
TEST(Pipeline, PushRunsFindsWhatPushFinds) {
  for (const generate::Mix mix : {generate::Mix::modbus_rtu, generate::Mix::all}) {
    for (const Adjust adjust : {Adjust::none, Adjust::one_stamp_reads, Adjust::seven_bits,
                                Adjust::early_starts, Adjust::split_directions}) {
      SCOPED_TRACE(
          fmt::format("mix {} adjust {}", static_cast<int>(mix), static_cast<int>(adjust)));
      TranscriptSink one_by_one(true);
      run_generated_runs(one_by_one, 0, adjust, mix);
      ASSERT_GT(one_by_one.messages, 5000u);
      for (const std::size_t batch : {1u, 3u, 300u}) {
        TranscriptSink batched(true);
        run_generated_runs(batched, batch, adjust, mix);
        ASSERT_EQ(one_by_one.records.size(), batched.records.size()) << "batch " << batch;
        for (std::size_t i = 0; i < one_by_one.records.size(); ++i)
          ASSERT_EQ(one_by_one.records[i], batched.records[i])
              << "batch " << batch << " record " << i;
      }
    }
  }
}

// A sink that takes no records (`read --stats`) has the telegrams dissected to their head only,
// without a Message (Pipeline::handle_telegram, DissectDepth::head): the summary must be what
// decoding every frame gives, on every link and with the bytes that need the byte-by-byte way.
TEST(Pipeline, HeadDissectionCountsWhatDecodingFinds) {
  for (const generate::Mix mix : {generate::Mix::modbus_rtu, generate::Mix::all}) {
    for (const Adjust adjust :
         {Adjust::none, Adjust::one_stamp_reads, Adjust::seven_bits, Adjust::early_starts,
          Adjust::slow_bytes, Adjust::zero_quantities, Adjust::split_directions}) {
      for (const bool drives : {false, true}) {
        SCOPED_TRACE(fmt::format("mix {} adjust {} drives {}", static_cast<int>(mix),
                                 static_cast<int>(adjust), drives));
        TranscriptSink decoded(false);
        run_generated_runs(decoded, 300, adjust, mix, nullptr, Prechecks::none, nullptr, drives);
        TranscriptSink counted(false);
        counted.records_wanted = false;
        run_generated_runs(counted, 300, adjust, mix, nullptr, Prechecks::none, nullptr, drives);
        ASSERT_FALSE(decoded.records.empty());
        ASSERT_FALSE(counted.records.empty());
        EXPECT_EQ(decoded.records.back(), counted.records.back());  // the summary
        // The events (protocol detection), in order; the frames counted from their head never
        // reached the sink.
        std::vector<std::string> decoded_events, counted_events;
        for (const std::string& r : decoded.records)
          if (r.starts_with("event ")) decoded_events.push_back(r);
        for (const std::string& r : counted.records)
          if (r.starts_with("event ")) counted_events.push_back(r);
        EXPECT_EQ(decoded_events, counted_events);
        // (Nearly every telegram taken whole and counted from its head, with requests and
        // replies on one channel or on two.)
        if (mix == generate::Mix::modbus_rtu &&
            (adjust == Adjust::none || adjust == Adjust::split_directions)) {
          EXPECT_LT(counted.messages, decoded.messages / 10);
        }
        // The drive level at work: bindings and state changes. (Binding needs paired
        // transactions: 7 data bits break most checksums, and requests and replies on channels
        // of their own here are two links, whose telegrams never pair.)
        const bool paired = adjust != Adjust::seven_bits && adjust != Adjust::split_directions;
        if (drives && paired) {
          EXPECT_GT(std::count_if(
                        counted_events.begin(), counted_events.end(),
                        [](const std::string& e) { return e.starts_with("event drive_bound"); }),
                    0);
          EXPECT_GT(counted_events.size(), 20u);
        }
        if (drives) {
          // A sink that shows no events (`read --stats`): the same summary, drive states and
          // counts of their changes included, and no state change made an event.
          TranscriptSink quiet(false);
          quiet.records_wanted = false;
          quiet.events_wanted = false;
          run_generated_runs(quiet, 300, adjust, mix, nullptr, Prechecks::none, nullptr, drives);
          ASSERT_FALSE(quiet.records.empty());
          EXPECT_EQ(decoded.records.back(), quiet.records.back());
          EXPECT_NE(decoded.records.back().find(" events"), std::string::npos);
          std::vector<std::string> unchanged_events;  // bindings and detection: not state changes
          for (const std::string& e : counted_events)
            if (e.starts_with("event drive_bound") || !e.starts_with("event "))
              unchanged_events.push_back(e);
          std::vector<std::string> quiet_events;
          for (const std::string& r : quiet.records)
            if (r.starts_with("event ")) quiet_events.push_back(r);
          for (const std::string& e : quiet_events)
            for (const char* kind :
                 {"command", "setpoint", "running", "direction", "fault", "warning"})
              EXPECT_FALSE(e.starts_with(fmt::format("event {} ", kind))) << e;
          if (paired) {
            EXPECT_LT(quiet_events.size(), counted_events.size());
          }
        }
      }
    }
  }
}

// The reader's prechecks (TelegramPrecheck, ReadAhead::precheck_with) stand in for the framer's
// check and the head's findings of telegrams taken whole: the summary must be what decoding every
// frame gives. Falsified ones credited to another decoder must be ignored; credited to the
// channel's own decoder they are used, and the summary shows it (the test can fail).
TEST(Pipeline, PrechecksGiveTheSameSummary) {
  for (const generate::Mix mix : {generate::Mix::modbus_rtu, generate::Mix::all}) {
    for (const Adjust adjust : {Adjust::none, Adjust::early_starts, Adjust::zero_quantities}) {
      SCOPED_TRACE(
          fmt::format("mix {} adjust {}", static_cast<int>(mix), static_cast<int>(adjust)));
      TranscriptSink decoded(false);
      run_generated_runs(decoded, 300, adjust, mix);
      ASSERT_FALSE(decoded.records.empty());
      for (const Prechecks kind : {Prechecks::made, Prechecks::foreign_falsified}) {
        TranscriptSink counted(false);
        counted.records_wanted = false;
        std::size_t prechecked = 0;
        run_generated_runs(counted, 300, adjust, mix, nullptr, kind, &prechecked);
        EXPECT_GT(prechecked, 1000u) << static_cast<int>(kind);
        ASSERT_FALSE(counted.records.empty());
        EXPECT_EQ(decoded.records.back(), counted.records.back()) << static_cast<int>(kind);
      }
      TranscriptSink falsified(false);
      falsified.records_wanted = false;
      run_generated_runs(falsified, 300, adjust, mix, nullptr, Prechecks::own_falsified);
      ASSERT_FALSE(falsified.records.empty());
      EXPECT_NE(decoded.records.back(), falsified.records.back());
    }
  }
}

// A sink that takes records keeps the reader's core busy with its writers: the pipeline asks for
// no prechecks then (Pipeline::precheck_decoder_of), only when it alone decodes.
TEST(Pipeline, PrechecksAreAskedForOnlyWhenNoRecordsAreTaken) {
  for (const bool records : {false, true}) {
    TranscriptSink sink(false);
    sink.records_wanted = records;
    GeneratedBus bus(50, generate::Mix::modbus_rtu, Adjust::none, nullptr);
    Pipeline pipeline(bus.options, bus.channels, sink);
    generate::Record r;
    while (bus.gen.next(r))
      for (std::size_t i = 0; i < r.bytes.size(); ++i)
        pipeline.push({r.start + static_cast<TimeNs>(i) * bus.options.timing.character_time,
                       r.bytes[i], 0, bus.channel(r.link), 0});
    ASSERT_GE(pipeline.channel_count(), 1u);
    const ProtocolDecoder* asked = pipeline.precheck_decoder_of(bus.channel(0));
    if (records) {
      EXPECT_EQ(asked, nullptr);
    } else {
      ASSERT_NE(asked, nullptr);
      EXPECT_EQ(asked->protocol(), protocols::modbus_rtu);
    }
    pipeline.finish();
  }
}

// A sink that decodes what the pipeline hands over undecoded (the ThreadedSink on its writer
// thread; Sink::on_deferred_frame() on the caller's) must get every record exactly as the pipeline
// decoding every frame hands them over: frames with their pairing and anomalies, in order.
TEST(Pipeline, TelegramsHandedOverUndissectedAreWhatThePipelineHandsOver) {
  for (const generate::Mix mix : {generate::Mix::modbus_rtu, generate::Mix::all}) {
    for (const Adjust adjust :
         {Adjust::none, Adjust::early_starts, Adjust::slow_bytes, Adjust::zero_quantities}) {
      for (const bool detail : {true, false}) {
        for (const bool drives : {false, true}) {
          SCOPED_TRACE(fmt::format("mix {} adjust {} detail {} drives {}", static_cast<int>(mix),
                                   static_cast<int>(adjust), detail, drives));
          TranscriptSink decoded(detail);
          run_generated_runs(decoded, 300, adjust, mix, nullptr, Prechecks::none, nullptr, drives);
          TranscriptSink decoding(detail);
          decoding.decodes = true;
          run_generated_runs(decoding, 300, adjust, mix, nullptr, Prechecks::none, nullptr, drives);
          TranscriptSink replayed(detail);
          {
            ThreadedSink threaded(replayed);
            run_generated_runs(threaded, 300, adjust, mix, nullptr, Prechecks::none, nullptr,
                               drives);
            threaded.finish();
          }
          ASSERT_GT(decoded.messages, 5000u);
          std::vector<std::string> decoding_records;  // (without the heads written down)
          for (const std::string& r : decoding.records)
            if (!r.starts_with("head #")) decoding_records.push_back(r);
          ASSERT_EQ(decoded.records.size(), decoding_records.size());
          for (std::size_t i = 0; i < decoded.records.size(); ++i)
            ASSERT_EQ(decoded.records[i], decoding_records[i]) << "record " << i;
          EXPECT_EQ(decoded.infos, decoding.infos);
          EXPECT_EQ(decoded.descriptors, decoding.descriptors);
          ASSERT_EQ(decoded.records.size(), replayed.records.size());
          for (std::size_t i = 0; i < decoded.records.size(); ++i)
            ASSERT_EQ(decoded.records[i], replayed.records[i]) << "record " << i;
          EXPECT_EQ(decoded.infos, replayed.infos);
          EXPECT_EQ(decoded.descriptors, replayed.descriptors);
          // An inner sink that decodes telegrams itself (the display filter's) gets them from
          // the writer thread undecoded, heads and all, as from the pipeline. (Without drives:
          // with them, this sink writes no annotation, so the pipeline hands it telegrams
          // decoded, and a ThreadedSink, which writes annotations, undecoded.)
          if (!drives) {
            TranscriptSink passed(detail);
            passed.decodes = true;
            {
              ThreadedSink threaded(passed);
              run_generated_runs(threaded, 300, adjust, mix, nullptr, Prechecks::none, nullptr,
                                 drives);
              threaded.finish();
            }
            ASSERT_GT(decoding.records.size(), decoded.records.size());  // (the heads)
            ASSERT_EQ(decoding.records.size(), passed.records.size());
            for (std::size_t i = 0; i < decoding.records.size(); ++i)
              ASSERT_EQ(decoding.records[i], passed.records[i]) << "record " << i;
            EXPECT_EQ(decoding.infos, passed.infos);
          }
          if (drives && detail) {  // annotations written, timing rules found
            std::size_t annotated = 0, timing = 0;
            for (const std::string& r : replayed.records) {
              annotated += r.starts_with("frame ") && r.find(" drive ''") == std::string::npos;
              timing += r.starts_with(
                  fmt::format("anomaly {} ", static_cast<int>(AnomalyKind::timing_rule)));
            }
            EXPECT_GT(annotated, 100u);
            if (mix == generate::Mix::all) {
              EXPECT_GT(timing, 0u);
            }
          }
        }
      }
    }
  }
}

// `read` to a file: the pipeline hands telegrams over undecoded to a ThreadedSink whose helpers
// decode and format batches on two threads; the text (plain and -V) and the JSON must be byte for
// byte what one sink writes, given every frame decoded by the pipeline.
TEST(Pipeline, FormattedOnSeveralThreadsAsByOne) {
  for (const int kind : {0, 1, 2}) {  // text, text -V, JSON
    SCOPED_TRACE(kind);
    const generate::Mix mix = kind == 1 ? generate::Mix::modbus_rtu : generate::Mix::all;
    std::string texts[2];
    for (const bool threaded : {false, true}) {
      ChannelTable channels;  // the sinks', which the bus interns its links into
      char* data = nullptr;
      std::size_t size = 0;
      std::FILE* file = open_memstream(&data, &size);
      ASSERT_NE(file, nullptr);
      auto make = [&](std::FILE* f) -> std::unique_ptr<FormattingSink> {
        if (kind == 2) return std::make_unique<JsonSink>(f, channels, 1000, true);
        TextSinkOptions options;
        options.verbose = kind == 1;
        return std::make_unique<TextSink>(f, channels, options);
      };
      {
        const std::unique_ptr<FormattingSink> inner = make(file);
        std::vector<std::unique_ptr<FormattingSink>> helpers;
        std::vector<FormattingSink*> pointers;
        for (int i = 0; i < 2; ++i) {
          helpers.push_back(make(nullptr));
          pointers.push_back(helpers.back().get());
        }
        if (threaded) {
          ThreadedSink sink(*inner, pointers);
          run_generated_runs(sink, 300, Adjust::slow_bytes, mix, &channels);
          sink.finish();
        } else {
          run_generated_runs(*inner, 300, Adjust::slow_bytes, mix, &channels);
        }
        ASSERT_TRUE(inner->flush());
      }
      std::fclose(file);
      texts[threaded] = std::string(data, size);
      std::free(data);
    }
    EXPECT_GT(texts[0].size(), 100000u);
    EXPECT_TRUE(texts[0] == texts[1]);
  }
}

// A sink that shows no decode (`read --stats`) lets dissectors skip fields and info lines; every
// key, verdict, pairing, anomaly and count must still be what a detailed run finds.
TEST(Pipeline, SummaryOnlyRunFindsWhatADetailedRunFinds) {
  TranscriptSink detailed(true), summary_only(false);
  run_generated(detailed);
  run_generated(summary_only);
  ASSERT_GT(detailed.messages, 10000u);
  EXPECT_EQ(detailed.with_info, detailed.messages);
  EXPECT_GT(detailed.with_fields, detailed.messages * 9 / 10);
  EXPECT_EQ(summary_only.with_fields, 0u);
  EXPECT_EQ(summary_only.with_info, 0u);
  ASSERT_EQ(detailed.records.size(), summary_only.records.size());
  for (std::size_t i = 0; i < detailed.records.size(); ++i)
    ASSERT_EQ(detailed.records[i], summary_only.records[i]) << "record " << i;
}

// A sink that shows info lines but no field tree (text output without -V) lets dissectors skip
// the tree: the info lines, and everything else, must be what a run with the tree finds.
TEST(Pipeline, InfoWithoutTreeFindsWhatADetailedRunFinds) {
  TranscriptSink detailed(true), info_only(true, /*fields=*/false);
  run_generated(detailed);
  run_generated(info_only);
  ASSERT_GT(detailed.messages, 10000u);
  EXPECT_GT(detailed.with_fields, detailed.messages * 9 / 10);
  EXPECT_EQ(info_only.with_fields, 0u);
  EXPECT_EQ(info_only.with_info, info_only.messages);
  ASSERT_EQ(detailed.records.size(), info_only.records.size());
  for (std::size_t i = 0; i < detailed.records.size(); ++i)
    ASSERT_EQ(detailed.records[i], info_only.records[i]) << "record " << i;
  ASSERT_EQ(detailed.infos.size(), info_only.infos.size());
  for (std::size_t i = 0; i < detailed.infos.size(); ++i)
    ASSERT_EQ(detailed.infos[i], info_only.infos[i]) << "message " << i;
}

// A sink that does nothing with transactions is not handed them; the count and everything else
// is as for one that takes them.
TEST(Pipeline, TransactionsOnlyToSinksThatWantThem) {
  TranscriptSink taking(true), not_taking(true);
  not_taking.transactions = false;
  run_generated(taking);
  run_generated(not_taking);
  std::vector<std::string> without;
  for (const std::string& r : taking.records)
    if (!r.starts_with("transaction ")) without.push_back(r);
  ASSERT_LT(without.size(), taking.records.size() - 5000);  // many transactions were handed over
  EXPECT_EQ(without, not_taking.records);                   // none here; the summary counts them
}

// Every field a dissector emits has an id of the one field table: its descriptor is listed
// there, or names the listed one whose id it shares (FieldDesc::shares_id_of: Danfoss FC's AK has
// a request and a response meaning). Sinks compare ids by FieldDesc::key() alone.
TEST(Pipeline, EveryFieldEmittedHasAnIdOfTheFieldTable) {
  TranscriptSink sink(true);
  run_generated(sink);
  const auto table = all_field_descriptors();
  const std::set<const FieldDesc*> listed(table.begin(), table.end());
  EXPECT_GT(sink.descriptors.size(), 30u);  // the four protocols' fields, not a few
  bool shared_seen = false;
  for (const FieldDesc* d : sink.descriptors) {
    EXPECT_TRUE(listed.count(d->key())) << "field " << d->id << " is not in the field table";
    EXPECT_EQ(d->id, d->key()->id);
    shared_seen = shared_seen || d->key() != d;
  }
  EXPECT_TRUE(shared_seen);  // the FC response's AK was among them
}

// push_batch() hands runs of bytes to the framer at once; what comes out must be exactly what
// push() of each byte gives, wherever the runs start and end.
// Also when bytes need adjusting first: push_batch() passes runs to the framer as given until a
// byte needs it, and adjusted copies from there.
TEST(Pipeline, PushBatchFindsWhatPushFinds) {
  for (const Adjust adjust : {Adjust::none, Adjust::one_stamp_reads, Adjust::seven_bits}) {
    SCOPED_TRACE(static_cast<int>(adjust));
    TranscriptSink one_by_one(true);
    run_generated(one_by_one, 0, adjust);
    ASSERT_GT(one_by_one.messages, 10000u);
    for (const std::size_t chunk : {1u, 7u, 64u, 4096u}) {
      TranscriptSink batched(true);
      run_generated(batched, chunk, adjust);
      ASSERT_EQ(one_by_one.records.size(), batched.records.size()) << "chunk " << chunk;
      for (std::size_t i = 0; i < one_by_one.records.size(); ++i)
        ASSERT_EQ(one_by_one.records[i], batched.records[i])
            << "chunk " << chunk << " record " << i;
    }
  }
}

// The pipeline decodes every frame into one Message: begin_message() must leave nothing of the
// previous frame behind, only storage.
TEST(Pipeline, BeginMessageResetsEveryMember) {
  Frame frame;
  frame.events = {{100, 0x01, 0, 0, 0}, {200, 0x03, 0, 0, 0}};
  Message dirty;
  begin_message(dirty, Frame(frame), protocols::danfoss_fc, Direction::response);
  dirty.bytes.push_back(9);
  dirty.address = 7;
  dirty.function = 0x83;
  dirty.is_exception = true;
  dirty.exception_code = 2;
  dirty.checksum.verdict = ChecksumVerdict::bad;
  dirty.checksum.name = "LRC";
  dirty.checksum.width = 1;
  dirty.checksum.stated_wire = 5;
  dirty.checksum.computed_wire = 6;
  dirty.checksum.text = true;
  dirty.text_encoded = true;
  dirty.fields.emplace_back();
  dirty.info = "old";
  dirty.drive_info = "old drive";
  static const DriveProfile profile;
  dirty.drive_profile = &profile;
  dirty.request = {1, 3};
  dirty.anomalies.push_back({AnomalyKind::noise, 1, 0, 1, "old"});
  dirty.latency = 5;
  dirty.request_number = 3;
  Message fresh;
  begin_message(fresh, Frame(frame), protocols::modbus_rtu, Direction::request);
  begin_message(dirty, Frame(frame), protocols::modbus_rtu, Direction::request);
  EXPECT_EQ(dirty.frame.events.size(), 2u);
  EXPECT_EQ(dirty.bytes, fresh.bytes);
  EXPECT_EQ(dirty.protocol, protocols::modbus_rtu);
  EXPECT_EQ(dirty.direction, Direction::request);
  EXPECT_EQ(dirty.address, fresh.address);
  EXPECT_EQ(dirty.function, fresh.function);
  EXPECT_EQ(dirty.is_exception, fresh.is_exception);
  EXPECT_EQ(dirty.exception_code, fresh.exception_code);
  EXPECT_EQ(dirty.checksum.verdict, fresh.checksum.verdict);
  EXPECT_EQ(dirty.checksum.name, fresh.checksum.name);
  EXPECT_EQ(dirty.checksum.width, fresh.checksum.width);
  EXPECT_EQ(dirty.checksum.stated_wire, fresh.checksum.stated_wire);
  EXPECT_EQ(dirty.checksum.computed_wire, fresh.checksum.computed_wire);
  EXPECT_EQ(dirty.checksum.text, fresh.checksum.text);
  EXPECT_EQ(dirty.text_encoded, fresh.text_encoded);
  EXPECT_TRUE(dirty.fields.empty());
  EXPECT_TRUE(dirty.info.empty());
  EXPECT_TRUE(dirty.drive_info.empty());
  EXPECT_EQ(dirty.drive_profile, nullptr);
  EXPECT_TRUE(dirty.request.empty());
  EXPECT_TRUE(dirty.anomalies.empty());
  EXPECT_EQ(dirty.latency, fresh.latency);
  EXPECT_EQ(dirty.request_number, fresh.request_number);
}

TEST(Pipeline, BeginMessageLeavesTheFrameHoldingThePreviousOne) {
  // The pipeline's frame batch gets the message's previous frame back, storage and all, and
  // builds a later frame in it.
  Frame first;
  first.events = {{100, 0x01, 0, 0, 0}, {200, 0x03, 0, 0, 0}, {300, 0x05, 0, 0, 0}};
  first.number = 1;
  Frame second;
  second.events = {{400, 0x02, 0, 0, 0}};
  second.number = 2;
  Message m;
  begin_message(m, std::move(first), protocols::modbus_rtu, Direction::request);
  begin_message(m, std::move(second), protocols::modbus_rtu, Direction::response);
  EXPECT_EQ(m.frame.number, 2u);
  EXPECT_EQ(m.bytes, (std::vector<std::uint8_t>{0x02}));
  EXPECT_EQ(second.number, 1u);
  EXPECT_EQ(second.events.size(), 3u);
}

TEST(Pipeline, BeginMessageTakesItsOwnFrameAsItIs) {
  // TelegramView::frame_for() builds the frame in the message and hands it over in place: a swap of
  // the frame with itself would leave it without its events.
  Message m;
  m.frame.events = {{100, 0x01, 0, 0, 0}, {200, 0x03, 0, 0, 0}};
  m.frame.number = 7;
  m.bytes = {9, 9, 9};
  begin_message(m, std::move(m.frame), protocols::modbus_rtu, Direction::request);
  EXPECT_EQ(m.frame.number, 7u);
  EXPECT_EQ(m.frame.events.size(), 2u);
  EXPECT_EQ(m.bytes, (std::vector<std::uint8_t>{0x01, 0x03}));
}

// Issue 37 §6: `decode "01 03 00 00 00 01 84 0A | 01 03 02 00 2A 38 5B"` counted the reply with a
// bad CRC as an `ok` transaction; it is a `bad_reply`, in the transactions, the summary counts
// and the frame's text line.
TEST(Pipeline, BadChecksumReplyIsABadReplyTransaction) {
  Bus b;
  auto bad = kReadRsp;
  bad[bad.size() - 1] ^= 0x40;   // the CRC's high byte changed
  for (int i = 0; i < 3; ++i) {  // (good exchanges first: detection needs three good telegrams)
    b.send(kReadReq, 5 * kNsPerMs);
    b.send(kReadRsp);
  }
  b.send(kReadReq, 5 * kNsPerMs);
  b.send(bad);
  b.finish();
  ASSERT_EQ(b.sink.transactions.size(), 4u);
  EXPECT_EQ(b.sink.transactions[3].outcome, Outcome::bad_reply);
  EXPECT_EQ(b.sink.transactions[3].request_number, 7u);
  EXPECT_EQ(b.sink.transactions[3].latency, 5 * kNsPerMs);
  const Stats& s = b.pipeline->stats();
  EXPECT_EQ(s.outcomes[static_cast<std::size_t>(Outcome::ok)], 3u);
  EXPECT_EQ(s.outcomes[static_cast<std::size_t>(Outcome::bad_reply)], 1u);
  ASSERT_EQ(b.sink.frames.size(), 8u);
  EXPECT_NE(frame_summary(b.sink.frames[7], true).find("bad reply to #7 in 5.000 ms"),
            std::string::npos)
      << frame_summary(b.sink.frames[7], true);
  EXPECT_NE(frame_summary(b.sink.frames[5], true).find("  reply to #5"), std::string::npos);
}

namespace {
// The frames' first bytes, in the order the sink got them.
std::vector<TimeNs> frame_starts(const RecordingSink& sink) {
  std::vector<TimeNs> starts;
  for (const Message& m : sink.frames) starts.push_back(m.frame.start());
  return starts;
}
}  // namespace

// Issue 37 §6: with several channels, the frames of a channel still detecting its protocol came
// out after later frames of a channel that had decided (`generate --frames 3000`: 65 frames out
// of time order). Frames now wait in the reorder stage while another channel holds bytes.
TEST(Pipeline, FramesOfADetectingChannelComeOutInTimeOrder) {
  Bus b;
  const ChannelId eds = b.channels.intern("x");  // a bus of its own
  const std::string text = "~010C00010FA0027C\r";
  const std::vector<std::uint8_t> eds_frame(text.begin(), text.end());
  // Modbus RTU on channel 0 and Easydrive on x, interleaved: x's frames start between channel
  // 0's, and x detects later (its telegrams are longer and fewer).
  for (int i = 0; i < 12; ++i) {
    const TimeNs at = b.clock;
    b.send(kReadReq, 5 * kNsPerMs);
    b.send(kReadRsp, 5 * kNsPerMs);
    b.clock = at + 3 * kNsPerMs;
    b.send(eds_frame, 0, eds);
    b.clock = std::max(b.clock, at + 60 * kNsPerMs);
  }
  b.finish();
  const std::vector<TimeNs> starts = frame_starts(b.sink);
  ASSERT_EQ(starts.size(), 36u);
  EXPECT_TRUE(std::is_sorted(starts.begin(), starts.end()));
  for (std::size_t i = 0; i < b.sink.frames.size(); ++i)
    EXPECT_EQ(b.sink.frames[i].frame.number, i + 1) << "frame numbers follow the time order";
  // Channel 0's replies pair with its requests, x's frames in between notwithstanding.
  EXPECT_EQ(b.sink.count(Outcome::ok), 12u);
  EXPECT_EQ(std::count_if(b.sink.frames.begin(), b.sink.frames.end(),
                          [&](const Message& m) { return m.frame.channel == eds; }),
            12);
}

// The hold is bounded: a channel that holds a byte for detection and then goes quiet holds the
// other channels' frames back for kDetectHold (1 s) at most, not until the end of the capture;
// without evidence by then it goes on listening without holding them.
TEST(Pipeline, DetectionHoldsOtherChannelsOneSecondAtMost) {
  Bus b;
  const ChannelId quiet = b.channels.intern("x");
  b.pipeline->push({0, 0x55, 0, quiet});  // one stray byte, then nothing on x
  b.clock = 1 * kNsPerMs;
  for (int i = 0; i < 40; ++i) {  // 40 exchanges, 2 s
    b.send(kReadReq, 5 * kNsPerMs);
    b.send(kReadRsp, 5 * kNsPerMs);
    b.clock += 25 * kNsPerMs;
  }
  // Before finish(): x had no evidence at its deadline, so it stopped holding the others back:
  // the frames of the first second came out, in order. x goes on listening.
  ASSERT_GE(b.sink.frames.size(), 60u);
  const std::vector<TimeNs> starts = frame_starts(b.sink);
  EXPECT_TRUE(std::is_sorted(starts.begin(), starts.end()));
  EXPECT_TRUE(b.sink.noise.empty());
  b.finish();
  EXPECT_EQ(b.sink.frames.size(), 80u);
  ASSERT_EQ(b.sink.noise.size(), 1u);  // x's byte, when its detection ends
  EXPECT_EQ(b.sink.noise[0].channel, quiet);
}
