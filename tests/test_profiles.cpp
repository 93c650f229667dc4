// Unit tests: drive profiles — built-in files load, errors name file, line and key.
#include <gtest/gtest.h>

#include "profiles/profile.hpp"
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

}  // namespace

TEST(DriveAnnotation, E9ReadReplyWriteAndVendorError) {
  const DriveProfile e9 = builtin("e9.toml");
  ChannelTable channels;
  channels.intern("bus");
  drivetap::testing::RecordingSink sink;
  PipelineOptions p;
  p.protocol = Protocol::modbus_rtu;
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
  pipeline.finish();
  ASSERT_EQ(sink.frames.size(), 5u);
  EXPECT_EQ(sink.frames[1].drive_info,
            "drive 2 (ERMAN E-9P/9G): frequency setpoint 50.00 Hz; output frequency 49.89 Hz");
  EXPECT_EQ(sink.frames[2].drive_info, "drive 2 (ERMAN E-9P/9G): set frequency setpoint 40.00 Hz");
  EXPECT_NE(sink.frames[3].drive_info.find("control word 0x0003 [run, reverse"), std::string::npos)
      << sink.frames[3].drive_info;
  EXPECT_NE(sink.frames[4].drive_info.find("error 0x04:"), std::string::npos)
      << sink.frames[4].drive_info;
}
