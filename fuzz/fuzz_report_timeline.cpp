// Fuzzes the time-interval code of `report` and `-z load` (src/sinks/report_sink.hpp's column
// series, src/sinks/stats_tables.cpp's load intervals; docs/reference.md "Report" and
// "Statistics"): records at any times, of any lengths, on a timeline shifted by any amount, for
// any station. Every loop over intervals must end in a bounded number of steps (libFuzzer's
// timeout catches one that does not), no arithmetic may overflow (UBSan), and the page's data
// must be one balanced JSON object.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>

#include "core/anomaly.hpp"
#include "core/message.hpp"
#include "core/protocol_desc.hpp"
#include "core/time.hpp"
#include "core/transaction.hpp"
#include "fuzz/fuzz_common.hpp"
#include "sinks/report_sink.hpp"
#include "sinks/stats_tables.hpp"

namespace {

// Reads the input front to back; past its end every value is 0.
struct Input {
  const std::uint8_t* data;
  std::size_t size;
  std::size_t at = 0;
  std::uint8_t byte() { return at < size ? data[at++] : 0; }
  std::int64_t i64() {
    std::uint64_t v = 0;
    for (int k = 0; k < 8; ++k) v = v << 8 | byte();
    std::int64_t out = 0;
    std::memcpy(&out, &v, sizeof out);
    return out;
  }
  [[nodiscard]] bool done() const { return at >= size; }
};

// Whether `json` is one object whose braces and brackets balance outside its strings.
bool balanced(const std::string& json) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t k = 0; k < json.size(); ++k) {
    const char c = json[k];
    if (in_string) {
      if (c == '\\')
        ++k;
      else if (c == '"')
        in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    if (c == '{' || c == '[') ++depth;
    if (c == '}' || c == ']') --depth;
    if (depth < 0) return false;
  }
  return depth == 0 && !in_string && !json.empty() && json.front() == '{' && json.back() == '}';
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace drivetap;
  Input in{data, size};
  ChannelTable channels;
  const ChannelId a = channels.intern("a"), b = channels.intern("b");
  // The header: the character time (250 ns .. 268 ms: 4 Mbaud to below 50 baud), the -z load
  // interval (what -z takes: 1 ms .. 86400 s).
  const TimeNs character = 250 + (TimeNs{in.byte()} << 20 | TimeNs{in.byte()} << 12);
  const TimeNs interval = std::min<TimeNs>(kNsPerMs << (in.byte() % 27), 86400 * kNsPerSecond);
  const FramingTiming timing{character * 3 / 2, character * 7 / 2, character};
  ReportSink report(channels);
  StatsTablesSink tables(channels, timing, true,
                         {{StatisticKind::stations, kNsPerSecond},
                          {StatisticKind::load, interval},
                          {StatisticKind::gaps, kNsPerSecond}});
  const Protocol protocol(registered_protocols().front());
  bool open = false;
  std::uint64_t number = 0;
  // Records until the input ends: an operation byte, then its values. (Each takes at least one
  // byte of the input, so the loop ends.)
  for (int records = 0; !in.done() && records < 4096; ++records) {
    const std::uint8_t op = in.byte();
    // (as every source keeps them: inside +-2^62 ns)
    const TimeNs t = in.i64() % kTimeLimit;
    if (!open || op % 16 == 0) {
      if (open) report.end_capture(tables.tables(true));
      ReportCapture c;
      c.file = "fuzz";
      c.timing = timing;
      c.shift = in.i64();
      report.begin_capture(c);
      open = true;
      continue;
    }
    Message m;
    m.frame.channel = op & 1 ? b : a;
    m.frame.number = ++number;
    m.frame.gap_before = in.byte() * character;
    const std::size_t bytes = 1 + in.byte() % 64;
    for (std::size_t k = 0; k < bytes; ++k)
      m.frame.events.push_back(ByteEvent{t, 0, 0, m.frame.channel, 0});
    m.address = in.byte();
    m.protocol = protocol;
    m.direction = op & 2 ? Direction::response : Direction::request;
    if (op % 4 == 3) {
      report.on_noise(m.frame);
      tables.on_noise(m.frame);
      continue;
    }
    m.bytes = m.frame.bytes();
    report.on_frame(m);
    tables.on_frame(m);
    Anomaly anomaly;
    anomaly.kind = static_cast<AnomalyKind>(in.byte() % kAnomalyKindCount);
    anomaly.time = t;
    anomaly.channel = m.frame.channel;
    anomaly.frame_number = m.frame.number;
    report.on_anomaly(anomaly);
    Transaction x;
    x.channel = m.frame.channel;
    x.protocol = protocol;
    x.address = m.address;
    x.request_number = m.frame.number;
    x.request_time = t;
    x.latency = in.i64();
    if (x.latency >= 0) x.response_number = m.frame.number;
    report.on_transaction(x);
    tables.on_transaction(x);
  }
  if (!open) return 0;
  report.end_capture(tables.tables(true));
  (void)tables.tables(false);
  if (!balanced(report.data_json(""))) fuzz::contract_broken("the report's data is not one object");
  return 0;
}
