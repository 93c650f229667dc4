// `drivetap wireshark`: drivetap's Wireshark plugin printed or installed (docs/formats.md
// "drivetap's Wireshark plugin"; the plugin itself: src/app/wireshark_plugin.*).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <string>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/wireshark_plugin.hpp"

namespace drivetap::app {
namespace {

struct WiresharkOptions {
  bool print_plugin = false;
  bool install = false;
  CommonOptions profiles;  // --profile, --profile-dir: the drive ids the plugin knows
};

int run_wireshark(const WiresharkOptions& w) {
  if (w.print_plugin == w.install) die("wireshark: give --print-plugin or --install");
  const std::string lua = wireshark_plugin_lua(loaded_drive_profiles(w.profiles));
  if (w.print_plugin) {
    std::fwrite(lua.data(), 1, lua.size(), stdout);
    finish_stdout();
    return 0;
  }
  std::string error;
  const std::string path = install_wireshark_plugin(lua, &error);
  if (path.empty()) die(fmt::format("--install: {}", error), 1);
  std::printf("%s\n", path.c_str());
  finish_stdout();
  return 0;
}

}  // namespace

Command add_wireshark_command(CLI::App& app) {
  auto w = std::make_shared<WiresharkOptions>();
  CLI::App* cmd = app.add_subcommand(
      "wireshark", "drivetap's Wireshark plugin (Lua): decodes its pcapng's comments into fields");
  cmd->add_flag("--print-plugin", w->print_plugin,
                "Print the plugin (Lua, Wireshark 4.0 and later) generated from drivetap's tables");
  cmd->add_flag("--install", w->install,
                "Write the plugin to ~/.local/lib/wireshark/plugins/drivetap.lua (HOME's)");
  cmd->add_option("--profile", w->profiles.profiles,
                  "Also know the drive.* ids of this drive profile (TOML; repeatable)");
  cmd->add_option("--profile-dir", w->profiles.profile_dirs,
                  "Also know the drive.* ids of every *.toml drive profile in DIR");
  return {cmd, [w] { return run_wireshark(*w); }};
}

}  // namespace drivetap::app
