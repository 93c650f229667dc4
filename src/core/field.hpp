// Field descriptors and the generic field tree that every sink walks.
//
// A FieldDesc is a constexpr description of one protocol field with a stable dotted id
// ("modbus.func_code", "danfoss_fc.pke.ak"); ids are part of drivetap's output contract (JSON
// keys, -V lines, tests). Where Wireshark 4.0 has the field, the id is Wireshark's, with a type
// Wireshark's agrees with (`drivetap fields` lists them as `tshark -G fields` does). A FieldNode is
// one occurrence of a field in a decoded frame, with its byte span. All descriptors are listed in
// one explicit table (gathered from the protocols' descriptors in dissectors/registry.cpp), so a
// test can check that ids are unique and well formed.
#pragma once

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/format.hpp"

namespace drivetap {

enum class FieldType : std::uint8_t {
  group,       // no value of its own: a heading for the nodes below it
  uint,        // unsigned number of `bits`, shown in decimal
  hex,         // unsigned number of `bits`, shown as 0x.. (bits / 4 digits), decimal in brackets
  boolean,     // 0/1 flag
  enumerated,  // unsigned number of `bits` with a name from `names`
  bytes,       // raw bytes of the span, shown as hex
  text,        // computed text held in the node
  real,        // a measured number (seconds, milliseconds): record fields only, never in a tree
};

struct ValueName {
  std::uint32_t value;
  std::string_view name;
};

struct FieldDesc;

// The fields of one protocol layer, as `drivetap fields` lists them: its name and its display
// filter name (Wireshark's where Wireshark has the layer: "modbus", "mbrtu"), which prefixes every
// id of its fields.
struct FieldProtocol {
  std::string_view name;         // "Modbus RTU"
  std::string_view filter_name;  // "mbrtu"
  std::span<const FieldDesc* const> fields;
  // Descriptors that share a listed id under the label a reply gives it (Danfoss FC's AK: "Response
  // (AK)"): Wireshark's tree names a reply's field by these.
  std::span<const FieldDesc* const> response_fields{};
};

struct FieldDesc {
  std::string_view id;    // stable dotted id
  std::string_view name;  // human label
  FieldType type = FieldType::uint;
  // Width of a uint, hex or enumerated value: 8, 16 or 32 (Wireshark's FT_UINT8/16/32); 0 for
  // the other types.
  std::uint8_t bits = 0;
  std::span<const ValueName> names{};
  std::string_view blurb{};  // what it holds, when the name does not say it all
  // The bits of its bytes the value is, shifted down (Danfoss FC's AK: 0xF0); 0: all of them.
  std::uint32_t bitmask = 0;
  // The descriptor listed in the field table under this id, for one that shares it with a label
  // of its own (Danfoss FC's AK has a request and a response meaning; a Modbus output address and
  // register address are both Wireshark's reference number); null for a listed one.
  const FieldDesc* shares_id_of = nullptr;

  // The listed descriptor of this id: two descriptors have the same id exactly when their keys
  // are the same (tests/test_pipeline.cpp checks every descriptor a dissector emits).
  [[nodiscard]] constexpr const FieldDesc* key() const {
    return shares_id_of ? shares_id_of : this;
  }

  // Name of `value` in `names`, or empty.
  [[nodiscard]] constexpr std::string_view name_of(std::uint32_t value) const {
    for (const ValueName& vn : names)
      if (vn.value == value) return vn.name;
    return "";  // empty, not null: compiled fmt formats copy from data() even when empty
  }
};

// A descriptor under the id (and width) of the listed `of`, with a label and type of its own:
// Wireshark has one id for several meanings (reference_num: an output, a register or a FIFO
// address).
constexpr FieldDesc sharing_id_of(const FieldDesc& of, std::string_view name, FieldType type,
                                  std::span<const ValueName> names = {}) {
  FieldDesc d{.id = of.id, .name = name, .type = type, .bits = of.bits, .names = names};
  d.bitmask = of.bitmask;
  d.shares_id_of = &of;
  return d;
}

// A field whose value is text its dissector makes (no width, no value names); `blurb` says what it
// holds where the name does not say it all.
constexpr FieldDesc text_field(std::string_view id, std::string_view name,
                               std::string_view blurb = {}) {
  return {.id = id, .name = name, .type = FieldType::text, .blurb = blurb};
}

// One occurrence of a field. Plain data (copied as bytes): its text, if any, is held by the tree
// it belongs to (FieldTree::text), so a whole tree copies as two blocks, not a string per node.
struct FieldNode {
  const FieldDesc* desc = nullptr;
  std::int64_t value = 0;    // numeric value (uint/hex/boolean/enumerated)
  std::uint32_t offset = 0;  // byte span in the frame
  std::uint32_t length = 0;
  // The node's text, in its tree's text storage: a text field's value, or an optional note on
  // any field (text_size 0: none).
  std::uint32_t text_at = 0;
  std::uint32_t text_size = 0;
  std::uint16_t depth = 0;  // 0 = top level; children follow their parent in pre-order
};
static_assert(std::is_trivially_copyable_v<FieldNode>);

// The ids a reader of a tree reads (a display filter's tree ids): a FieldTree told to keep only
// them (FieldTree::keep_only) gets no node of another id, and each node it keeps is the node a full
// tree has (value, span, depth, text). Few ids: looked up one by one.
class FieldIdSet {
 public:
  void add(const FieldDesc& desc) {
    if (!contains(desc)) keys_.push_back(desc.key());
  }
  [[nodiscard]] bool contains(const FieldDesc& desc) const {
    const FieldDesc* key = desc.key();
    return std::find(keys_.begin(), keys_.end(), key) != keys_.end();
  }
  [[nodiscard]] bool empty() const { return keys_.empty(); }

