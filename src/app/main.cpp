// drivetap command line: the subcommands registered, the one given parsed and run (README
// "Commands"; each subcommand is in its own file, src/app/commands.hpp).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/conventions.hpp"
#include "core/protocol_desc.hpp"

int main(int argc, char** argv) {
  using namespace drivetap::app;
  // A file size limit (ulimit -f) must fail the write (EFBIG) like a full disk, so that outputs
  // are cut back to whole packets and closed, rather than kill the process mid-packet. A reader
  // that went away (`| head`) fails the write too (EPIPE): the -w file is closed whole, then the
  // run ends as SIGPIPE would have ended it (finish_stdout()).
  std::signal(SIGXFSZ, SIG_IGN);
  std::signal(SIGPIPE, SIG_IGN);
  std::vector<char*> args(argv, argv + argc);
  // Wireshark running drivetap as an extcap (--extcap-interfaces, --capture, ...; or through a
  // link named drivetap-extcap): `drivetap extcap ...`.
  static char extcap_word[] = "extcap";
  if (wireshark_called(argc, argv)) args.insert(args.begin() + 1, extcap_word);
  // The short, tcpdump-like form: `drivetap -i /dev/ttyUSB0 -s "19200 8E1"` is a capture.
  static char capture_word[] = "capture";
  if (args.size() == static_cast<std::size_t>(argc) && argc > 1 &&
      (std::string_view(argv[1]) == "-i" || std::string_view(argv[1]) == "--interface" ||
       std::string_view(argv[1]).starts_with("-i/")))
    args.insert(args.begin() + 1, capture_word);
  // tshark's: `drivetap -r FILE ...` reads FILE (read takes -r too), `drivetap -D` lists ports.
  static char read_word[] = "read";
  if (args.size() == static_cast<std::size_t>(argc) && argc > 1 &&
      std::string_view(argv[1]).starts_with("-r"))
    args.insert(args.begin() + 1, read_word);
  if (argc == 2 &&
      (std::string_view(argv[1]) == "-D" || std::string_view(argv[1]) == "--list-interfaces"))
    return list_serial_ports();
  argc = static_cast<int>(args.size());
  argv = args.data();
  CLI::App app{fmt::format("drivetap: passive RS-485 bus analyser for drive networks ({})",
                           drivetap::protocol_labels_text())};
  app.require_subcommand(1);
  app.footer(
      "As tshark: drivetap -r FILE reads FILE, drivetap -i PORT captures, drivetap -D lists the "
      "serial ports. drivetap COMMAND --help lists the options of COMMAND.");
  app.set_version_flag("--version", "drivetap 0.1.0");
  // In the order `drivetap --help` lists them.
  const std::vector<Command> commands = {
      add_decode_command(app),  add_read_command(app),      add_diagnose_command(app),
      add_capture_command(app), add_generate_command(app),  add_profiles_command(app),
      add_fields_command(app),  add_wireshark_command(app), add_extcap_command(app),
      add_report_command(app),
  };
  // A first word that is no command and no option: the closest command is suggested.
  if (argc > 1 && argv[1][0] != '-') {
    std::vector<std::string> names;
    for (const Command& command : commands) names.push_back(command.given->get_name());
    if (std::find(names.begin(), names.end(), argv[1]) == names.end()) {
      say(unknown_command_message(argv[1], names));
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every command-line error is one line and exits 2 (CLI11's own
    // codes vary).
    if (e.get_exit_code() == 0) return app.exit(e);
    const std::string line =
        parse_error_line(app, e, std::vector<std::string>(argv + 1, argv + argc));
    std::fputs(line.c_str(), stderr);
    return 2;
  }
  int status = 2;
  try {
    for (const Command& command : commands)
      if (*command.given) status = command.run();
  } catch (const std::system_error& e) {
    // fmt::print's failed write to standard output (a listing's: `drivetap fields | head`): ended
    // as finish_stdout() ends any other, silently as SIGPIPE would for a reader that went away.
    if (!std::ferror(stdout) || e.code().category() != std::generic_category()) throw;
    if (e.code().value() == EPIPE) std::_Exit(128 + SIGPIPE);
    die(fmt::format("standard output: write failed: {}", e.code().message()), 1);
  }
  finish_stdout();
  return status;
}
