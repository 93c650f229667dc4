// `drivetap fields`: every field id, as `tshark -G fields` lists Wireshark's (docs/formats.md
// "Field ids"): a P line per protocol layer, then an F line per field, tab separated.
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <set>
#include <string>
#include <string_view>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "core/anomaly.hpp"
#include "core/field.hpp"
#include "core/protocol_desc.hpp"
#include "core/record_fields.hpp"
#include "drive/drive_fields.hpp"

namespace drivetap::app {
namespace {

// Tabs and line ends would split a line's columns: none of the texts has one, but a blurb is
// prose, so they are blanked rather than trusted.
std::string one_column(std::string_view text) {
  std::string out(text);
  for (char& c : out)
    if (c == '\t' || c == '\n' || c == '\r') c = ' ';
  return out;
}

// A finding's detail template as a blurb: its placeholders shown as "…".
std::string template_blurb(std::string_view text) {
  std::string out;
  for (std::size_t at = 0; at < text.size(); ++at) {
    if (text[at] == '{') {
      const std::size_t close = text.find('}', at);
      if (close != std::string_view::npos) {
        out += "…";
        at = close;
        continue;
      }
    }
    out += text[at];
  }
  return one_column(out);
}

// A layer's fields, then the typed findings whose ids it prefixes (as tshark lists a protocol's
// expert infos with its fields): a filter or -e name whose value is the finding's detail.
void print_layer(const FieldProtocol& layer, std::set<std::string_view>& findings_listed) {
  fmt::print("P\t{}\t{}\n", one_column(layer.name), layer.filter_name);
  for (const FieldDesc* d : layer.fields)
    fmt::print("F\t{}\t{}\t{}\t{}\t{}\t0x{:x}\t{}\n", one_column(d->name), d->id,
               wireshark_field_type(*d), layer.filter_name, wireshark_field_base(*d), d->bitmask,
               one_column(d->blurb));
  for (const ProtocolDesc* p : registered_protocols())
    for (const FindingDesc* f : p->findings) {
      const std::string_view id = f->id;
      if (!id.starts_with(layer.filter_name) || id.size() <= layer.filter_name.size() ||
          id[layer.filter_name.size()] != '.' || !findings_listed.insert(id).second)
        continue;
      fmt::print("F\tFinding: {} ({})\t{}\tFT_STRING\t{}\t\t0x0\t{}\n", anomaly_id(f->kind),
                 severity_id(f->severity), id, layer.filter_name, template_blurb(f->text));
    }
}

// The drive values the built-in profiles give (`drive.*`), as the Wireshark plugin types them.
void print_drive_layer() {
  fmt::print("P\tdrivetap drive values\tdrive\n");
  // (A value with a unit: its name says it, and drive.<id>.unit gives it as a column.)
  for (const DriveFieldListing& f : drive_field_listing(loaded_drive_profiles(CommonOptions{}))) {
    fmt::print("F\t{}\tdrive.{}\t{}\tdrive\t{}\t0x0\t{}\n", one_column(drive_field_label(f)), f.id,
               f.wireshark_type, f.wireshark_base, one_column(f.blurb));
    if (!f.unit.empty())
      fmt::print("F\t{} unit\tdrive.{}.unit\tFT_STRING\tdrive\t\t0x0\tAlways {}\n",
                 one_column(f.name), f.id, one_column(f.unit));
  }
}

int run_fields() {
  std::set<std::string_view> findings_listed;
  print_layer(kRecordFieldProtocol, findings_listed);
  for (const FieldProtocol* layer : all_field_protocols()) print_layer(*layer, findings_listed);
  print_drive_layer();
  return 0;
}

}  // namespace

Command add_fields_command(CLI::App& app) {
  CLI::App* fields = app.add_subcommand(
      "fields", "List every field id with its type and protocol, as tshark -G fields does");
  return {fields, [] { return run_fields(); }};
}

}  // namespace drivetap::app
