// Display filters: lexer, parser and evaluator (src/filter/display_filter.hpp; the syntax is
// tshark's, docs/reference.md "Display filters").
#include "filter/display_filter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <functional>
#include <iterator>

namespace drivetap {
namespace {

struct Token {
  enum class Kind : std::uint8_t {
    end,
    word,  // a name, a keyword (and, or, not, eq, ..., contains, in) or a bare value
    number,
    string,
    lparen,
    rparen,
    lbrace,
    rbrace,
    comma,
    range,    // ..
    compare,  // ==, eq, <, lt, ...: which one in Token::compare
    and_,
    or_,
    not_,
  };
  Kind kind = Kind::end;
  DisplayFilter::Compare compare = DisplayFilter::Compare::eq;  // a `compare` token's
  std::string_view raw;                                         // as written
  std::size_t column = 1;
  std::string text;   // a string's characters (escapes resolved)
  double number = 0;  // a number's value
};

bool word_start(char c) {
  return std::isalpha(static_cast<unsigned char>(c)) != 0 || c == '_';
}
bool word_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '.' || c == '-';
}

// The comparisons, each with its symbol and its word; a symbol before those it begins ("<="
// before "<"). The lexer reads them before the other operators ("!=" before "!").
struct ComparisonSpelling {
  std::string_view symbol;
  std::string_view word;
  DisplayFilter::Compare compare;
};
constexpr ComparisonSpelling kComparisons[] = {
    {"==", "eq", DisplayFilter::Compare::eq}, {"!=", "ne", DisplayFilter::Compare::ne},
    {"<=", "le", DisplayFilter::Compare::le}, {"<", "lt", DisplayFilter::Compare::lt},
    {">=", "ge", DisplayFilter::Compare::ge}, {">", "gt", DisplayFilter::Compare::gt},
};
// The other operators, each spelling before those it begins with.
struct OperatorSpelling {
  std::string_view text;
  Token::Kind kind;
};
constexpr OperatorSpelling kOperators[] = {
    {"(", Token::Kind::lparen}, {")", Token::Kind::rparen}, {"{", Token::Kind::lbrace},
    {"}", Token::Kind::rbrace}, {",", Token::Kind::comma},  {"!", Token::Kind::not_},
    {"&&", Token::Kind::and_},  {"||", Token::Kind::or_},   {"..", Token::Kind::range},
};
// Characters that begin an operator but are none alone, and what to write instead.
struct LoneCharacter {
  char character;
  const char* error;
};
constexpr LoneCharacter kNotOperators[] = {
    {'=', "'=' is no operator (compare with '==')"},
    {'&', "'&' is no operator (use '&&' or 'and')"},
    {'|', "'|' is no operator (use '||' or 'or')"},
};

class Lexer {
 public:
  explicit Lexer(std::string_view s) : s_(s) {}

