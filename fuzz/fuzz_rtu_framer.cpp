// Fuzzes RtuFramer, the Modbus RTU dissector and the pairer: data is a stream of (time delta,
// byte, flags) records turned into ByteEvents and pushed through the Pipeline; then, as runs,
// dissected to their head (counted, or handed over undecoded) against decoding every frame.
//
//   header (3 bytes, missing bytes read as 0):
//     [0] bits 0-2 baud (1200..115200), bit 3-4 parity N/E/O, bit 5 7 data bits, bit 6 2 stop
//     [1] bits 0-1 --max-hold, bits 2-3 --timeout, bits 4-5 --t15, bits 6-7 --t35
//     [2] start time: 0, 1000 s, -1 s (a pcap packet stamped near 0 lays bytes out before it)
//   record (4 bytes): delta lo, delta hi, byte, flags
//     delta: bits 0-13 amount, bits 14-15 unit: ns, us, ms, or us backwards (time_reversed lines,
//     several channels); the time is the start of this byte, relative to the previous byte's start
//     flags: bits 0-3 UART marks, bits 4-5 channel: bus, m, s, link2 (a second bus);
//       bits 6-7 (no byte log seed sets them): 1 (bit 6) the record is the CRC-16 of the bytes
//       since the last telegram start, two bytes one character apart in wire order (a telegram
//       with a good CRC, which random bytes almost never make), 3 the same byte-swapped
//       (docs/protocols.md §6), 2 the byte starts a telegram; each CRC record also ends the
//       telegram
//     delta 0xC000 (0 us backwards) is a burst instead: the byte 4100 times with one timestamp
//     (a USB read; the pipeline lays the copies back to back), enough to reach the framer's
//     4096-byte segmentation without silence from a small input. At most 8192 events per input.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/checksum.hpp"
#include "drive/annotate.hpp"
#include "fuzz/fuzz_common.hpp"

namespace {

using namespace drivetap;

constexpr std::array<std::uint32_t, 8> kBauds = {1200,  2400,  4800,  9600,
                                                 19200, 38400, 57600, 115200};

PipelineOptions options_from(std::uint8_t line, std::uint8_t timing) {
  PipelineOptions p;
  p.serial.baud = kBauds[line & 7];
  const unsigned parity = (line >> 3) & 3;
  p.serial.parity = parity == 1 ? Parity::even : parity == 2 ? Parity::odd : Parity::none;
  p.serial.data_bits = (line & 0x20) ? 7 : 8;
  p.serial.stop_bits = (line & 0x40) ? 2 : 1;
  p.timing = FramingTiming::from(p.serial);
  // Values reachable with --max-hold, --timeout, --t15 and --t35 (--t35 must be > 0).
  constexpr std::array<TimeNs, 4> kHold = {100 * kNsPerMs, 0, 5 * kNsPerMs, 2 * kNsPerSecond};
  constexpr std::array<TimeNs, 4> kTimeout = {1 * kNsPerSecond, 0, 10 * kNsPerMs,
                                              60 * kNsPerSecond};
  p.max_hold = kHold[timing & 3];
  p.reply_timeout = kTimeout[(timing >> 2) & 3];
  const TimeNs c = p.timing.character_time;
  const std::array<TimeNs, 4> t15 = {p.timing.t15, 0, 10 * c, 1};
  const std::array<TimeNs, 4> t35 = {p.timing.t35, 1, 20 * c, c / 2 + 1};
  p.timing.t15 = t15[(timing >> 4) & 3];
  p.timing.t35 = t35[(timing >> 6) & 3];
  p.auto_candidates = fuzz::builtin_candidates();
  return p;
}

// Records as text: what dissecting to the head must keep as decoding every frame gives it. A sink
// that decodes (`decodes`) also writes the drive annotation, as the threaded sink does.
struct DigestSink final : Sink {
  explicit DigestSink(bool records, bool decodes) : records_(records), decodes_(decodes) {}
  std::string digest;
  std::string events;  // the events alone (a sink without records gets them too)
  void on_frame(const Message& m) override {
    if (m.drive_profile) {  // (only a sink whose needs say drive_info gets one)
      read_for_drive_into(*m.drive_profile, m, m.request, DriveReadingWants::text, reading_);
      digest += "D" + reading_.text + ";";
    } else {
      digest += "D" + m.drive_info + ";";
    }
    digest += "F" + std::to_string(m.frame.number) + ":" +
              std::to_string(static_cast<int>(m.direction)) + "," + std::to_string(m.address) +
              "," + std::to_string(m.function) + "," + std::to_string(m.exception_code) + "," +
              std::to_string(static_cast<int>(m.checksum.verdict)) + "," +
              std::to_string(m.latency) + "," + std::to_string(m.request_number) + "," +
              std::to_string(m.frame.size()) + "," + m.info + ";";
  }
  void on_noise(const Frame& f) override { digest += "N" + std::to_string(f.number) + ";"; }
  void on_anomaly(const Anomaly& a) override {
    digest += "A" + std::to_string(static_cast<int>(a.kind)) + "," +
              std::to_string(a.frame_number) + "," + a.detail + ";";
  }
  void on_transaction(const Transaction& t) override {
    digest += "T" + std::to_string(static_cast<int>(t.outcome)) + "," +
              std::to_string(t.request_number) + "," + std::to_string(t.response_number) + "," +
              std::to_string(t.latency) + ";";
  }
  void on_event(const BusEvent& e) override {
    const std::string record = "E" + std::string(event_kind_id(e.kind)) + "," + e.detail + ";";
    digest += record;
    events += record;
  }
  void on_summary(const Stats& st) override {
    digest += "S" + std::to_string(st.frames) + "," + std::to_string(st.bytes) + "," +
              std::to_string(st.noise_records) + "," + std::to_string(st.transactions) + "," +
              std::to_string(st.latency_sum) + "," + std::to_string(st.latency_count) + "," +
              std::to_string(st.anomaly_total) + "," + std::to_string(st.first_time) + "," +
              std::to_string(st.last_time);
    for (const std::uint64_t n : st.checksum) digest += "," + std::to_string(n);
    for (const std::uint64_t n : st.outcomes) digest += "," + std::to_string(n);
    for (const std::uint64_t n : st.anomalies) digest += "," + std::to_string(n);
  }
  bool flush() override { return true; }
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n;
    n.records = records_;
    n.deferred_decode = decodes_;
    n.drive_info = decodes_;
    return n;
  }

