// drivetap command line: the files drivetap puts into Wireshark's folders
// (src/app/wireshark_install.hpp).
#include "app/wireshark_install.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <string_view>
#include <system_error>
#include <utility>

namespace drivetap::app {

namespace fs = std::filesystem;

namespace {

// Whether `ec` holds a failure; if so, `error` says which path it was and what could not be done.
bool failed(const std::error_code& ec, const fs::path& path, std::string_view what,
            std::string* error) {
  if (!ec) return false;
  *error = fmt::format("{}: cannot {}: {}", path.string(), what, ec.message());
  return true;
}

// Puts `entry` in place: the line to report, or nullopt with *error.
std::optional<std::string> install_entry(const WiresharkEntry& entry, std::string* error) {
  const fs::path path = entry.path();
  std::error_code ec;
  fs::create_directories(entry.folder, ec);
  if (failed(ec, entry.folder, "create", error)) return std::nullopt;
  // Made whole beside the old one, then renamed over it: a failed write (a full disk, a file-size
  // limit) leaves the old file as it was and no truncated plugin for Wireshark to load.
  const fs::path made = entry.folder / ("." + entry.name + ".new");
  fs::remove(made, ec);
  ec.clear();
  if (!entry.link_to.empty()) {
    fs::create_symlink(entry.link_to, made, ec);
    if (failed(ec, path, "create", error)) return std::nullopt;
  } else {
    std::ofstream out(made, std::ios::binary);
    out << entry.content;
    out.flush();
    out.close();
    if (!out) {
      fs::remove(made, ec);
      *error = fmt::format("{}: cannot write", path.string());
      return std::nullopt;
    }
    if (entry.executable)
      fs::permissions(made, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                      fs::perm_options::add, ec);
  }
  fs::rename(made, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(made, ignored);
  }
  if (failed(ec, path, "replace", error)) return std::nullopt;
  return entry.link_to.empty() ? path.string()
                               : fmt::format("{} -> {}", path.string(), entry.link_to.string());
}

// Removes `entry` if it is there: the line to report (empty: it was not there), or nullopt with
// *error.
std::optional<std::string> remove_entry(const WiresharkEntry& entry, std::string* error) {
  const fs::path path = entry.path();
  std::error_code ec;
  if (!fs::is_symlink(path, ec) && !fs::exists(path, ec)) return std::string();
  if (!fs::remove(path, ec) || ec) {
    *error = fmt::format("{}: cannot remove: {}", path.string(), ec.message());
    return std::nullopt;
  }
  return path.string();
}

// Makes `change` to each entry in turn, its lines added to `report`, until one fails.
bool change_entries(const std::vector<WiresharkEntry>& entries,
                    std::optional<std::string> (*change)(const WiresharkEntry&, std::string*),
                    std::vector<std::string>* report, std::string* error) {
  for (const WiresharkEntry& entry : entries) {
    const std::optional<std::string> done = change(entry, error);
    if (!done) return false;
    if (!done->empty()) report->push_back(*done);
  }
  return true;
}

}  // namespace

std::optional<WiresharkFolders> personal_wireshark_folders(std::string* error) {
  const char* home = std::getenv("HOME");
  if (!home || !*home || fs::path(home).is_relative()) {
    *error = fmt::format("wireshark: HOME is {}: the personal folders need an absolute home "
                         "(or use --system)",
                         home && *home ? fmt::format("'{}', not an absolute path", home) : "unset");
    return std::nullopt;
  }
  const fs::path home_path(home);
  fs::path config = home_path / ".config" / "wireshark";
  // (A relative XDG_CONFIG_HOME is invalid, as the XDG spec says: ignored.)
  if (const char* xdg = std::getenv("XDG_CONFIG_HOME"); xdg && *xdg && fs::path(xdg).is_absolute())
    config = fs::path(xdg) / "wireshark";
  return WiresharkFolders{config / "extcap", home_path / ".local" / "lib" / "wireshark" / "plugins"};
}

WiresharkFolders system_wireshark_folders() {
  WiresharkFolders folders{"/usr/lib/x86_64-linux-gnu/wireshark/extcap",
                           "/usr/lib/x86_64-linux-gnu/wireshark/plugins"};
  // (tshark prints its folders as "Name:<TAB>path"; stderr only warns about running as root.)
  std::FILE* tshark = ::popen("tshark -G folders 2>/dev/null", "r");
  if (!tshark) return folders;
  char line[4096];
  while (std::fgets(line, sizeof line, tshark)) {
    std::string text(line);
    while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
    const std::size_t colon = text.find(':');
    if (colon == std::string::npos) continue;
    const std::string name = text.substr(0, colon);
    const std::size_t start = text.find_first_not_of(" \t", colon + 1);
    if (start == std::string::npos) continue;
    if (name == "Global Extcap path" || name == "Extcap path") folders.extcap = text.substr(start);
    if (name == "Global Lua Plugins") folders.plugins = text.substr(start);
  }
  ::pclose(tshark);
  return folders;
}

std::vector<WiresharkEntry> wireshark_entries(const WiresharkFolders& folders,
                                              const fs::path& drivetap, std::string plugin_lua) {
  std::vector<WiresharkEntry> entries;
  // A link, not a copy: the extcap is the drivetap installed, and stays its version. The name
  // tells drivetap it runs as an extcap.
  WiresharkEntry extcap;
  extcap.folder = folders.extcap;
  extcap.name = "drivetap-extcap";
  extcap.link_to = drivetap;
  entries.push_back(extcap);
  // The plugin is a copy: generated from this drivetap's tables and profiles.
  WiresharkEntry plugin;
  plugin.folder = folders.plugins;
  plugin.name = "drivetap.lua";
  plugin.content = std::move(plugin_lua);
  entries.push_back(std::move(plugin));
  return entries;
}

bool install_wireshark_entries(const std::vector<WiresharkEntry>& entries,
                               std::vector<std::string>* report, std::string* error) {
  return change_entries(entries, install_entry, report, error);
}

bool uninstall_wireshark_entries(const std::vector<WiresharkEntry>& entries,
                                 std::vector<std::string>* report, std::string* error) {
  return change_entries(entries, remove_entry, report, error);
}

}  // namespace drivetap::app