  // The next token, or nullopt with `error` set.
  bool next(Token& t, std::string& error, std::size_t& error_column) {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_])) != 0) ++i_;
    t = Token{};
    t.column = i_ + 1;
    if (i_ >= s_.size()) return true;
    const std::size_t start = i_;
    const char c = s_[i_];
    const std::string_view rest = s_.substr(start);
    auto take = [&](Token::Kind kind, std::size_t length) {
      t.kind = kind;
      t.raw = rest.substr(0, length);
      i_ += length;
      return true;
    };
    for (const ComparisonSpelling& k : kComparisons) {
      if (rest.starts_with(k.symbol)) {
        t.compare = k.compare;
        return take(Token::Kind::compare, k.symbol.size());
      }
    }
    for (const OperatorSpelling& o : kOperators)
      if (rest.starts_with(o.text)) return take(o.kind, o.text.size());
    for (const LoneCharacter& l : kNotOperators) {
      if (c == l.character) {
        error = l.error;
        error_column = t.column;
        return false;
      }
    }
    if (c == '"') return string(t, error, error_column);
    if (std::isdigit(static_cast<unsigned char>(c)) != 0 ||
        (c == '-' && i_ + 1 < s_.size() && std::isdigit(static_cast<unsigned char>(s_[i_ + 1]))))
      return number(t, error, error_column);
    if (word_start(c)) {
      while (i_ < s_.size() && word_char(s_[i_])) ++i_;
      t.kind = Token::Kind::word;
      t.raw = s_.substr(start, i_ - start);
      return true;
    }
    error = fmt::format("unexpected character '{}'", c);
    error_column = t.column;
    return false;
  }

 private:
  bool string(Token& t, std::string& error, std::size_t& error_column) {
    const std::size_t start = i_++;
    while (i_ < s_.size() && s_[i_] != '"') {
      char c = s_[i_++];
      if (c == '\\' && i_ < s_.size()) {
        const char e = s_[i_++];
        switch (e) {
          case 'n':
            c = '\n';
            break;
          case 't':
            c = '\t';
            break;
          case 'r':
            c = '\r';
            break;
          case 'x': {
            unsigned v = 0;
            const auto r =
                std::from_chars(s_.data() + i_, s_.data() + std::min(i_ + 2, s_.size()), v, 16);
            if (r.ptr != s_.data() + i_ + 2) {
              error = "\\x needs two hex digits";
              error_column = i_ - 1;
              return false;
            }
            i_ += 2;
            c = static_cast<char>(v);
            break;
          }
          default:
            c = e;  // \" \\ and any other character as itself
            break;
        }
      }
      t.text += c;
    }
    if (i_ >= s_.size()) {
      error = "unterminated string";
      error_column = start + 1;
      return false;
    }
    ++i_;
    t.kind = Token::Kind::string;
    t.raw = s_.substr(start, i_ - start);
    return true;
  }

  static constexpr const char* kOutOfRange =
      "number out of range (a value has at most 64 bits: 18446744073709551615)";

  bool number(Token& t, std::string& error, std::size_t& error_column) {
    const std::size_t start = i_;
    const bool negative = s_[i_] == '-';
    if (negative) ++i_;
    if (s_.compare(i_, 2, "0x") == 0 || s_.compare(i_, 2, "0X") == 0) {
      i_ += 2;
      const std::size_t digits = i_;
      while (i_ < s_.size() && std::isxdigit(static_cast<unsigned char>(s_[i_])) != 0) ++i_;
      std::uint64_t v = 0;
      const auto r = std::from_chars(s_.data() + digits, s_.data() + i_, v, 16);
      if (digits == i_ || r.ec != std::errc{}) {
        error = r.ec == std::errc::result_out_of_range ? kOutOfRange : "bad hex number";
        error_column = start + 1;
        return false;
      }
      t.number = negative ? -static_cast<double>(v) : static_cast<double>(v);
    } else {
      while (i_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[i_])) != 0) ++i_;
      // A decimal point, not the ".." of a range.
      const std::size_t integer_end = i_;
      if (i_ + 1 < s_.size() && s_[i_] == '.' &&
          std::isdigit(static_cast<unsigned char>(s_[i_ + 1])) != 0) {
        ++i_;
        while (i_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[i_])) != 0) ++i_;
      }
      // No value is larger than 64 bits: a literal past that (or past a double's range) would
      // compare as some other number, or as 0.
      std::uint64_t whole = 0;
      const auto w = std::from_chars(s_.data() + (negative ? start + 1 : start),
                                     s_.data() + integer_end, whole);
      const auto r = std::from_chars(s_.data() + start, s_.data() + i_, t.number);
      if (w.ec == std::errc::result_out_of_range || r.ec == std::errc::result_out_of_range) {
        error = kOutOfRange;
        error_column = start + 1;
        return false;
      }
    }
    if (i_ < s_.size() && word_char(s_[i_]) &&
        !(s_[i_] == '.' && i_ + 1 < s_.size() && s_[i_ + 1] == '.')) {
      error = "bad number";
      error_column = start + 1;
      return false;
    }
    t.kind = Token::Kind::number;
    t.raw = s_.substr(start, i_ - start);
    return true;
  }

  std::string_view s_;
  std::size_t i_ = 0;
};

// A word token as the keyword or operator it spells (and, eq, ...); any other stays a word.
void spell_keyword(Token& t) {
  struct K {
    std::string_view word;
    Token::Kind kind;
  };
  static constexpr K kWords[] = {
      {"and", Token::Kind::and_}, {"or", Token::Kind::or_}, {"not", Token::Kind::not_}};
  for (const K& k : kWords)
    if (k.word == t.raw) {
      t.kind = k.kind;
      return;
    }
  for (const ComparisonSpelling& k : kComparisons)
    if (k.word == t.raw) {
      t.kind = Token::Kind::compare;
      t.compare = k.compare;
      return;
    }
}

}  // namespace

