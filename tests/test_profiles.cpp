// Unit tests: drive profiles — built-in files load, errors name file, line and key.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "dissectors/modbus/modbus_protocol.hpp"
#include "drive/drive_fields.hpp"
#include "drive/profile.hpp"
#include "sinks/json_sink.hpp"
#include "sinks/threaded_sink.hpp"
#include "test_support.hpp"

using namespace drivetap;

namespace {

std::string error_of(std::string_view toml) {
  ProfileError e;
  EXPECT_FALSE(parse_profile(toml, "user.toml", &e));
  return e.text();
}

}  // namespace

TEST(Profiles, EveryBuiltinProfileLoads) {
  ASSERT_GE(builtin_profile_texts().size(), 2u);
  for (const BuiltinProfileText& p : builtin_profile_texts()) {
    ProfileError e;
    auto profile = parse_profile(p.text, p.file, &e);
    ASSERT_TRUE(profile) << e.text();
    EXPECT_FALSE(profile->id.empty()) << p.file;
    EXPECT_FALSE(profile->registers.empty()) << p.file;
  }
}

// Each register's `drive.<id>` names one register of its profile, and is a valid filter name.
TEST(Profiles, BuiltinRegisterFieldIdsAreUniqueAndWellFormed) {
  for (const BuiltinProfileText& p : builtin_profile_texts()) {
    ProfileError e;
    auto profile = parse_profile(p.text, p.file, &e);
    ASSERT_TRUE(profile) << e.text();
    std::set<std::string> seen;
    for (const RegisterDef& r : profile->registers) {
      EXPECT_TRUE(valid_register_field_id(r.field_id)) << p.file << ": " << r.name;
      EXPECT_TRUE(seen.insert(r.field_id).second) << p.file << ": " << r.field_id << " twice";
    }
  }
}

TEST(Profiles, RegisterFieldIdFromNameOrKey) {
  EXPECT_EQ(register_field_id("Output frequency (Hz)"), "output_frequency_hz");
  EXPECT_EQ(register_field_id("16-13 Frequency"), "16_13_frequency");
  EXPECT_FALSE(valid_register_field_id("_x"));
  EXPECT_FALSE(valid_register_field_id("X"));
  ProfileError e;
  const std::string base =
      "[drive]\nid = \"t\"\nname = \"T\"\nprotocols = [\"modbus-rtu\"]\n"
      "[[register]]\naddress = 1\nname = \"DC bus\"\n";
  auto named = parse_profile(base + "id = \"dc_bus_voltage\"\n", "t.toml", &e);
  ASSERT_TRUE(named) << e.text();
  EXPECT_EQ(named->registers[0].field_id, "dc_bus_voltage");
  auto derived = parse_profile(base, "t.toml", &e);
  ASSERT_TRUE(derived) << e.text();
  EXPECT_EQ(derived->registers[0].field_id, "dc_bus");
  EXPECT_FALSE(parse_profile(base + "id = \"DC bus\"\n", "t.toml", &e));
  EXPECT_NE(e.text().find("register[1].id"), std::string::npos) << e.text();
  // A name two registers have: the second is told apart by its address.
  auto twice =
      parse_profile(base + "[[register]]\naddress = 17\nname = \"DC bus\"\n", "t.toml", &e);
  ASSERT_TRUE(twice) << e.text();
  EXPECT_EQ(twice->registers[1].field_id, "dc_bus_0011");
}

