// drivetap's Wireshark plugin generated from the field, finding and drive tables
// (src/app/wireshark_plugin.hpp; docs/formats.md "drivetap's Wireshark plugin").
#include "app/wireshark_plugin.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <string_view>
#include <vector>

#include "core/anomaly.hpp"
#include "core/enum_text.hpp"
#include "core/field.hpp"
#include "core/protocol_desc.hpp"
#include "drive/drive_fields.hpp"
#include "sinks/capture_sink.hpp"

namespace drivetap::app {
namespace {

// `s` as a Lua string literal: quotes, backslashes, controls and non-ASCII bytes escaped.
std::string lua_string(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (u < 0x20 || u >= 0x7F) {
      out += fmt::format("\\{:03d}", u);
    } else {
      out += c;
    }
  }
  return out + "\"";
}

// Wireshark's type and base names ("FT_UINT8", "BASE_HEX") as Lua's `ftypes.X` and `base.X`.
std::string lua_ftype(std::string_view t) {
  if (t.starts_with("FT_")) t.remove_prefix(3);
  return fmt::format("ftypes.{}", t);
}
std::string lua_base(std::string_view b) {
  if (b == "0") return "base.NONE";
  if (b.starts_with("BASE_")) return fmt::format("base.{}", b.substr(5));
  return "nil";
}
std::string lua_value_names(const FieldDesc& d) {
  if (d.names.empty()) return "nil";
  std::string out = "{";
  for (const ValueName& vn : d.names) out += fmt::format("[{}]={},", vn.value, lua_string(vn.name));
  return out + "}";
}

// How Wireshark groups a generic finding in its expert infos.
std::string_view expert_group(AnomalyKind k) {
  switch (k) {
    case AnomalyKind::checksum_bad:
    case AnomalyKind::checksum_swapped:
      return "CHECKSUM";
    case AnomalyKind::malformed:
    case AnomalyKind::implausible:
    case AnomalyKind::uart_framing:
    case AnomalyKind::uart_parity:
    case AnomalyKind::uart_break:
    case AnomalyKind::uart_overrun:
      return "MALFORMED";
    case AnomalyKind::noise:
    case AnomalyKind::packet_split_frame:
    case AnomalyKind::packet_merged_frames:
      return "UNDECODED";
    case AnomalyKind::intra_frame_gap:
    case AnomalyKind::short_interframe_gap:
    case AnomalyKind::unanswered_request:
    case AnomalyKind::unsolicited_response:
    case AnomalyKind::time_reversed:
    case AnomalyKind::timing_rule:
    case AnomalyKind::kCount:
      break;
  }
  return "SEQUENCE";
}

// Wireshark's expert severity (PI_NOTE, PI_WARN, PI_ERROR) of each Severity, in its order.
std::string_view expert_severity(Severity s) {
  static constexpr std::string_view kExpertSeverities[] = {"NOTE", "WARN", "ERROR"};
  static_assert(std::size(kExpertSeverities) == static_cast<std::size_t>(Severity::error) + 1);
  return enum_text(s, kExpertSeverities, std::string_view{"NOTE"});
}

// A finding's expert abbreviation: its id, unless a field has that id (Modbus's reference_type is
// both), then `<id>.finding`: Wireshark takes an abbreviation once.
std::string expert_abbrev(std::string_view id) {
  for (const FieldDesc* d : all_field_descriptors())
    if (d->id == id) return fmt::format("{}.finding", id);
  return std::string(id);
}

// The part of the plugin that reads packets: the same for every build of the tables.
constexpr std::string_view kDissectors = R"lua(
-- The packet comment: line 1 the decode, then the fields line (docs/formats.md "Packet comments").
local comment_field = Field.new("frame.comment")
local pdu_name_field = Field.new("exported_pdu.prot_name")

local function unescape(s)
  return (s:gsub("%%(%x%x)", function(h) return string.char(tonumber(h, 16)) end))
end

-- This packet's drivetap comment: its decode and the items of its fields line, or nil.
local function drivetap_comment()
  for _, fi in ipairs({ comment_field() }) do
    local text = tostring(fi.value)
    local decode, line = text:match("^([^\n]*)\n(drivetap/[^\n]*)")
    -- (Each version only adds to the one before: every earlier one reads.)
    local version = line and tonumber(line:match("^drivetap/(%d+)"))
    if version and version <= tonumber(FORMAT_VERSION) then
      local items = {}
      local first = true
      for item in line:gmatch("%S+") do
        if first then
          first = false
        elseif item:sub(1, 1) == "!" then
          local id, value = item:match("^!([^=]*)=?(.*)$")
          items[#items + 1] = { kind = "finding", id = id, value = unescape(value) }
        elseif item:sub(1, 1) == "*" then
          local id, value = item:match("^%*([^=]*)=?(.*)$")
          items[#items + 1] = { kind = "event", id = id, value = unescape(value) }
        else
          local depth, id, offset, length, rest = item:match("^(>*)([^@=>]+)@(%d+)%+(%d+)(.*)$")
          if id then
            items[#items + 1] = { kind = "field", id = id, depth = #depth, offset = tonumber(offset),
                                  length = tonumber(length),
                                  value = rest:sub(1, 1) == "=" and unescape(rest:sub(2)) or nil }
          else
            local vid, value = item:match("^([^=]+)=(.*)$")
            if vid then items[#items + 1] = { kind = "value", id = vid, value = unescape(value) } end
          end
        end
      end
      return decode, items
    end
  end
  return nil
end

-- One field of the fields line, with its bytes of the telegram (`tvb`: the bus bytes).
local function add_field(tree, tvb, spec, item)
  local range = nil
  if item.offset + item.length <= tvb:len() and item.length > 0 then
    range = tvb(item.offset, item.length)
  end
  local ft, value = spec.ftype, item.value
  if ft == ftypes.NONE or value == nil then
    if range then return tree:add(spec.field, range) else return tree:add(spec.field) end
  elseif ft == ftypes.STRING then
    if range then return tree:add(spec.field, range, value) else return tree:add(spec.field, value) end
  elseif ft == ftypes.BYTES then
    if range and #value == 2 * item.length then
      return tree:add(spec.field, range)
    elseif #value > 0 then
      -- (Modbus ASCII: the bytes are the hex text of the span; shown decoded.)
      return tree:add(spec.field, ByteArray.new(value):tvb(spec.name)())
    end
  else
    local n = tonumber(value) or 0
    if spec.shift > 0 then n = n * 2 ^ spec.shift end
    if ft == ftypes.BOOLEAN then n = n ~= 0 and 1 or 0 end
    if range then return tree:add(spec.field, range, n) else return tree:add(spec.field, n) end
  end
  return nil
end

-- A protocol Wireshark has no dissector for: found by exported_pdu under its name.
for _, p in pairs(PROTOCOLS) do
  p.proto.fields = p.list
  p.proto.dissector = function(tvb, pinfo, tree)
    local decode, items = drivetap_comment()
    pinfo.cols.protocol = p.label
    local subtree = tree:add(p.proto, tvb())
    if not decode then return tvb:len() end
    -- The decode without the protocol's name ("Danfoss FC  addr 1  ..."): the Info column.
    local rest = decode:sub(1, #p.label) == p.label and decode:sub(#p.label + 1):gsub("^%s+", "")
                 or decode
    if rest:sub(1, 9) == "broadcast" then pinfo.cols.protocol = p.label .. " broadcast" end
    pinfo.cols.info = rest
    -- The tree as drivetap's (-V): a field under the last one a level up.
    local parents = { [0] = subtree }
    for _, item in ipairs(items) do
      -- (A reply, inbound in the EPB flags, names a direction's field by the reply's label.)
      local spec = item.kind == "field" and
                   (pinfo.p2p_dir == P2P_DIR_RECV and p.reply_by_id[item.id] or p.by_id[item.id])
      local parent = spec and parents[math.min(item.depth or 0, #parents)]
      if spec then
        parents[item.depth + 1] = add_field(parent, tvb, spec, item) or parent
        for k = item.depth + 2, #parents do parents[k] = nil end
      end
    end
    return tvb:len()
  end
end

-- Findings, drive values, the drive annotation and events of every drivetap packet, Modbus RTU's
-- (Wireshark's own dissector) included.
drivetap.fields = DRIVETAP_FIELDS
drivetap.experts = EXPERT_LIST
function drivetap.dissector(tvb, pinfo, tree)
  local decode, items = drivetap_comment()
  if not decode then return end
  local subtree = tree:add(drivetap, tvb())
  local pdu = pdu_name_field()
  if pdu and tostring(pdu.value) == "data" then pinfo.cols.info = decode end  -- noise
  for _, item in ipairs(items) do
    if item.kind == "finding" then
      local finding = subtree:add(finding_field, item.id)
      local expert_info = EXPERTS[item.id]
      if expert_info then finding:add_proto_expert_info(expert_info, item.value) end
    elseif item.kind == "event" then
      subtree:add(event_field, item.id .. ": " .. item.value)
    elseif item.kind == "value" then
      local spec = VALUES[item.id]
      if spec and spec.text then
        subtree:add(spec.field, item.value)
      elseif spec then
        subtree:add(spec.field, tonumber(item.value) or 0)
      end
    end
  end
end
register_postdissector(drivetap)
)lua";

}  // namespace

std::string wireshark_plugin_lua(std::span<const DriveProfile* const> profiles) {
  std::string lua;
  auto out = std::back_inserter(lua);
  lua +=
      "-- drivetap's Wireshark plugin (Lua; Wireshark 4.0 and later), generated by `drivetap "
      "wireshark\n"
      "-- --print-plugin` from drivetap's field, finding and drive tables: regenerate, do not "
      "edit.\n"
      "-- It reads the fields line of drivetap's packet comments (docs/formats.md \"Packet "
      "comments\").\n";
  const std::string_view version =
      kCommentFieldsVersion.substr(kCommentFieldsVersion.find('/') + 1);
  fmt::format_to(out, "local FORMAT_VERSION = {}\n\n", lua_string(version));
  lua +=
      "local PROTOCOLS = {}\n"
      "local function protocol(name, label)\n"
      "  local p = { proto = Proto(name, label), label = label, list = {}, by_id = {}, reply_by_id "
      "= {} }\n"
      "  PROTOCOLS[name] = p\n"
      "  return p\n"
      "end\n"
      "local function field(p, id, name, ftype, display, names, mask, blurb, reply)\n"
      "  local f = ProtoField.new(name, id, ftype, names, display, mask ~= 0 and mask or nil,\n"
      "                           blurb ~= \"\" and blurb or nil)\n"
      "  local shift = 0\n"
      "  while mask ~= 0 and mask % 2 == 0 do mask = mask / 2; shift = shift + 1 end\n"
      "  p.list[#p.list + 1] = f\n"
      "  local by_id = reply and p.reply_by_id or p.by_id\n"
      "  by_id[id] = { field = f, ftype = ftype, shift = shift, name = name }\n"
      "end\n\n";
  // The protocols' fields, each layer's as `drivetap fields` lists them.
  for (const ProtocolDesc* p : registered_protocols()) {
    if (p->wireshark_dissector.empty() || p->wireshark_builtin) continue;
    fmt::format_to(out, "do\n  local p = protocol({}, {})\n", lua_string(p->wireshark_dissector),
                   lua_string(p->label));
    // (A reply's label of a shared id, FieldProtocol::response_fields, is the same field under the
    // same id: Wireshark keeps both, and a reply's tree shows the reply's.)
    auto add_field = [&](const FieldDesc* d, bool reply) {
      fmt::format_to(out, "  field(p, {}, {}, {}, {}, {}, {}, {}{})\n", lua_string(d->id),
                     lua_string(d->name), lua_ftype(wireshark_field_type(*d)),
                     lua_base(wireshark_field_base(*d)), lua_value_names(*d), d->bitmask,
                     lua_string(d->blurb), reply ? ", true" : "");
    };
    for (const FieldProtocol* layer : p->field_protocols) {
      for (const FieldDesc* d : layer->fields) add_field(d, false);
      for (const FieldDesc* d : layer->response_fields) add_field(d, true);
    }
    lua += "end\n";
  }
  // The postdissector's fields: findings, the drive annotation and events, the drive values.
  lua +=
      "\nlocal drivetap = Proto(\"drivetap\", \"drivetap annotation\")\n"
      "local finding_field = ProtoField.string(\"drivetap.finding\", \"Finding\")\n"
      "local event_field = ProtoField.string(\"drivetap.event\", \"Drive event\")\n"
      "local annotation_field = ProtoField.string(\"drive\", \"Drive annotation\")\n"
      "local DRIVETAP_FIELDS = { finding_field, event_field, annotation_field }\n"
      "local VALUES = { drive = { field = annotation_field, text = true } }\n"
      "local function value(id, f, text)\n"
      "  DRIVETAP_FIELDS[#DRIVETAP_FIELDS + 1] = f\n"
      "  VALUES[id] = { field = f, text = text }\n"
      "end\n";
  for (const DriveFieldListing& f : drive_field_listing(profiles))
    fmt::format_to(out, "value({0}, ProtoField.new({1}, {0}, {2}, nil, {3}, nil, {4}), {5})\n",
                   lua_string("drive." + f.id), lua_string(drive_field_label(f)),
                   lua_ftype(f.wireshark_type), lua_base(f.wireshark_base), lua_string(f.blurb),
                   f.kind == DriveFieldKind::text ? "true" : "false");
  // Findings: each protocol's typed ids as they are, the generic kinds as drivetap.<kind>; keyed
  // by the id the fields line gives.
  lua +=
      "\nlocal EXPERTS, EXPERT_LIST = {}, {}\n"
      "local function finding(id, abbrev, text, group, severity)\n"
      "  local e = ProtoExpert.new(abbrev, text, group, severity)\n"
      "  EXPERTS[id] = e\n"
      "  EXPERT_LIST[#EXPERT_LIST + 1] = e\n"
      "end\n";
  std::vector<std::string_view> listed;  // (the Modbus PDU's findings are both Modbus's)
  for (const ProtocolDesc* p : registered_protocols())
    for (const FindingDesc* d : p->findings)
      if (std::find(listed.begin(), listed.end(), d->id) == listed.end() &&
          (listed.push_back(d->id), true))
        fmt::format_to(out, "finding({}, {}, {}, expert.group.{}, expert.severity.{})\n",
                       lua_string(d->id), lua_string(expert_abbrev(d->id)),
                       lua_string(anomaly_label(d->kind)), expert_group(d->kind),
                       expert_severity(d->severity));
  for (std::size_t k = 0; k < kAnomalyKindCount; ++k) {
    const auto kind = static_cast<AnomalyKind>(k);
    fmt::format_to(out, "finding({}, {}, {}, expert.group.{}, expert.severity.{})\n",
                   lua_string(anomaly_id(kind)),
                   lua_string(fmt::format("drivetap.{}", anomaly_id(kind))),
                   lua_string(anomaly_label(kind)), expert_group(kind),
                   expert_severity(anomaly_severity(kind)));
  }
  lua += kDissectors;
  return lua;
}

}  // namespace drivetap::app
