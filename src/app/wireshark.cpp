// `drivetap wireshark`: puts drivetap's extcap where Wireshark looks for it, or takes it away
// (README "Capture from Wireshark's dialog"; the extcap itself: src/app/extcap.cpp).
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
#include "core/printable.hpp"

namespace drivetap::app {
namespace {

struct WiresharkOptions {
  bool install = false;
  bool uninstall = false;
  bool system = false;
};

int run_wireshark(const WiresharkOptions& w) {
  if (w.install == w.uninstall) die("wireshark: give --install or --uninstall");
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) die(fmt::format("wireshark: cannot tell where drivetap is: {}", ec.message()), 1);
  const WiresharkFolders folders =
      w.system ? system_wireshark_folders() : personal_wireshark_folders();
  const std::vector<WiresharkEntry> entries = wireshark_entries(folders, self);
  std::vector<std::string> report;
  std::string error;
  const bool ok = w.install ? install_wireshark_entries(entries, &report, &error)
                            : uninstall_wireshark_entries(entries, &report, &error);
  for (const std::string& line : report)
    std::printf("%s %s\n", w.install ? "installed" : "removed", printable(line, false).c_str());
  if (!ok) die(error, 1);
  if (w.uninstall && report.empty())
    std::printf("nothing to remove in %s\n", printable(folders.extcap.string(), false).c_str());
  if (w.install)
    std::printf(
        "Wireshark lists each serial port as \"RS-485 tap PORT\" (restart it, or Capture > "
        "Refresh Interfaces); tshark -D shows them too\n");
  return 0;
}

}  // namespace

Command add_wireshark_command(CLI::App& app) {
  auto w = std::make_shared<WiresharkOptions>();
  CLI::App* wireshark = app.add_subcommand(
      "wireshark", "Install drivetap as a Wireshark extcap (capture from Wireshark's dialog)");
  wireshark->add_flag("--install", w->install,
                      "Put the extcap into your Wireshark folder ($XDG_CONFIG_HOME or "
                      "~/.config/wireshark/extcap)");
  wireshark->add_flag("--uninstall", w->uninstall, "Remove what --install put there");
  wireshark->add_flag("--system", w->system,
                      "The system's extcap folder instead (tshark -G folders; needs root)");
  return {wireshark, [w] { return run_wireshark(*w); }};
}

}  // namespace drivetap::app