// texts_plain says whether the JSON escaping leaves a profile's texts as they are.
TEST(Profiles, TextsPlainWhenTheJsonEscapingLeavesThemAlone) {
  for (const BuiltinProfileText& p : builtin_profile_texts()) {
    ProfileError e;
    auto profile = parse_profile(p.text, p.file, &e);
    ASSERT_TRUE(profile) << e.text();
    bool escaped = false;  // whether json_quote() changes any of its texts
    auto check = [&](std::string_view s) {
      escaped |= json_quote(s) != '"' + std::string(s) + '"';
    };
    check(profile->id);
    check(profile->name);
    for (const RegisterDef& r : profile->registers) {
      for (const std::string* s : {&r.number, &r.name, &r.field_id, &r.unit}) check(*s);
      for (const RegisterBit& b : r.bits) {
        check(b.when_clear);
        check(b.when_set);
      }
    }
    for (const auto& [name, names] : profile->enums)
      for (const auto& [number, text] : names) check(text);
    for (const auto& [number, text] : profile->exceptions) check(text);
    for (const auto& [number, text] : profile->parameter_errors) check(text);
    EXPECT_EQ(profile->texts_plain, !escaped) << p.file;
    EXPECT_TRUE(profile->texts_plain) << p.file;  // the JSON writes theirs without a scan
  }
  const std::string base =
      "[drive]\nid = \"t\"\nname = \"T\"\nprotocols = [\"modbus-rtu\"]\n"
      "[[register]]\naddress = 1\nid = \"r\"\nname = ";
  for (const auto& [name, plain] : std::vector<std::pair<std::string, bool>>{
           {"\"plain\"", true},
           {"\"a \\\"quoted\\\" name\"", false},
           {"\"back\\\\slash\"", false},
           {"\"tab\\tname\"", false},
           {"\"parameter 1-05 (\\u00a7 7.10.6)\"", true},  // well-formed UTF-8 stays as it is
           {"\"C1 \\u0085 control\"", false},              // escaped in JSON
       }) {
    ProfileError e;
    auto profile = parse_profile(base + name + "\nunit = \"Hz\"\n", "t.toml", &e);
    ASSERT_TRUE(profile) << e.text();
    EXPECT_EQ(profile->texts_plain, plain) << name;
  }
}

// The JSON `drive` object written from a profile's plain texts and register pieces is byte for
// byte the one the general way writes (every text escaped, every value spelt by
// drive_value_text()), for every register of every built-in profile and raw values at the edges.
TEST(Profiles, JsonDriveObjectFromPiecesIsTheGeneralOne) {
  ChannelTable channels;
  channels.intern("rtu");
  auto json_of = [&](const Message& m) {
    JsonSink sink(nullptr, channels, 1000, true);
    sink.on_frame(m);
    return std::string(sink.formatted()->view());
  };
  for (const BuiltinProfileText& p : builtin_profile_texts()) {
    ProfileError e;
    auto profile = parse_profile(p.text, p.file, &e);
    ASSERT_TRUE(profile) << e.text();
    DriveProfile general = *profile;  // (its registers are not the values')
    general.texts_plain = false;
    // One message for each raw value (a register's value under one id is written once).
    for (const std::uint32_t raw : {0u, 1u, 9u, 10u, 99u, 100u, 12345u, 0x7FFFu, 0x8000u, 0xFFFFu,
                                    0x10000u, 0x80000000u, 0xFFFFFFFFu}) {
      Message m;
      m.address = 7;
      m.drive_info = "drive 7 (" + profile->name + "): ";
      for (const RegisterDef& r : profile->registers) {
        m.drive_info += r.name + " " + r.unit + "; ";
        DriveValue v;
        v.kind = DriveValue::Kind::reg;
        v.reg = &r;
        v.raw = raw;
        v.double_word = raw > 0xFFFF;
        v.id = r.field_id;
        m.drive_values.push_back(v);
        v.id = "setpoint";  // a shared id
        m.drive_values.push_back(v);
        DriveValue text;
        text.kind = DriveValue::Kind::text;
        text.id = "fault_name";
        text.text = r.name;
        text.reg = &r;
        m.drive_values.push_back(text);
        DriveValue integer;
        integer.id = "status_word";
        integer.integer = static_cast<std::int64_t>(raw) - 0x8000;
        integer.reg = &r;
        m.drive_values.push_back(integer);
      }
      m.drive_read_with = &*profile;
      const std::string fast = json_of(m);
      m.drive_read_with = &general;
      EXPECT_EQ(fast, json_of(m)) << p.file << " raw " << raw;
      EXPECT_NE(fast.find("\"values\":{\""), std::string::npos) << fast;
    }
  }
}

