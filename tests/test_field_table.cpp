// The explicit field table: every id unique, dotted lower-case, with a protocol prefix; and the
// field tree's node texts (FieldTree).
#include <gtest/gtest.h>

#include <regex>
#include <set>
#include <string>
#include <vector>

#include "core/field.hpp"

using namespace drivetap;

TEST(FieldTable, IdsAreUniqueAndWellFormed) {
  const auto fields = all_field_descriptors();
  ASSERT_GT(fields.size(), 40u);
  std::set<std::string> seen;
  const std::regex form("^[a-z][a-z0-9]*(\\.[a-z0-9_]+)+$");
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
