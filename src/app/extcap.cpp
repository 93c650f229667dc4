// `drivetap extcap`: drivetap as a Wireshark extcap program, so that Wireshark's capture dialog
// captures an RS-485 tap live (docs/reference.md "Capture from Wireshark's dialog"; the bus and
// its settings: docs/protocols.md §1, §2). Wireshark runs it in four ways: --extcap-interfaces
// (the serial ports), --extcap-dlts, --extcap-config (the options of the dialog) and --capture
// --fifo PATH (the pcapng of `drivetap capture -w`, through the same capture run).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <fcntl.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "app/capture.hpp"
#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/stop_signals.hpp"
#include "core/printable.hpp"
#include "core/protocol_desc.hpp"
#include "sources/live/port_list.hpp"

namespace drivetap::app {
namespace {

// What Wireshark passes, and the options --extcap-config offers in its dialog.
struct ExtcapOptions {
  bool list_interfaces = false;   // --extcap-interfaces
  std::string wireshark_version;  // --extcap-version
  std::string interface;          // --extcap-interface
  bool list_dlts = false;         // --extcap-dlts
  bool config = false;            // --extcap-config
  std::string reload_option;      // --extcap-reload-option
  bool capture = false;           // --capture
  std::string fifo;               // --fifo
  std::string capture_filter;     // --extcap-capture-filter
  std::string control_in, control_out;
  bool debug = false;
  std::string debug_file;
  // The dialog's options, each mapped to `drivetap capture`'s own.
  std::string baud;         // -s, first half
  std::string line_format;  // -s, second half: 8N1, 8E1, ...
  bool detect = false;      // the settings found by capture --scan's search instead
  std::string protocol;     // -P
  std::string drives;       // --drive, several separated by spaces or commas
  std::string t35;          // --t35
  std::string timeout;      // --timeout
  std::string second_port;  // a second -i: the slave pair of a 4-wire link
};

constexpr std::string_view kVersion = "0.1.0";
constexpr int kLoggerControl = 0;  // the "Log" button of the interface toolbar

// Text shown in Wireshark's `{key=value}` sentences (a display, a tooltip): one line of printable
// UTF-8 (a newline would end the sentence, invalid UTF-8 makes Wireshark drop it), its braces
// shown as parentheses.
std::string sentence_value(std::string_view text) {
  std::string out;
  for (char ch : printable(text, false)) out += ch == '{' ? '(' : ch == '}' ? ')' : ch;
  return out;
}

// Whether Wireshark reads `value` back from `{value=...}` as it is, to hand it to
// --extcap-interface: printable UTF-8 on one line, and no '}' that its sentence parser takes
// for the end (one followed by '{' or by white space; extcap_parser.c).
bool survives_sentence(std::string_view value) {
  if (printable(value, false) != value) return false;
  for (std::size_t k = 0; k + 1 < value.size(); ++k)
    if (value[k] == '}' &&
        (value[k + 1] == '{' || std::isspace(static_cast<unsigned char>(value[k + 1]))))
      return false;
  return true;
}

// An interface name as a port: a path as it is (a /dev path under DRIVETAP_DEVICE_ROOT, as
// --extcap-interfaces listed it); a bare name (ttyUSB0) in /dev.
std::string port_of(const std::string& interface) {
  const std::filesystem::path root = device_root();
  if (interface.starts_with("/dev/") && root != "/") return (root / interface.substr(1)).string();
  if (interface.empty() || interface.front() == '/') return interface;
  return (root / "dev" / interface).string();
}

int print_interfaces() {
  fmt::print("extcap {{version={}}}{{display=drivetap RS-485 bus tap}}\n", kVersion);
  for (const SerialPortEntry& port : find_serial_ports()) {
    if (!survives_sentence(port.path)) {
      // (A changed name could not be captured: Wireshark would hand it back changed.)
      say(
          fmt::format("{}: not listed for Wireshark: its name cannot pass through an extcap "
                      "sentence unchanged (capture it with drivetap capture -i)",
                      printable(port.path)));
      continue;
    }
    std::string display = "RS-485 tap " + port.path;
    if (!port.by_id.empty()) display += fmt::format(" ({})", fmt::join(port.by_id, ", "));
    fmt::print("interface {{value={}}}{{display={}}}\n", port.path, sentence_value(display));
  }
  // The toolbar's log: what drivetap says about the port (a slow USB latency timer, ...).
  // Declaring a control also makes Wireshark pass the control pipes, which carry the status bar.
  std::printf(
      "control {number=%d}{type=button}{role=logger}{display=Log}{tooltip=drivetap's notes on "
      "the port and the line}\n",
      kLoggerControl);
  return 0;
}

int print_dlts() {
  std::printf(
      "dlt {number=252}{name=WIRESHARK_UPPER_PDU}{display=drivetap frames (exported PDU: Modbus "
      "RTU through Wireshark's dissector)}\n");
  return 0;
}

int print_config() {
  int number = 0;
  const auto arg = [&number](std::string_view call, std::string_view display, std::string_view type,
                             std::string_view rest) {
    fmt::print("arg {{number={}}}{{call={}}}{{display={}}}{{type={}}}{}\n", number, call, display,
               type, rest);
    return number++;
  };
  const auto value = [](int a, std::string_view v, std::string_view display, bool is_default) {
    fmt::print("value {{arg={}}}{{value={}}}{{display={}}}{{default={}}}\n", a, v,
               sentence_value(display), is_default ? "true" : "false");
  };
  // (Wireshark 4.0 has no editable selector: a number field takes any integer rate.)
  arg("--baud", "Baud rate", "unsigned",
      "{range=50,4000000}{default=9600}{tooltip=Any integer rate: 1200, 2400, 4800, 9600, "
      "19200, 38400, 57600, 115200, ... (-s)}{group=Line}");
  const int format = arg("--line-format", "Data bits, parity, stop bits", "selector",
                         "{tooltip=The character format (-s)}{group=Line}");
  value(format, "8N1", "8N1 (no parity)", true);
  value(format, "8E1", "8E1 (even parity: the Modbus default)", false);
  value(format, "8O1", "8O1 (odd parity)", false);
  value(format, "8N2", "8N2 (no parity, 2 stop bits)", false);
  value(format, "7E1", "7E1 (Modbus ASCII)", false);
  value(format, "7O1", "7O1", false);
  value(format, "7N2", "7N2", false);
  arg("--detect", "Detect the line settings", "boolflag",
      "{default=false}{tooltip=Listen a quarter of a second at each standard rate and format (48 "
      "settings, 12 s, as capture --scan) and capture with the one that gives good checksums (the "
      "first tried of those it cannot tell apart, the log says which); the rate and format above "
      "are then not used}{group=Line}");
  const int protocol = arg("--protocol", "Protocol", "selector",
                           "{tooltip=The protocol on the bus (-P)}{group=Decoding}");
  value(protocol, "auto", "detected from the first frames", true);
  for (const ProtocolDesc* d : registered_protocols())
    value(protocol, d->option_names.front(), d->label, false);
  arg("--drive", "Drive bindings", "string",
      "{default=auto}{tooltip=auto (guess each station's drive family), none, or ADDRESS=FAMILY "
      "bindings separated by spaces, e.g. 2=e9 3=erg (--drive; drivetap profiles lists the "
      "families)}{group=Decoding}");
  arg("--t35", "Frame silence t3.5", "string",
      "{placeholder=3.5c}{tooltip=Silence between frames: 3.5c, 1750us, 2ms (--t35; default "
      "Modbus's)}{validation=^([0-9.]+(c|us|ms|s))?$}{group=Timing}");
  arg("--timeout", "Reply timeout", "string",
      "{default=1s}{tooltip=A request unanswered this long is reported timeout "
      "(--timeout)}{validation=^([0-9.]+(us|ms|s))?$}{group=Timing}");
  std::vector<std::string> ports;
  for (const SerialPortEntry& port : find_serial_ports()) ports.push_back(port.path);
  arg("--second-port", "Second port (4-wire)", "string",
      fmt::format("{{placeholder=none (2-wire bus)}}{{tooltip=The port on the slave pair of a "
                  "4-wire link: this interface is then the master pair, both merged on one link "
                  "(ports here: {})}}{{group=4-wire}}",
                  sentence_value(ports.empty() ? std::string("none")
                                               : fmt::format("{}", fmt::join(ports, ", ")))));
  return 0;
}

// Wireshark's control pipe out of the extcap (--extcap-control-out): messages for the status
// bar and the toolbar's log. Each is the sync pipe header ('T', a 3-byte big-endian length),
// the control number, the command and the payload. Opened without blocking and written without
// blocking: tshark declares the pipe but never reads it, and a message that does not fit is
// dropped rather than stall the capture.
class ControlPipe {
 public:
  enum Command : std::uint8_t { add = 2, statusbar = 6 };
  explicit ControlPipe(std::string path) : path_(std::move(path)) {}
  ControlPipe(const ControlPipe&) = delete;
  ControlPipe& operator=(const ControlPipe&) = delete;
  ~ControlPipe() {
    if (fd_ >= 0) ::close(fd_);
  }

