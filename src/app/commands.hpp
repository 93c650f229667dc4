// drivetap command line: the subcommands (README "Commands"). Each registers its own
// options on the command line and says how it runs; main() parses and runs the one given.
#pragma once

#include <functional>
#include <string>

namespace CLI {
class App;
}

namespace drivetap::app {

// One registered subcommand: run() when `given` was on the command line; it returns the exit
// status.
struct Command {
  CLI::App* given = nullptr;
  std::function<int()> run;
};

struct CommonOptions;

// A subcommand that takes the common options and one capture file (read, diagnose).
Command add_file_command(CLI::App& app, const std::string& name, const std::string& description,
                         const std::string& file_help,
                         int (*run)(const CommonOptions& o, const std::string& path));

Command add_decode_command(CLI::App& app);     // decode.cpp: frames given as hex
Command add_read_command(CLI::App& app);       // read.cpp: a capture file
Command add_diagnose_command(CLI::App& app);   // diagnose.cpp: the line's health
Command add_capture_command(CLI::App& app);    // capture.cpp: live from serial ports, --scan
Command add_generate_command(CLI::App& app);   // generate.cpp: a large reproducible capture
Command add_profiles_command(CLI::App& app);   // profiles.cpp: list and check drive profiles
Command add_fields_command(CLI::App& app);     // fields.cpp: every field id (tshark -G fields)
Command add_report_command(CLI::App& app);     // report.cpp: a capture drawn as an HTML page
Command add_wireshark_command(CLI::App& app);  // wireshark.cpp: install the extcap for Wireshark
Command add_extcap_command(CLI::App& app);     // extcap.cpp: what Wireshark runs to capture

// Whether Wireshark runs this program as an extcap (extcap.cpp): its arguments (--capture,
// --extcap-*) or the name drivetap-extcap.
bool wireshark_called(int argc, char** argv);

}  // namespace drivetap::app
