// Unit tests: the drive level — parameter numbering rules, profile schema errors, drive readings
// of Modbus RTU/ASCII, Danfoss FC and Easydrive frames with the built-in profiles, the
// drive-state timeline and drive binding by guess. Values are the manuals' (docs/protocols.md
// §2-§5).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/protocol.hpp"
#include "dissectors/common/plausibility.hpp"
#include "dissectors/danfoss_fc/fc_protocol.hpp"
#include "dissectors/easydrive/eds_protocol.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "drive/annotate.hpp"
#include "drive/binder.hpp"
#include "drive/profile.hpp"
#include "drive/timeline.hpp"
#include "test_support.hpp"

using namespace drivetap;
using drivetap::testing::ascii_frame;
using drivetap::testing::eds_frame;
using drivetap::testing::with_crc;

namespace {

DriveProfile builtin_profile(std::string_view file) {
  for (const BuiltinProfileText& p : builtin_profile_texts()) {
    if (p.file != file) continue;
    ProfileError e;
    auto profile = parse_profile(p.text, p.file, &e);
    if (!profile) {
      ADD_FAILURE() << e.text();
      return {};
    }
    return *profile;
  }
  ADD_FAILURE() << file << " not built in";
  return {};
}

std::vector<const DriveProfile*> builtin_candidates() {
  std::vector<const DriveProfile*> out;
  for (const DriveProfile& p : drivetap::testing::builtin_profiles()) out.push_back(&p);
  return out;
}

// A frame of `bytes`, one character time apart, starting at `start`.
Frame frame_of(const std::vector<std::uint8_t>& bytes, std::uint64_t number, TimeNs start) {
  const TimeNs ct = FramingTiming::from(SerialConfig{}).character_time;
  Frame f;
  TimeNs t = start;
  for (std::uint8_t b : bytes) {
    f.events.push_back({t, b, 0, 0, 0});
    t += ct;
  }
  f.number = number;
  return f;
}

// Runs `bytes` through the protocol's own dissector, as the pipeline does.
Message decode(Protocol protocol, const std::vector<std::uint8_t>& bytes, Direction direction,
               std::span<const std::uint8_t> request = {}, std::uint64_t number = 1,
               TimeNs start = 0) {
  const ProtocolDecoder* d = decoder_for(protocol);
  EXPECT_NE(d, nullptr);
  return d->dissect(frame_of(bytes, number, start), direction, FramingTiming::from(SerialConfig{}),
                    request);
}

Message rtu(const std::vector<std::uint8_t>& body, Direction direction,
            std::span<const std::uint8_t> request = {}, std::uint64_t number = 1) {
  return decode(protocols::modbus_rtu, with_crc(body), direction, request, number);
}

// Danfoss FC telegram: appends BCC (XOR of every byte from STX on).
std::vector<std::uint8_t> with_bcc(std::vector<std::uint8_t> b) {
  std::uint8_t x = 0;
  for (std::uint8_t c : b) x ^= c;
  b.push_back(x);
  return b;
}

std::string load_error(std::string_view toml) {
  ProfileError e;
  EXPECT_FALSE(parse_profile(toml, "user.toml", &e)) << toml;
  return e.text();
}

// An E-9 poll of station 2: read of registers 0..4 (status .. current), its reply, and a write of
// control word and setpoint.
struct E9Poll {
  Message req = rtu({0x02, 0x03, 0x00, 0x00, 0x00, 0x05}, Direction::request);
  Message rsp = rtu({0x02, 0x03, 0x0A, 0x00, 0x0A, 0x13, 0x88, 0x13, 0x7D, 0x01, 0x7C, 0x00, 0x64},
                    Direction::response);
  Message write =
      rtu({0x02, 0x10, 0x00, 0x10, 0x00, 0x02, 0x04, 0x00, 0x01, 0x13, 0x88}, Direction::request);
};

// An Easydrive poll of station 1: a read of running value 000F, its reply (value 0001, current
// fault 03), and a run command with frequency (index 0002, data 0FA0).
struct EdsPoll {
  Message query = decode(protocols::easydrive, eds_frame("010B000F"), Direction::request);
  Message answer =
      decode(protocols::easydrive, eds_frame("0100030F0001"), Direction::response, query.bytes);
  Message run = decode(protocols::easydrive, eds_frame("010C00020FA0"), Direction::request);
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// Which decoders read a reply's request (the pipeline hands every reply its request, a deferred
// one too): Easydrive's alone.

TEST(ReadsRequest, RepliesDecodeAlikeWithoutTheRequestWhereTheDecoderDoesNotReadIt) {
  struct Case {
    Protocol protocol;
    std::vector<std::uint8_t> request, reply;
  };
  const std::vector<Case> cases = {
      {protocols::modbus_rtu, with_crc({0x01, 0x03, 0x25, 0x20, 0x00, 0x02}),
       with_crc({0x01, 0x03, 0x04, 0x00, 0x06, 0x13, 0x88})},
      {protocols::modbus_ascii, ascii_frame({0x01, 0x03, 0x25, 0x23, 0x00, 0x01}),
       ascii_frame({0x01, 0x03, 0x02, 0x00, 0x2A})},
      {protocols::danfoss_fc, with_bcc({0x02, 0x06, 0x01, 0x04, 0x7C, 0x20, 0x00}),
       with_bcc({0x02, 0x06, 0x01, 0x04, 0x7C, 0x20, 0x00})},
      {protocols::easydrive, eds_frame("010B000F"), eds_frame("0100030F0001")},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(protocol_id(c.protocol)));
    const Message with = decode(c.protocol, c.reply, Direction::response, c.request);
    const Message without = decode(c.protocol, c.reply, Direction::response);
    const bool alike = with.info == without.info &&
                       with.anomalies.size() == without.anomalies.size() &&
                       with.fields.size() == without.fields.size();
    // The other decoders decode alike without the request; Easydrive's replies name the value
    // their request asked for.
    EXPECT_EQ(c.protocol == protocols::easydrive, !alike) << with.info << " / " << without.info;
  }
}

// ---------------------------------------------------------------------------------------------
// Parameter numbering rules (profile.hpp ParameterRule; docs/protocols.md §2, §4, §5).

TEST(ParameterRules, ParsesTheManualsNumbersUnderEachRule) {
  // E5-8200 GGPP (004): 08-03 -> 0x0803, 10-11 -> 0x0A0B.
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("ggpp"), "08-03"), 0x0803u);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("ggpp"), "10-11"), 0x0A0Bu);
  // Danfoss G-NN -> PNU G*100+NN (002 §7.5.1: 4-14 -> PNU 414).
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("danfoss"), "4-14"), 414u);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("danfoss"), "16-13"), 1613u);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("danfoss"), "0-01"), 1u);
  // Easydrive Fg.nn -> g << 8 | nn (001 tables 11-6/11-7: F0.05 -> 0005, F2.11 -> 020B).
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("easydrive"), "F0.05"), 0x0005u);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("easydrive"), "F2.11"), 0x020Bu);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("easydrive"), "F2.15"), 0x020Fu);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("easydrive"), "FD.01"), 0x0D01u);
}

TEST(ParameterRules, RejectsMalformedNumbers) {
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("danfoss"), "4.14"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("danfoss"), "4-140"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("danfoss"), "4-"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("danfoss"), "-14"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("danfoss"), "4-1x"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("easydrive"), "F0-05"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("easydrive"), "0.05"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("easydrive"), "Fd.01"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("easydrive"), "FG.01"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("ggpp"), "08.03"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(parameter_numbering_named("ggpp"), "256-00"), std::nullopt);
  EXPECT_EQ(parse_parameter_number(nullptr, "4-14"), std::nullopt);
}

TEST(ParameterRules, DanfossRegisterAddressIsTenTimesPnuMinusOne) {
  DriveProfile p;
  p.parameter_rule = parameter_numbering_named("danfoss");
  // 002 §7.9.1/§7.8.8: parameter 4-14 -> register 4140 -> wire address 4139 (0x102B).
  EXPECT_EQ(p.parameter_of_register(4139), 414u);
  EXPECT_EQ(p.parameter_of_register(0x102B), 414u);
  // §7.10.6: parameter 1-05 -> wire 0x0419.
  EXPECT_EQ(p.parameter_of_register(0x0419), 105u);
  EXPECT_EQ(p.parameter_of_register(4140), std::nullopt);
  EXPECT_EQ(p.parameter_of_register(4138), std::nullopt);

  DriveProfile ggpp;
  ggpp.parameter_rule = parameter_numbering_named("ggpp");
  EXPECT_EQ(ggpp.parameter_of_register(0x0803), 0x0803u);
  DriveProfile eds;
  eds.parameter_rule =
      parameter_numbering_named("easydrive");  // Easydrive parameters are not on Modbus
  EXPECT_EQ(eds.parameter_of_register(0x0005), std::nullopt);
  DriveProfile none;
  EXPECT_EQ(none.parameter_of_register(4139), std::nullopt);
}

TEST(ParameterRules, LabelsRoundTrip) {
  DriveProfile danfoss, ggpp, eds;
  danfoss.parameter_rule = parameter_numbering_named("danfoss");
  ggpp.parameter_rule = parameter_numbering_named("ggpp");
  eds.parameter_rule = parameter_numbering_named("easydrive");
  EXPECT_EQ(danfoss.parameter_label(414), "4-14");
  EXPECT_EQ(danfoss.parameter_label(1613), "16-13");
  EXPECT_EQ(danfoss.parameter_label(1), "0-01");
  EXPECT_EQ(ggpp.parameter_label(0x0803), "08-03");
  EXPECT_EQ(ggpp.parameter_label(0x0A0B), "10-11");
  EXPECT_EQ(eds.parameter_label(0x0005), "F0.05");
  EXPECT_EQ(eds.parameter_label(0x020B), "F2.11");
  EXPECT_EQ(eds.parameter_label(0x0D01), "FD.01");
  for (const char* text : {"4-14", "16-13", "0-01", "65-53"})
    EXPECT_EQ(danfoss.parameter_label(
                  *parse_parameter_number(parameter_numbering_named("danfoss"), text)),
              text);
  for (const char* text : {"08-03", "10-11", "00-00"})
    EXPECT_EQ(
        ggpp.parameter_label(*parse_parameter_number(parameter_numbering_named("ggpp"), text)),
        text);
  for (const char* text : {"F0.05", "F2.11", "FD.01", "FF.99"})
    EXPECT_EQ(
        eds.parameter_label(*parse_parameter_number(parameter_numbering_named("easydrive"), text)),
        text);
}

TEST(ParameterRules, FindHoldingOnVltAqua) {
  const DriveProfile vlt = builtin_profile("vlt-aqua.toml");
  ASSERT_EQ(vlt.parameter_rule, parameter_numbering_named("danfoss"));
  std::string label = "stale";
  const RegisterDef* r = vlt.find_holding(4139, &label);
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->kind, RegisterKind::parameter);
  EXPECT_EQ(r->number, "4-14");
  EXPECT_EQ(r->address, 414u);
  EXPECT_DOUBLE_EQ(r->scale, 0.1);
  EXPECT_EQ(r->unit, "Hz");
  EXPECT_EQ(label, "");
  EXPECT_EQ(display_name(*r), "4-14 motor speed high limit [Hz]");

  // 16-12 is rule-mapped (register 16120 -> wire 16119) but the profile does not name it.
  EXPECT_EQ(vlt.find_holding(1612 * 10 - 1, &label), nullptr);
  EXPECT_EQ(label, "16-12");
  // An address the rule does not map: no register, no label.
  EXPECT_EQ(vlt.find_holding(1612 * 10, &label), nullptr);
  EXPECT_EQ(label, "");
  // A named holding register wins over the rule (CTW at register 50000, wire 49999).
  const RegisterDef* ctw = vlt.find_holding(49999, &label);
  ASSERT_NE(ctw, nullptr);
  EXPECT_EQ(ctw->name, "control word (CTW)");
  EXPECT_EQ(ctw->kind, RegisterKind::holding);
  EXPECT_EQ(label, "");
}

// ---------------------------------------------------------------------------------------------
// Profile schema: the loader's errors name file, line and key.

TEST(ProfileSchema, ParameterRuleErrors) {
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[parameters]\nrule = \"x\"\n"),
            "user.toml:5: key 'parameters.rule': must be ggpp, danfoss or easydrive");
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[parameters]\nrule = \"danfoss\"\n"
                       "[[parameter]]\nnumber = \"4.14\"\nname = \"a\"\n"),
            "user.toml:7: key 'parameter[1].number': expected a parameter number like \"4-14\" "
            "under this rule");
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[parameters]\nrule = \"ggpp\"\n"
                       "[[parameter]]\nnumber = \"8-3-1\"\nname = \"a\"\n"),
            "user.toml:7: key 'parameter[1].number': expected a parameter number like \"08-03\" "
            "under this rule");
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[parameters]\nrule = \"easydrive\"\n"
                       "[[parameter]]\nname = \"a\"\nnumber = \"F0-05\"\n"),
            "user.toml:8: key 'parameter[1].number': expected a parameter number like \"F0.05\" "
            "under this rule");
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[[parameter]]\nnumber = \"4-14\"\n"
                       "name = \"a\"\n"),
            "user.toml:5: key 'parameter[1].number': parameters need a [parameters] rule (ggpp, "
            "danfoss or easydrive)");
  // A [[parameter]] has a number, not an address.
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[parameters]\nrule = \"danfoss\"\n"
                       "[[parameter]]\nnumber = \"4-14\"\nname = \"a\"\naddress = 4139\n"),
            "user.toml:9: key 'parameter[1].address': unknown key");
}

