// drivetap's Wireshark plugin (Lua, Wireshark 4.0 and later), generated from drivetap's own tables
// (docs/formats.md "Packet comments", "drivetap's Wireshark plugin"): the dissectors the
// exported-PDU tags name (`danfoss_fc`, `easydrive`, `mbascii`) with a ProtoField per field id,
// and the `drivetap` postdissector with the findings as expert infos and the `drive.*` values.
#pragma once

#include <span>
#include <string>

#include "drive/profile.hpp"

namespace drivetap::app {

// The plugin's Lua text: every protocol Wireshark has no dissector of its own for, with every
// field of its layers (`drivetap fields`), every finding (typed ids and generic kinds), and the
// `drive.*` ids `profiles` can produce.
std::string wireshark_plugin_lua(std::span<const DriveProfile* const> profiles);

}  // namespace drivetap::app