 private:
  std::vector<const FieldDesc*> keys_;  // listed descriptors (FieldDesc::key)
};

// The field tree of one frame: its nodes in pre-order, and the texts they name. Read like a
// std::vector<FieldNode> (size, [], iteration); a node's text is text(node). The texts of all
// nodes share one string, so copying a tree (a Message handed to the writer thread) costs two
// copies, and clearing it frees nothing.
class FieldTree {
 public:
  using value_type = FieldNode;
  using iterator = std::vector<FieldNode>::iterator;
  using const_iterator = std::vector<FieldNode>::const_iterator;

  [[nodiscard]] std::size_t size() const { return nodes_.size(); }
  [[nodiscard]] bool empty() const { return nodes_.empty(); }
  [[nodiscard]] FieldNode& operator[](std::size_t i) { return nodes_[i]; }
  [[nodiscard]] const FieldNode& operator[](std::size_t i) const { return nodes_[i]; }
  [[nodiscard]] iterator begin() { return nodes_.begin(); }
  [[nodiscard]] iterator end() { return nodes_.end(); }
  [[nodiscard]] const_iterator begin() const { return nodes_.begin(); }
  [[nodiscard]] const_iterator end() const { return nodes_.end(); }

  // Clears the nodes and texts; the ids kept (keep_only) stay.
  void clear() {
    nodes_.clear();
    text_.clear();
  }
  // From now on the tree's builders add only nodes of `ids` (nullptr: every node), a tree for a
  // reader of those alone: the rest of the tree costs no node and no text. `ids` outlives it.
  void keep_only(const FieldIdSet* ids) { kept_ids_ = ids; }
  [[nodiscard]] const FieldIdSet* kept_ids() const { return kept_ids_; }
  void reserve(std::size_t nodes) { nodes_.reserve(nodes); }
  // A new node with no text, for the caller to fill in.
  FieldNode& emplace_back() { return nodes_.emplace_back(); }
  // A node of another tree (or of this one), its text copied into this tree.
  FieldNode& push_back_from(const FieldTree& from, const FieldNode& node) {
    const std::string_view t = from.text(node);
    FieldNode& n = nodes_.emplace_back(node);
    n.text_size = 0;
    set_text(n, t);
    return n;
  }

  // Empty for a node with none. Never reads outside this tree's texts, but a node of another tree
  // may name some other text here: take nodes across with push_back_from().
  [[nodiscard]] std::string_view text(const FieldNode& node) const {
    if (node.text_size == 0 || node.text_at > text_.size()) return {};
    return {text_.data() + node.text_at,
            std::min<std::size_t>(node.text_size, text_.size() - node.text_at)};
  }
  // `node` (one of this tree's) has `text` from now on; a text it had before is left unused.
  void set_text(FieldNode& node, std::string_view text) {
    node.text_at = static_cast<std::uint32_t>(text_.size());
    node.text_size = static_cast<std::uint32_t>(text.size());
    text_.append(text);
  }

  friend bool operator==(const FieldTree& a, const FieldTree& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
      const FieldNode &x = a[i], &y = b[i];
      if (x.desc != y.desc || x.value != y.value || x.offset != y.offset || x.length != y.length ||
          x.depth != y.depth || a.text(x) != b.text(y))
        return false;
    }
    return true;
  }

 private:
  std::vector<FieldNode> nodes_;
  std::string text_;
  const FieldIdSet* kept_ids_ = nullptr;
};

// Builds a pre-order field tree. Dissectors add nodes; open()/close() nest them.
// A builder made with `enabled` false keeps nothing: a run that prints no per-frame decode
// (`read --stats`) pays for no tree, as Wireshark dissects with a null tree when none is shown.
// add() then hands back a scratch node, so dissector code runs the same either way. A tree that
// keeps only some ids (FieldTree::keep_only) gets the scratch node for the others' nodes: the kept
// ones have the depth and, for a group, the span they have in the full tree.
class FieldTreeBuilder {
 public:
  explicit FieldTreeBuilder(FieldTree& out, bool enabled = true)
      : out_(out), enabled_(enabled), kept_ids_(out.kept_ids()) {}

  [[nodiscard]] bool enabled() const { return enabled_; }
  // Whether the tree gets nodes of `desc`'s id: a dissector may step over values no one reads.
  [[nodiscard]] bool keeps(const FieldDesc& desc) const {
    return enabled_ && (!kept_ids_ || kept_ids_->contains(desc));
  }

