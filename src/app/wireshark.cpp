// `drivetap wireshark`: drivetap's Lua plugin printed, or the plugin and the extcap put where
// Wireshark looks for them, or taken away (README "drivetap in Wireshark"; docs/formats.md
// "drivetap's Wireshark plugin"; the extcap itself: src/app/extcap.cpp).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/wireshark_install.hpp"
#include "app/wireshark_plugin.hpp"
#include "core/printable.hpp"

namespace drivetap::app {
namespace {

struct WiresharkOptions {
  bool print_plugin = false;
  bool install = false;
  bool uninstall = false;
  bool system = false;
  CommonOptions profiles;  // --profile, --profile-dir: the drive ids the plugin knows
};

int run_wireshark(const WiresharkOptions& w) {
  if (w.print_plugin + w.install + w.uninstall != 1)
    die("wireshark: give one of --print-plugin, --install or --uninstall");
  if (w.system && w.print_plugin) die("--system: applies to --install and --uninstall");
  const std::string lua =
      w.uninstall ? std::string() : wireshark_plugin_lua(loaded_drive_profiles(w.profiles));
  if (w.print_plugin) {
    std::fwrite(lua.data(), 1, lua.size(), stdout);
    finish_stdout();
    return 0;
  }
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) die(fmt::format("wireshark: cannot tell where drivetap is: {}", ec.message()), 1);
  std::string error;
  std::optional<WiresharkFolders> personal;
  if (!w.system && !(personal = personal_wireshark_folders(&error))) die(error, 1);
  const WiresharkFolders folders = w.system ? system_wireshark_folders() : *personal;
  const std::vector<WiresharkEntry> entries = wireshark_entries(folders, self, lua);
  std::vector<std::string> report;
  const bool ok = w.install ? install_wireshark_entries(entries, &report, &error)
                            : uninstall_wireshark_entries(entries, &report, &error);
  for (const std::string& line : report)
    std::printf("%s %s\n", w.install ? "installed" : "removed", printable(line, false).c_str());
  if (!ok) die(error, 1);
  if (w.uninstall && report.empty())
    std::printf("nothing to remove in %s or %s\n",
                printable(folders.extcap.string(), false).c_str(),
                printable(folders.plugins.string(), false).c_str());
  if (w.install)
    std::printf(
        "Restart Wireshark (or Analyze > Reload Lua Plugins, Capture > Refresh Interfaces): "
        "drivetap's fields are there to filter on, and each serial port is listed as \"RS-485 "
        "tap PORT\"; tshark -D shows them too\n");
  finish_stdout();
  return 0;
}

}  // namespace

Command add_wireshark_command(CLI::App& app) {
  auto w = std::make_shared<WiresharkOptions>();
  CLI::App* cmd = app.add_subcommand(
      "wireshark",
      "drivetap in Wireshark: its Lua plugin (fields, findings, drive values) and its extcap "
      "(capture from Wireshark's dialog)");
  cmd->add_flag("--print-plugin", w->print_plugin,
                "Print the plugin (Lua, Wireshark 4.0 and later) generated from drivetap's tables");
  cmd->add_flag("--install", w->install,
                "Put the plugin into ~/.local/lib/wireshark/plugins and the extcap into "
                "$XDG_CONFIG_HOME or ~/.config/wireshark/extcap");
  cmd->add_flag("--uninstall", w->uninstall, "Remove what --install put there");
  cmd->add_flag("--system", w->system,
                "The system's folders instead (tshark -G folders; needs root)");
  cmd->add_option("--profile", w->profiles.profiles,
                  "Also know the drive.* ids of this drive profile (TOML; repeatable)");
  cmd->add_option("--profile-dir", w->profiles.profile_dirs,
                  "Also know the drive.* ids of every *.toml drive profile in DIR");
  return {cmd, [w] { return run_wireshark(*w); }};
}

}  // namespace drivetap::app