TEST(Profiles, E9FromManual000) {
  for (const BuiltinProfileText& p : builtin_profile_texts()) {
    if (p.file != "e9.toml") continue;
    ProfileError e;
    auto profile = parse_profile(p.text, p.file, &e);
    ASSERT_TRUE(profile) << e.text();
    EXPECT_EQ(profile->id, "e9");
    EXPECT_EQ(profile->min_silence_chars, 24.0);
    EXPECT_EQ(profile->min_reply_to_request_ms, 200.0);
    const RegisterDef* setpoint = profile->find(RegisterKind::holding, 0x0011);
    ASSERT_NE(setpoint, nullptr);
    EXPECT_DOUBLE_EQ(setpoint->scale, 0.01);
    EXPECT_EQ(setpoint->unit, "Hz");
    EXPECT_EQ(profile->enums.at("fault").size(), 32u);
    return;
  }
  FAIL() << "e9.toml is not built in";
}

// A walk finds what find() finds, for addresses asked in ascending order from any start (the
// registers of every kind of each built-in profile and their neighbours), and after an address
// below the last one; find_holding() on a walk (of holding registers or not) as without.
TEST(Profiles, WalkFindsWhatFindFinds) {
  const RegisterKind kinds[] = {RegisterKind::holding, RegisterKind::input,
                                RegisterKind::coil,    RegisterKind::discrete,
                                RegisterKind::running, RegisterKind::parameter};
  std::size_t found = 0;
  for (const DriveProfile& p : drivetap::testing::builtin_profiles()) {
    std::vector<std::uint32_t> starts = {0};
    for (const RegisterDef& r : p.registers)
      for (std::uint32_t d : {0u, 1u, 2u}) starts.push_back(r.address > d ? r.address - d : 0);
    for (const RegisterKind kind : kinds) {
      for (const std::uint32_t start : starts) {
        DriveProfile::Walk walk(p, kind, start), holding(p, RegisterKind::holding, start);
        for (std::uint32_t a = start; a < start + 40; ++a) {
          const RegisterDef* expected = p.find(kind, a);
          ASSERT_EQ(walk.find(a), expected) << p.name << " kind " << int(kind) << " at " << a;
          if (expected) ++found;
          ASSERT_EQ(p.find_holding(a, holding), p.find_holding(a)) << p.name << " at " << a;
          // (A walk of another kind is not used.)
          ASSERT_EQ(p.find_holding(a, walk), p.find_holding(a)) << p.name << " at " << a;
        }
        const std::uint32_t back = start / 2;  // below the last one asked
        ASSERT_EQ(walk.find(back), p.find(kind, back)) << p.name << " back to " << back;
        ASSERT_EQ(walk.find(back + 1), p.find(kind, back + 1)) << p.name << " on from " << back;
      }
    }
  }
  EXPECT_GT(found, 1000u);
}

TEST(Profiles, ErrorsNameFileLineAndKey) {
  EXPECT_EQ(error_of("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\nname = \"a\"\n"
                     "scale = \"big\"\n"),
            "user.toml:7: key 'register[1].scale': expected a number");
  EXPECT_EQ(error_of("[drive]\nid = \"x\"\nname = \"X\"\ncolour = \"red\"\n"),
            "user.toml:4: key 'drive.colour': unknown key");
  EXPECT_EQ(error_of("[drive]\nname = \"X\"\n"), "user.toml:1: key 'drive.id': missing");
  EXPECT_EQ(
      error_of("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 70000\nname = \"a\"\n"),
      "user.toml:5: key 'register[1].address': must be in 0..65535");
  EXPECT_NE(error_of("[drive\nid = 1\n").find("user.toml:1: "), std::string::npos);
  EXPECT_EQ(
      error_of("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\nname = \"a\"\n"
               "[register.bits]\n3 = [\"off\"]\n"),
      "user.toml:8: key 'register[1].bits.3': expected [\"meaning when 0\", \"meaning when 1\"]");
}