// Recursive descent over the tokens, lowest precedence first: or, and, not, a test.
class FilterParser {
 public:
  FilterParser(std::string_view text, DisplayFilter& out) : text_(text), lexer_(text), out_(out) {}

  bool parse(std::string* error) {
    std::uint32_t root = 0;
    if (!advance() || !parse_binary(root)) return fail(error);
    if (token_.kind != Token::Kind::end) {
      set_error(fmt::format("unexpected '{}'", token_.raw), token_.column);
      return fail(error);
    }
    out_.root_ = root;
    return true;
  }

 private:
  using Kind = Token::Kind;

  bool fail(std::string* error) {
    if (error) *error = fmt::format("{} at column {}: {}", error_, error_column_, text_);
    return false;
  }
  void set_error(std::string message, std::size_t column) {
    error_ = std::move(message);
    error_column_ = column;
  }
  bool advance() {
    if (!lexer_.next(token_, error_, error_column_)) return false;
    if (token_.kind == Kind::word) spell_keyword(token_);
    return true;
  }
  bool is_word(std::string_view w) const { return token_.kind == Kind::word && token_.raw == w; }
  std::uint32_t add(DisplayFilter::Node node) {
    out_.nodes_.push_back(node);
    return static_cast<std::uint32_t>(out_.nodes_.size() - 1);
  }
  std::string describe_end() const {
    return token_.kind == Kind::end ? "the end" : fmt::format("'{}'", token_.raw);
  }

  // A node of `op` over `first` (and `second`: all, any).
  std::uint32_t add_logic(DisplayFilter::Node::Op op, std::uint32_t first,
                          std::uint32_t second = 0) {
    DisplayFilter::Node n;
    n.op = op;
    n.first = first;
    n.second = second;
    return add(n);
  }

  // The binary operators by precedence, loosest first (`a or b and c` is `a or (b and c)`); each
  // groups to the left. The operands of the last are parse_not()'s.
  struct BinaryOperator {
    Kind token;
    DisplayFilter::Node::Op op;
  };
  static constexpr BinaryOperator kBinaryOperators[] = {
      {Kind::or_, DisplayFilter::Node::Op::any},
      {Kind::and_, DisplayFilter::Node::Op::all},
  };

  // An expression of the operators from kBinaryOperators[level] on.
  bool parse_binary(std::uint32_t& node, std::size_t level = 0) {
    const auto parse_operand = [this, level](std::uint32_t& operand) {
      return level + 1 < std::size(kBinaryOperators) ? parse_binary(operand, level + 1)
                                                     : parse_not(operand);
    };
    if (!parse_operand(node)) return false;
    if (token_.kind != kBinaryOperators[level].token) return true;
    // A chain `a && b && c` is kept as a && (b && c): the same tests in the same order, and
    // eval() walks the chain in a loop, so a long chain costs no stack.
    std::vector<std::uint32_t> operands{node};
    while (token_.kind == kBinaryOperators[level].token) {
      if (!advance()) return false;
      std::uint32_t right = 0;
      if (!parse_operand(right)) return false;
      operands.push_back(right);
    }
    node = operands.back();
    for (std::size_t k = operands.size() - 1; k-- > 0;)
      node = add_logic(kBinaryOperators[level].op, operands[k], node);
    return true;
  }

  // Parentheses and `!` nest at most kMaxNesting deep: the parser and eval() recurse on them.
  static constexpr std::size_t kMaxNesting = 256;
  bool enter(std::size_t column) {
    if (++nesting_ <= kMaxNesting) return true;
    set_error(fmt::format("parentheses and '!' nest more than {} deep", kMaxNesting), column);
    return false;
  }

  bool parse_not(std::uint32_t& node) {
    if (token_.kind == Kind::not_) {
      if (!enter(token_.column) || !advance()) return false;
      std::uint32_t operand = 0;
      if (!parse_not(operand)) return false;
      --nesting_;
      node = add_logic(DisplayFilter::Node::Op::negate, operand);
      return true;
    }
    return parse_primary(node);
  }

