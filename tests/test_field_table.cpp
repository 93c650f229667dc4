// The explicit field table: every id unique, dotted lower-case, with a protocol prefix.
#include <gtest/gtest.h>

#include <regex>
#include <set>
#include <string>

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
    if (d->type == FieldType::enumerated) {
      EXPECT_FALSE(d->names.empty()) << id;
    }
  }
}
