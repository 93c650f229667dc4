// drivetap command line: the files drivetap puts into Wireshark's folders (README "Capture from
// Wireshark's dialog"), as a list of entries, each a file and the folder it goes to: installed
// and removed by `drivetap wireshark` and checked by its tests.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace drivetap::app {

// Wireshark's folders that drivetap puts files into.
struct WiresharkFolders {
  std::filesystem::path extcap;   // extcap programs
  std::filesystem::path plugins;  // Lua plugins
};

// One file for Wireshark: a symbolic link to `link_to` (the drivetap binary), or, when that is
// empty, a file holding `content` (with `executable`).
struct WiresharkEntry {
  std::filesystem::path folder;
  std::string name;
  std::filesystem::path link_to;
  std::string content;
  bool executable = false;
  [[nodiscard]] std::filesystem::path path() const { return folder / name; }
};

// The personal folders: extcaps under $XDG_CONFIG_HOME/wireshark (when absolute), else
// $HOME/.config/wireshark; Lua plugins in $HOME/.local/lib/wireshark/plugins (where Wireshark 4
// looks for them). Nullopt with *error when HOME is unset or relative.
std::optional<WiresharkFolders> personal_wireshark_folders(std::string* error);
// The system-wide folders `tshark -G folders` names ("Global Extcap path", "Extcap path" before
// 4.2; "Global Lua Plugins"), else Debian's under /usr/lib/x86_64-linux-gnu/wireshark.
WiresharkFolders system_wireshark_folders();

// What drivetap installs into `folders`: the extcap, drivetap-extcap, a link to `drivetap`; the
// Lua plugin, drivetap.lua, holding `plugin_lua`.
std::vector<WiresharkEntry> wireshark_entries(const WiresharkFolders& folders,
                                              const std::filesystem::path& drivetap,
                                              std::string plugin_lua);

// Puts each entry in place (its folder made, a file of the same name replaced by a rename, so
// that a failed write leaves the old file whole); one line per
// file to `report` ("extcap: PATH -> TARGET"). False with *error (naming the path) on the first
// failure.
bool install_wireshark_entries(const std::vector<WiresharkEntry>& entries,
                               std::vector<std::string>* report, std::string* error);
// Removes each entry that is there (a missing one is no error); one line per file removed.
bool uninstall_wireshark_entries(const std::vector<WiresharkEntry>& entries,
                                 std::vector<std::string>* report, std::string* error);

}  // namespace drivetap::app