TEST(ProfileSchema, ProcessDataErrors) {
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\n"
                       "name = \"a\"\n[process_data]\nto_drive = [1]\nfrom_drive = [1, 1]\n"),
            "user.toml:8: key 'process_data.to_drive': expected [PCD1, PCD2] addresses");
  EXPECT_EQ(
      load_error("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\n"
                 "name = \"a\"\n[process_data]\nto_drive = [1, 70000]\nfrom_drive = [1, 1]\n"),
      "user.toml:8: key 'process_data.to_drive': each must be a register address 0..65535");
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\n"
                       "name = \"a\"\n[process_data]\nto_drive = [1, 1]\n"),
            "user.toml:7: key 'process_data.from_drive': missing");
  // An address with no [[register]] (written inline on line 1: the table and its keys share it).
  const std::string tail =
      "[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\n"
      "name = \"a\"\n[[register]]\naddress = 2\nname = \"b\"\nkind = \"coil\"\n";
  EXPECT_EQ(load_error("process_data = { to_drive = [1, 3], from_drive = [1, 1] }\n" + tail),
            "user.toml:1: key 'process_data.to_drive': no [[register]] with address 3");
  EXPECT_EQ(load_error("process_data = { to_drive = [1, 1], from_drive = [3, 1] }\n" + tail),
            "user.toml:1: key 'process_data.from_drive': no [[register]] with address 3");
  // A coil at the address does not count: PCD words are holding registers.
  EXPECT_EQ(load_error("process_data = { to_drive = [1, 2], from_drive = [1, 1] }\n" + tail),
            "user.toml:1: key 'process_data.to_drive': no [[register]] with address 2");
  // The same profile with both addresses registered loads.
  ProfileError e;
  EXPECT_TRUE(parse_profile("process_data = { to_drive = [1, 1], from_drive = [1, 1] }\n" + tail,
                            "user.toml", &e))
      << e.text();
}

TEST(ProfileSchema, RegisterStateWordsAndEnumErrors) {
  const std::string head =
      "[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\n"
      "name = \"a\"\n";  // lines 1..6
  EXPECT_EQ(load_error(head + "[register.state]\nrunning = 40\n"),
            "user.toml:8: key 'register[1].state.running': expected a bit number 0..31 or a list "
            "of them");
  EXPECT_EQ(load_error(head + "[register.state]\nrun = 0\nrunning = [1, 32]\n"),
            "user.toml:9: key 'register[1].state.running': expected a bit number 0..31 or a list "
            "of them");
  EXPECT_EQ(load_error(head + "[register.state]\nrunning = []\n"),
            "user.toml:8: key 'register[1].state.running': expected a bit number 0..31 or a list "
            "of them");
  EXPECT_EQ(load_error(head + "[register.state]\nspinning = 1\n"),
            "user.toml:8: key 'register[1].state.spinning': unknown state (run, reset, running, "
            "forward, reverse, fault, warning, ready)");
  EXPECT_EQ(load_error(head + "words = 3\n"),
            "user.toml:7: key 'register[1].words': must be in 1..2");
  EXPECT_EQ(load_error(head + "enum = \"nope\"\nunit = \"Hz\"\n"),
            "user.toml:7: key 'register[1].enum': no [enums.nope] table");
  EXPECT_EQ(load_error(head + "role = \"speed\"\n"),
            "user.toml:7: key 'register[1].role': must be control, status, setpoint, "
            "output_frequency, current, voltage, fault, start, stop or reset");
  EXPECT_EQ(load_error(head + "kind = \"running\"\nwords = 0\n"),
            "user.toml:8: key 'register[1].words': must be in 1..2");
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\n"
                       "name = \"a\"\n[[register]]\naddress = 2\nname = \"b\"\nenum = \"nope\"\n"),
            "user.toml:10: key 'register[2].enum': no [enums.nope] table");
  // One unit per shared id: a role's register in another unit is refused.
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\n"
                       "name = \"speed\"\nrole = \"output_frequency\"\nunit = \"rpm\"\n"),
            "user.toml:8: key 'register[1].unit': role output_frequency is in Hz "
            "(drive.output_frequency) or % (drive.output_frequency_pct), not 'rpm'");
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\n"
                       "name = \"amps\"\nrole = \"current\"\nunit = \"%\"\n"),
            "user.toml:8: key 'register[1].unit': role current is in A (drive.output_current), "
            "not '%'");
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\n"
                       "name = \"set\"\nrole = \"setpoint\"\n"),
            "user.toml:7: key 'register[1].unit': role setpoint is in Hz (drive.setpoint) or % "
            "(drive.setpoint_pct), not ''");
  EXPECT_EQ(load_error("[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\n"
                       "name = \"w\"\nbits = \"danfoss_fc.nope\"\n"),
            "user.toml:7: key 'register[1].bits': no word 'danfoss_fc.nope' (danfoss_fc.ctw, "
            "danfoss_fc.stw)");
}

TEST(ProfileSchema, NewKeysLoad) {
  ProfileError e;
  const auto p = parse_profile(
      "[drive]\nid = \"x\"\nname = \"X\"\nprotocols = [\"danfoss-fc\"]\n"
      "[parameters]\nrule = \"danfoss\"\n"
      "[process_data]\nto_drive = [49999, 50009]\nfrom_drive = [50199, 50209]\n"
      "[[register]]\naddress = 49999\nname = \"CTW\"\nrole = \"control\"\n"
      "[register.state]\nrun = 6\nreset = 7\nreverse = 15\n"
      "[[register]]\naddress = 50009\nname = \"REF\"\nrole = \"setpoint\"\nunit = \"%\"\n"
      "signed = true\n"
      "[[register]]\naddress = 50199\nname = \"STW\"\nrole = \"status\"\n"
      "[register.state]\nrunning = 11\nfault = [3, 6]\n"
      "[[register]]\naddress = 50209\nname = \"MAV\"\nwords = 1\n"
      "[[parameter]]\nnumber = \"1-05\"\nname = \"current\"\nwords = 2\nscale = 0.01\n"
      "[parameter_errors]\n2 = \"limit\"\n0x11 = \"mode\"\n",
      "user.toml", &e);
  ASSERT_TRUE(p) << e.text();
  EXPECT_EQ(p->parameter_rule, parameter_numbering_named("danfoss"));
  EXPECT_EQ(p->pcd_to_drive, (std::vector<std::uint32_t>{49999, 50009}));
  EXPECT_EQ(p->pcd_from_drive, (std::vector<std::uint32_t>{50199, 50209}));
  const RegisterDef* ctw = p->find(RegisterKind::holding, 49999);
  ASSERT_NE(ctw, nullptr);
  EXPECT_EQ(ctw->state.run, std::vector<int>{6});
  EXPECT_EQ(ctw->state.reset, std::vector<int>{7});
  EXPECT_EQ(ctw->state.reverse, std::vector<int>{15});
  const RegisterDef* stw = p->find(RegisterKind::holding, 50199);
  ASSERT_NE(stw, nullptr);
  EXPECT_EQ(stw->state.fault, (std::vector<int>{3, 6}));
  const RegisterDef* par = p->find(RegisterKind::parameter, 105);
  ASSERT_NE(par, nullptr);
  EXPECT_EQ(par->number, "1-05");
  EXPECT_EQ(par->words, 2);
  EXPECT_EQ(p->parameter_errors.at(17), "mode");
  EXPECT_EQ(p->parameter_errors.at(2), "limit");
}

TEST(ProfileSchema, BitsComeOutSortedByBitNumber) {
  ProfileError e;
  const auto p = parse_profile(
      "[drive]\nid = \"x\"\nname = \"X\"\n[[register]]\naddress = 1\nname = \"a\"\n"
      "[register.bits]\n10 = [\"\", \"ten\"]\n2 = [\"\", \"two\"]\n1 = [\"off\", \"one\"]\n",
      "user.toml", &e);
  ASSERT_TRUE(p) << e.text();
  const RegisterDef* r = p->find(RegisterKind::holding, 1);
  ASSERT_NE(r, nullptr);
  ASSERT_EQ(r->bits.size(), 3u);
  EXPECT_EQ(r->bits[0].bit, 1);
  EXPECT_EQ(r->bits[1].bit, 2);
  EXPECT_EQ(r->bits[2].bit, 10);
  EXPECT_EQ(r->bits[2].when_set, "ten");
  // Meanings are shown in bit order too.
  EXPECT_EQ(describe_value(*p, *r, 0x0404), "0x0404 [off, two, ten]");
  EXPECT_EQ(describe_value(*p, *r, 0x0006), "0x0006 [one, two]");
  EXPECT_EQ(describe_value(*p, *r, 0x00ABCDEF, true), "0x00ABCDEF [one, two, ten]");
  EXPECT_EQ(describe_value(*p, *r, 0), "0x0000 [off]");
}

// Scaled values printed from integers (decimal and whole scales) read exactly as the double
// printed with fmt's "{:.Nf}", as they always were; other scales still go through the double.
TEST(ProfileSchema, ScaledValuesReadAsTheDoublePrinted) {
  const DriveProfile profile;
  const double scales[] = {1,   0.1,  0.01,          0.001, 0.0001, 0.00001, 10, 100,
                           0.5, 0.25, 100.0 / 16384, 0.02,  -1,     -0.1,    2.5};
  const std::uint32_t raws[] = {0,     1,     5,          9,          10,         99,
                                100,   4989,  5000,       32767,      32768,      0x8001,
                                65535, 65536, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF, 123456789};
  for (const double scale : scales)
    for (const bool is_signed : {false, true})
      for (const bool double_word : {false, true})
        for (const std::uint32_t raw32 : raws) {
          const std::uint32_t raw = double_word ? raw32 : (raw32 & 0xFFFF);
          RegisterDef r;
          r.scale = scale;
          r.is_signed = is_signed;
          r.unit = "Hz";
          double v = raw;
          if (is_signed)
            v = double_word ? static_cast<double>(static_cast<std::int32_t>(raw))
                            : static_cast<double>(static_cast<std::int16_t>(raw));
          int decimals = 0;
          for (double s = scale; decimals < 6 && std::fabs(s - std::round(s)) > 1e-9; s *= 10)
            ++decimals;
          // (No exact decimal: the resolution's decimals, one step of the raw value shown.)
          if (decimals >= 6) decimals = static_cast<int>(std::ceil(-std::log10(std::fabs(scale))));
          EXPECT_EQ(describe_value(profile, r, raw, double_word),
                    fmt::format("{:.{}f} Hz", v * scale, decimals))
              << "scale " << scale << " raw " << raw << " signed " << is_signed;
        }
}

// ---------------------------------------------------------------------------------------------
// Drive readings (read_for_drive) with the built-in profiles.

TEST(DriveReading, E9WriteOfControlWordAndSetpoint) {
  const DriveProfile e9 = builtin_profile("e9.toml");
  // 000 §5.1: FC 10 at 0x0010, 2 registers: control word 0x0001 (run), setpoint 5000 = 50.00 Hz.
  const Message m =
      rtu({0x02, 0x10, 0x00, 0x10, 0x00, 0x02, 0x04, 0x00, 0x01, 0x13, 0x88}, Direction::request);
  ASSERT_EQ(m.checksum.verdict, ChecksumVerdict::good);
  const DriveReading r = read_for_drive(e9, m, {});
  EXPECT_EQ(r.text,
            "drive 2 (ERMAN E-9P/9G): set control word 0x0001 [run, forward]; frequency setpoint "
            "50.00 Hz");
  EXPECT_EQ(r.observed.run_command, true);
  EXPECT_EQ(r.observed.reverse_command, false);
  EXPECT_FALSE(r.observed.reset_command);
  ASSERT_TRUE(r.observed.setpoint_command);
  EXPECT_DOUBLE_EQ(r.observed.setpoint_command->value, 50.0);
  EXPECT_EQ(r.observed.setpoint_command->text(), "50.00 Hz");
  // A write is a command: nothing the drive reported.
  EXPECT_FALSE(r.observed.running);
  EXPECT_FALSE(r.observed.setpoint);
}

