// The explicit field table: every id unique, dotted lower-case, with its layer's prefix, and a
// width where it is a number; the record fields beside it; and the field tree's node texts
// (FieldTree).
#include <gtest/gtest.h>

#include <regex>
#include <set>
#include <string>
#include <vector>

#include "core/anomaly.hpp"
#include "core/field.hpp"
#include "core/protocol_desc.hpp"
#include "core/record_fields.hpp"

using namespace drivetap;

TEST(FieldTable, IdsAreUniqueAndWellFormed) {
  const auto fields = all_field_descriptors();
  ASSERT_GT(fields.size(), 40u);
  std::set<std::string> seen;
  const std::regex form("^[a-z][a-z0-9_]*(\\.[a-z0-9_]+)+$");
  for (const FieldDesc* d : fields) {
    ASSERT_NE(d, nullptr);
    const std::string id(d->id);
    EXPECT_TRUE(std::regex_match(id, form)) << id;
    EXPECT_TRUE(seen.insert(id).second) << "duplicate id " << id;
    EXPECT_FALSE(d->name.empty()) << id;
    EXPECT_EQ(d->key(), d) << id << ": a listed descriptor is its id's own";
    if (d->type == FieldType::enumerated) {
      EXPECT_FALSE(d->names.empty()) << id;
    }
  }
}

// A typed finding id is a filter name too (-Y mbrtu.intra_frame_gap): unique, of its layer's
// form, under a layer's prefix (`drivetap fields` lists it there), and no field's id, which a
// filter would read instead (modbus.coil_value was both).
TEST(FieldTable, FindingIdsAreUniqueAndNoFieldsId) {
  std::set<std::string_view> field_ids;
  for (const FieldDesc* d : all_field_descriptors()) field_ids.insert(d->id);
  std::set<std::string_view> layers;
  for (const FieldProtocol* layer : all_field_protocols()) layers.insert(layer->filter_name);
  const std::regex form("^[a-z][a-z0-9_]*(\\.[a-z0-9_]+)+$");
  std::set<const FindingDesc*> descs;
  std::set<std::string_view> ids;
  for (const ProtocolDesc* p : registered_protocols())
    for (const FindingDesc* f : p->findings) {
      if (!descs.insert(f).second) continue;  // (a layer's findings shared by two protocols)
      const std::string_view id = f->id;
      EXPECT_TRUE(std::regex_match(std::string(id), form)) << id;
      EXPECT_TRUE(ids.insert(id).second) << "duplicate finding id " << id;
      EXPECT_EQ(field_ids.count(id), 0u) << id << " is a field's id too";
      EXPECT_EQ(layers.count(id.substr(0, id.find('.'))), 1u) << id << ": under no layer";
    }
  EXPECT_GT(ids.size(), 20u);
}

bool is_number(FieldType t) {
  return t == FieldType::uint || t == FieldType::hex || t == FieldType::enumerated;
}

// `drivetap fields` prints a layer's filter name beside each of its fields, and Wireshark's
// FT_UINT8/16/32 from the width: ids carry their layer's prefix, numbers have a width they fit.
TEST(FieldTable, LayersPrefixTheirIdsAndNumbersHaveAWidth) {
  std::set<const FieldDesc*> in_layers;
  std::set<std::string_view> filter_names;
  for (const FieldProtocol* layer : all_field_protocols()) {
    EXPECT_TRUE(filter_names.insert(layer->filter_name).second) << layer->filter_name;
    EXPECT_FALSE(layer->name.empty()) << layer->filter_name;
    for (const FieldDesc* d : layer->fields) {
      in_layers.insert(d);
      EXPECT_TRUE(d->id.starts_with(std::string(layer->filter_name) + ".")) << d->id;
      EXPECT_NE(d->type, FieldType::real) << d->id << ": no dissector field is a real number";
      if (is_number(d->type)) {
        EXPECT_TRUE(d->bits == 8 || d->bits == 16 || d->bits == 32) << d->id;
        for (const ValueName& vn : d->names)
          EXPECT_LT(std::uint64_t{vn.value}, std::uint64_t{1} << d->bits) << d->id;
        EXPECT_LT(std::uint64_t{d->bitmask}, std::uint64_t{1} << d->bits) << d->id;
      } else {
        EXPECT_EQ(d->bits, 0) << d->id;
        EXPECT_EQ(d->bitmask, 0u) << d->id;
      }
    }
  }
  const auto table = all_field_descriptors();
  EXPECT_EQ(in_layers.size(), table.size()) << "each descriptor in one layer, once";
  EXPECT_EQ(filter_names,
            (std::set<std::string_view>{"mbrtu", "mbascii", "modbus", "danfoss_fc", "easydrive"}));
}