  bool parse_primary(std::uint32_t& node) {
    if (token_.kind == Kind::lparen) {
      const std::size_t open = token_.column;
      if (!enter(open) || !advance() || !parse_binary(node)) return false;
      --nesting_;
      if (token_.kind != Kind::rparen) {
        set_error(
            fmt::format("expected ')' for the '(' of column {}, found {}", open, describe_end()),
            token_.column);
        return false;
      }
      return advance();
    }
    if (token_.kind != Kind::word) {
      set_error(fmt::format("expected a field name, found {}", describe_end()), token_.column);
      return false;
    }
    const std::optional<RecordField> field = resolve_record_field(token_.raw);
    if (!field) {
      set_error(fmt::format("unknown field '{}' (names: JSON keys, field ids, finding ids, see "
                            "docs/reference.md)",
                            token_.raw),
                token_.column);
      return false;
    }
    if (field->kind == RecordField::Kind::finding_kind &&
        finding_may_come_after_frame(field->finding_kind))
      out_.names_late_findings_ = true;
    const RecordFieldNeeds needs = field->needs();
    out_.needs_.detail = out_.needs_.detail || needs.detail;
    out_.needs_.annotation = out_.needs_.annotation || needs.annotation;
    out_.needs_.tree = out_.needs_.tree || needs.tree;
    out_.needs_.drive_values = out_.needs_.drive_values || needs.drive_values;
    out_.needs_.message = out_.needs_.message || needs.message;
    out_.needs_.telegram_tree = out_.needs_.telegram_tree || needs.telegram_tree;
    if (field->kind == RecordField::Kind::tree) out_.tree_ids_.add(*field->desc);
    out_.fields_.push_back(*field);
    DisplayFilter::Node n;
    n.field = static_cast<std::uint32_t>(out_.fields_.size() - 1);
    if (!advance()) return false;
    bool negated_in = false;
    if (token_.kind == Kind::not_) {  // "field not in {...}"
      negated_in = true;
      if (!advance()) return false;
      if (!is_word("in")) {
        set_error(fmt::format("expected 'in' after 'not', found {}", describe_end()),
                  token_.column);
        return false;
      }
    }
    if (token_.kind == Kind::compare) {
      const std::string op(token_.raw);
      n.compare = token_.compare;
      if (!advance()) return false;
      n.op = DisplayFilter::Node::Op::compare;
      if (!parse_value(n.literal, op)) return false;
    } else if (is_word("contains")) {
      if (!advance()) return false;
      if (token_.kind != Kind::string) {
        set_error(fmt::format("expected a \"string\" after 'contains', found {}", describe_end()),
                  token_.column);
        return false;
      }
      n.op = DisplayFilter::Node::Op::contains;
      if (!parse_value(n.literal, "contains")) return false;
    } else if (is_word("in")) {
      if (!advance()) return false;
      n.op = DisplayFilter::Node::Op::in_set;
      if (!parse_set(n)) return false;
    } else if (is_word("matches")) {
      set_error("'matches' (regular expressions) is not supported; use 'contains'", token_.column);
      return false;
    } else {
      n.op = DisplayFilter::Node::Op::exists;
    }
    // A finding's text (what a comparison reads) is the Message's; its presence, the head's.
    if (field->kind == RecordField::Kind::finding_kind && n.op != DisplayFilter::Node::Op::exists)
      out_.needs_.message = true;
    node = add(n);
    if (negated_in) node = add_logic(DisplayFilter::Node::Op::negate, node);
    return true;
  }

  // A number, a "string" or a bare word (a string: dir == request).
  bool take_literal(DisplayFilter::Literal& lit, std::string_view after) {
    switch (token_.kind) {
      case Kind::number:
        lit.is_number = true;
        lit.number = token_.number;
        break;
      case Kind::string:
        lit.text = token_.text;
        break;
      case Kind::word:
        lit.text = std::string(token_.raw);
        break;
      default:
        set_error(fmt::format("expected a value after '{}', found {}", after, describe_end()),
                  token_.column);
        return false;
    }
    return advance();
  }

  bool parse_value(std::uint32_t& literal, std::string_view after) {
    DisplayFilter::Literal lit;
    if (!take_literal(lit, after)) return false;
    out_.literals_.push_back(std::move(lit));
    literal = static_cast<std::uint32_t>(out_.literals_.size() - 1);
    return true;
  }