TEST(DriveReading, E9StatusReplyReadWithItsRequest) {
  const DriveProfile e9 = builtin_profile("e9.toml");
  const Message req = rtu({0x02, 0x03, 0x00, 0x00, 0x00, 0x05}, Direction::request);
  EXPECT_EQ(read_for_drive(e9, req, {}).text,
            "drive 2 (ERMAN E-9P/9G): read drive status .. output current");
  // Status 0x000A (forward, fault), setpoint 50.00 Hz, output 49.89 Hz, 380 V, 10.0 A.
  const Message rsp =
      rtu({0x02, 0x03, 0x0A, 0x00, 0x0A, 0x13, 0x88, 0x13, 0x7D, 0x01, 0x7C, 0x00, 0x64},
          Direction::response);
  const DriveReading r = read_for_drive(e9, rsp, req.bytes);
  EXPECT_EQ(r.text,
            "drive 2 (ERMAN E-9P/9G): drive status 0x000A [stopped, forward, normal rotation, "
            "fault]; frequency setpoint 50.00 Hz; output frequency 49.89 Hz; output voltage 380 V; "
            "output current 10.0 A");
  EXPECT_EQ(r.observed.running, false);
  EXPECT_EQ(r.observed.fault_active, true);
  EXPECT_EQ(r.observed.reverse, false);  // bit 1 = 1 means forward on the E-9
  ASSERT_TRUE(r.observed.setpoint);
  EXPECT_EQ(r.observed.setpoint->text(), "50.00 Hz");
  ASSERT_TRUE(r.observed.output_frequency);
  EXPECT_DOUBLE_EQ(r.observed.output_frequency->value, 49.89);
  ASSERT_TRUE(r.observed.voltage);
  EXPECT_EQ(r.observed.voltage->text(), "380 V");
  ASSERT_TRUE(r.observed.current);
  EXPECT_EQ(r.observed.current->text(), "10.0 A");
  EXPECT_FALSE(r.observed.run_command);
  // Without its request a reply says nothing.
  EXPECT_EQ(read_for_drive(e9, rsp, {}).text, "");
  // The fault code register names the manual's fault.
  const Message fault_req = rtu({0x02, 0x03, 0x00, 0x0B, 0x00, 0x01}, Direction::request);
  const DriveReading f =
      read_for_drive(e9, rtu({0x02, 0x03, 0x02, 0x00, 0x04}, Direction::response), fault_req.bytes);
  EXPECT_EQ(f.observed.fault_code, 4u);
  EXPECT_EQ(f.observed.fault.text(), "4 (output overcurrent)");
}

// Two quantities read alike exactly when their texts are equal, whichever way same_text() decides
// it (the timeline's setpoint changes): for every pair of registers of each built-in profile, on
// values around the edges of 16 bits and small ones (Danfoss's 100/16384 % among the scales), and
// on a text written without a register.
TEST(Quantity, SameTextIsTheTextsCompared) {
  const std::uint32_t raws[] = {0, 1, 2, 3, 50, 5000, 0x4000, 0x7FFF, 0x8000, 0xFFFF};
  std::size_t pairs = 0, alike_apart = 0;
  for (const DriveProfile& p : drivetap::testing::builtin_profiles()) {
    for (const RegisterDef& a : p.registers) {
      for (const RegisterDef& b : p.registers) {
        for (const std::uint32_t x : raws) {
          for (const std::uint32_t y : {x, x + 1, x ^ 1u}) {
            const Quantity qa = Quantity::of(p, a, x, false), qb = Quantity::of(p, b, y, false);
            const bool alike = qa.text() == qb.text();
            ASSERT_EQ(qa.same_text(qb), alike)
                << p.name << ": " << a.name << " " << x << " (" << qa.text() << ") against "
                << b.name << " " << y << " (" << qb.text() << ")";
            ++pairs;
            if (alike && x != y && &a == &b) ++alike_apart;
          }
        }
      }
    }
  }
  EXPECT_GT(pairs, 10000u);
  // Shown at its resolution, no step of one register's raw value prints as its neighbour.
  EXPECT_EQ(alike_apart, 0u);
  Quantity written{4, "4 (overcurrent)"};
  const DriveProfile e9 = builtin_profile("e9.toml");
  EXPECT_TRUE(written.same_text(Quantity{4, "4 (overcurrent)"}));
  EXPECT_FALSE(written.same_text(Quantity::of(e9, e9.registers.front(), 4, false)));
}

// Without the text (read --stats), a reading observes exactly what it observes with it.
TEST(DriveReading, WithoutTextTheObservationIsTheSame) {
  const DriveProfile e9 = builtin_profile("e9.toml");
  const E9Poll poll;
  const Message &req = poll.req, &rsp = poll.rsp, &write = poll.write;
  auto text = [](const std::optional<Quantity>& q) { return q ? q->text() : "-"; };
  for (const auto& [m, request] :
       {std::pair{req, std::vector<std::uint8_t>()}, std::pair{rsp, req.bytes},
        std::pair{write, std::vector<std::uint8_t>()}}) {
    const DriveReading full = read_for_drive(e9, m, request);
    const DriveReading bare = read_for_drive(e9, m, request, false);
    EXPECT_FALSE(full.text.empty());
    EXPECT_EQ(bare.text, "");
    const DriveObservation &a = full.observed, &b = bare.observed;
    EXPECT_EQ(a.running, b.running);
    EXPECT_EQ(a.reverse, b.reverse);
    EXPECT_EQ(a.fault_active, b.fault_active);
    EXPECT_EQ(text(a.setpoint), text(b.setpoint));
    EXPECT_EQ(text(a.output_frequency), text(b.output_frequency));
    EXPECT_EQ(text(a.current), text(b.current));
    EXPECT_EQ(text(a.voltage), text(b.voltage));
    EXPECT_EQ(text(a.setpoint_command), text(b.setpoint_command));
    EXPECT_EQ(a.run_command, b.run_command);
    EXPECT_EQ(a.reverse_command, b.reverse_command);
    EXPECT_EQ(a.fault_code, b.fault_code);
  }
}

// The pipeline reads every frame into one DriveReading, whose strings keep their storage: each
// frame reads as it does into a new one, whatever the frame before left there.
TEST(DriveReading, ReadingIntoOneReadingIsReadingAfresh) {
  const DriveProfile e9 = builtin_profile("e9.toml");
  const DriveProfile eds = builtin_profile("eds1000.toml");
  const E9Poll poll;
  const Message &req = poll.req, &rsp = poll.rsp, &write = poll.write;
  const Message fault_req = rtu({0x02, 0x03, 0x00, 0x0B, 0x00, 0x01}, Direction::request);
  const Message fault = rtu({0x02, 0x03, 0x02, 0x00, 0x04}, Direction::response);
  const Message exception = rtu({0x02, 0x83, 0x02}, Direction::response);
  const EdsPoll eds_poll;
  const Message &eds_q = eds_poll.query, &eds_a = eds_poll.answer, &eds_run = eds_poll.run;
  struct Case {
    const DriveProfile& profile;
    const Message& message;
    std::vector<std::uint8_t> request;
  };
  const Case cases[] = {{e9, req, {}},
                        {e9, rsp, req.bytes},
                        {e9, fault, fault_req.bytes},
                        {e9, write, {}},
                        {e9, rsp, {}},
                        {e9, exception, req.bytes},
                        {eds, eds_a, eds_q.bytes},
                        {eds, eds_run, {}},
                        {eds, eds_q, {}},
                        {e9, fault, fault_req.bytes},
                        {e9, req, {}}};
  for (const bool want_text : {true, false}) {
    DriveReading reused;
    for (const Case& c : cases) {
      read_for_drive_into(
          c.profile, c.message, c.request,
          want_text ? DriveReadingWants::text_and_observation : DriveReadingWants::observation,
          reused);
      const DriveReading fresh = read_for_drive(c.profile, c.message, c.request, want_text);
      EXPECT_EQ(reused.text, fresh.text);
      EXPECT_TRUE(reused.observed == fresh.observed) << fresh.text;
    }
  }
  // Cleared, an observation is a new one (every member set first); its fault text keeps its
  // storage.
  DriveReading r = read_for_drive(e9, fault, fault_req.bytes);
  ASSERT_EQ(r.observed.fault.text(), "4 (output overcurrent)");
  DriveObservation& o = r.observed;
  o.running = o.reverse = o.fault_active = o.warning = true;
  o.setpoint = o.output_frequency = o.current = o.voltage = Quantity{50, "50.00 Hz"};
  o.fault_code = 4;
  o.run_command = o.reverse_command = true;
  o.reset_command = true;
  o.setpoint_command = Quantity{25, "25.00 Hz, a text too long for a short string"};
  o.fault.written = "4 (a text too long for a short string)";
  ASSERT_FALSE(o.registers.empty());  // the fault register read
  const std::size_t capacity = o.fault.written.capacity();
  o.clear();
  EXPECT_TRUE(o == DriveObservation{});
  EXPECT_EQ(o.fault.written.capacity(), capacity);
}

// The writer thread of a ThreadedSink reads a frame for its text alone (the pipeline made the
// observation): the same text as a full reading, from one reused reading, without applying the
// register roles.
TEST(DriveReading, TheTextAloneIsTheTextOfAFullReading) {
  const DriveProfile e9 = builtin_profile("e9.toml");
  const DriveProfile eds = builtin_profile("eds1000.toml");
  const DriveProfile vlt = builtin_profile("vlt-aqua.toml");
  const E9Poll poll;
  const EdsPoll eds_poll;
  const Message &eds_q = eds_poll.query, &eds_a = eds_poll.answer, &eds_run = eds_poll.run;
  const Message fc_start =
      decode(protocols::danfoss_fc, with_bcc({0x02, 0x06, 0x01, 0x04, 0x7C, 0x20, 0x00}),
             Direction::request);
  struct Case {
    const DriveProfile& profile;
    const Message& message;
    std::vector<std::uint8_t> request;
  };
  const Case cases[] = {{e9, poll.req, {}},   {e9, poll.rsp, poll.req.bytes},
                        {e9, poll.write, {}}, {eds, eds_a, eds_q.bytes},
                        {eds, eds_run, {}},   {vlt, fc_start, {}}};
  DriveReading reused;
  for (const Case& c : cases) {
    read_for_drive_into(c.profile, c.message, c.request, DriveReadingWants::text, reused);
    const DriveReading full = read_for_drive(c.profile, c.message, c.request);
    EXPECT_FALSE(full.text.empty());
    EXPECT_EQ(reused.text, full.text);
  }
  // The E-9 reply's registers are its status, setpoint and output frequency: a full reading
  // observes them, the text alone does not.
  read_for_drive_into(e9, poll.rsp, poll.req.bytes, DriveReadingWants::text, reused);
  EXPECT_TRUE(read_for_drive(e9, poll.rsp, poll.req.bytes).observed.output_frequency);
  EXPECT_FALSE(reused.observed.output_frequency);
  EXPECT_FALSE(reused.observed.running);
}

// One decoding of a word: for every value of the control and status word, the FC frame line's
// bit names and the `=` line's (the VLT AQUA profile's `bits = "danfoss_fc.ctw"`) are the same
// text, read over the FC protocol and over Modbus (registers 50000 and 50200).
TEST(DriveReading, EveryControlAndStatusWordNamedAlikeOnTheFrameLineAndTheDriveLine) {
  const DriveProfile vlt = builtin_profile("vlt-aqua.toml");
  auto bracket = [](const std::string& text, std::string_view after) {
    const std::size_t at = text.find(after);
    if (at == std::string::npos) return std::string("(no ") + std::string(after) + ")";
    const std::size_t open = text.find('[', at), close = text.find(']', at);
    return text.substr(open, close - open + 1);
  };
  int compared = 0;
  for (std::uint32_t w = 0; w <= 0xFFFF; w += 1) {
    const auto hi = static_cast<std::uint8_t>(w >> 8), lo = static_cast<std::uint8_t>(w);
    const std::string hex = fmt::format("0x{:04X}", w);
    for (const Direction d : {Direction::request, Direction::response}) {
      const bool to_drive = d == Direction::request;
      const Message fc = decode(protocols::danfoss_fc,
                                with_bcc({0x02, 0x06, 0x01, hi, lo, 0x20, 0x00}), d);
      const std::string frame_line = bracket(fc.info, (to_drive ? "CTW " : "STW ") + hex);
      const DriveReading reading = read_for_drive(vlt, fc, {});
      const std::string drive_line =
          bracket(reading.text, (to_drive ? "(CTW) " : "(STW) ") + hex);
      ASSERT_EQ(frame_line, drive_line) << fc.info << " / " << reading.text;
      ++compared;
    }
  }
  // And over Modbus: a read of the status word (register 50200) names its bits as the FC reply.
  const Message req = decode(protocols::modbus_rtu, with_crc({0x01, 0x03, 0xC4, 0x17, 0x00, 0x01}),
                             Direction::request);
  const Message rsp = decode(protocols::modbus_rtu, with_crc({0x01, 0x03, 0x02, 0x0E, 0x07}),
                             Direction::response, req.bytes);
  const Message fc_rsp = decode(protocols::danfoss_fc,
                                with_bcc({0x02, 0x06, 0x01, 0x0E, 0x07, 0x20, 0x00}),
                                Direction::response);
  EXPECT_EQ(bracket(read_for_drive(vlt, rsp, req.bytes).text, "(STW) 0x0E07"),
            bracket(fc_rsp.info, "STW 0x0E07"));
  EXPECT_EQ(compared, 2 * 65536);
}

