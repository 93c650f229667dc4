// Unit tests: per-channel protocol detection (--protocol auto).
#include <gtest/gtest.h>

#include "dissectors/danfoss_fc/fc_dissector.hpp"
#include "dissectors/danfoss_fc/fc_protocol.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::testing;

namespace {}  // namespace

TEST(Detection, ModbusRtuWithHighConfidence) {
  AutoRun r;
  for (int i = 0; i < 10; ++i) {
    r.send(with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01}));
    r.send(with_crc({0x01, 0x03, 0x02, 0x00, 0x2A}));
  }
  r.pipeline->finish();
  ASSERT_EQ(r.sink.events.size(), 1u);
  EXPECT_EQ(r.sink.events[0].kind, EventKind::protocol_detected);
  EXPECT_EQ(r.sink.events[0].protocol, protocols::modbus_rtu);
  EXPECT_EQ(r.sink.events[0].confidence, "high");
  EXPECT_EQ(r.sink.frames.frames.size(), 20u);
}

// One protocol weighed: no second candidate to compare with, and the same decision.
TEST(Detection, OneProtocolWeighedAlone) {
  AutoRun r(false, {&modbus::kRtuProtocol});
  for (int i = 0; i < 10; ++i) {
    r.send(with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01}));
    r.send(with_crc({0x01, 0x03, 0x02, 0x00, 0x2A}));
  }
  r.pipeline->finish();
  ASSERT_EQ(r.sink.events.size(), 1u);
  EXPECT_EQ(r.sink.events[0].protocol, protocols::modbus_rtu);
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
  EXPECT_EQ(r.sink.events.front().protocol, protocols::modbus_rtu);
  EXPECT_EQ(r.sink.events.back().protocol, protocols::danfoss_fc);
  std::size_t fc = 0;
  for (const Message& m : r.sink.frames.frames) fc += m.protocol == protocols::danfoss_fc;
  EXPECT_GE(fc, 60u) << "most FC telegrams decoded after the switch";
}