  // {a b c}, {1, 2}, {1..5 "x"}
  bool parse_set(DisplayFilter::Node& n) {
    if (token_.kind != Kind::lbrace) {
      set_error(fmt::format("expected '{{' after 'in', found {}", describe_end()), token_.column);
      return false;
    }
    const std::size_t open = token_.column;
    if (!advance()) return false;
    DisplayFilter::Set set;
    bool any_member = false;
    while (token_.kind != Kind::rbrace) {
      if (token_.kind == Kind::end) {
        set_error(fmt::format("expected '}}' for the '{{' of column {}", open), token_.column);
        return false;
      }
      DisplayFilter::Literal lit;
      if (!take_literal(lit, "in {")) return false;
      any_member = true;
      if (token_.kind == Kind::range) {
        if (!lit.is_number) {
          set_error("a range needs numbers at both ends", token_.column);
          return false;
        }
        if (!advance()) return false;
        if (token_.kind != Kind::number) {
          set_error(fmt::format("expected a number after '..', found {}", describe_end()),
                    token_.column);
          return false;
        }
        // A range whose low end is above its high one holds no value.
        if (lit.number <= token_.number) set.ranges.emplace_back(lit.number, token_.number);
        if (!advance()) return false;
      } else if (lit.is_number) {
        set.numbers.push_back(lit.number);
      } else {
        set.texts.push_back(std::move(lit.text));
      }
      if (token_.kind == Kind::comma && !advance()) return false;
    }
    if (!any_member) {
      set_error("an empty set matches nothing", open);
      return false;
    }
    std::ranges::sort(set.numbers);
    set.numbers.erase(std::unique(set.numbers.begin(), set.numbers.end()), set.numbers.end());
    std::ranges::sort(set.texts);
    set.texts.erase(std::unique(set.texts.begin(), set.texts.end()), set.texts.end());
    std::ranges::sort(set.ranges);
    std::vector<std::pair<double, double>> merged;
    for (const auto& r : set.ranges) {
      if (!merged.empty() && r.first <= merged.back().second)
        merged.back().second = std::max(merged.back().second, r.second);
      else
        merged.push_back(r);
    }
    set.ranges = std::move(merged);
    out_.sets_.push_back(std::move(set));
    n.literal = static_cast<std::uint32_t>(out_.sets_.size() - 1);
    return advance();
  }

  std::string_view text_;
  Lexer lexer_;
  DisplayFilter& out_;
  Token token_;
  std::string error_;
  std::size_t error_column_ = 1;
  std::size_t nesting_ = 0;
};

namespace {

// Whether `v` stands in relation `c` to the literal (values of another type never do).
bool holds(const RecordValue& v, DisplayFilter::Compare c, const DisplayFilter::Literal& lit) {
  if (lit.is_number != v.is_number) return false;
  int order = 0;
  if (lit.is_number) {
    order = v.number < lit.number ? -1 : v.number > lit.number ? 1 : 0;
  } else {
    const int cmp = v.text.compare(lit.text);
    order = cmp < 0 ? -1 : cmp > 0 ? 1 : 0;
  }
  switch (c) {
    case DisplayFilter::Compare::eq:
      return order == 0;
    case DisplayFilter::Compare::ne:
      return order != 0;
    case DisplayFilter::Compare::lt:
      return order < 0;
    case DisplayFilter::Compare::gt:
      return order > 0;
    case DisplayFilter::Compare::le:
      return order <= 0;
    case DisplayFilter::Compare::ge:
      return order >= 0;
  }
  return false;
}

// The tests on a field's values: each stops at the first value that decides.
struct AnyValue final : ValueVisitor {
  AnyValue() : ValueVisitor(false, true) {}
  bool visit(const RecordValue&) override { return true; }
};
struct AnyCompares final : ValueVisitor {
  DisplayFilter::Compare compare;
  const DisplayFilter::Literal* literal;
  AnyCompares(DisplayFilter::Compare c, const DisplayFilter::Literal* l)
      : ValueVisitor(false), compare(c), literal(l) {}
  bool visit(const RecordValue& v) override { return holds(v, compare, *literal); }
};
// For !=: remembers whether the field had a value at all; stops at one equal to the literal.
struct AnyEqual final : ValueVisitor {
  const DisplayFilter::Literal* literal;
  bool seen = false;
  explicit AnyEqual(const DisplayFilter::Literal* l) : ValueVisitor(false), literal(l) {}
  bool visit(const RecordValue& v) override {
    seen = true;
    return holds(v, DisplayFilter::Compare::eq, *literal);
  }
};
struct AnyContains final : ValueVisitor {
  std::string_view needle;
  explicit AnyContains(std::string_view n) : ValueVisitor(false), needle(n) {}
  bool visit(const RecordValue& v) override {
    return !v.is_number && v.text.find(needle) != std::string_view::npos;
  }
};
struct AnyInSet final : ValueVisitor {
  const DisplayFilter::Set* set;
  explicit AnyInSet(const DisplayFilter::Set* s) : ValueVisitor(false), set(s) {}
  bool visit(const RecordValue& v) override { return set->holds(v); }
};

}  // namespace