  void send(std::uint8_t control, Command command, std::string_view payload) {
    if (path_.empty()) return;
    std::string message = "T";
    const std::size_t length = payload.size() + 2;
    message += static_cast<char>((length >> 16) & 0xff);
    message += static_cast<char>((length >> 8) & 0xff);
    message += static_cast<char>(length & 0xff);
    message += static_cast<char>(control);
    message += static_cast<char>(command);
    message += payload;
    waiting_.push_back(std::move(message));
    if (waiting_.size() > 64) waiting_.pop_front();
    write_waiting();
  }
  // Messages sent before Wireshark opened its end go out once it has.
  void write_waiting() {
    if (fd_ < 0) fd_ = ::open(path_.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
    while (fd_ >= 0 && !waiting_.empty()) {
      const std::string& m = waiting_.front();
      const ssize_t n = ::write(fd_, m.data(), m.size());
      if (n < 0 && errno == EAGAIN) return;
      // (A pipe write of at most PIPE_BUF bytes is all or nothing.)
      waiting_.pop_front();
      if (n < 0) {
        ::close(fd_);
        fd_ = -1;
        path_.clear();  // the reader is gone: nothing more to say
        waiting_.clear();
      }
    }
  }

 private:
  std::string path_;
  int fd_ = -1;
  std::deque<std::string> waiting_;
};

// Wireshark's control pipe into the extcap: drained and ignored (drivetap's toolbar has only
// the log), but opened, since Wireshark writes its first message to it when the capture starts.
class ControlInput {
 public:
  explicit ControlInput(const std::string& path) {
    if (!path.empty()) fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  }
  ControlInput(const ControlInput&) = delete;
  ControlInput& operator=(const ControlInput&) = delete;
  ~ControlInput() {
    if (fd_ >= 0) ::close(fd_);
  }
  void drain() const {
    char buffer[512];
    while (fd_ >= 0 && ::read(fd_, buffer, sizeof buffer) > 0) continue;
  }

