// Record fields: the names a display filter (-Y) and `-T fields -e` read of a frame or noise
// record, and their values (docs/reference.md "Display filters"; the JSON frame record of
// docs/formats.md). A name is resolved once, when the filter or the field list is parsed, to a
// RecordField; values are then read without a string lookup and without allocating.
//
// Names, in the order they are tried: the JSON record's keys (n, t, addr, summary, ...), `finding`
// (every finding id of the frame) and `drive` (the drive annotation), the field tree's ids
// (all_field_descriptors), the findings' ids (the protocols' typed ids and the generic kinds), and
// last the names of the sources added with add_record_field_source (the drive layer's `drive.*`).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/anomaly.hpp"
#include "core/byte_event.hpp"
#include "core/field.hpp"
#include "core/frame.hpp"
#include "core/message.hpp"

namespace drivetap {

struct DeferredTelegram;
struct ProtocolDesc;

// What the record of a finding reported after its frame (finding_known_after_frame()) says of
// that frame besides the finding's own n, t and channel: its protocol, addr and fc (none for
// noise).
struct LateFindingFrame {
  std::uint64_t number = 0;  // 0: the frame is not known
  bool telegram = false;
  Protocol protocol = Protocol::unknown;
  int address = -1;
  int function = -1;
};

struct DriveReading;

// A telegram known by its head (RecordView::telegram), decoded when a field first reads what no
// head holds, and only then: to its tree of the filter's tree ids alone (DissectDepth::fields,
// tree()), or to the Message the pipeline would have handed over (DeferredTelegram::decode_into,
// message()): its info line, its findings with their texts and, with `annotate`, its drive
// annotation. A filter that reads such a field after a cheaper test that fails decodes nothing.
class TelegramDecode {
 public:
  // `ids`: the tree ids read (both trees keep only theirs).
  TelegramDecode(const FieldIdSet& ids, bool annotate);
  ~TelegramDecode();
  TelegramDecode(const TelegramDecode&) = delete;
  TelegramDecode& operator=(const TelegramDecode&) = delete;
  // The telegram read next (valid until the next reset).
  void reset(const DeferredTelegram& telegram) {
    telegram_ = &telegram;
    tree_made_ = message_made_ = false;
  }
  [[nodiscard]] const Message& tree();
  [[nodiscard]] const Message& message();

 private:
  const DeferredTelegram* telegram_ = nullptr;
  bool annotate_;
  bool tree_made_ = false;
  bool message_made_ = false;
  Message tree_;
  Message message_;
  std::unique_ptr<DriveReading> drive_;  // the annotation's storage, reused
};

// One frame or noise record as the filter sees it.
struct RecordView {
  const Message* message = nullptr;  // a telegram; or
  const Frame* noise = nullptr;      // a noise record; or
  // a telegram known by its head (DeferredTelegram::head): the fields whose needs() say no
  // `message` or `telegram_tree` are read of the head, the others through `decode`
  const DeferredTelegram* telegram = nullptr;
  // with it, for the fields no head holds: the telegram decoded on the first read of one
  TelegramDecode* decode = nullptr;
  // or the record of a late finding (the one in `findings`), with what it says of its frame
  const LateFindingFrame* late_frame = nullptr;
  const ChannelTable* channels = nullptr;
  TimeNs character_time = 0;  // t_end: the last byte's start plus one character
  bool show_latency = true;   // false (decode): latency_ms and gap_before_ms are null, as in JSON
  // The findings handed over with the record (a telegram's Message::anomalies; for noise, the
  // noise finding and its UART marks).
  std::span<const Anomaly> findings;

  // Its drive values: the message's (Message::drive_values), or those handed over with the
  // telegram (DeferredTelegram::drive_values); none for the other records.
  [[nodiscard]] std::span<const DriveValue> drive_values() const;
};

// The views of one sink's records: what a record is read with (its channel names, the character
// time, whether latencies show), and a noise record's findings, made as the pipeline reports them
// after it (storage reused).
class RecordViews {
 public:
  RecordViews(const ChannelTable& channels, TimeNs character_time, bool show_latency)
      : channels_(channels), character_time_(character_time), show_latency_(show_latency) {}
  [[nodiscard]] RecordView of(const Message& message) const;
  [[nodiscard]] RecordView of(const DeferredTelegram& telegram) const;
  RecordView of(const Frame& noise);  // valid until the next noise record
  // The record of the late finding `finding` about the frame `frame` (both kept by the caller).
  [[nodiscard]] RecordView of(const Anomaly& finding, const LateFindingFrame& frame) const;

 private:
  // A view of no record yet: what the views of every record share.
  [[nodiscard]] RecordView shared_view() const;
  const ChannelTable& channels_;
  TimeNs character_time_;
  bool show_latency_;
  std::vector<Anomaly> noise_findings_;
};

// One value of a field: a number (its JSON text in `text`) or a string.
struct RecordValue {
  bool is_number = false;
  double number = 0;
  std::string_view text;
};

// Called for each value of a field; returns true to stop (a match was found).
class ValueVisitor {
 public:
  virtual bool visit(const RecordValue& value) = 0;
  // False for a visitor that reads numbers by value only (the filter's tests): an integer's
  // `text` is then left empty, not written.
  [[nodiscard]] bool wants_number_text() const { return wants_number_text_; }
  // True for a visitor that asks only whether the field is there (its first value stops it):
  // a finding's presence is then read off a telegram's head, its text not made.
  [[nodiscard]] bool presence_only() const { return presence_only_; }