TEST(DriveReading, DanfossFcProcessData) {
  const DriveProfile vlt = builtin_profile("vlt-aqua.toml");
  // CTW 0x047C (start), REF 0x2000 = 50 % (0x4000 = 100 %).
  const Message req =
      decode(protocols::danfoss_fc, with_bcc({0x02, 0x06, 0x01, 0x04, 0x7C, 0x20, 0x00}),
             Direction::request);
  ASSERT_EQ(req.checksum.verdict, ChecksumVerdict::good);
  ASSERT_EQ(req.address, 1);
  const DriveReading q = read_for_drive(vlt, req, {});
  EXPECT_EQ(
      q.text,
      "drive 1 (Danfoss VLT AQUA): control word (CTW) 0x047C [ramp, no coast, ramp, use ramp, "
      "start, data valid]; bus reference (REF) 50.000 %");
  EXPECT_EQ(q.observed.run_command, true);
  EXPECT_EQ(q.observed.reverse_command, false);
  EXPECT_FALSE(q.observed.reset_command);
  ASSERT_TRUE(q.observed.setpoint_command);
  EXPECT_DOUBLE_EQ(q.observed.setpoint_command->value, 50.0);
  EXPECT_EQ(q.observed.setpoint_command->text(), "50.000 %");

  // STW 0x0E07 (bit 11 running), MAV 0x2000 = 50 %.
  const Message rsp =
      decode(protocols::danfoss_fc, with_bcc({0x02, 0x06, 0x01, 0x0E, 0x07, 0x20, 0x00}),
             Direction::response, req.bytes);
  ASSERT_EQ(rsp.checksum.verdict, ChecksumVerdict::good);
  const DriveReading a = read_for_drive(vlt, rsp, req.bytes);
  EXPECT_EQ(a.observed.running, true);
  EXPECT_EQ(a.observed.fault_active, false);
  EXPECT_EQ(a.observed.warning, false);
  ASSERT_TRUE(a.observed.output_frequency);
  EXPECT_DOUBLE_EQ(a.observed.output_frequency->value, 50.0);
  EXPECT_EQ(a.observed.output_frequency->text(), "50.000 %");
  EXPECT_FALSE(a.observed.run_command);

  // Reverse with a negative reference: 0xE000 = -8192 = -50 %; reset bit 7 set.
  const DriveReading rev = read_for_drive(
      vlt,
      decode(protocols::danfoss_fc, with_bcc({0x02, 0x06, 0x01, 0x84, 0xFC, 0xE0, 0x00}),
             Direction::request),
      {});
  EXPECT_EQ(rev.observed.run_command, true);
  EXPECT_EQ(rev.observed.reverse_command, true);
  EXPECT_TRUE(rev.observed.reset_command);
  ASSERT_TRUE(rev.observed.setpoint_command);
  EXPECT_EQ(rev.observed.setpoint_command->text(), "-50.000 %");

  // STW with trip (bit 3) and warning (bit 7).
  const DriveReading trip = read_for_drive(
      vlt,
      decode(protocols::danfoss_fc, with_bcc({0x02, 0x06, 0x01, 0x00, 0x8B, 0x00, 0x00}),
             Direction::response),
      req.bytes);
  EXPECT_EQ(trip.observed.fault_active, true);
  EXPECT_EQ(trip.observed.warning, true);
  EXPECT_EQ(trip.observed.running, false);
}

TEST(DriveReading, DanfossFcParameterBlock) {
  const DriveProfile vlt = builtin_profile("vlt-aqua.toml");
  // The helper's BCC matches docs/protocols.md §4's verified AK 7 telegram.
  const std::vector<std::uint8_t> ak7 = {0x02, 0x0E, 0x01, 0x71, 0x9E, 0,    0,    0,
                                         0,    0,    0x02, 0x06, 0x07, 0x00, 0x00, 0xE1};
  ASSERT_EQ(with_bcc({ak7.begin(), ak7.end() - 1}), ak7);
  const Message err = decode(protocols::danfoss_fc, ak7, Direction::response);
  ASSERT_EQ(err.checksum.verdict, ChecksumVerdict::good);
  // (the answer to docs/protocols.md §4's write of 4-14 = 1000, PKE E19E)
  const std::vector<std::uint8_t> write_4_14 = {0x02, 0x0E, 0x81, 0xE1, 0x9E, 0,    0,    0,
                                                0,    0x03, 0xE8, 0x04, 0x7C, 0x20, 0x00, 0x41};
  const DriveReading e = read_for_drive(vlt, err, write_4_14);
  EXPECT_EQ(e.text.find("drive 1 (Danfoss VLT AQUA): cannot execute on 4-14 motor speed high "
                        "limit [Hz]: error 2 (data value exceeds the parameter's limits); status "
                        "word (STW) 0x0607 ["),
            0u)
      << e.text;
  EXPECT_EQ(e.observed.running, false);  // STW 0x0607: bit 11 clear
  // The same reply with no request seen: shown, marked, and it observes nothing.
  const DriveReading unseen = read_for_drive(vlt, err, {});
  EXPECT_EQ(unseen.text.find("drive 1 (Danfoss VLT AQUA): no request seen, not used: cannot "
                             "execute on 4-14 motor speed high limit [Hz]"),
            0u)
      << unseen.text;
  EXPECT_FALSE(unseen.observed.running.has_value());

  // Read 4-14: PKE 0x119E (AK 1, PNU 414).
  const Message read =
      decode(protocols::danfoss_fc,
             with_bcc({0x02, 0x0E, 0x01, 0x11, 0x9E, 0, 0, 0, 0, 0, 0, 0x04, 0x7C, 0x20, 0x00}),
             Direction::request);
  const DriveReading r = read_for_drive(vlt, read, {});
  EXPECT_EQ(r.text.find("drive 1 (Danfoss VLT AQUA): read 4-14 motor speed high limit [Hz]; "
                        "control word (CTW) 0x047C"),
            0u)
      << r.text;

  // Its value, AK 1: 03E8 = 1000 = 100.0 Hz at 0.1 Hz (002 §7.5.1).
  const DriveReading v = read_for_drive(vlt,
                                        decode(protocols::danfoss_fc,
                                               with_bcc({0x02, 0x0E, 0x01, 0x11, 0x9E, 0, 0, 0, 0,
                                                         0x03, 0xE8, 0x06, 0x07, 0x00, 0x00}),
                                               Direction::response),
                                        read.bytes);
  EXPECT_EQ(v.text.find("drive 1 (Danfoss VLT AQUA): 4-14 motor speed high limit [Hz] 100.0 Hz; "),
            0u)
      << v.text;

  // A reply naming another parameter (PKE 119C: 4-12) does not answer the read of 4-14: shown,
  // and its tripped status word (0x060A) observes nothing. Read with a request of 4-12, it stands.
  const Message other = decode(protocols::danfoss_fc,
                               with_bcc({0x02, 0x0E, 0x01, 0x11, 0x9C, 0, 0, 0, 0, 0x03, 0xE8, 0x06,
                                         0x0A, 0x00, 0x00}),
                               Direction::response);
  const DriveReading o = read_for_drive(vlt, other, read.bytes);
  EXPECT_EQ(o.text.find("drive 1 (Danfoss VLT AQUA): not the answer to its request (parameter "
                        "4-14 asked for), not used: "),
            0u)
      << o.text;
  EXPECT_FALSE(o.observed.running.has_value());
  EXPECT_FALSE(o.observed.fault_active.has_value());
  const Message read_4_12 =
      decode(protocols::danfoss_fc,
             with_bcc({0x02, 0x0E, 0x01, 0x11, 0x9C, 0, 0, 0, 0, 0, 0, 0x04, 0x7C, 0x20, 0x00}),
             Direction::request);
  EXPECT_EQ(read_for_drive(vlt, other, read_4_12.bytes).observed.fault_active, true);

  // docs/protocols.md §4: write 4-14 = 1000 to RAM+EEPROM, address 1 in the 1..126 format.
  const Message write =
      decode(protocols::danfoss_fc,
             {0x02, 0x0E, 0x81, 0xE1, 0x9E, 0, 0, 0, 0, 0x03, 0xE8, 0x04, 0x7C, 0x20, 0x00, 0x41},
             Direction::request);
  ASSERT_EQ(write.checksum.verdict, ChecksumVerdict::good);
  const DriveReading w = read_for_drive(vlt, write, {});
  EXPECT_EQ(w.text.find("drive 1 (Danfoss VLT AQUA): set 4-14 motor speed high limit [Hz] = 100.0 "
                        "Hz (RAM and EEPROM); control word (CTW) 0x047C"),
            0u)
      << w.text;

  // A parameter the profile does not name is labelled by the rule: PNU 1614 = 16-14.
  const DriveReading un =
      read_for_drive(vlt,
                     decode(protocols::danfoss_fc,
                            {0x02, 0x0E, 0x01, 0x16, 0x4E, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x55},
                            Direction::request),
                     {});
  EXPECT_EQ(un.text.find("drive 1 (Danfoss VLT AQUA): read parameter 16-14; "), 0u) << un.text;
}

TEST(DriveReading, VltAquaModbusMapping) {
  const DriveProfile vlt = builtin_profile("vlt-aqua.toml");
  // FC 06 to CTW (register 50000, wire 49999 = 0xC34F): 0x04BC = reset (bit 7), no start (bit 6).
  const Message m = rtu({0x01, 0x06, 0xC3, 0x4F, 0x04, 0xBC}, Direction::request);
  const DriveReading r = read_for_drive(vlt, m, {});
  EXPECT_EQ(r.text,
            "drive 1 (Danfoss VLT AQUA): set control word (CTW) 0x04BC [ramp, no coast, ramp, use "
            "ramp, ramp stop, reset, data valid]");
  EXPECT_TRUE(r.observed.reset_command);
  EXPECT_EQ(r.observed.run_command, false);

  // 002 §7.10.6: set 1-05 = 738 (7.38 A), FC 10 at 0x0419, two registers 0000 02E2.
  const DriveReading p = read_for_drive(
      vlt,
      rtu({0x01, 0x10, 0x04, 0x19, 0x00, 0x02, 0x04, 0x00, 0x00, 0x02, 0xE2}, Direction::request),
      {});
  EXPECT_EQ(p.text,
            "drive 1 (Danfoss VLT AQUA): set 1-05 parameter 1-05 (a current per the §7.10.6 "
            "example) 7.38 A");

  // Reading a parameter the profile does not name: labelled by the rule.
  EXPECT_EQ(
      read_for_drive(vlt, rtu({0x01, 0x03, 0x3E, 0xF7, 0x00, 0x01}, Direction::request), {}).text,
      "drive 1 (Danfoss VLT AQUA): read parameter 16-12");

  // STW and MAV read over Modbus (50199 = 0xC417 .. 50209).
  const Message q = rtu({0x01, 0x03, 0xC4, 0x17, 0x00, 0x01}, Direction::request);
  const DriveReading s =
      read_for_drive(vlt, rtu({0x01, 0x03, 0x02, 0x08, 0x48}, Direction::response), q.bytes);
  EXPECT_EQ(s.observed.running, true);  // 0x0848: bits 3 trip, 6 trip lock, 11 running
  EXPECT_EQ(s.observed.fault_active, true);
  EXPECT_EQ(s.observed.warning, false);

  // Vendor exception code 0x42 (§7.8.11, decimal 66), allowed as drivetap allows the codes of the
  // profiles it loads (src/app/common.cpp).
  allow_vendor_exception_code(0x42);
  EXPECT_EQ(read_for_drive(vlt, rtu({0x01, 0x86, 0x42}, Direction::response), m.bytes).text,
            "drive 1 (Danfoss VLT AQUA): error 0x42: illegal data length or value");
  // The observation alone (read --stats) has that text too, and no other.
  EXPECT_EQ(read_for_drive(vlt, rtu({0x01, 0x86, 0x42}, Direction::response), m.bytes, false).text,
            "drive 1 (Danfoss VLT AQUA): error 0x42: illegal data length or value");
  EXPECT_EQ(read_for_drive(vlt, q, {}, false).text, "");
  EXPECT_NE(read_for_drive(vlt, q, {}).text, "");
}

TEST(DriveReading, ErgCoilsAndState) {
  const DriveProfile erg = builtin_profile("erg.toml");
  struct CoilWrite {
    const char* what;
    std::uint8_t coil, on;
    const char* text;  // nullptr: not checked
    std::optional<bool> run_command;
    bool reset_command;
  };
  const CoilWrite writes[] = {
      {"fault reset", 0x09, 0xFF, "drive 1 (ERMAN ER-G): set fault reset command ON", std::nullopt,
       true},
      {"start", 0x00, 0xFF, nullptr, true, false},
      {"stop", 0x01, 0xFF, nullptr, false, false},
      // A start coil written OFF commands nothing.
      {"start written OFF", 0x00, 0x00, nullptr, std::nullopt, false},
  };
  for (const CoilWrite& w : writes) {
    SCOPED_TRACE(w.what);
    const DriveReading r =
        read_for_drive(erg, rtu({0x01, 0x05, 0x00, w.coil, w.on, 0x00}, Direction::request), {});
    if (w.text) {
      EXPECT_EQ(r.text, w.text);
    }
    EXPECT_EQ(r.observed.run_command, w.run_command);
    EXPECT_EQ(r.observed.reset_command, w.reset_command);
  }

  // FC 04 0x0400: state 2 = running, accelerating; output frequency 0x0001 at 0.1 Hz.
  const Message q = rtu({0x01, 0x04, 0x04, 0x00, 0x00, 0x01}, Direction::request);
  const DriveReading st =
      read_for_drive(erg, rtu({0x01, 0x04, 0x02, 0x00, 0x02}, Direction::response), q.bytes);
  EXPECT_EQ(st.text,
            "drive 1 (ERMAN ER-G): drive state (bits 0..15, assumed) 2 (running, "
            "accelerating)");
  EXPECT_EQ(st.observed.running, true);
  const Message fq = rtu({0x01, 0x04, 0x00, 0x01, 0x00, 0x01}, Direction::request);
  const DriveReading f =
      read_for_drive(erg, rtu({0x01, 0x04, 0x02, 0x01, 0xF4}, Direction::response), fq.bytes);
  ASSERT_TRUE(f.observed.output_frequency);
  EXPECT_EQ(f.observed.output_frequency->text(), "50.0 Hz");
}

