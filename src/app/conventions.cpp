// drivetap command line: tshark's conventions (src/app/conventions.hpp).
#include "app/conventions.hpp"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <numeric>

#include "core/printable.hpp"
#include "sources/live/port_list.hpp"

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

int list_serial_ports() {
  const std::vector<SerialPortEntry> ports = find_serial_ports();
  if (ports.empty()) {
    std::fputs("drivetap: no serial ports found (/dev/ttyUSB*, /dev/ttyACM*, /dev/ttyS*)\n",
               stderr);
    return 1;
  }
  for (std::size_t k = 0; k < ports.size(); ++k) {
    std::string line = fmt::format("{}. {}", k + 1, ports[k].path);
    if (!ports[k].by_id.empty()) line += fmt::format(" ({})", fmt::join(ports[k].by_id, ", "));
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
