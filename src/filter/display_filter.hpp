// Display filters (-Y): tshark's filter syntax over drivetap's frame records (docs/reference.md
// "Display filters"). compile() parses the text once into a small program whose field names are
// resolved (src/filter/record_fields.hpp); matches() runs it on a record without allocating once
// its scratch text has grown.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "filter/record_fields.hpp"

namespace drivetap {

class DisplayFilter {
 public:
  // The program of `text`, or nullopt with `error` set to one line saying what broke and where:
  // "expected a value after '==' at column 6: addr == && x".
  static std::optional<DisplayFilter> compile(std::string_view text, std::string* error);

  // Whether the record passes the filter. Not thread-safe (scratch text).
  [[nodiscard]] bool matches(const RecordView& record) const;

  // What the pipeline must make for the filter to read its fields.
  [[nodiscard]] const RecordFieldNeeds& needs() const { return needs_; }
  // The field-tree ids it reads: a tree of these alone gives it the values a full tree does.
  [[nodiscard]] const FieldIdSet& tree_ids() const { return tree_ids_; }
  [[nodiscard]] const std::string& text() const { return text_; }
  // The test the filter evaluates first reads what no telegram's head holds (a text, a tree id
  // no head has): every telegram known by its head is decoded for it.
  [[nodiscard]] bool first_test_decodes() const;
  // The filter names a finding reported after its frame (finding_known_after_frame()): it is
  // also evaluated against each such finding's own record.
  [[nodiscard]] bool names_late_findings() const { return names_late_findings_; }

  enum class Compare : std::uint8_t { eq, ne, lt, gt, le, ge };
  struct Literal {
    bool is_number = false;
    double number = 0;
    std::string text;  // a string
  };
  // A set's members sorted, so that a test costs a few comparisons however many members it
  // has: numbers and texts without repeats, ranges merged where they overlap.
  struct Set {
    std::vector<double> numbers;
    std::vector<std::string> texts;
    std::vector<std::pair<double, double>> ranges;  // low, high; disjoint, by low
    [[nodiscard]] bool holds(const RecordValue& v) const;
  };
  struct Node {
    enum class Op : std::uint8_t { exists, compare, contains, in_set, all, any, negate };
    Op op = Op::exists;
    Compare compare = Compare::eq;
    std::uint32_t field = 0;  // index into fields_
    // compare/contains: the literal; in_set: the set
    std::uint32_t literal = 0;
    // all/any: the operands; negate: first
    std::uint32_t first = 0;
    std::uint32_t second = 0;
  };

 private:
  friend class FilterParser;
  bool eval(std::uint32_t node, const RecordView& record) const;

  std::string text_;
  std::vector<RecordField> fields_;
  std::vector<Literal> literals_;
  std::vector<Set> sets_;
  std::vector<Node> nodes_;
  std::uint32_t root_ = 0;
  RecordFieldNeeds needs_;
  FieldIdSet tree_ids_;
  bool names_late_findings_ = false;
  mutable std::string scratch_;
};

}  // namespace drivetap