 protected:
  explicit ValueVisitor(bool wants_number_text = true, bool presence_only = false)
      : wants_number_text_(wants_number_text), presence_only_(presence_only) {}
  ~ValueVisitor() = default;

 private:
  bool wants_number_text_;
  bool presence_only_;
};

// What reading a field costs the pipeline (folded into the filter sink's SinkNeeds).
struct RecordFieldNeeds {
  bool detail = false;        // Message::info_text: the info line (summary) or the drive annotation
  bool annotation = false;    // Message::drive_info: the drive annotation (`drive`)
  bool tree = false;          // Message::tree: the field tree (without the texts)
  bool drive_values = false;  // Message::drive_values: the `drive.*` fields
  // The decoded Message: the field is not read from a telegram's head (the keys, checksum
  // verdict and finding kinds a DeferredTelegram carries); a telegram known by its head is
  // decoded when the field is read (RecordView::decode, TelegramDecode::message()).
  bool message = false;
  // A tree id no head holds: a telegram known by its head is decoded for its tree alone when
  // the field is read (TelegramDecode::tree()).
  bool telegram_tree = false;
};

// A source of fields beyond the record and the field tree, such as the drive layer's `drive.*`
// values: resolves its names to slots once, then gives a slot's values for a record.
class RecordFieldSource {
 public:
  virtual ~RecordFieldSource() = default;
  // The slot of `name`, or nullopt when the name is not this source's.
  [[nodiscard]] virtual std::optional<int> resolve(std::string_view name) const = 0;
  [[nodiscard]] virtual RecordFieldNeeds needs(int slot) const = 0;
  // visit() of each value of `slot` in `record`, until one returns true; true when one did.
  virtual bool values(int slot, const RecordView& record, std::string& scratch,
                      ValueVisitor& visit) const = 0;
};

// Adds a source that names are looked up in after the built-in ones (not thread-safe: at start-up).
void add_record_field_source(std::unique_ptr<RecordFieldSource> source);

// The keys of the JSON frame and noise records a filter can read.
enum class RecordKey : std::uint8_t {
  type,
  n,
  t,
  t_end,
  channel,
  dir,
  protocol,
  addr,
  fc,
  hex,
  checksum,
  checksum_stated,
  checksum_computed,
  exception,
  drive,
  latency_ms,
  request_n,
  gap_before_ms,
  close,
  summary,
  finding,  // not a JSON key: each finding id of the frame (typed id and generic kind)
};

// A name resolved: what it reads.
struct RecordField {
  enum class Kind : std::uint8_t { key, tree, finding_kind, finding_id, source };
  Kind kind = Kind::key;
  RecordKey key = RecordKey::n;
  const FieldDesc* desc = nullptr;  // tree: the listed descriptor (FieldDesc::key)
  bool in_head = false;             // tree: every telegram's head holds it (or no layer has it)
  // tree: the protocols none of whose layers has it (their telegrams are not decoded for it)
  std::array<const ProtocolDesc*, 8> lacking{};
  std::uint8_t lacking_count = 0;
  AnomalyKind finding_kind{};        // finding_kind
  const char* finding_id = nullptr;  // finding_id: a protocol's typed id
  const RecordFieldSource* source = nullptr;
  int slot = 0;
  std::string_view name;  // as resolved (static storage)

  [[nodiscard]] RecordFieldNeeds needs() const;
};

// The field `name` names, or nullopt.
std::optional<RecordField> resolve_record_field(std::string_view name);

// Findings reported after their frame was handed on (the conversation's and the capture packets'):
// no filter sees them with the frame; a filter naming one is also evaluated against each such
// finding's own record (RecordViews::of(const Anomaly&, ...)).
bool finding_known_after_frame(AnomalyKind kind);
// Those, and a drive's timing-rule findings, which are held until the binder is sure of the
// station's family and then handed on after their frame (Anomaly::address set).
bool finding_may_come_after_frame(AnomalyKind kind);

// What a late finding's record says of a frame or noise record (RecordView of a frame).
LateFindingFrame late_finding_frame_of(const RecordView& frame);

// visit() of each value of `field` in `record` until one returns true; true when one did. Numbers
// come with their JSON text; text is written into `scratch` where it is made (hex; the summary
// into a buffer of the thread's own).
bool record_values(const RecordField& field, const RecordView& record, std::string& scratch,
                   ValueVisitor& visit);

// The record time as -T fields and the filter's `t` show it: seconds, 9 decimals (JSON's `t`).
// The one place to change when other time formats come.
void append_record_time(std::string& out, TimeNs t);

}  // namespace drivetap
