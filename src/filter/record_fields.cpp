// Record fields: names resolved to what they read, and their values (src/filter/record_fields.hpp;
// the JSON frame record of docs/formats.md).
#include "filter/record_fields.hpp"

#include <charconv>
#include <cstring>
#include <iterator>
#include <vector>

#include "core/checksum.hpp"
#include "core/format.hpp"
#include "core/line_buffer.hpp"
#include "core/protocol_desc.hpp"
#include "core/record_fields.hpp"
#include "drive/annotate.hpp"
#include "drive/drive_fields.hpp"
#include "sinks/sink.hpp"
#include "sinks/text_sink.hpp"

namespace drivetap {
namespace {

// The name of each RecordKey, in its order: the JSON key it reads (and `finding`).
constexpr std::string_view kKeyNames[] = {"type",
                                          "n",
                                          "t",
                                          "t_end",
                                          "channel",
                                          "dir",
                                          "protocol",
                                          "addr",
                                          "fc",
                                          "hex",
                                          "checksum",
                                          "checksum_stated",
                                          "checksum_computed",
                                          "exception",
                                          "drive",
                                          "latency_ms",
                                          "request_n",
                                          "gap_before_ms",
                                          "close",
                                          "summary",
                                          "finding"};
static_assert(std::size(kKeyNames) == static_cast<std::size_t>(RecordKey::finding) + 1);

std::vector<std::unique_ptr<RecordFieldSource>>& sources() {
  static std::vector<std::unique_ptr<RecordFieldSource>> list;
  return list;
}

// Hands `visit` a number given as an integer.
bool visit_int(std::int64_t v, std::string& scratch, ValueVisitor& visit) {
  if (!visit.wants_number_text()) return visit.visit({true, static_cast<double>(v), {}});
  scratch.clear();
  append_int(scratch, v);
  return visit.visit({true, static_cast<double>(v), scratch});
}

// Hands `visit` a number given as its JSON text (decimals): the value is the text's, as a reader
// of the JSON gets it.
bool visit_decimal_text(std::string& scratch, ValueVisitor& visit) {
  double v = 0;
  std::from_chars(scratch.data(), scratch.data() + scratch.size(), v);
  return visit.visit({true, v, scratch});
}

bool visit_string(std::string_view s, ValueVisitor& visit) {
  return visit.visit({false, 0, s});
}

bool visit_time(TimeNs t, std::string& scratch, ValueVisitor& visit) {
  scratch.clear();
  append_record_time(scratch, t);
  return visit_decimal_text(scratch, visit);
}

bool visit_ms(TimeNs t, std::string& scratch, ValueVisitor& visit) {
  scratch.clear();
  append_ms(scratch, t);
  return visit_decimal_text(scratch, visit);
}

TimeNs end_time(const ByteEvents& events, TimeNs character_time) {
  return events.empty() ? 0 : events.back().time + character_time;
}

bool noise_key_values(RecordKey key, const RecordView& r, std::string& scratch,
                      ValueVisitor& visit) {
  const Frame& f = *r.noise;
  switch (key) {
    case RecordKey::type:
      return visit_string("noise", visit);
    case RecordKey::n:
      return visit_int(static_cast<std::int64_t>(f.number), scratch, visit);
    case RecordKey::t:
      return visit_time(f.start(), scratch, visit);
    case RecordKey::t_end:
      return visit_time(end_time(f.events, r.character_time), scratch, visit);
    case RecordKey::channel:
      return visit_string(r.channels->at(f.channel).name, visit);
    case RecordKey::hex:
      scratch.clear();
      append_hex_bytes(scratch, f.events.bytes(), "");
      return visit_string(scratch, visit);
    default:
      return false;
  }
}

// The keys of a telegram known by its head, as its decoded Message would give them (the keys a
// head does not hold need the Message: RecordField::needs()).
bool head_key_values(RecordKey key, const RecordView& r, std::string& scratch,
                     ValueVisitor& visit) {
  const DeferredTelegram& t = *r.telegram;
  const TelegramFindings& head = *t.head;
  switch (key) {
    case RecordKey::type:
      return visit_string("frame", visit);
    case RecordKey::n:
      return visit_int(static_cast<std::int64_t>(t.number), scratch, visit);
    case RecordKey::t:
      return visit_time(t.run.first, scratch, visit);
    case RecordKey::t_end:
      return visit_time(t.run.time(t.run.size() - 1) + r.character_time, scratch, visit);
    case RecordKey::channel:
      return visit_string(r.channels->at(t.run.channel).name, visit);
    case RecordKey::dir:
      return visit_string(direction_id(t.direction), visit);
    case RecordKey::protocol:
      return visit_string(protocol_id(t.decoder->protocol()), visit);
    case RecordKey::addr:
      return head.address >= 0 && visit_int(head.address, scratch, visit);
    case RecordKey::fc:
      return head.function >= 0 && visit_int(head.function, scratch, visit);
    case RecordKey::hex:
      scratch.clear();
      append_hex_bytes(scratch, t.run.bytes, "");
      return visit_string(scratch, visit);
    case RecordKey::checksum:
      return visit_string(to_string(head.verdict), visit);
    case RecordKey::exception:
      return head.is_exception && visit_int(head.exception_code, scratch, visit);
    case RecordKey::latency_ms:
      return t.request_number != 0 && t.latency >= 0 && r.show_latency &&
             visit_ms(t.latency, scratch, visit);
    case RecordKey::request_n:
      return t.request_number != 0 &&
             visit_int(static_cast<std::int64_t>(t.request_number), scratch, visit);
    case RecordKey::gap_before_ms:
      return t.taken.timing.gap_before >= 0 && r.show_latency &&
             visit_ms(t.taken.timing.gap_before, scratch, visit);
    case RecordKey::close:
      return visit_string(frame_close_id(FrameClose::silence), visit);
    default:
      return false;  // (needs the Message)
  }
}

// Whether the telegram known by its head has a finding of `kind`.
bool head_has_finding(const RecordView& r, AnomalyKind kind) {
  const TelegramFindings& head = *r.telegram->head;
  if (kind == AnomalyKind::malformed && head.malformed > 0) return true;
  if ((head.other_kinds & (1u << static_cast<unsigned>(kind))) != 0) return true;
  for (const Anomaly& a : r.telegram->anomalies)
    if (a.kind == kind) return true;
  return false;
}

// The keys of a late finding's record: the finding's n, t and channel, its frame's protocol, addr
// and fc.
bool late_key_values(RecordKey key, const RecordView& r, std::string& scratch,
                     ValueVisitor& visit) {
  const Anomaly& a = r.findings.front();
  const LateFindingFrame& f = *r.late_frame;
  const bool telegram = f.telegram && f.number == a.frame_number;
  switch (key) {
    case RecordKey::type:
      return visit_string("anomaly", visit);
    case RecordKey::n:
      return a.frame_number != 0 &&
             visit_int(static_cast<std::int64_t>(a.frame_number), scratch, visit);
    case RecordKey::t:
      return visit_time(a.time, scratch, visit);
    case RecordKey::channel:
      return visit_string(r.channels->at(a.channel).name, visit);
    case RecordKey::protocol:
      return telegram && visit_string(protocol_id(f.protocol), visit);
    case RecordKey::addr:
      return telegram && f.address >= 0 && visit_int(f.address, scratch, visit);
    case RecordKey::fc:
      return telegram && f.function >= 0 && visit_int(f.function, scratch, visit);
    default:
      return false;
  }
}

// Whether the telegram known by its head has any finding.
bool head_has_findings(const RecordView& r) {
  const TelegramFindings& head = *r.telegram->head;
  return head.malformed > 0 || head.other_kinds != 0 || !r.telegram->anomalies.empty();
}

// The record of a telegram known by its head, as its decoded Message gives it.
RecordView decoded_view(const RecordView& r) {
  RecordView d = r;
  d.telegram = nullptr;
  d.decode = nullptr;
  d.message = &r.decode->message();
  d.findings = d.message->anomalies;
  return d;
}

bool key_values(RecordKey key, const RecordView& r, std::string& scratch, ValueVisitor& visit) {
  if (r.telegram) {
    switch (key) {
      case RecordKey::finding:  // (none without one of the head's finding kinds)
        if (!head_has_findings(r)) return false;
        return r.decode && key_values(key, decoded_view(r), scratch, visit);
      case RecordKey::drive:  // (none where no drive profile reads the telegram)
        if (!r.telegram->drive_profile) return false;
        return r.decode && key_values(key, decoded_view(r), scratch, visit);
      case RecordKey::summary:
      case RecordKey::checksum_stated:
      case RecordKey::checksum_computed:
        return r.decode && key_values(key, decoded_view(r), scratch, visit);
      default:
        return head_key_values(key, r, scratch, visit);
    }
  }
  if (key == RecordKey::finding) {
    for (const Anomaly& a : r.findings) {
      if (a.finding && visit_string(a.finding->id, visit)) return true;
      if (visit_string(anomaly_id(a.kind), visit)) return true;
    }
    return false;
  }
  if (r.late_frame) return late_key_values(key, r, scratch, visit);
  if (r.noise) return noise_key_values(key, r, scratch, visit);
  const Message& m = *r.message;
  switch (key) {
    case RecordKey::type:
      return visit_string("frame", visit);
    case RecordKey::n:
      return visit_int(static_cast<std::int64_t>(m.frame.number), scratch, visit);
    case RecordKey::t:
      return visit_time(m.frame.start(), scratch, visit);
    case RecordKey::t_end:
      return visit_time(end_time(m.frame.events, r.character_time), scratch, visit);
    case RecordKey::channel:
      return visit_string(r.channels->at(m.frame.channel).name, visit);
    case RecordKey::dir:
      return visit_string(direction_id(m.direction), visit);
    case RecordKey::protocol:
      return visit_string(protocol_id(m.protocol), visit);
    case RecordKey::addr:
      return m.address >= 0 && visit_int(m.address, scratch, visit);
    case RecordKey::fc:
      return m.function >= 0 && visit_int(m.function, scratch, visit);
    case RecordKey::hex:
      scratch.clear();
      append_hex_bytes(scratch, m.bytes, "");
      return visit_string(scratch, visit);
    case RecordKey::checksum:
      return visit_string(to_string(m.checksum.verdict), visit);
    case RecordKey::checksum_stated:
    case RecordKey::checksum_computed:
      if (m.checksum.verdict == ChecksumVerdict::none) return false;
      scratch.clear();
      append_wire_hex(
          scratch,
          key == RecordKey::checksum_stated ? m.checksum.stated_wire : m.checksum.computed_wire,
          m.checksum.width, "");
      return visit_string(scratch, visit);
    case RecordKey::exception:
      return m.is_exception && visit_int(m.exception_code, scratch, visit);
    case RecordKey::drive:
      return !m.drive_info.empty() && visit_string(m.drive_info, visit);
    case RecordKey::latency_ms:
      return m.request_number != 0 && m.latency >= 0 && r.show_latency &&
             visit_ms(m.latency, scratch, visit);
    case RecordKey::request_n:
      return m.request_number != 0 &&
             visit_int(static_cast<std::int64_t>(m.request_number), scratch, visit);
    case RecordKey::gap_before_ms:
      return m.frame.gap_before >= 0 && r.show_latency &&
             visit_ms(m.frame.gap_before, scratch, visit);
    case RecordKey::close:
      return visit_string(frame_close_id(m.frame.close), visit);
    case RecordKey::summary: {
      // Written where its pieces are appended inline (a filter reading it makes one a telegram).
      thread_local LineBuffer line;
      line.clear();
      append_frame_summary(line, m, r.show_latency);
      return visit_string(line.view(), visit);
    }
    case RecordKey::finding:
      return false;  // (above)
  }
  return false;
}

// A tree node's value as JSON has it: a number, or the hex of a bytes field, or a text.
bool tree_values(const FieldDesc* key, const Message& m, std::string& scratch,
                 ValueVisitor& visit) {
  for (const FieldNode& node : m.fields) {
    if (node.desc->key() != key) continue;
    bool stop = false;
    switch (node.desc->type) {
      case FieldType::text:
        stop = visit_string(m.fields.text(node), visit);
        break;
      case FieldType::bytes:
        scratch.clear();
        append_field_bytes_hex(scratch, node, m.bytes, m.text_encoded);
        stop = visit_string(scratch, visit);
        break;
      case FieldType::group:
        stop = visit.visit({false, 0, {}});  // present, with no value of its own
        break;
      default:
        stop = visit_int(node.value, scratch, visit);
        break;
    }
    if (stop) return true;
  }
  return false;
}

// Which value of a telegram's head the tree id `key` is in protocol `p`'s telegrams
// (ProtocolDesc::head_address_field, head_function_field).
enum class HeadValue : std::uint8_t { none, address, function };
HeadValue head_value_of(const ProtocolDesc& p, const FieldDesc* key) {
  if (p.head_address_field && p.head_address_field->key() == key) return HeadValue::address;
  if (p.head_function_field && p.head_function_field->key() == key) return HeadValue::function;
  return HeadValue::none;
}

// Whether one of protocol `p`'s layers has the field `key`.
bool has_field(const ProtocolDesc& p, const FieldDesc* key) {
  for (const FieldProtocol* layer : p.field_protocols)
    for (const FieldDesc* d : layer->fields)
      if (d->key() == key) return true;
  return false;
}

// Whether every telegram read to its head holds `key`'s value, or cannot have the field: for each
// protocol, the field is one of its head's or of none of its layers.
bool head_holds(const FieldDesc* key) {
  for (const ProtocolDesc* p : registered_protocols())
    if (head_value_of(*p, key) == HeadValue::none && has_field(*p, key)) return false;
  return true;
}

// Whether the telegram's protocol is one of those `field` lists as lacking it.
bool protocol_lacks(const RecordField& field, const DeferredTelegram& telegram) {
  const ProtocolDesc* p = telegram.decoder->protocol().desc();
  for (std::uint8_t i = 0; i < field.lacking_count; ++i)
    if (field.lacking[i] == p) return true;
  return false;
}

// A tree field of a telegram known by its head (head_holds() of it): the head's value, or none
// (a field of another protocol's layers).
bool head_tree_values(const FieldDesc* key, const RecordView& r, std::string& scratch,
                      ValueVisitor& visit) {
  const ProtocolDesc* p = r.telegram->decoder->protocol().desc();
  const TelegramFindings& head = *r.telegram->head;
  switch (p ? head_value_of(*p, key) : HeadValue::none) {
    case HeadValue::address:
      return head.address >= 0 && visit_int(head.address, scratch, visit);
    case HeadValue::function: {
      const std::uint32_t mask = key->bitmask ? key->bitmask : ~0u;
      return head.function >= 0 &&
             visit_int(static_cast<std::uint32_t>(head.function) & mask, scratch, visit);
    }
    case HeadValue::none:
      break;
  }
  return false;
}

}  // namespace

void add_record_field_source(std::unique_ptr<RecordFieldSource> source) {
  sources().push_back(std::move(source));
}

bool finding_known_after_frame(AnomalyKind kind) {
  return kind == AnomalyKind::unanswered_request || kind == AnomalyKind::unsolicited_response ||
         kind == AnomalyKind::packet_split_frame || kind == AnomalyKind::packet_merged_frames;
}

bool finding_may_come_after_frame(AnomalyKind kind) {
  return finding_known_after_frame(kind) || kind == AnomalyKind::timing_rule;
}

RecordFieldNeeds RecordField::needs() const {
  RecordFieldNeeds n;
  switch (kind) {
    case Kind::key:
      n.detail = key == RecordKey::summary || key == RecordKey::drive;
      n.annotation = key == RecordKey::drive;
      n.message = n.detail || key == RecordKey::checksum_stated ||
                  key == RecordKey::checksum_computed || key == RecordKey::finding;
      break;
    case Kind::tree:
      n.tree = true;  // (for the telegrams decoded anyway)
      n.telegram_tree = !in_head;
      break;
    case Kind::finding_id:  // (a typed id is the Anomaly's)
      n.message = true;
      break;
    case Kind::finding_kind:  // (its presence is the head's; its text, the Message's)
      break;
    case Kind::source:
      n = source->needs(slot);
      break;
  }
  return n;
}

std::optional<RecordField> resolve_record_field(std::string_view name) {
  RecordField f;
  for (std::size_t k = 0; k < std::size(kKeyNames); ++k)
    if (kKeyNames[k] == name) {
      f.kind = RecordField::Kind::key;
      f.key = static_cast<RecordKey>(k);
      f.name = kKeyNames[k];
      return f;
    }
  for (const FieldDesc* d : all_field_descriptors())
    if (d->id == name) {
      f.kind = RecordField::Kind::tree;
      f.desc = d->key();
      f.in_head = head_holds(f.desc);
      for (const ProtocolDesc* p : registered_protocols())
        if (!has_field(*p, f.desc) && f.lacking_count < f.lacking.size())
          f.lacking[f.lacking_count++] = p;
      f.name = d->id;
      return f;
    }
  for (const ProtocolDesc* p : registered_protocols())
    for (const FindingDesc* d : p->findings)
      if (name == d->id) {
        f.kind = RecordField::Kind::finding_id;
        f.finding_id = d->id;
        f.finding_kind = d->kind;
        f.name = d->id;
        return f;
      }
  for (std::size_t k = 0; k < kAnomalyKindCount; ++k)
    if (name == anomaly_id(static_cast<AnomalyKind>(k))) {
      f.kind = RecordField::Kind::finding_kind;
      f.finding_kind = static_cast<AnomalyKind>(k);
      f.name = anomaly_id(f.finding_kind);
      return f;
    }
  for (const auto& source : sources())
    if (const std::optional<int> slot = source->resolve(name)) {
      f.kind = RecordField::Kind::source;
      f.source = source.get();
      f.slot = *slot;
      return f;
    }
  return std::nullopt;
}

bool record_values(const RecordField& field, const RecordView& record, std::string& scratch,
                   ValueVisitor& visit) {
  switch (field.kind) {
    case RecordField::Kind::key:
      return key_values(field.key, record, scratch, visit);
    case RecordField::Kind::tree:
      if (record.message) return tree_values(field.desc, *record.message, scratch, visit);
      if (!record.telegram) return false;
      if (field.in_head) return head_tree_values(field.desc, record, scratch, visit);
      return record.decode && !protocol_lacks(field, *record.telegram) &&
             tree_values(field.desc, record.decode->tree(), scratch, visit);
    case RecordField::Kind::finding_kind:
      // A telegram known by its head: decoded for the finding's text, and only when it has one.
      if (record.telegram) {
        if (!head_has_finding(record, field.finding_kind)) return false;
        if (visit.presence_only()) return visit_string("", visit);
        return record.decode && record_values(field, decoded_view(record), scratch, visit);
      }
      for (const Anomaly& a : record.findings)
        if (a.kind == field.finding_kind && visit_string(a.detail, visit)) return true;
      return false;
    case RecordField::Kind::finding_id:
      // A typed id is one of its kind: a telegram known by its head without that kind has none.
      if (record.telegram)
        return head_has_finding(record, field.finding_kind) && record.decode &&
               record_values(field, decoded_view(record), scratch, visit);
      for (const Anomaly& a : record.findings)
        if (a.finding && std::strcmp(a.finding->id, field.finding_id) == 0 &&
            visit_string(a.detail, visit))
          return true;
      return false;
    case RecordField::Kind::source:
      return field.source->values(field.slot, record, scratch, visit);
  }
  return false;
}

TelegramDecode::TelegramDecode(const FieldIdSet& ids, bool annotate)
    : annotate_(annotate), drive_(std::make_unique<DriveReading>()) {
  tree_.detail = tree_.tree = true;
  tree_.info_text = false;
  tree_.fields.keep_only(&ids);
  message_.detail = message_.info_text = true;
  message_.tree = !ids.empty();
  message_.fields.keep_only(&ids);
}

TelegramDecode::~TelegramDecode() = default;

const Message& TelegramDecode::tree() {
  if (message_made_ && message_.tree) return message_;
  if (!tree_made_) {
    telegram_->dissect_fields_into(tree_);  // (the tree is all a filter reads of it)
    tree_made_ = true;
  }
  return tree_;
}

const Message& TelegramDecode::message() {
  if (!message_made_) {
    telegram_->decode_into(message_);
    if (!annotate_)
      message_.drive_profile = nullptr;  // (no field read reads the annotation)
    else if (telegram_->drive_values_with_annotation)
      complete_drive_info_and_values(message_, *drive_);
    else
      complete_drive_info(message_, *drive_);
    message_made_ = true;
  }
  return message_;
}

std::span<const DriveValue> RecordView::drive_values() const {
  if (message) return message->drive_values;
  if (telegram) return telegram->drive_values;
  return {};
}

RecordView RecordViews::shared_view() const {
  RecordView r;
  r.channels = &channels_;
  r.character_time = character_time_;
  r.show_latency = show_latency_;
  return r;
}

RecordView RecordViews::of(const Message& message) const {
  RecordView r = shared_view();
  r.message = &message;
  r.findings = message.anomalies;
  return r;
}

RecordView RecordViews::of(const DeferredTelegram& telegram) const {
  RecordView r = shared_view();
  r.telegram = &telegram;
  return r;
}

RecordView RecordViews::of(const Anomaly& finding, const LateFindingFrame& frame) const {
  RecordView r = shared_view();
  r.late_frame = &frame;
  r.findings = std::span<const Anomaly>(&finding, 1);
  return r;
}

LateFindingFrame late_finding_frame_of(const RecordView& r) {
  LateFindingFrame f;
  if (r.message) {
    f.number = r.message->frame.number;
    f.telegram = true;
    f.protocol = r.message->protocol;
    f.address = r.message->address;
    f.function = r.message->function;
  } else if (r.telegram) {
    f.number = r.telegram->number;
    f.telegram = true;
    f.protocol = r.telegram->decoder->protocol();
    f.address = r.telegram->head->address;
    f.function = r.telegram->head->function;
  } else if (r.noise) {
    f.number = r.noise->number;
  }
  return f;
}

RecordView RecordViews::of(const Frame& noise) {
  noise_findings_.clear();
  noise_findings_.push_back(
      {AnomalyKind::noise, noise.start(), noise.channel, noise.number, noise_detail(noise.events)});
  append_uart_anomalies(noise.events, noise.number, noise_findings_);
  RecordView r = shared_view();
  r.noise = &noise;
  r.findings = noise_findings_;
  return r;
}

void append_record_time(std::string& out, TimeNs t) {
  append_seconds(out, t, 9);
}

}  // namespace drivetap