TEST(DriveReading, E5AsciiReply) {
  const DriveProfile e5 = builtin_profile("e5-8200.toml");
  // docs/protocols.md §3: ":010325230001B3\r\n" reads 0x2523.
  const std::vector<std::uint8_t> req_bytes = ascii_frame({0x01, 0x03, 0x25, 0x23, 0x00, 0x01});
  ASSERT_EQ(std::string(req_bytes.begin(), req_bytes.end()), ":010325230001B3\r\n");
  const Message req = decode(protocols::modbus_ascii, req_bytes, Direction::request);
  EXPECT_EQ(read_for_drive(e5, req, {}).text, "drive 1 (E5-8200): read frequency setpoint");
  const Message rsp = decode(protocols::modbus_ascii, ascii_frame({0x01, 0x03, 0x02, 0x17, 0x70}),
                             Direction::response);
  ASSERT_EQ(rsp.checksum.verdict, ChecksumVerdict::good);
  EXPECT_EQ(read_for_drive(e5, rsp, req.bytes).text,
            "drive 1 (E5-8200): frequency setpoint 60.00 Hz");
  // Control word with the reset bit (3) and reverse (bit 1), via FC 06 on 0x2501.
  const DriveReading c =
      read_for_drive(e5,
                     decode(protocols::modbus_ascii,
                            ascii_frame({0x01, 0x06, 0x25, 0x01, 0x00, 0x0B}), Direction::request),
                     {});
  EXPECT_EQ(c.observed.run_command, true);
  EXPECT_EQ(c.observed.reverse_command, true);
  EXPECT_TRUE(c.observed.reset_command);
  // Vendor exception 0x52 (the manual's RTU example 02 83 52).
  // (drivetap allows the vendor codes of the profiles it loads, src/app/common.cpp: an exception
  // with a code no profile lists is implausible, and its telegram says nothing of the drive)
  allow_vendor_exception_code(0x52);
  const Message read_request = rtu({0x02, 0x03, 0x20, 0x00, 0x00, 0x01}, Direction::request);
  EXPECT_EQ(
      read_for_drive(e5, rtu({0x02, 0x83, 0x52}, Direction::response), read_request.bytes).text,
      "drive 2 (E5-8200): error 0x52: address error");
}

TEST(DriveReading, E5ParametersFollowTheGgppRule) {
  // docs/protocols.md §2 and docs/reference.md "Drive profiles": E5-8200 parameters map to register
  // GGPP (08-03 -> 0x0803), the rule profile.hpp names for the E5-8200.
  const DriveProfile e5 = builtin_profile("e5-8200.toml");
  EXPECT_EQ(e5.parameter_rule, parameter_numbering_named("ggpp"));
  EXPECT_EQ(
      read_for_drive(e5, rtu({0x01, 0x03, 0x08, 0x03, 0x00, 0x01}, Direction::request), {}).text,
      "drive 1 (E5-8200): read parameter 08-03");
}

TEST(DriveReading, EasydriveRunAndStatus) {
  const DriveProfile eds = builtin_profile("eds1000.toml");
  // Run control (0C), index 0002 = run with frequency, data 0FA0 = 4000 = 40.00 Hz.
  const Message req = decode(protocols::easydrive, eds_frame("010C00020FA0"), Direction::request);
  ASSERT_EQ(req.bytes.size(), 18u);
  ASSERT_EQ(req.checksum.verdict, ChecksumVerdict::good);
  ASSERT_EQ(req.address, 1);
  const DriveReading r = read_for_drive(eds, req, {});
  EXPECT_EQ(r.text, "drive 1 (Easydrive EDS1000): run; setpoint 40.00 Hz");
  EXPECT_EQ(r.observed.run_command, true);
  EXPECT_FALSE(r.observed.reverse_command);
  ASSERT_TRUE(r.observed.setpoint_command);
  EXPECT_DOUBLE_EQ(r.observed.setpoint_command->value, 40.0);
  EXPECT_EQ(r.observed.setpoint_command->text(), "40.00 Hz");

  // Read the status word (0B, index 000F); reply: OK, AUX fault 03, index 0F, data 0001 (running).
  const Message q = decode(protocols::easydrive, eds_frame("010B000F"), Direction::request);
  ASSERT_EQ(q.bytes.size(), 14u);
  EXPECT_EQ(read_for_drive(eds, q, {}).text, "drive 1 (Easydrive EDS1000): read status word");
  const Message a =
      decode(protocols::easydrive, eds_frame("0100030F0001"), Direction::response, q.bytes);
  ASSERT_EQ(a.checksum.verdict, ChecksumVerdict::good);
  const DriveReading s = read_for_drive(eds, a, q.bytes);
  EXPECT_EQ(s.observed.running, true);
  EXPECT_EQ(s.observed.reverse, false);
  EXPECT_EQ(s.observed.fault_code, 3u);
  EXPECT_NE(s.observed.fault.text().find("overcurrent at constant speed"), std::string::npos)
      << s.observed.fault.text();
  EXPECT_EQ(s.observed.fault.text(), "3 (overcurrent at constant speed)");
  EXPECT_EQ(s.text,
            "drive 1 (Easydrive EDS1000): status word 0x0001 [running, voltage normal, forward]; "
            "fault 3 (overcurrent at constant speed)");

  // A reply echoing another index (0E) than its request's (0F) does not answer it: shown, and it
  // observes nothing, its fault code neither.
  const Message other =
      decode(protocols::easydrive, eds_frame("0100030E0001"), Direction::response, q.bytes);
  ASSERT_EQ(other.checksum.verdict, ChecksumVerdict::good);
  const DriveReading o = read_for_drive(eds, other, q.bytes);
  EXPECT_EQ(o.text.find("drive 1 (Easydrive EDS1000): not the answer to its request (index 000F "
                        "asked for), not used: "),
            0u)
      << o.text;
  EXPECT_FALSE(o.observed.running.has_value());
  EXPECT_FALSE(o.observed.fault_code.has_value());

  // The fault code travels in hex: AUX "10" is fault 16.
  const DriveReading hex = read_for_drive(
      eds, decode(protocols::easydrive, eds_frame("0100100F0005"), Direction::response, q.bytes),
      q.bytes);
  EXPECT_EQ(hex.observed.fault_code, 16u);
  EXPECT_EQ(hex.observed.fault.text(), "16 (RS485 communication fault)");
  EXPECT_EQ(hex.observed.reverse, true);  // status bit 2

  // Stop, fault reset, run reverse; write F0.08 = 03E8 (100.0 s at 0.1 s); read F2.11, which
  // the profile does not name: labelled by the rule.
  struct Request {
    const char* body;
    const char* text;  // nullptr: not checked
    std::optional<bool> run_command, reverse_command;
    bool reset_command;
  };
  const Request requests[] = {
      {"010C0007", nullptr, false, std::nullopt, false},
      {"010C000C", nullptr, std::nullopt, std::nullopt, true},
      {"010C0004", nullptr, true, true, false},
      {"010E000803E8", "drive 1 (Easydrive EDS1000): set F0.08 acceleration time 1 = 100.0 s",
       std::nullopt, std::nullopt, false},
      {"010D020B", "drive 1 (Easydrive EDS1000): read function code F2.11", std::nullopt,
       std::nullopt, false},
  };
  for (const Request& q : requests) {
    SCOPED_TRACE(q.body);
    const DriveReading r = read_for_drive(
        eds, decode(protocols::easydrive, eds_frame(q.body), Direction::request), {});
    if (q.text) {
      EXPECT_EQ(r.text, q.text);
    }
    EXPECT_EQ(r.observed.run_command, q.run_command);
    EXPECT_EQ(r.observed.reverse_command, q.reverse_command);
    EXPECT_EQ(r.observed.reset_command, q.reset_command);
  }
}

// ---------------------------------------------------------------------------------------------
// Drive-state timeline.

namespace {

struct TimelineRig {
  DriveProfile profile;
  DriveTimeline timeline;
  std::uint64_t frame = 0;

  explicit TimelineRig(std::string_view file) : profile(builtin_profile(file)) {}

  std::vector<BusEvent> feed(const DriveObservation& o, int address = 2) {
    Message m;
    m.protocol = protocols::modbus_rtu;
    m.address = address;
    m.frame.number = ++frame;
    m.frame.channel = 0;
    m.frame.events.push_back({static_cast<TimeNs>(frame) * kNsPerMs, 0x02, 0, 0, 0});
    return timeline.observe(0, m, profile, o);
  }
};

Quantity hz(double v) {
  return {v, fmt::format("{:.2f} Hz", v)};
}

}  // namespace

TEST(DriveTimeline, FirstStatusAndRepeats) {
  TimelineRig rig("e9.toml");
  DriveObservation stopped;
  stopped.running = false;
  auto ev = rig.feed(stopped);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].kind, EventKind::running);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): stopped");
  EXPECT_EQ(ev[0].from, "");
  EXPECT_EQ(ev[0].to, "stopped");
  EXPECT_EQ(ev[0].address, 2);
  EXPECT_EQ(ev[0].profile, "e9");
  EXPECT_EQ(ev[0].frame, 1u);
  EXPECT_EQ(ev[0].time, 1 * kNsPerMs);
  EXPECT_EQ(ev[0].protocol, protocols::modbus_rtu);

  EXPECT_TRUE(rig.feed(stopped).empty());
  EXPECT_TRUE(rig.feed(DriveObservation{}).empty());

  DriveObservation running;
  running.running = true;
  ev = rig.feed(running);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): running");
  EXPECT_EQ(ev[0].from, "stopped");
  EXPECT_EQ(ev[0].to, "running");
  EXPECT_EQ(ev[0].frame, 4u);
  EXPECT_TRUE(rig.feed(running).empty());

  // Another station on the same link has its own state.
  ev = rig.feed(running, 3);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].address, 3);
  EXPECT_EQ(ev[0].detail, "drive 3 (ERMAN E-9P/9G): running");
  EXPECT_EQ(ev[0].from, "");
  EXPECT_EQ(rig.timeline.drives().size(), 2u);
}

TEST(DriveTimeline, RunCommandsOnce) {
  TimelineRig rig("e9.toml");
  DriveObservation start;
  start.run_command = true;
  auto ev = rig.feed(start);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].kind, EventKind::command);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): start commanded");
  EXPECT_EQ(ev[0].from, "");
  EXPECT_EQ(ev[0].to, "start");
  EXPECT_TRUE(rig.feed(start).empty());
  DriveObservation stop;
  stop.run_command = false;
  ev = rig.feed(stop);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): stop commanded");
  EXPECT_EQ(ev[0].from, "start");
  EXPECT_EQ(ev[0].to, "stop");
  EXPECT_EQ(ev[0].frame, 3u);
}

TEST(DriveTimeline, ResetOnRisingEdgesOnly) {
  TimelineRig rig("vlt-aqua.toml");
  DriveObservation idle;  // a command word without run or reset bit
  idle.run_command = false;
  ASSERT_EQ(rig.feed(idle).size(), 1u);  // "stop commanded"
  DriveObservation reset = idle;
  reset.reset_command = true;
  auto ev = rig.feed(reset);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].kind, EventKind::command);
  EXPECT_EQ(ev[0].detail, "drive 2 (Danfoss VLT AQUA): fault reset commanded");
  EXPECT_EQ(ev[0].to, "reset");
  EXPECT_EQ(ev[0].profile, "vlt-aqua");
  EXPECT_TRUE(rig.feed(reset).empty());
  // A reply (no command in it) does not end the reset level.
  DriveObservation telemetry;
  telemetry.output_frequency = hz(12.5);
  EXPECT_TRUE(rig.feed(telemetry).empty());
  EXPECT_TRUE(rig.feed(reset).empty());
  // The command word drops the bit, then sets it again: a second event.
  EXPECT_TRUE(rig.feed(idle).empty());
  ev = rig.feed(reset);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].detail, "drive 2 (Danfoss VLT AQUA): fault reset commanded");
  EXPECT_EQ(ev[0].frame, 7u);
}

