// drivetap command line: tshark's conventions (src/app/conventions.hpp).
#include "app/conventions.hpp"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <numeric>
#include <system_error>

#include "core/printable.hpp"

namespace drivetap::app {

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  std::iota(row.begin(), row.end(), std::size_t{0});
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string unknown_command_message(std::string_view word, const std::vector<std::string>& names) {
  const std::string shown = printable(word, false);
  std::string best;
  std::size_t best_distance = 3;  // a typo is one or two edits away; further is another word
  for (const std::string& name : names)
    if (const std::size_t d = edit_distance(word, name); d < best_distance) {
      best = name;
      best_distance = d;
    }
  if (!best.empty()) return fmt::format("unknown command '{}' (did you mean {}?)", shown, best);
  return fmt::format("unknown command '{}' (commands: {})", shown, fmt::join(names, ", "));
}

namespace {

namespace fs = std::filesystem;

fs::path device_root() {
  const char* root = std::getenv("DRIVETAP_DEVICE_ROOT");
  return root && *root ? fs::path(root) : fs::path("/");
}

// Whether the kernel found a UART behind /dev/ttySN (ttyS0..31 exist whether or not it did; the
// type of one without is 0, PORT_UNKNOWN). Read from sysfs: opening the port is not needed.
bool has_uart(const fs::path& root, const std::string& name) {
  std::ifstream type(root / "sys/class/tty" / name / "type");
  int value = 0;
  if (!(type >> value)) return true;  // no sysfs to ask: shown
  return value != 0;
}

// Orders ttyUSB2 before ttyUSB10.
bool port_before(const std::string& a, const std::string& b) {
  const auto split = [](const std::string& s) {
    const std::size_t digits = s.find_last_not_of("0123456789") + 1;
    return std::pair<std::string, unsigned long>(
        s.substr(0, digits), digits < s.size() ? std::stoul(s.substr(digits)) : 0ul);
  };
  return split(a) < split(b);
}

}  // namespace

int list_serial_ports() {
  const fs::path root = device_root();
  std::error_code ec;
  // Each /dev/serial/by-id name, by the device it points to.
  std::map<std::string, std::vector<std::string>> by_id;
  for (fs::directory_iterator it(root / "dev/serial/by-id", ec), end; !ec && it != end;
       it.increment(ec)) {
    std::error_code link_ec;
    const fs::path target = fs::read_symlink(it->path(), link_ec);
    if (!link_ec) by_id[target.filename().string()].push_back(it->path().filename().string());
  }
  std::vector<std::string> ports;
  for (fs::directory_iterator it(root / "dev", ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.starts_with("ttyUSB") || name.starts_with("ttyACM") ||
        (name.starts_with("ttyS") && has_uart(root, name)))
      ports.push_back(name);
  }
  if (ports.empty()) {
    std::fputs("drivetap: no serial ports found (/dev/ttyUSB*, /dev/ttyACM*, /dev/ttyS*)\n",
               stderr);
    return 1;
  }
  std::sort(ports.begin(), ports.end(), port_before);
  for (std::size_t k = 0; k < ports.size(); ++k) {
    std::string line = fmt::format("{}. /dev/{}", k + 1, ports[k]);
    if (const auto found = by_id.find(ports[k]); found != by_id.end()) {
      std::sort(found->second.begin(), found->second.end());
      line += fmt::format(" ({})", fmt::join(found->second, ", "));
    }
    std::printf("%s\n", printable(line, false).c_str());
  }
  return 0;
}

std::string parse_error_line(CLI::App& app, const CLI::ParseError& error,
                             const std::vector<std::string>& args) {
  CLI::App* command = nullptr;
  for (CLI::App* sub : app.get_subcommands()) command = sub;
  const std::string where = command ? command->get_name() + ": " : std::string();
  // An option the command does not know: named, with the commands that take it.
  if (command && error.get_exit_code() == static_cast<int>(CLI::ExitCodes::ExtrasError)) {
    bool after_command = false;
    for (const std::string& arg : args) {
      if (arg == command->get_name()) after_command = true;
      if (!after_command || arg.size() < 2 || arg[0] != '-' || arg == "--") continue;
      std::string name = arg.substr(0, arg.find('='));
      if (name.size() > 2 && name[1] != '-') name.resize(2);  // -c5
      if (command->get_option_no_throw(name)) continue;
      std::vector<std::string> takers;
      const std::function<bool(CLI::App*)> every;
      for (CLI::App* other : app.get_subcommands(every))
        if (other != command && other->get_option_no_throw(name))
          takers.push_back(other->get_name());
      if (takers.empty())
        return fmt::format("drivetap: {}unknown option {} (drivetap {} --help lists them)\n", where,
                           printable(name, false), command->get_name());
      return fmt::format("drivetap: {}{} does not apply to {} (it is for {})\n", where,
                         printable(name, false), command->get_name(), fmt::join(takers, ", "));
    }
  }
  std::string what = error.what();
  if (const std::size_t newline = what.find('\n'); newline != std::string::npos)
    what.resize(newline);
  return fmt::format("drivetap: {}{}\n", where, printable(what, false));
}

}  // namespace drivetap::app