bool DisplayFilter::Set::holds(const RecordValue& v) const {
  if (!v.is_number) return std::ranges::binary_search(texts, v.text, std::less<>{});
  // NaN is unordered: a binary search would take it for any member.
  if (std::isnan(v.number)) return false;
  if (std::ranges::binary_search(numbers, v.number)) return true;
  // The last range starting at or below the value is the only one that can hold it.
  const auto after =
      std::ranges::upper_bound(ranges, v.number, {}, &std::pair<double, double>::first);
  return after != ranges.begin() && v.number <= std::prev(after)->second;
}

std::optional<DisplayFilter> DisplayFilter::compile(std::string_view text, std::string* error) {
  DisplayFilter f;
  f.text_ = std::string(text);
  FilterParser parser(f.text_, f);
  if (!parser.parse(error)) return std::nullopt;
  return f;
}

bool DisplayFilter::matches(const RecordView& record) const {
  return eval(root_, record);
}

bool DisplayFilter::first_test_decodes() const {
  // The test evaluated first: the left operand of each `&&` and `||` (the right one only when
  // the left does not decide), the operand of `!`.
  std::uint32_t at = root_;
  while (nodes_[at].op == Node::Op::all || nodes_[at].op == Node::Op::any ||
         nodes_[at].op == Node::Op::negate)
    at = nodes_[at].first;
  const RecordField& f = fields_[nodes_[at].field];
  const RecordFieldNeeds n = f.needs();
  // A key the head lacks, but `finding`, which is decoded only where the head has one (as a
  // finding's text or typed id only where it has its kind).
  return n.telegram_tree ||
         (f.kind == RecordField::Kind::key && n.message && f.key != RecordKey::finding);
}

bool DisplayFilter::eval(std::uint32_t index, const RecordView& record) const {
  // A chain of && or || goes on in `second` (the parser's right fold): a loop, not recursion.
  while (nodes_[index].op == Node::Op::all || nodes_[index].op == Node::Op::any) {
    const Node& n = nodes_[index];
    if (eval(n.first, record) != (n.op == Node::Op::all)) return n.op == Node::Op::any;
    index = n.second;
  }
  const Node& n = nodes_[index];
  switch (n.op) {
    case Node::Op::all:
    case Node::Op::any:
      break;  // (the loop above)
    case Node::Op::negate:
      return !eval(n.first, record);
    case Node::Op::exists: {
      AnyValue v;
      return record_values(fields_[n.field], record, scratch_, v);
    }
    case Node::Op::compare: {
      // Wireshark's !=: the field is there and none of its values is equal (!(a == b) for a
      // field that is present); the other comparisons hold when any value does.
      if (n.compare == Compare::ne) {
        AnyEqual v(&literals_[n.literal]);
        const bool equal_found = record_values(fields_[n.field], record, scratch_, v);
        return v.seen && !equal_found;
      }
      AnyCompares v(n.compare, &literals_[n.literal]);
      return record_values(fields_[n.field], record, scratch_, v);
    }
    case Node::Op::contains: {
      AnyContains v(literals_[n.literal].text);
      return record_values(fields_[n.field], record, scratch_, v);
    }
    case Node::Op::in_set: {
      AnyInSet v(&sets_[n.literal]);
      return record_values(fields_[n.field], record, scratch_, v);
    }
  }
  return false;
}

}  // namespace drivetap
