// Test helpers: a sink that records everything, and a runner for byte logs and event vectors.
#pragma once

#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "core/checksum.hpp"
#include "dissectors/danfoss_fc/fc_dissector.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "drive/profile.hpp"
#include "pipeline/pipeline.hpp"
#include "sources/file/byte_log.hpp"

namespace drivetap::testing {

// All built-in drive profiles, loaded once for the whole test binary.
inline const std::vector<DriveProfile>& builtin_profiles() {
  static const std::vector<DriveProfile> profiles = [] {
    ProfileError e;
    auto loaded = load_builtin_profiles(&e);
    if (!loaded) ADD_FAILURE() << e.text();
    return loaded.value_or(std::vector<DriveProfile>{});
  }();
  return profiles;
}

struct RecordingSink final : Sink {
  std::vector<Message> frames;
  std::vector<Frame> noise;
  std::vector<Anomaly> anomalies;
  std::vector<Transaction> transactions;
  Stats summary;
  int summaries = 0;
  void on_frame(const Message& m) override { frames.push_back(m); }
  void on_noise(const Frame& f) override { noise.push_back(f); }
  void on_anomaly(const Anomaly& a) override { anomalies.push_back(a); }
  void on_transaction(const Transaction& t) override { transactions.push_back(t); }
  void on_summary(const Stats& s) override {
    summary = s;
    ++summaries;
  }
  bool flush() override { return true; }

  [[nodiscard]] std::size_t count(AnomalyKind k) const {
    std::size_t n = 0;
    for (const Anomaly& a : anomalies) n += a.kind == k;
    return n;
  }
  [[nodiscard]] std::size_t count(Outcome o) const {
    std::size_t n = 0;
    for (const Transaction& t : transactions) n += t.outcome == o;
    return n;
  }
};

// Appends the Modbus CRC (low byte first) to a frame's bytes.
inline std::vector<std::uint8_t> with_crc(std::vector<std::uint8_t> b) {
  const std::uint16_t c = crc16_modbus(b);
  b.push_back(static_cast<std::uint8_t>(c & 0xFF));
  b.push_back(static_cast<std::uint8_t>(c >> 8));
  return b;
}

// Modbus ASCII frame: ':' hex(ADDR..DATA) LRC CR LF.
inline std::vector<std::uint8_t> ascii_frame(const std::vector<std::uint8_t>& binary) {
  std::string text = ":";
  for (std::uint8_t b : binary) text += fmt::format("{:02X}", b);
  text += fmt::format("{:02X}\r\n", lrc8(binary));
  return {text.begin(), text.end()};
}

// Easydrive frame: '~' body SUM CR, SUM = 16-bit sum of the body's ASCII codes, 4 hex digits.
inline std::vector<std::uint8_t> eds_frame(std::string_view body) {
  unsigned sum = 0;
  for (char c : body) sum += static_cast<unsigned char>(c);
  const std::string text = fmt::format("~{}{:04X}\r", body, sum & 0xFFFF);
  return {text.begin(), text.end()};
}

inline std::string hex_of(const std::vector<std::uint8_t>& bytes) {
  std::string s;
  char buf[3];
  for (std::uint8_t b : bytes) {
    std::snprintf(buf, sizeof buf, "%02X", b);
    s += buf;
  }
  return s;
}

// Runs a byte log file through the whole pipeline.
inline bool run_byte_log(const std::string& path, RecordingSink& sink, ChannelTable& channels,
                         std::string* error, Protocol protocol = protocols::modbus_rtu) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    *error = "cannot open " + path;
    return false;
  }
  ByteLogReader reader(f, path, channels);
  if (!reader.read_header()) {
    *error = reader.error();
    std::fclose(f);
    return false;
  }
  PipelineOptions p;
  p.serial = reader.header_serial().value_or(SerialConfig{});
  p.timing = FramingTiming::from(p.serial);
  reader.set_character_time(p.timing.character_time);
  p.protocol = protocol;
  Pipeline pipeline(p, channels, sink);
  ByteEvent e;
  while (reader.next(e)) pipeline.push(e);
  pipeline.finish();
  std::fclose(f);
  *error = reader.error();
  return error->empty();
}

// A sink that keeps the frames (RecordingSink), the bus events and the summary.
struct EventSink final : Sink {
  RecordingSink frames;
  std::vector<BusEvent> events;
  Stats summary;
  void on_frame(const Message& m) override { frames.on_frame(m); }
  void on_noise(const Frame& f) override { frames.on_noise(f); }
  void on_anomaly(const Anomaly& a) override { frames.on_anomaly(a); }
  void on_transaction(const Transaction& t) override { frames.on_transaction(t); }
  void on_summary(const Stats& s) override {
    frames.on_summary(s);
    summary = s;
  }
  void on_event(const BusEvent& e) override { events.push_back(e); }
  bool flush() override { return true; }
};

// A Danfoss FC telegram: STX, LGE, ADR, the data, BCC.
inline std::vector<std::uint8_t> fc_telegram(std::uint8_t adr, std::vector<std::uint8_t> data) {
  std::vector<std::uint8_t> t;
  t.reserve(data.size() + 4);
  t.push_back(0x02);
  t.push_back(static_cast<std::uint8_t>(data.size() + 2));
  t.push_back(adr);
  for (std::uint8_t b : data) t.push_back(b);
  t.push_back(danfoss_fc::bcc(t));
  return t;
}

// One channel with --protocol auto (an IP flow's when `ip_flow`), 9600 8N1; send() puts a
// telegram on it, 20 ms of silence after.
struct AutoRun {
  ChannelTable channels;
  EventSink sink;
  PipelineOptions options;
  std::unique_ptr<Pipeline> pipeline;
  TimeNs clock = 0;
  explicit AutoRun(bool ip_flow = false, std::vector<const ProtocolDesc*> weighed = {}) {
    channels.intern(ip_flow ? "udp 10.0.0.1:1>10.0.0.2:2" : "bus", "link", ChannelRole::bus,
                    ip_flow);
    options.timing = FramingTiming::from(options.serial);  // protocol stays unknown: auto
    options.detect_protocols = std::move(weighed);
    pipeline = std::make_unique<Pipeline>(options, channels, sink);
  }
  void send(const std::vector<std::uint8_t>& bytes) {
    for (std::uint8_t b : bytes) {
      pipeline->push({clock, b, 0, 0, 0});
      clock += options.timing.character_time;
    }
    clock += 20 * kNsPerMs;
  }
};

}  // namespace drivetap::testing