namespace {

DriveProfile builtin(std::string_view file) {
  for (const BuiltinProfileText& p : builtin_profile_texts()) {
    ProfileError e;
    if (p.file == file) return *parse_profile(p.text, p.file, &e);
  }
  ADD_FAILURE() << file << " not built in";
  return {};
}

// A sink that says it writes the drive annotation itself, and does not: what the pipeline hands
// such a sink.
struct DeferringSink final : Sink {
  drivetap::testing::RecordingSink inner;
  void on_frame(const Message& m) override { inner.on_frame(m); }
  void on_noise(const Frame& f) override { inner.on_noise(f); }
  void on_anomaly(const Anomaly& a) override { inner.on_anomaly(a); }
  void on_transaction(const Transaction& t) override { inner.on_transaction(t); }
  void on_summary(const Stats& s) override { inner.on_summary(s); }
  bool flush() override { return true; }
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n;
    n.drive_info = true;
    return n;
  }
};

// E-9 traffic for station 2 (read, reply, write, write, vendor error) through `sink`, the
// station bound to `e9`.
void run_e9_traffic(const DriveProfile& e9, Sink& sink, ThreadedSink* finish_first = nullptr) {
  ChannelTable channels;
  channels.intern("bus");
  PipelineOptions p;
  p.protocol = protocols::modbus_rtu;
  p.timing = FramingTiming::from(p.serial);
  p.drives[2] = &e9;
  Pipeline pipeline(p, channels, sink);
  TimeNs t = 0;
  using drivetap::testing::with_crc;
  for (const auto& f : {with_crc({0x02, 0x03, 0x00, 0x01, 0x00, 0x02}),
                        with_crc({0x02, 0x03, 0x04, 0x13, 0x88, 0x13, 0x7D}),
                        with_crc({0x02, 0x06, 0x00, 0x11, 0x0F, 0xA0}),
                        with_crc({0x02, 0x10, 0x00, 0x10, 0x00, 0x01, 0x02, 0x00, 0x03}),
                        with_crc({0x02, 0x90, 0x04})}) {
    for (std::uint8_t b : f) pipeline.push({t += p.timing.character_time, b, 0, 0, 0});
    t += 20 * kNsPerMs;
  }
  // With the writer stopped, the last frame (still held by the framer) goes straight through.
  if (finish_first) finish_first->finish();
  pipeline.finish();
}

}  // namespace

TEST(DriveAnnotation, E9ReadReplyWriteAndVendorError) {
  const DriveProfile e9 = builtin("e9.toml");
  drivetap::testing::RecordingSink sink;
  run_e9_traffic(e9, sink);
  ASSERT_EQ(sink.frames.size(), 5u);
  EXPECT_EQ(sink.frames[1].drive_info,
            "drive 2 (ERMAN E-9P/9G): frequency setpoint 50.00 Hz; output frequency 49.89 Hz");
  EXPECT_EQ(sink.frames[2].drive_info, "drive 2 (ERMAN E-9P/9G): set frequency setpoint 40.00 Hz");
  EXPECT_NE(sink.frames[3].drive_info.find("control word 0x0003 [run, reverse"), std::string::npos)
      << sink.frames[3].drive_info;
  EXPECT_NE(sink.frames[4].drive_info.find("error 0x04:"), std::string::npos)
      << sink.frames[4].drive_info;
}