TEST(DriveTimeline, FaultAppearsAndClears) {
  TimelineRig rig("e9.toml");
  auto fault = [](std::uint32_t code, std::string text) {
    DriveObservation o;
    o.fault_code = code;
    o.fault.value = code;
    o.fault.written = std::move(text);
    return o;
  };
  EXPECT_TRUE(rig.feed(fault(0, "0 (no fault)")).empty());
  auto ev = rig.feed(fault(4, "4 (output overcurrent)"));
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].kind, EventKind::fault);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): fault 4 (output overcurrent) appeared");
  EXPECT_EQ(ev[0].from, "");
  EXPECT_EQ(ev[0].to, "4 (output overcurrent)");
  EXPECT_EQ(ev[0].frame, 2u);
  EXPECT_TRUE(rig.feed(fault(4, "4 (output overcurrent)")).empty());
  ev = rig.feed(fault(0, "0 (no fault)"));
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): fault 4 (output overcurrent) cleared");
  EXPECT_EQ(ev[0].from, "4 (output overcurrent)");
  EXPECT_EQ(ev[0].to, "");
  // One fault replaced by another.
  rig.feed(fault(4, "4 (output overcurrent)"));
  ev = rig.feed(fault(8, "8 (drive overheat)"));
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].detail,
            "drive 2 (ERMAN E-9P/9G): fault 4 (output overcurrent) -> 8 (drive "
            "overheat)");
  EXPECT_EQ(ev[0].from, "4 (output overcurrent)");
  EXPECT_EQ(ev[0].to, "8 (drive overheat)");
}

TEST(DriveTimeline, SetpointCommandThenReadback) {
  TimelineRig rig("e9.toml");
  DriveObservation cmd;
  cmd.setpoint_command = hz(40);
  auto ev = rig.feed(cmd);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].kind, EventKind::setpoint);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): setpoint 40.00 Hz commanded");
  EXPECT_EQ(ev[0].from, "");
  EXPECT_EQ(ev[0].to, "40.00 Hz");
  DriveObservation readback;
  readback.setpoint = hz(40);
  EXPECT_TRUE(rig.feed(readback).empty());
  readback.setpoint = hz(50);
  ev = rig.feed(readback);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].kind, EventKind::setpoint);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): setpoint 40.00 Hz -> 50.00 Hz");
  EXPECT_EQ(ev[0].from, "40.00 Hz");
  EXPECT_EQ(ev[0].to, "50.00 Hz");
  EXPECT_EQ(ev[0].frame, 3u);
  cmd.setpoint_command = hz(45);
  ev = rig.feed(cmd);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): setpoint 50.00 Hz -> 45.00 Hz commanded");
}

TEST(DriveTimeline, ReverseAndDirection) {
  TimelineRig rig("e9.toml");
  DriveObservation fwd;
  fwd.reverse_command = false;
  EXPECT_TRUE(rig.feed(fwd).empty());  // forward is every drive's default
  DriveObservation rev;
  rev.reverse_command = true;
  auto ev = rig.feed(rev);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].kind, EventKind::command);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): reverse commanded");
  EXPECT_EQ(ev[0].from, "forward");
  EXPECT_EQ(ev[0].to, "reverse");
  EXPECT_TRUE(rig.feed(rev).empty());
  ev = rig.feed(fwd);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): forward commanded");
  EXPECT_EQ(ev[0].from, "reverse");

  // Reported direction: the first report is silent, a change is an event.
  DriveObservation turning;
  turning.reverse = false;
  EXPECT_TRUE(rig.feed(turning).empty());
  turning.reverse = true;
  ev = rig.feed(turning);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].kind, EventKind::direction);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): direction forward -> reverse");
  EXPECT_EQ(ev[0].from, "forward");
  EXPECT_EQ(ev[0].to, "reverse");
}

TEST(DriveTimeline, FromRealFramesAndSummary) {
  const DriveProfile e9 = builtin_profile("e9.toml");
  DriveTimeline timeline;
  const Message req = rtu({0x02, 0x03, 0x00, 0x00, 0x00, 0x05}, Direction::request, {}, 1);
  const Message rsp =
      rtu({0x02, 0x03, 0x0A, 0x00, 0x0B, 0x13, 0x88, 0x13, 0x7D, 0x01, 0x7C, 0x00, 0x64},
          Direction::response, {}, 2);
  EXPECT_TRUE(timeline.observe(0, req, e9, read_for_drive(e9, req, {}).observed).empty());
  const auto ev = timeline.observe(0, rsp, e9, read_for_drive(e9, rsp, req.bytes).observed);
  ASSERT_EQ(ev.size(), 3u);
  EXPECT_EQ(ev[0].detail, "drive 2 (ERMAN E-9P/9G): running");
  EXPECT_EQ(ev[1].detail, "drive 2 (ERMAN E-9P/9G): setpoint 50.00 Hz");
  EXPECT_EQ(ev[2].detail, "drive 2 (ERMAN E-9P/9G): status word shows a fault");
  for (const BusEvent& e : ev) {
    EXPECT_EQ(e.frame, 2u);
    EXPECT_EQ(e.address, 2);
    EXPECT_EQ(e.profile, "e9");
  }
  const DriveState& s = timeline.drives().at({0, 2});
  EXPECT_EQ(s.summary(),
            "running, forward, setpoint 50.00 Hz, output frequency 49.89 Hz, current 10.0 A, "
            "voltage 380 V, fault");
  EXPECT_EQ(s.events, 3u);
}

// Without a sink that shows events (`read --stats`), the timeline keeps each drive's state and
// counts its changes but makes no event: the same state and count as with events.
TEST(DriveTimeline, UndescribedChangesKeepTheStateAndTheCount) {
  const DriveProfile e9 = builtin_profile("e9.toml");
  const Message req = rtu({0x02, 0x03, 0x00, 0x00, 0x00, 0x05}, Direction::request, {}, 1);
  const std::vector<std::vector<std::uint8_t>> replies = {
      {0x02, 0x03, 0x0A, 0x00, 0x0B, 0x13, 0x88, 0x13, 0x7D, 0x01, 0x7C, 0x00, 0x64},
      {0x02, 0x03, 0x0A, 0x00, 0x0A, 0x0F, 0xA0, 0x0F, 0x9B, 0x01, 0x7C, 0x00, 0x64},
      {0x02, 0x03, 0x0A, 0x00, 0x00, 0x0F, 0xA0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}};
  DriveTimeline described, counted;
  std::size_t events = 0;
  std::uint64_t number = 1;
  for (const auto& reply : replies) {
    const Message rsp = rtu(reply, Direction::response, {}, ++number);
    const DriveObservation o = read_for_drive(e9, rsp, req.bytes).observed;
    events += described.observe(0, head_of(rsp), e9, o, true).size();
    EXPECT_TRUE(counted.observe(0, head_of(rsp), e9, o, false).empty());
  }
  const DriveState& with = described.drives().at({0, 2});
  const DriveState& without = counted.drives().at({0, 2});
  EXPECT_GE(events, 5u);
  EXPECT_EQ(with.events, events);
  EXPECT_EQ(without.events, with.events);
  EXPECT_EQ(without.summary(), with.summary());
}

// ---------------------------------------------------------------------------------------------
// Drive binding by evidence, with every built-in profile as a candidate.

namespace {

struct BinderRig {
  std::vector<const DriveProfile*> candidates = builtin_candidates();
  DriveBinder binder{candidates};
  std::vector<BusEvent> events;
  std::uint64_t number = 0;

  // (learn_bound(): the binding after it checked against bound().) A reply with the request it
  // answers, as the pipeline hands it over.
  void learn(const Message& m, std::span<const std::uint8_t> request = {}) {
    std::optional<BusEvent> e;
    const DriveProfile* now = binder.learn_bound(0, head_of(m), e, request);
    EXPECT_EQ(now, binder.bound(0, m.address)) << "frame " << m.frame.number;
    if (e) events.push_back(*e);
  }
  // A request and its reply.
  void exchange(Protocol p, const std::vector<std::uint8_t>& req,
                const std::vector<std::uint8_t>& rsp) {
    const Message q = decode(p, req, Direction::request, {}, ++number);
    learn(q);
    learn(decode(p, rsp, Direction::response, q.bytes, ++number), q.bytes);
  }
  // One E-9 status poll of station 2 and its reply: status 0x000A (forward, fault) sets only
  // bits the manual describes, and only the E-9 names the register so.
  void poll_e9() {
    exchange(
        protocols::modbus_rtu, with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x05}),
        with_crc({0x02, 0x03, 0x0A, 0x00, 0x0A, 0x13, 0x88, 0x13, 0x7D, 0x01, 0x7C, 0x00, 0x64}));
  }
  [[nodiscard]] std::string bound_id(int address) const {
    const DriveProfile* p = binder.bound(0, address);
    return p ? p->id : "generic";
  }
  [[nodiscard]] const DriveBinder::Tally& tally(int address, std::string_view id) const {
    const DriveBinder::Station& st = binder.stations().at({0, address});
    for (std::size_t c = 0; c < candidates.size(); ++c)
      if (candidates[c]->id == id) return st.tally[c];
    throw std::runtime_error("no candidate " + std::string(id));
  }
};

}  // namespace

TEST(DriveBinder, E9PollingBindsE9OnTwoTransactionsAndIsHighFromEight) {
  BinderRig rig;
  // One transaction is never enough.
  rig.poll_e9();
  EXPECT_EQ(rig.bound_id(2), "generic");
  EXPECT_TRUE(rig.events.empty());
  EXPECT_EQ(rig.tally(2, "e9").alone, 1u);
  rig.poll_e9();
  EXPECT_EQ(rig.bound_id(2), "e9");
  ASSERT_EQ(rig.events.size(), 1u);
  const BusEvent& e = rig.events[0];
  EXPECT_EQ(e.kind, EventKind::drive_bound);
  EXPECT_EQ(e.profile, "e9");
  EXPECT_EQ(e.to, "e9");
  EXPECT_EQ(e.from, "");
  EXPECT_EQ(e.address, 2);
  EXPECT_EQ(e.frame, 4u);  // the second reply
  EXPECT_EQ(e.protocol, protocols::modbus_rtu);
  EXPECT_EQ(e.detail,
            "drive 2 bound to ERMAN E-9P/9G (auto, confidence medium: ERMAN E-9P/9G: 2 "
            "transactions only it explains (a status word setting only bits the manual describes), 0 "
            "contradicting, over 2 paired transactions; next best " +
                rig.binder.evidence(rig.binder.stations().at({0, 2})).substr(
                    rig.binder.evidence(rig.binder.stations().at({0, 2})).find("next best ") +
                    10) +
                ")");
  EXPECT_EQ(e.confidence, "medium");
  for (int i = 0; i < 5; ++i) rig.poll_e9();
  EXPECT_EQ(rig.binder.stations().at({0, 2}).confidence, "medium");  // 7
  rig.poll_e9();
  EXPECT_EQ(rig.binder.stations().at({0, 2}).confidence, "high");  // 8
  EXPECT_EQ(rig.events.size(), 1u);
  EXPECT_EQ(rig.binder.stations().at({0, 2}).frames, 16u);
  EXPECT_EQ(rig.binder.stations().at({0, 2}).transactions, 8u);
}

TEST(DriveBinder, RequestsAndRepliesAloneProveNothing) {
  BinderRig rig;
  const auto poll = with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x05});
  const auto reply =
      with_crc({0x02, 0x03, 0x0A, 0x00, 0x0A, 0x13, 0x88, 0x13, 0x7D, 0x01, 0x7C, 0x00, 0x64});
  for (int i = 0; i < 20; ++i)
    rig.learn(decode(protocols::modbus_rtu, poll, Direction::request, {}, ++rig.number));
  // Replies read without the request they answer (the pairer had none).
  for (int i = 0; i < 20; ++i)
    rig.learn(decode(protocols::modbus_rtu, reply, Direction::response, poll, ++rig.number));
  EXPECT_EQ(rig.bound_id(2), "generic");
  EXPECT_TRUE(rig.events.empty());
  const DriveBinder::Station& st = rig.binder.stations().at({0, 2});
  EXPECT_EQ(st.transactions, 0u);
  EXPECT_EQ(rig.binder.evidence(st),
            "no reply paired with its request yet: requests and replies alone prove nothing");
  // FC requests alone, of the one family that speaks the protocol, prove nothing either.
  BinderRig fc;
  for (int i = 0; i < 10; ++i)
    fc.learn(decode(protocols::danfoss_fc, with_bcc({0x02, 0x06, 0x01, 0x04, 0x7C, 0x20, 0x00}),
                    Direction::request, {}, ++fc.number));
  EXPECT_EQ(fc.bound_id(1), "generic");
}