 private:
  bool records_, decodes_;
  DriveReading reading_;
};

// Telegrams dissected to their head (Pipeline::handle_telegram: `read --stats`, and `read` handing
// telegrams over undecoded): the events as runs through push_runs(), as `read` gives a capture's
// packets, once decoded frame by frame, once counted, once handed over undecoded, without and
// with drive profiles (bindings, observations, timing rules and the timeline from the head). The
// counts must be those of decoding, the events the same events, and the records handed over
// undecoded the same records.
void check_head_dissection(const PipelineOptions& options, const ChannelTable& channels,
                           std::span<const ByteEvent> events) {
  RunBatch runs;
  runs.add_events(events);
  for (const bool drives : {false, true}) {
    PipelineOptions lane = options;
    if (!drives) lane.auto_candidates.clear();
    DigestSink decoded(true, false), counted(false, false), handed_over(true, true);
    for (DigestSink* sink : {&decoded, &counted, &handed_over}) {
      Pipeline pipeline(lane, channels, *sink);
      pipeline.push_runs(runs);
      pipeline.finish();
    }
    const std::string what = drives ? "head dissection with drive profiles" : "head dissection";
    const std::size_t summary = decoded.digest.rfind('S');
    if (summary == std::string::npos || counted.events != decoded.events ||
        counted.digest.substr(counted.digest.rfind('S')) != decoded.digest.substr(summary))
      fuzz::contract_broken(
          (what + ": counts or events not those of decoding every frame").c_str());
    if (handed_over.digest != decoded.digest)
      fuzz::contract_broken((what + ": records handed over undecoded differ").c_str());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> in(data, size);
  auto header = [&](std::size_t i) -> std::uint8_t { return i < in.size() ? in[i] : 0; };
  const PipelineOptions options = options_from(header(0), header(1));
  constexpr std::array<TimeNs, 3> kStart = {0, 1000 * kNsPerSecond, -kNsPerSecond};
  TimeNs t = kStart[header(2) % 3];

  ChannelTable channels;
  const std::array<ChannelId, 4> ids = {channels.intern("bus"), channels.intern("m"),
                                        channels.intern("s"), channels.intern("link2")};
  fuzz::CheckedRun run(options, channels);
  std::vector<ByteEvent> events;
  std::size_t budget = 1 << 13;        // events per input: keeps one run short
  std::vector<std::uint8_t> telegram;  // bytes since the last telegram start, for a CRC record
  auto emit = [&](ByteEvent e, unsigned copies) {
    for (; copies > 0 && budget > 0; --copies, --budget) {
      run.push(e);
      events.push_back(e);
    }
  };
  for (std::size_t i = 3; i + 4 <= in.size(); i += 4) {
    const unsigned delta = in[i] | (unsigned{in[i + 1]} << 8);
    const TimeNs amount = delta & 0x3FFF;
    unsigned copies = 1;
    if (delta == 0xC000) {
      copies = 4100;
    } else {
      switch (delta >> 14) {
        case 0:
          t += amount;
          break;
        case 1:
          t += amount * kNsPerUs;
          break;
        case 2:
          t += amount * kNsPerMs;
          break;
        default:
          t -= amount * kNsPerUs;
          break;
      }
    }
    ByteEvent e;
    e.time = t;
    e.byte = in[i + 2];
    e.flags = in[i + 3] & 0x0F;
    e.channel = ids[(in[i + 3] >> 4) & 3];
    const unsigned telegram_mark = in[i + 3] >> 6;
    if (telegram_mark == 1 || telegram_mark == 3) {
      const std::uint16_t crc = crc16_modbus(telegram);
      const auto low = static_cast<std::uint8_t>(crc & 0xFF);
      const auto high = static_cast<std::uint8_t>(crc >> 8);
      e.byte = telegram_mark == 1 ? low : high;
      emit(e, 1);
      t += options.timing.character_time;
      e.time = t;
      e.byte = telegram_mark == 1 ? high : low;
      emit(e, 1);
      telegram.clear();
      continue;
    }
    if (telegram_mark == 2) telegram.clear();
    if (telegram.size() < 300) telegram.push_back(e.byte);
    emit(e, copies);
  }
  run.finish();
  check_head_dissection(options, channels, events);
  return 0;
}
