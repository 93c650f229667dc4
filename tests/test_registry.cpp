// The protocol registry (dissectors/registry.cpp): each protocol's names resolve to it, and its
// findings (core/anomaly.hpp FindingDesc) have unique dotted ids and the severity of their kind.
#include <gtest/gtest.h>

#include <regex>
#include <set>
#include <string>

#include "core/protocol.hpp"

using namespace drivetap;

TEST(Registry, NamesResolveToTheirProtocol) {
  const auto protocols = registered_protocols();
  ASSERT_EQ(protocols.size(), 4u);
  EXPECT_EQ(default_protocol().desc(), protocols[0]);
  std::set<std::string_view> ids, names;
  for (const ProtocolDesc* p : protocols) {
    EXPECT_TRUE(ids.insert(p->id).second) << p->id;
    EXPECT_EQ(protocol_id(Protocol(p)), p->id);
    EXPECT_EQ(protocol_from_option(p->id).desc(), p) << p->id;
    ASSERT_FALSE(p->option_names.empty()) << p->id;
    for (std::string_view name : p->option_names) {
      EXPECT_TRUE(names.insert(name).second || name == p->id) << name;
      EXPECT_EQ(protocol_from_option(name).desc(), p) << name;
    }
    ASSERT_NE(p->decoder, nullptr) << p->id;
    EXPECT_EQ(p->decoder->protocol().desc(), p) << p->id;
    EXPECT_FALSE(p->field_protocols.empty()) << p->id;
    if (p->text_start != 0) {
      EXPECT_EQ(protocol_for_text_start(p->text_start).desc(), p);
    }
  }
  EXPECT_EQ(protocol_from_option("auto"), Protocol::unknown);
  EXPECT_EQ(protocol_for_text_start('x'), Protocol::unknown);
  EXPECT_EQ(protocol_id(Protocol::unknown), "unknown");
  EXPECT_EQ(protocol_ids_text(), "modbus-rtu, modbus-ascii, danfoss-fc or easydrive");
}

TEST(Registry, FindingsAreUniqueDottedAndWeighAsTheirKind) {
  std::set<const FindingDesc*> counted;
  std::set<std::string> ids;
  const std::regex form("^[a-z][a-z0-9_]*(\\.[a-z0-9_]+)+$");
  for (const ProtocolDesc* p : registered_protocols()) {
    EXPECT_FALSE(p->findings.empty()) << p->id;
    for (const FindingDesc* f : p->findings) {
      ASSERT_NE(f, nullptr) << p->id;
      if (!counted.insert(f).second) continue;  // shared (the Modbus PDU layer's)
      const std::string id(f->id);
      EXPECT_TRUE(std::regex_match(id, form)) << id;
      EXPECT_TRUE(ids.insert(id).second) << "duplicate id " << id;
      EXPECT_NE(id.rfind("fc.", 0), 0u) << id << ": fc.* is Wireshark's Fibre Channel";
      // Prefixed as the protocol's fields are: by one of its layers' filter names.
      bool layer_prefix = false;
      for (const FieldProtocol* layer : p->field_protocols)
        layer_prefix = layer_prefix || id.starts_with(std::string(layer->filter_name) + ".");
      EXPECT_TRUE(layer_prefix) << id << " has none of " << p->id << "'s field prefixes";
      // The JSON output weighs a finding by its kind: the two agree.
      EXPECT_EQ(f->severity, anomaly_severity(f->kind)) << id;
      EXPECT_FALSE(f->text.empty()) << id;
    }
  }
}