// Generic slaves answering on the E-9's own addresses: zeros prove nothing however often; a
// status word with bits the E-9 manual does not describe contradicts it, and a control word
// (ER-G's register 1) read back proves nothing, whatever it holds. Neither is ever bound.
TEST(DriveBinder, GenericSlaveOnAFamilysAddressesStaysGeneric) {
  BinderRig zeros;
  for (int i = 0; i < 300; ++i)
    zeros.exchange(protocols::modbus_rtu, with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x05}),
                   with_crc({0x02, 0x03, 0x0A, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(zeros.bound_id(2), "generic");
  EXPECT_TRUE(zeros.events.empty());
  EXPECT_EQ(zeros.tally(2, "e9").fits, 0u);
  EXPECT_EQ(zeros.tally(2, "e9").contradicts, 0u);
  EXPECT_EQ(zeros.binder.evidence(zeros.binder.stations().at({0, 2})).find(
                "no family profile fits its traffic (over 300 paired transactions; best "),
            0u)
      << zeros.binder.evidence(zeros.binder.stations().at({0, 2}));
  BinderRig counting;
  for (int i = 0; i < 20; ++i)
    counting.exchange(protocols::modbus_rtu, with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x05}),
                      with_crc({0x02, 0x03, 0x0A, 0x12, 0x34, 0, 1, 0, 2, 0, 3, 0, 4}));
  EXPECT_EQ(counting.bound_id(2), "generic");
  EXPECT_EQ(counting.tally(2, "e9").contradicts, 20u);
  EXPECT_TRUE(counting.tally(2, "e9").denied & reason_bit(BindingReason::undescribed_bits));
  EXPECT_EQ(counting.tally(2, "erg").fits, 0u);
}

TEST(DriveBinder, ErgStateWordBindsErg) {
  BinderRig rig;
  for (int i = 0; i < 2; ++i)  // state 1, "running, steady frequency", from the manual's table
    rig.exchange(protocols::modbus_rtu, with_crc({0x01, 0x04, 0x04, 0x00, 0x00, 0x02}),
                 with_crc({0x01, 0x04, 0x04, 0x00, 0x01, 0, 0}));
  EXPECT_EQ(rig.bound_id(1), "erg");
  ASSERT_EQ(rig.events.size(), 1u);
  EXPECT_EQ(rig.events[0].profile, "erg");
  EXPECT_NE(rig.events[0].detail.find("a value the manual's table lists"), std::string::npos);
  // A state outside the table contradicts it (with the overload bit beside it, 0x21 fits).
  BinderRig odd;
  odd.exchange(protocols::modbus_rtu, with_crc({0x01, 0x04, 0x04, 0x00, 0x00, 0x02}),
               with_crc({0x01, 0x04, 0x04, 0x00, 0x09, 0, 0}));
  odd.exchange(protocols::modbus_rtu, with_crc({0x01, 0x04, 0x04, 0x00, 0x00, 0x02}),
               with_crc({0x01, 0x04, 0x04, 0x00, 0x21, 0, 0}));
  EXPECT_EQ(odd.tally(1, "erg").contradicts, 1u);
  EXPECT_EQ(odd.tally(1, "erg").fits, 1u);
}

TEST(DriveBinder, E5MonitorReadBindsE5) {
  BinderRig rig;
  for (int i = 0; i < 2; ++i)
    rig.exchange(protocols::modbus_rtu, with_crc({0x01, 0x03, 0x25, 0x20, 0x00, 0x08}),
                 with_crc({0x01, 0x03, 0x10, 0x00, 0x03, 0, 0, 0, 0, 0x17, 0x70, 0x17, 0x70, 0x0E,
                           0xD8, 0x02, 0x1C, 0x00, 0x32}));
  EXPECT_EQ(rig.bound_id(1), "e5-8200");
  ASSERT_EQ(rig.events.size(), 1u);
  EXPECT_EQ(rig.events[0].profile, "e5-8200");

  // Modbus ASCII: the same.
  BinderRig ascii;
  for (int i = 0; i < 2; ++i)
    ascii.exchange(protocols::modbus_ascii, ascii_frame({0x01, 0x03, 0x25, 0x20, 0x00, 0x08}),
                   ascii_frame({0x01, 0x03, 0x10, 0x00, 0x03, 0, 0, 0, 0, 0x17, 0x70, 0x17, 0x70,
                                0x0E, 0xD8, 0x02, 0x1C, 0x00, 0x32}));
  EXPECT_EQ(ascii.bound_id(1), "e5-8200");
  EXPECT_EQ(ascii.events.size(), 1u);
}

TEST(DriveBinder, VendorExceptionCodeFitsTheFamilyThatListsIt) {
  // (drivetap allows the vendor codes of the profiles it loads, src/app/common.cpp.)
  allow_vendor_exception_code(0x52);
  BinderRig rig;
  for (int i = 0; i < 2; ++i)  // 0x52, E5-8200's own exception code
    rig.exchange(protocols::modbus_rtu, with_crc({0x01, 0x03, 0x25, 0x20, 0x00, 0x08}),
                 with_crc({0x01, 0x83, 0x52}));
  EXPECT_EQ(rig.bound_id(1), "e5-8200");
  EXPECT_NE(rig.events.at(0).detail.find("an exception code the manual lists"),
            std::string::npos);
  // A refused request contradicts nothing by its size: 40 registers is past E5-8200's 37.
  BinderRig big;
  big.exchange(protocols::modbus_rtu, with_crc({0x01, 0x03, 0x25, 0x20, 0x00, 0x28}),
               with_crc({0x01, 0x83, 0x02}));
  EXPECT_EQ(big.tally(1, "e5-8200").contradicts, 0u);
}

TEST(DriveBinder, VltAquaModbusAndFcBindVltAqua) {
  // Polling STW (register 50200, wire 50199 = 0xC417): a word of described bits.
  BinderRig rig;
  for (int i = 0; i < 2; ++i)
    rig.exchange(protocols::modbus_rtu, with_crc({0x01, 0x03, 0xC4, 0x17, 0x00, 0x01}),
                 with_crc({0x01, 0x03, 0x02, 0x0E, 0x07}));
  EXPECT_EQ(rig.bound_id(1), "vlt-aqua");
  ASSERT_EQ(rig.events.size(), 1u);
  EXPECT_EQ(rig.events[0].profile, "vlt-aqua");
  EXPECT_EQ(rig.events[0].frame, 4u);

  // FC: its own protocol, on each paired transaction.
  BinderRig fc;
  for (int i = 0; i < 2; ++i)
    fc.exchange(protocols::danfoss_fc, with_bcc({0x02, 0x06, 0x01, 0x04, 0x7C, 0x20, 0x00}),
                with_bcc({0x02, 0x06, 0x01, 0x0E, 0x07, 0x20, 0x00}));
  EXPECT_EQ(fc.bound_id(1), "vlt-aqua");
  ASSERT_EQ(fc.events.size(), 1u);
  EXPECT_EQ(fc.events[0].profile, "vlt-aqua");
  EXPECT_EQ(fc.events[0].protocol, protocols::danfoss_fc);
  EXPECT_EQ(fc.events[0].frame, 4u);
  EXPECT_NE(fc.events[0].detail.find("its own protocol"), std::string::npos);
}

TEST(DriveBinder, EasydriveBindsEds1000) {
  BinderRig rig;
  for (int i = 0; i < 2; ++i)
    rig.exchange(protocols::easydrive, eds_frame("010B000F"), eds_frame("0100000F0001"));
  EXPECT_EQ(rig.bound_id(1), "eds1000");
  ASSERT_EQ(rig.events.size(), 1u);
  EXPECT_EQ(rig.events[0].profile, "eds1000");
  EXPECT_EQ(rig.events[0].protocol, protocols::easydrive);
}

TEST(DriveBinder, BadChecksumsTeachNothing) {
  BinderRig rig;
  auto bad_crc = with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x05});
  bad_crc.back() ^= 0x01;
  auto bad_bcc = with_bcc({0x02, 0x06, 0x01, 0x04, 0x7C, 0x20, 0x00});
  bad_bcc.back() ^= 0x01;
  auto bad_sum = eds_frame("010B000F");
  bad_sum[bad_sum.size() - 2] = bad_sum[bad_sum.size() - 2] == '0' ? '1' : '0';
  for (int i = 0; i < 5; ++i) {
    const Message a = decode(protocols::modbus_rtu, bad_crc, Direction::request);
    const Message b = decode(protocols::danfoss_fc, bad_bcc, Direction::request);
    const Message c = decode(protocols::easydrive, bad_sum, Direction::request);
    ASSERT_EQ(a.checksum.verdict, ChecksumVerdict::bad);
    ASSERT_EQ(b.checksum.verdict, ChecksumVerdict::bad);
    ASSERT_EQ(c.checksum.verdict, ChecksumVerdict::bad);
    rig.learn(a);
    rig.learn(b);
    rig.learn(c);
  }
  EXPECT_EQ(rig.binder.bound(0, 2), nullptr);
  EXPECT_EQ(rig.binder.bound(0, 1), nullptr);
  EXPECT_TRUE(rig.events.empty());
  EXPECT_TRUE(rig.binder.stations().empty());
  // A damaged request between a good one and the reply: the reply answers the damaged one, and
  // the good request is put aside.
  BinderRig aside;
  const auto poll = with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x05});
  const auto reply =
      with_crc({0x02, 0x03, 0x0A, 0x00, 0x0A, 0x13, 0x88, 0x13, 0x7D, 0x01, 0x7C, 0x00, 0x64});
  for (int i = 0; i < 3; ++i) {
    aside.learn(decode(protocols::modbus_rtu, poll, Direction::request, {}, ++aside.number));
    aside.learn(decode(protocols::modbus_rtu, bad_crc, Direction::request, {}, ++aside.number));
    aside.learn(decode(protocols::modbus_rtu, reply, Direction::response, poll, ++aside.number),
                poll);
  }
  EXPECT_EQ(aside.binder.stations().at({0, 2}).transactions, 0u);
  EXPECT_EQ(aside.bound_id(2), "generic");
}

TEST(DriveBinder, DiagnosticsAloneStaysGeneric) {
  BinderRig rig;
  for (int i = 0; i < 4; ++i)
    rig.exchange(protocols::modbus_rtu, with_crc({0x02, 0x08, 0x00, 0x00, 0x12, 0x34}),
                 with_crc({0x02, 0x08, 0x00, 0x00, 0x12, 0x34}));
  EXPECT_EQ(rig.binder.bound(0, 2), nullptr);
  EXPECT_TRUE(rig.events.empty());
  const DriveBinder::Station& st = rig.binder.stations().at({0, 2});
  EXPECT_EQ(st.bound, -1);
  EXPECT_EQ(st.frames, 8u);
  EXPECT_EQ(st.transactions, 4u);
  EXPECT_EQ(rig.binder.evidence(st).find("no family profile fits its traffic (over 4 paired "
                                         "transactions; best "),
            0u)
      << rig.binder.evidence(st);
}

TEST(DriveBinder, BroadcastIsNeverBound) {
  BinderRig rig;
  for (int i = 0; i < 4; ++i) {
    rig.learn(rtu({0x00, 0x10, 0x00, 0x10, 0x00, 0x02, 0x04, 0x00, 0x01, 0x13, 0x88},
                  Direction::request));
    rig.learn(rtu({0x00, 0x03, 0x25, 0x20, 0x00, 0x08}, Direction::request));
  }
  EXPECT_EQ(rig.binder.bound(0, 0), nullptr);
  EXPECT_TRUE(rig.events.empty());
  EXPECT_TRUE(rig.binder.stations().empty());
}

// A request's addressing is judged once for every candidate and remembered, up to a bound past
// which the memo starts again: on a bus that never repeats a request (here distinct reads enough
// for the memo to restart twice a pass) and on one that does (the same again), every transaction
// is judged as on a binder that has seen nothing else. (The reads are spread over every station
// address, so that no station is decided: a decided station is no longer weighed.)
TEST(DriveBinder, RememberedJudgementsAreTheJudgementsAfresh) {
  constexpr int kStations = 247;
  auto station = [](int i) { return 1 + i % kStations; };
  auto exchange = [&](BinderRig& rig, int i) {
    const auto function = static_cast<std::uint8_t>(0x03 + i % 2);
    const auto count = static_cast<std::uint8_t>(1 + 3 * (i / 2 % 4));
    const int address = i / 8;
    const auto unit = static_cast<std::uint8_t>(station(i));
    std::vector<std::uint8_t> reply = {unit, function, static_cast<std::uint8_t>(2 * count)};
    for (int k = 0; k < count; ++k) {  // words that set one bit: they fit or contradict
      reply.push_back(0);
      reply.push_back(static_cast<std::uint8_t>(1u << (k % 8)));
    }
    rig.exchange(protocols::modbus_rtu,
                 with_crc({unit, function, static_cast<std::uint8_t>(address >> 8),
                           static_cast<std::uint8_t>(address), 0x00, count}),
                 with_crc(reply));
  };
  constexpr int kRequests = 3 * static_cast<int>(DriveBinder::kMaxRememberedRequests) - 100;
  std::map<int, std::vector<DriveBinder::Tally>> expected;
  for (int i = 0; i < kRequests; ++i) {
    BinderRig alone;
    exchange(alone, i);
    const auto& tally = alone.binder.stations().at({0, station(i)}).tally;
    auto& sum = expected[station(i)];
    sum.resize(tally.size());
    for (std::size_t c = 0; c < tally.size(); ++c) {
      sum[c].fits += tally[c].fits;
      sum[c].contradicts += tally[c].contradicts;
    }
  }
  bool any = false;
  for (const auto& [address, sum] : expected)
    for (const auto& t : sum) any = any || t.fits != 0 || t.contradicts != 0;
  ASSERT_TRUE(any) << "the transactions showed nothing for any candidate";
  BinderRig rig;
  for (const std::uint32_t passes : {1u, 2u}) {
    for (int i = 0; i < kRequests; ++i) exchange(rig, i);
    for (const auto& [address, sum] : expected) {
      const DriveBinder::Station& st = rig.binder.stations().at({0, address});
      ASSERT_EQ(st.decided_after, 0u) << "station " << address << " decided: not all weighed";
      for (std::size_t c = 0; c < sum.size(); ++c) {
        EXPECT_EQ(st.tally[c].fits, passes * sum[c].fits)
            << rig.candidates[c]->id << ", station " << address << ", pass " << passes;
        EXPECT_EQ(st.tally[c].contradicts, passes * sum[c].contradicts)
            << rig.candidates[c]->id << ", station " << address << ", pass " << passes;
      }
    }
  }
}

