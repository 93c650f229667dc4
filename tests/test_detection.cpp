// Unit tests: per-channel protocol detection (--protocol auto).
#include <gtest/gtest.h>

#include "dissectors/danfoss_fc/fc_dissector.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::testing;

namespace {

struct EventSink final : Sink {
  RecordingSink frames;
  std::vector<BusEvent> events;
  void on_frame(const Message& m) override { frames.on_frame(m); }
  void on_noise(const Frame& f) override { frames.on_noise(f); }
  void on_anomaly(const Anomaly& a) override { frames.on_anomaly(a); }
  void on_transaction(const Transaction& t) override { frames.on_transaction(t); }
  void on_summary(const Stats& s) override { frames.on_summary(s); }
  void on_event(const BusEvent& e) override { events.push_back(e); }
  bool flush() override { return true; }
};

std::vector<std::uint8_t> fc_telegram(std::uint8_t adr, std::vector<std::uint8_t> data) {
  std::vector<std::uint8_t> t;
  t.reserve(data.size() + 4);
  t.push_back(0x02);
  t.push_back(static_cast<std::uint8_t>(data.size() + 2));
  t.push_back(adr);
  for (std::uint8_t b : data) t.push_back(b);
  t.push_back(danfoss_fc::bcc(t));
  return t;
}

struct AutoRun {
  ChannelTable channels;
  EventSink sink;
  PipelineOptions options;
  std::unique_ptr<Pipeline> pipeline;
  TimeNs clock = 0;
  AutoRun() {
    channels.intern("bus");
    options.timing = FramingTiming::from(options.serial);  // protocol stays unknown: auto
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

}  // namespace

TEST(Detection, ModbusRtuWithHighConfidence) {
  AutoRun r;
  for (int i = 0; i < 10; ++i) {
    r.send(with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01}));
    r.send(with_crc({0x01, 0x03, 0x02, 0x00, 0x2A}));
  }
  r.pipeline->finish();
  ASSERT_EQ(r.sink.events.size(), 1u);
  EXPECT_EQ(r.sink.events[0].kind, "protocol_detected");
  EXPECT_EQ(r.sink.events[0].protocol, Protocol::modbus_rtu);
  EXPECT_EQ(r.sink.events[0].confidence, "high");
  EXPECT_EQ(r.sink.frames.frames.size(), 20u);
}

TEST(Detection, DanfossFcNotDecidedOnOneLuckyChecksum) {
  AutoRun r;
  r.send(fc_telegram(0x04, {0x04, 0x7C, 0x20, 0x00}));
  r.pipeline->finish();
  ASSERT_EQ(r.sink.events.size(), 1u);
  EXPECT_EQ(r.sink.events[0].protocol, Protocol::unknown) << "one telegram decides nothing";
  EXPECT_EQ(r.sink.events[0].confidence, "none");
}

TEST(Detection, ReDecidesWhenTheBusChanges) {
  AutoRun r;
  for (int i = 0; i < 30; ++i) {  // > 2048 bytes would not be needed: 3 good frames decide
    r.send(with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01}));
    r.send(with_crc({0x01, 0x03, 0x02, 0x00, 0x2A}));
  }
  for (int i = 0; i < 40; ++i) {
    r.send(fc_telegram(0x04, {0x04, 0x7C, 0x20, 0x00}));
    r.send(fc_telegram(0x04, {0x06, 0x07, 0x00, 0x00}));
  }
  r.pipeline->finish();
  ASSERT_GE(r.sink.events.size(), 2u);
  EXPECT_EQ(r.sink.events.front().protocol, Protocol::modbus_rtu);
  EXPECT_EQ(r.sink.events.back().protocol, Protocol::danfoss_fc);
  std::size_t fc = 0;
  for (const Message& m : r.sink.frames.frames) fc += m.protocol == Protocol::danfoss_fc;
  EXPECT_GE(fc, 60u) << "most FC telegrams decoded after the switch";
}