// A sink that writes the annotation on its own thread (the ThreadedSink) gets the profile and the
// request's bytes instead of the text, and writes the text the pipeline writes for other sinks.
TEST(DriveAnnotation, WrittenOnTheWriterThreadAsOnTheDecodingOne) {
  const DriveProfile e9 = builtin("e9.toml");
  drivetap::testing::RecordingSink direct;
  run_e9_traffic(e9, direct);
  ASSERT_EQ(direct.frames.size(), 5u);
  EXPECT_FALSE(direct.frames[1].drive_info.empty());

  DeferringSink deferring;
  run_e9_traffic(e9, deferring);
  ASSERT_EQ(deferring.inner.frames.size(), 5u);
  for (const Message& m : deferring.inner.frames) {
    EXPECT_EQ(m.drive_info, "");
    EXPECT_EQ(m.drive_profile, &e9);
  }
  EXPECT_EQ(deferring.inner.frames[1].request,
            direct.frames[0].bytes);  // the reply's request
  EXPECT_TRUE(deferring.inner.frames[0].request.empty());

  for (const bool finish_first : {false, true}) {
    drivetap::testing::RecordingSink replayed;
    {
      ThreadedSink threaded(replayed);
      EXPECT_TRUE(threaded.needs().drive_info);
      run_e9_traffic(e9, threaded, finish_first ? &threaded : nullptr);
    }
    ASSERT_EQ(replayed.frames.size(), 5u);
    for (std::size_t i = 0; i < 5; ++i) {
      EXPECT_EQ(replayed.frames[i].drive_info, direct.frames[i].drive_info) << i;
      EXPECT_EQ(replayed.frames[i].drive_profile, nullptr);
    }
  }
}

TEST(DriveTimingRules, E9SilenceAndReplyToRequestE5Guard) {
  const DriveProfile e9 = builtin("e9.toml");
  const DriveProfile e5 = builtin("e5-8200.toml");
  ChannelTable channels;
  channels.intern("bus");
  drivetap::testing::RecordingSink sink;
  PipelineOptions p;
  p.protocol = protocols::modbus_rtu;
  p.timing = FramingTiming::from(p.serial);
  p.drives[2] = &e9;
  p.drives[1] = &e5;
  Pipeline pipeline(p, channels, sink);
  const TimeNs ct = p.timing.character_time;
  TimeNs t = 0;
  auto send = [&](const std::vector<std::uint8_t>& f, TimeNs silence_after) {
    for (std::uint8_t b : f) pipeline.push({t, b, 0, 0, 0}), t += ct;
    t += silence_after;
  };
  using drivetap::testing::with_crc;
  const auto e9_read = with_crc({0x02, 0x03, 0x00, 0x01, 0x00, 0x01});
  const auto e9_reply = with_crc({0x02, 0x03, 0x02, 0x13, 0x88});
  send(e9_read, 15 * kNsPerMs);    // reply 15 ms later: fine
  send(e9_reply, 250 * kNsPerMs);  // next request 250 ms after the reply: fine
  send(e9_read, 15 * kNsPerMs);
  send(e9_reply, 50 * kNsPerMs);  // next request 50 ms after the reply: breaks the 200 ms rule
  send(e9_read, 15 * kNsPerMs);
  send(e9_reply, 12 * ct);  // then only 12 characters of silence (< 24) and 12.5 ms
  send(e9_read, 15 * kNsPerMs);
  send(e9_reply, 300 * kNsPerMs);
  const auto e5_read = with_crc({0x01, 0x03, 0x25, 0x23, 0x00, 0x01});
  send(e5_read, 4 * kNsPerMs);  // E5 replies after 4 ms: below its 10 ms guard
  send(with_crc({0x01, 0x03, 0x02, 0x07, 0xD0}), 300 * kNsPerMs);
  pipeline.finish();
  std::vector<std::string> rules;
  for (const Anomaly& a : sink.anomalies)
    if (a.kind == AnomalyKind::timing_rule) rules.push_back(a.detail);
  ASSERT_EQ(rules.size(), 4u);
  EXPECT_EQ(rules[0].find("request 50.0 ms after the drive's last reply; the drive needs 200 ms"),
            0u)
      << rules[0];
  EXPECT_EQ(rules[1].find("12.0 characters of silence before the request; the drive needs 24"), 0u)
      << rules[1];
  EXPECT_NE(rules[2].find("the drive needs 200 ms"), std::string::npos) << rules[2];
  EXPECT_EQ(rules[3].find("reply 4.0 ms after the request; the drive keeps at least 10 ms"), 0u)
      << rules[3];
  EXPECT_NE(rules[3].find("004_b52caedc7a1dba3d.txt"), std::string::npos);
}