  // Inlined: dissectors call it for every field, and without a tree it is a few stores.
  [[gnu::always_inline]] FieldNode& add(const FieldDesc& desc, std::size_t offset,
                                        std::size_t length, std::int64_t value = 0) {
    FieldNode& n = !enabled_   ? scratch_
                   : kept_ids_ ? kept_node(desc, offset, length)
                               : out_.emplace_back();
    n.desc = &desc;
    n.value = value;
    n.offset = static_cast<std::uint32_t>(offset);
    n.length = static_cast<std::uint32_t>(length);
    n.text_size = 0;
    n.depth = depth_;
    return n;
  }
  // A node with a text: a text field's value, or a note on any field (its value `value`).
  FieldNode& add_text(const FieldDesc& desc, std::size_t offset, std::size_t length,
                      std::string_view text, std::int64_t value = 0) {
    FieldNode& n = add(desc, offset, length, value);
    if (&n != &scratch_) out_.set_text(n, text);
    return n;
  }
  // Adds a group node and nests what follows under it until close(), which stretches the
  // group's span over its children.
  void open(const FieldDesc& desc, std::size_t offset, std::size_t length, std::int64_t value = 0) {
    const FieldNode& n = add(desc, offset, length, value);
    if (!enabled_) return;
    open_.push_back(&n == &scratch_ ? kNotKept : out_.size() - 1);
    if (kept_ids_) open_end_.push_back(n.offset + n.length);
    ++depth_;
  }
  void close() {
    if (open_.empty()) return;
    const std::size_t at = open_.back();
    open_.pop_back();
    --depth_;
    if (kept_ids_) {
      // The end of everything under the group, kept or not (as the full tree stretches it).
      const std::uint32_t end = open_end_.back();
      open_end_.pop_back();
      if (!open_end_.empty()) open_end_.back() = std::max(open_end_.back(), end);
      if (at != kNotKept && end > out_[at].offset + out_[at].length)
        out_[at].length = end - out_[at].offset;
      return;
    }
    FieldNode& group = out_[at];
    for (std::size_t i = at + 1; i < out_.size(); ++i) {
      const std::uint32_t end = out_[i].offset + out_[i].length;
      if (end > group.offset + group.length) group.length = end - group.offset;
    }
  }

 private:
  static constexpr std::size_t kNotKept = ~std::size_t{0};

  // A node of a tree that keeps only some ids: its own for a kept id, else the scratch node.
  [[gnu::always_inline]] FieldNode& kept_node(const FieldDesc& desc, std::size_t offset,
                                              std::size_t length) {
    if (!open_end_.empty())
      open_end_.back() = std::max(open_end_.back(), static_cast<std::uint32_t>(offset + length));
    return kept_ids_->contains(desc) ? out_.emplace_back() : scratch_;
  }

  FieldTree& out_;
  bool enabled_;
  const FieldIdSet* kept_ids_;     // the tree's (FieldTree::keep_only), nullptr for all
  FieldNode scratch_;              // what add() fills for a node the tree does not keep
  std::vector<std::size_t> open_;  // indices of open group nodes (kNotKept: not kept)
  // With kept_ids_: the end of the span of everything under each open group so far.
  std::vector<std::uint32_t> open_end_;
  std::uint16_t depth_ = 0;
};

// The value of a node as an engineer reads it: "3 (Read Holding Registers)", "0x0010 (16)".
// `text_encoded`: the frame spells bytes as hex characters (Modbus ASCII), so a bytes field shows
// the characters of its span rather than their codes.
std::string format_field_value(const FieldTree& tree, const FieldNode& node,
                               std::span<const std::uint8_t> frame, bool text_encoded = false);
// A bytes field's value as compact upper-case hex ("A537"), for JSON; a text-encoded frame's
// characters upper-cased instead. Appended to `out` (std::string or LineBuffer).
template <class Out>
void append_field_bytes_hex(Out& out, const FieldNode& node, std::span<const std::uint8_t> frame,
                            bool text_encoded) {
  const std::size_t end = std::min(std::size_t{node.offset} + node.length, frame.size());
  for (std::size_t i = node.offset; i < end; ++i) {
    if (text_encoded) {
      out += static_cast<char>(std::toupper(frame[i]));
    } else {
      out += kHexDigits[frame[i] >> 4];
      out += kHexDigits[frame[i] & 0x0F];
    }
  }
}
// The same as a string.
std::string field_bytes_hex(const FieldNode& node, std::span<const std::uint8_t> frame,
                            bool text_encoded);

// Every descriptor of every dissector (dissectors/registry.cpp), each once.
std::span<const FieldDesc* const> all_field_descriptors();
// Every protocol layer with fields, each once, in registry order (dissectors/registry.cpp).
std::span<const FieldProtocol* const> all_field_protocols();

// Wireshark's name of the field's type ("FT_UINT16", "FT_BYTES", "FT_NONE") and display base
// ("BASE_HEX"; "" where Wireshark prints none), as `tshark -G fields` prints them.
std::string_view wireshark_field_type(const FieldDesc& d);
std::string_view wireshark_field_base(const FieldDesc& d);

}  // namespace drivetap
