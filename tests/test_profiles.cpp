// Unit tests: drive profiles — built-in files load, errors name file, line and key.
#include <gtest/gtest.h>

#include "profiles/profile.hpp"

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
