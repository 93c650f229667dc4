// `drivetap fields`: every field id, as `tshark -G fields` lists Wireshark's (docs/formats.md
// "Field ids"): a P line per protocol layer, then an F line per field, tab separated.
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "core/field.hpp"
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

void print_layer(const FieldProtocol& layer) {
  fmt::print("P\t{}\t{}\n", one_column(layer.name), layer.filter_name);
  for (const FieldDesc* d : layer.fields)
    fmt::print("F\t{}\t{}\t{}\t{}\t{}\t0x{:x}\t{}\n", one_column(d->name), d->id,
               wireshark_field_type(*d), layer.filter_name, wireshark_field_base(*d), d->bitmask,
               one_column(d->blurb));
}

// The drive values the built-in profiles give (`drive.*`), as the Wireshark plugin types them.
void print_drive_layer() {
  fmt::print("P\tdrivetap drive values\tdrive\n");
  for (const DriveFieldListing& f : drive_field_listing(loaded_drive_profiles(CommonOptions{})))
    fmt::print("F\t{}\tdrive.{}\t{}\tdrive\t{}\t0x0\t{}\n", one_column(f.name), f.id,
               f.wireshark_type, f.wireshark_base, one_column(f.blurb));
}

int run_fields() {
  print_layer(kRecordFieldProtocol);
  for (const FieldProtocol* layer : all_field_protocols()) print_layer(*layer);
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