// The record's fields are the JSON frame record's keys: bare, unique, none a protocol's id.
TEST(FieldTable, RecordFieldsAreBareUniqueKeys) {
  std::set<std::string_view> ids;
  for (const FieldDesc* d : all_field_descriptors()) ids.insert(d->id);
  const std::regex form("^[a-z][a-z_]*$");
  EXPECT_EQ(kRecordFieldProtocol.filter_name, "drivetap");
  for (const FieldDesc* d : kRecordFieldProtocol.fields) {
    EXPECT_TRUE(std::regex_match(std::string(d->id), form)) << d->id;
    EXPECT_TRUE(ids.insert(d->id).second) << "duplicate id " << d->id;
    EXPECT_FALSE(d->name.empty()) << d->id;
    EXPECT_FALSE(d->blurb.empty()) << d->id;
    if (is_number(d->type)) {
      EXPECT_TRUE(d->bits == 8 || d->bits == 32) << d->id;
    }
  }
  EXPECT_EQ(kRecordFieldProtocol.fields.size(), 15u);
}

// The type names tshark prints for each kind of field.
TEST(FieldTable, WiresharkTypeNames) {
  constexpr FieldDesc kByte{"test.byte", "Byte", FieldType::hex, 8};
  constexpr FieldDesc kWord{"test.word", "Word", FieldType::enumerated, 16};
  constexpr FieldDesc kLong{"test.long", "Long", FieldType::uint, 32};
  constexpr FieldDesc kFlag{"test.flag", "Flag", FieldType::boolean};
  constexpr FieldDesc kRaw{"test.raw", "Raw", FieldType::bytes};
  constexpr FieldDesc kName{"test.name", "Name", FieldType::text};
  constexpr FieldDesc kHead{"test.head", "Head", FieldType::group};
  constexpr FieldDesc kSeconds{"test.seconds", "Seconds", FieldType::real};
  EXPECT_EQ(wireshark_field_type(kByte), "FT_UINT8");
  EXPECT_EQ(wireshark_field_base(kByte), "BASE_HEX");
  EXPECT_EQ(wireshark_field_type(kWord), "FT_UINT16");
  EXPECT_EQ(wireshark_field_base(kWord), "BASE_DEC");
  EXPECT_EQ(wireshark_field_type(kLong), "FT_UINT32");
  EXPECT_EQ(wireshark_field_type(kFlag), "FT_BOOLEAN");
  EXPECT_EQ(wireshark_field_type(kRaw), "FT_BYTES");
  EXPECT_EQ(wireshark_field_base(kRaw), "");
  EXPECT_EQ(wireshark_field_type(kName), "FT_STRING");
  EXPECT_EQ(wireshark_field_type(kHead), "FT_NONE");
  EXPECT_EQ(wireshark_field_type(kSeconds), "FT_DOUBLE");
}

namespace {
constexpr FieldDesc kNumber{"test.number", "Number"};
constexpr FieldDesc kWords{"test.words", "Words", FieldType::text};
}  // namespace

// Texts live in the tree: a copy of the tree has them, a node taken into another tree brings its
// text along, and a node whose text is not in a tree reads as having none there.
TEST(FieldTree, NodeTextsStayWithTheirTree) {
  FieldTree tree;
  FieldTreeBuilder builder(tree);
  builder.add(kNumber, 0, 1, 7);
  builder.add_text(kWords, 1, 2, "start, 50.00 Hz");
  builder.add_text(kNumber, 3, 1, "a note", 9);
  ASSERT_EQ(tree.size(), 3u);
  EXPECT_EQ(tree.text(tree[0]), "");
  EXPECT_EQ(tree.text(tree[1]), "start, 50.00 Hz");
  EXPECT_EQ(tree.text(tree[2]), "a note");
  EXPECT_EQ(tree[2].value, 9);
  EXPECT_EQ(format_field_value(tree, tree[2], std::vector<std::uint8_t>(4)), "9 [a note]");

  const FieldTree copy = tree;
  EXPECT_EQ(copy, tree);
  EXPECT_EQ(copy.text(copy[1]), "start, 50.00 Hz");

  FieldTree other;
  FieldTreeBuilder(other).add_text(kWords, 0, 1, "xy");
  const FieldNode& moved = other.push_back_from(tree, tree[1]);
  EXPECT_EQ(other.text(other[0]), "xy");
  EXPECT_EQ(other.text(moved), "start, 50.00 Hz");
  EXPECT_EQ(moved.offset, 1u);

  FieldNode stray = tree[1];  // its text is in `tree`, beyond what `other` holds
  stray.text_at = 1000;
  EXPECT_EQ(other.text(stray), "");

  tree.clear();
  EXPECT_TRUE(tree.empty());
  FieldTreeBuilder(tree, /*enabled=*/false).add_text(kWords, 0, 1, "kept nowhere");
  EXPECT_TRUE(tree.empty());
}