// A station every family's profile contradicts kDecidedContradictions times is decided generic
// and no longer weighed; a telegram of another protocol weighs it again.
TEST(DriveBinder, DecidedStationIsNoLongerWeighed) {
  BinderRig rig;
  // Reads of 32 input registers high in the address space: no family has them.
  const auto read_far = with_crc({0x07, 0x04, 0xFF, 0x00, 0x00, 0x20});
  std::vector<std::uint8_t> zeros = {0x07, 0x04, 0x40};
  zeros.resize(3 + 0x40, 0);
  const auto reply = with_crc(zeros);
  std::uint32_t transactions = 0;
  while (rig.binder.stations().count({0, 7}) == 0 ||
         rig.binder.stations().at({0, 7}).decided_after == 0) {
    ASSERT_LT(transactions, 100u) << "never decided";
    rig.exchange(protocols::modbus_rtu, read_far, reply);
    ++transactions;
  }
  const DriveBinder::Station& st = rig.binder.stations().at({0, 7});
  EXPECT_EQ(st.bound, -1);
  EXPECT_EQ(transactions, DriveBinder::kDecidedContradictions);
  EXPECT_EQ(st.decided_after, 2u * transactions);
  const std::string evidence = rig.binder.evidence(st);
  EXPECT_NE(evidence.find(fmt::format("decided after {} of {} frames", 2 * transactions,
                                      2 * transactions)),
            std::string::npos)
      << evidence;
  for (int i = 0; i < 10; ++i) rig.exchange(protocols::modbus_rtu, read_far, reply);
  EXPECT_EQ(st.transactions, transactions);
  EXPECT_EQ(st.frames, 2u * transactions + 20);
  EXPECT_TRUE(rig.events.empty());
  // Another protocol: weighed again (FC transactions for the one family that speaks it bind it).
  for (int i = 0; i < 2; ++i)
    rig.exchange(protocols::danfoss_fc, with_bcc({0x02, 0x06, 0x07, 0x04, 0x7C, 0x20, 0x00}),
                 with_bcc({0x02, 0x06, 0x07, 0x0E, 0x07, 0x20, 0x00}));
  EXPECT_EQ(st.transactions, transactions + 2);
  EXPECT_EQ(st.decided_after, 0u);
}

// A bound family contradicted by more than one transaction in four of those it fits is let go,
// with an event, and its account says what contradicted it.
TEST(DriveBinder, ContradictedFamilyIsLetGo) {
  BinderRig rig;
  for (int i = 0; i < 4; ++i) rig.poll_e9();
  ASSERT_EQ(rig.bound_id(2), "e9");
  // Status words with bits the E-9 manual does not describe.
  const auto poll = with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x05});
  const auto odd = with_crc({0x02, 0x03, 0x0A, 0x80, 0x00, 0, 0, 0, 0, 0, 0, 0, 0});
  rig.exchange(protocols::modbus_rtu, poll, odd);
  EXPECT_EQ(rig.bound_id(2), "e9");  // 1 in 4
  rig.exchange(protocols::modbus_rtu, poll, odd);
  EXPECT_EQ(rig.bound_id(2), "generic");  // 2 in 4
  ASSERT_EQ(rig.events.size(), 2u);
  EXPECT_EQ(rig.events[1].from, "e9");
  EXPECT_EQ(rig.events[1].to, "generic");
  EXPECT_EQ(rig.events[1].detail.find("drive 2 let go: its traffic contradicts the family that "
                                      "fits it"),
            0u)
      << rig.events[1].detail;
  EXPECT_NE(rig.events[1].detail.find("2 contradicting (a bit the manual does not describe)"),
            std::string::npos)
      << rig.events[1].detail;
}

// A station polled first as an E-9 and then on the E5-8200 monitor block: the E-9 is let go when
// the reads of addresses it does not have contradict it, and the E5-8200 bound once it alone
// explains more transactions than the E-9 did.
TEST(DriveBinder, AnotherFamilysEvidenceRebinds) {
  BinderRig rig;
  for (int i = 0; i < 2; ++i) rig.poll_e9();
  ASSERT_EQ(rig.bound_id(2), "e9");
  for (int i = 0; i < 8; ++i)
    rig.exchange(protocols::modbus_rtu, with_crc({0x02, 0x03, 0x25, 0x20, 0x00, 0x08}),
                 with_crc({0x02, 0x03, 0x10, 0x00, 0x03, 0, 0, 0, 0, 0x17, 0x70, 0x17, 0x70, 0x0E,
                           0xD8, 0x02, 0x1C, 0x00, 0x32}));
  EXPECT_EQ(rig.bound_id(2), "e5-8200");
  ASSERT_EQ(rig.events.size(), 3u);
  EXPECT_EQ(rig.events[1].to, "generic");
  EXPECT_EQ(rig.events[1].frame, 6u);
  const BusEvent& e = rig.events[2];
  EXPECT_EQ(e.profile, "e5-8200");
  EXPECT_EQ(e.from, "");
  // The third: the E5-8200 explains 3 alone, the E-9 2 (a tie binds neither); the E-9 polls read
  // addresses the E5-8200's parameter rule has, and contradict it in nothing.
  EXPECT_EQ(e.frame, 10u);
  EXPECT_EQ(e.detail.find("drive 2 bound to E5-8200 (auto, confidence medium: "), 0u) << e.detail;
  // A frame with a bad checksum teaches nothing, and its station stays bound.
  auto bad = with_crc({0x02, 0x03, 0x25, 0x20, 0x00, 0x08});
  bad.back() ^= 0x01;
  const Message m = decode(protocols::modbus_rtu, bad, Direction::request);
  std::optional<BusEvent> changed;
  EXPECT_EQ(rig.binder.learn_bound(0, head_of(m), changed), rig.binder.bound(0, 2));
  EXPECT_EQ(rig.bound_id(2), "e5-8200");
  EXPECT_FALSE(changed);
}

// The pipeline reads a telegram's records once, a reply with its request, and hands that reading
// to the binder and then to the annotation: it binds as the binder's own reading does, over
// exchanges of every protocol (register and coil reads and their replies, writes, exception
// replies with standard and vendor codes).
TEST(DriveBinder, SharedReadingBindsAsItsOwn) {
  struct Exchange {
    Protocol protocol;
    std::vector<std::uint8_t> request, reply;
  };
  const std::vector<Exchange> exchanges = {
      {protocols::modbus_rtu, with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x05}),
       with_crc({0x02, 0x03, 0x0A, 0x00, 0x0A, 0x13, 0x88, 0x13, 0x7D, 0x01, 0x7C, 0x00, 0x64})},
      {protocols::modbus_rtu, with_crc({0x02, 0x03, 0x25, 0x20, 0x00, 0x08}),
       with_crc({0x02, 0x83, 0x52})},
      {protocols::modbus_rtu, with_crc({0x01, 0x03, 0x25, 0x20, 0x00, 0x08}),
       with_crc({0x01, 0x03, 0x10, 0x00, 0x03, 0, 0, 0, 0, 0x17, 0x70, 0x17, 0x70, 0x0E, 0xD8, 0x02,
                 0x1C, 0x00, 0x32})},
      {protocols::modbus_rtu, with_crc({0x01, 0x06, 0x25, 0x01, 0x00, 0x01}),
       with_crc({0x01, 0x06, 0x25, 0x01, 0x00, 0x01})},
      {protocols::modbus_rtu, with_crc({0x03, 0x01, 0x00, 0x00, 0x00, 0x0A}),
       with_crc({0x03, 0x01, 0x02, 0x05, 0x01})},
      {protocols::modbus_rtu, with_crc({0x03, 0x04, 0x00, 0x01, 0x00, 0x06}),
       with_crc({0x03, 0x84, 0x02})},
      {protocols::modbus_rtu, with_crc({0x04, 0x03, 0xC4, 0x17, 0x00, 0x01}),
       with_crc({0x04, 0x86, 0x42})},
      {protocols::modbus_ascii, ascii_frame({0x05, 0x03, 0x25, 0x23, 0x00, 0x01}),
       ascii_frame({0x05, 0x03, 0x02, 0x00, 0x2A})},
      {protocols::danfoss_fc, with_bcc({0x02, 0x06, 0x06, 0x04, 0x7C, 0x20, 0x00}),
       with_bcc({0x02, 0x06, 0x06, 0x0E, 0x07, 0x20, 0x00})},
      {protocols::easydrive, eds_frame("070B000F"), eds_frame("0700000F0001")},
  };
  BinderRig alone, shared;
  DriveRecordReader reader;
  std::uint64_t number = 0;
  std::size_t replies_with_values = 0;
  for (int pass = 0; pass < 3; ++pass) {
    for (const Exchange& x : exchanges) {
      const Message q = decode(x.protocol, x.request, Direction::request, {}, ++number);
      const Message r = decode(x.protocol, x.reply, Direction::response, q.bytes, ++number);
      for (const auto& [m, request] :
           {std::pair<const Message*, std::span<const std::uint8_t>>{&q, {}}, {&r, q.bytes}}) {
        alone.learn(*m, request);
        const TelegramHead head = head_of(*m);
        TelegramDriveRecords records(reader, head, request);
        std::optional<BusEvent> e;
        const DriveProfile* now = shared.binder.learn_bound(0, records, e);
        EXPECT_EQ(now, shared.binder.bound(0, m->address)) << "frame " << m->frame.number;
        if (e) shared.events.push_back(*e);
        if (m == &r && !records.get().records.empty() &&
            records.get().records.front().addressed_by_request)
          ++replies_with_values;
      }
    }
  }
  EXPECT_GT(replies_with_values, 0u) << "no reply was read with its request";
  ASSERT_EQ(shared.binder.stations().size(), alone.binder.stations().size());
  for (const auto& [key, st] : alone.binder.stations()) {
    const DriveBinder::Station& other = shared.binder.stations().at(key);
    for (std::size_t c = 0; c < st.tally.size(); ++c) {
      EXPECT_EQ(other.tally[c].fits, st.tally[c].fits) << "station " << key.second;
      EXPECT_EQ(other.tally[c].alone, st.tally[c].alone) << "station " << key.second;
      EXPECT_EQ(other.tally[c].contradicts, st.tally[c].contradicts) << "station " << key.second;
    }
    EXPECT_EQ(other.excluded, st.excluded) << "station " << key.second;
    EXPECT_EQ(other.bound, st.bound) << "station " << key.second;
    EXPECT_EQ(other.confidence, st.confidence) << "station " << key.second;
    EXPECT_EQ(other.frames, st.frames) << "station " << key.second;
  }
  ASSERT_EQ(shared.events.size(), alone.events.size());
  EXPECT_FALSE(alone.events.empty());
  for (std::size_t i = 0; i < alone.events.size(); ++i)
    EXPECT_EQ(shared.events[i].detail, alone.events[i].detail);
}

// The binder weighs a request's addresses from per-block running sums; they must give what
// weighing each address does, for every profile, register kind and range, block edges included.
TEST(AddressEvidence, TableGivesTheWeightOfEachAddressSummed) {
  std::uint64_t state = 0x9E3779B97F4A7C15u;
  auto next = [&state] {  // splitmix64
    std::uint64_t z = (state += 0x9E3779B97F4A7C15u);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9u;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBu;
    return z ^ (z >> 31);
  };
  for (const DriveProfile* profile : builtin_candidates()) {
    AddressEvidence table(*profile);
    for (const RegisterKind kind : {RegisterKind::holding, RegisterKind::input, RegisterKind::coil,
                                    RegisterKind::discrete, RegisterKind::parameter}) {
      std::vector<std::pair<std::uint32_t, std::uint32_t>> ranges = {
          {0, 1}, {0, 40}, {255, 2}, {250, 32}, {256, 1}, {0xFFFF, 1}, {0xFFF0, 16}, {0xFFF0, 17}};
      for (const RegisterDef& r : profile->registers) ranges.push_back({r.address, 8});
      for (int i = 0; i < 3000; ++i)
        ranges.push_back({static_cast<std::uint32_t>(next() % 0x10010),
                          static_cast<std::uint32_t>(next() % 40)});
      for (const auto& [start, count] : ranges)
        ASSERT_EQ(table.sum(kind, start, count), table.walk(kind, start, count))
            << profile->id << " kind " << static_cast<int>(kind) << " start " << start << " count "
            << count;
    }
  }
}