 private:
  int fd_ = -1;
};

// A capture that fails before it opened its FIFO (a missing port, a bad option) must still open
// and close it: Wireshark's reader waits in open() until a writer comes, and would never see the
// error. At exit, the FIFO is opened without blocking for a few seconds (until the reader is
// there) and closed at once; the reader sees an empty stream and Wireshark shows the error line.
std::string g_unopened_fifo;  // empty once the outputs opened it
void release_unopened_fifo() {
  if (g_unopened_fifo.empty()) return;
  for (int attempt = 0; attempt < 60; ++attempt) {
    const int fd = ::open(g_unopened_fifo.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd >= 0) {
      ::close(fd);
      return;
    }
    if (errno != ENXIO) return;  // no FIFO there (not Wireshark's): nothing waits
    ::usleep(50'000);
  }
}

std::vector<std::string> split_drives(const std::string& text) {
  std::vector<std::string> drives;
  std::string word;
  for (char ch : text + " ") {
    if (ch == ' ' || ch == ',' || ch == '\t') {
      if (!word.empty()) drives.push_back(word);
      word.clear();
    } else {
      word += ch;
    }
  }
  return drives;
}

// `--capture --fifo PATH`: `drivetap capture -i PORT -w PATH` with the dialog's options, quiet
// on stderr unless something fails (Wireshark shows whatever an extcap writes there as an error),
// counts on the status bar. SIGTERM (Wireshark's stop) and the reader going away end it with
// exit 0 and the stream whole.
int run_extcap_capture(const ExtcapOptions& e) {
  if (e.fifo.empty()) die("--capture: --fifo PATH is missing (Wireshark passes it)");
  if (e.interface.empty()) die("--capture: --extcap-interface PORT is missing");
  if (!e.capture_filter.empty())
    die("capture filters are not supported: use a display filter (drivetap captures every frame)");
  g_unopened_fifo = e.fifo;
  std::atexit(release_unopened_fifo);
  CommonOptions o;
  if (!e.baud.empty() || !e.line_format.empty())
    o.serial = fmt::format("{} {}", e.baud.empty() ? "9600" : e.baud,
                           e.line_format.empty() ? "8N1" : e.line_format);
  if (!e.protocol.empty() && e.protocol != "auto") {
    if (protocol_from_option(e.protocol) == Protocol::unknown) {
      std::vector<std::string_view> names;
      for (const ProtocolDesc* d : registered_protocols()) names.push_back(d->option_names.front());
      die(fmt::format("--protocol {}: not a protocol (auto, {})", printable(e.protocol, false),
                      fmt::join(names, ", ")),
          2);
    }
    o.protocol = e.protocol;
  }
  o.drives = split_drives(e.drives);
  o.t35 = e.t35;
  o.timeout = e.timeout;
  o.write = e.fifo;
  // The decode goes to the packets' comments; the text output is not wanted.
  o.output = "/dev/null";
  o.stats_only = true;
  CaptureOptions c;
  const std::string port = port_of(e.interface);
  if (e.second_port.empty()) {
    c.ports = {port};
  } else {
    // (run_capture refuses one port by two names too)
    if (port_of(e.second_port) == port)
      die(fmt::format("--second-port {}: the same port as --extcap-interface",
                      printable(e.second_port, false)),
          2);
    c.ports = {port + "=line.m", port_of(e.second_port) + "=line.s"};
  }
  ControlPipe control(e.control_out);
  ControlInput control_in(e.control_in);
  if (e.detect) {
    if (!e.second_port.empty()) die("--detect: only with one port (not with --second-port)");
    catch_stop_signals();
    const ScanVerdict verdict = scan_line_settings(o, port, 0.25, [&](const ScanResult& r) {
      control_in.drain();
      control.send(0, ControlPipe::statusbar,
                   fmt::format("drivetap: detecting the line settings: {} gave {} good frames",
                               r.serial.to_string(), r.frames_ok));
    });
    if (g_stop) return 0;
    if (verdict.best.empty())
      die(fmt::format("{}: no standard setting gave a frame with a good checksum (check the "
                      "wiring, or set the rate and format)",
                      port),
          1);
    // A tie captures with the first tried (a capture needs one), and the log says it was a tie.
    o.serial = verdict.best.front().serial.to_string();
    control.send(
        kLoggerControl, ControlPipe::add,
        fmt::format("detected {}: {} frames with a good checksum{}\n", o.serial,
                    verdict.best.front().frames_ok,
                    verdict.untold.empty() ? "" : " (first of a tie; " + verdict.untold + ")"));
  }
  CaptureVoice voice;
  voice.chatty = false;
  voice.outputs_open = [] { g_unopened_fifo.clear(); };
  voice.reader_may_leave = true;
  voice.warning = [&control](const std::string& warning) {
    control.send(kLoggerControl, ControlPipe::add, "warning: " + warning + "\n");
  };
  auto last_status = std::chrono::steady_clock::time_point{};
  std::uint64_t last_frames = ~std::uint64_t{0}, last_noise = 0;
  voice.each_round = [&](const Stats& stats) {
    control_in.drain();
    control.write_waiting();
    const auto now = std::chrono::steady_clock::now();
    if (now - last_status < std::chrono::milliseconds(500)) return;
    if (stats.frames == last_frames && stats.noise_records == last_noise) return;
    last_status = now;
    last_frames = stats.frames;
    last_noise = stats.noise_records;
    const std::uint64_t ok = stats.checksum[static_cast<std::size_t>(ChecksumVerdict::good)];
    control.send(0, ControlPipe::statusbar,
                 fmt::format("drivetap: {} frames ({} checksum ok), {} findings, {} noise records",
                             stats.frames, ok, stats.anomaly_total, stats.noise_records));
  };
  control.send(kLoggerControl, ControlPipe::add,
               fmt::format("capturing on {} at {} (listen only)\n", fmt::join(c.ports, ", "),
                           o.serial.empty() ? "9600 8N1" : o.serial));
  const int status = run_capture(o, c, voice);
  return status == 130 ? 0 : status;
}

}  // namespace

bool wireshark_called(int argc, char** argv) {
  if (argc < 1) return false;
  const std::string_view self = argv[0];
  const std::size_t slash = self.rfind('/');
  const std::string_view name = slash == std::string_view::npos ? self : self.substr(slash + 1);
  if (name == "drivetap-extcap") return argc < 2 || std::string_view(argv[1]) != "extcap";
  if (argc < 2 || argv[1][0] != '-') return false;  // a subcommand named
  for (int k = 1; k < argc; ++k) {
    const std::string_view arg = argv[k];
    if (arg == "--capture" || arg.starts_with("--extcap-")) return true;
  }
  return false;
}

Command add_extcap_command(CLI::App& app) {
  auto e = std::make_shared<ExtcapOptions>();
  CLI::App* extcap = app.add_subcommand(
      "extcap",
      "Act as a Wireshark extcap program (Wireshark runs it; `drivetap wireshark --install` "
      "puts it where Wireshark looks)");
  extcap->add_flag("--extcap-interfaces", e->list_interfaces, "List the serial ports");
  extcap->add_option("--extcap-version", e->wireshark_version, "Wireshark's version");
  extcap->add_option("--extcap-interface", e->interface, "The port (a path or a name in /dev)");
  extcap->add_flag("--extcap-dlts", e->list_dlts, "List the link type of --extcap-interface");
  extcap->add_flag("--extcap-config", e->config, "List the options of the capture dialog");
  extcap->add_option("--extcap-reload-option", e->reload_option, "Unused");
  extcap->add_flag("--capture", e->capture, "Capture to --fifo");
  extcap->add_option("--fifo", e->fifo, "Where the pcapng goes");
  extcap->add_option("--extcap-capture-filter", e->capture_filter,
                     "A capture filter (none is supported)");
  extcap->add_option("--extcap-control-in", e->control_in, "Wireshark's control pipe in");
  extcap->add_option("--extcap-control-out", e->control_out,
                     "Wireshark's control pipe out (status bar, log)");
  extcap->add_flag("--debug", e->debug, "Unused");
  extcap->add_option("--debug-file", e->debug_file, "Unused");
  extcap->add_option("--baud", e->baud, "Baud rate (the first half of capture's -s)");
  extcap->add_option("--line-format", e->line_format, "8N1, 8E1, ... (the second half of -s)");
  extcap->add_flag("--detect", e->detect, "Find the line settings first, as capture --scan");
  extcap->add_option("--protocol", e->protocol, "As capture's -P");
  extcap->add_option("--drive", e->drives, "As capture's --drive, several separated by spaces");
  extcap->add_option("--t35", e->t35, "As capture's --t35");
  extcap->add_option("--timeout", e->timeout, "As capture's --timeout");
  extcap->add_option("--second-port", e->second_port,
                     "The slave pair's port of a 4-wire link (a second -i)");
  return {extcap, [e] {
            if (e->list_interfaces) return print_interfaces();
            if (e->list_dlts) return print_dlts();
            if (e->config) return print_config();
            if (e->capture) return run_extcap_capture(*e);
            if (!e->capture_filter.empty()) {
              // Wireshark checks a capture filter this way: any output marks it invalid.
              std::printf("drivetap captures every frame: use a display filter instead\n");
              return 0;
            }
            die("extcap: give --extcap-interfaces, --extcap-dlts, --extcap-config or --capture");
          }};
}

}  // namespace drivetap::app
