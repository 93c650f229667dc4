// drivetap command line, what a tshark user expects of it: `-r FILE` for `read FILE`, `-D` to list
// the serial ports, a misspelt command answered with the closest one, and command-line errors as
// one line naming the option (docs/reference.md "Command line").
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace CLI {
class App;
class ParseError;
}  // namespace CLI

namespace drivetap::app {

// The edit distance (insertions, deletions, substitutions) between two words.
std::size_t edit_distance(std::string_view a, std::string_view b);
// The message for a first argument that is no command: the closest command when one is near.
std::string unknown_command_message(std::string_view word, const std::vector<std::string>& names);

// `drivetap -D`: the serial ports that exist (/dev/ttyUSB*, ttyACM*, ttyS* with a UART behind),
// numbered, with their /dev/serial/by-id names. Returns the exit status (1: none found).
// DRIVETAP_DEVICE_ROOT replaces "/" as the root of /dev and /sys (for tests).
int list_serial_ports();

// A command-line error as one line, "drivetap: ...": an option the command does not take is
// named with the commands that do take it.
std::string parse_error_line(CLI::App& app, const CLI::ParseError& error,
                             const std::vector<std::string>& args);

}  // namespace drivetap::app
