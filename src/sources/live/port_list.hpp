// The serial ports that exist on this machine (docs/protocols.md §1 the line): /dev/ttyUSB*,
// /dev/ttyACM* and the /dev/ttyS* with a UART behind them, each with its /dev/serial/by-id names.
// `drivetap -D` and the Wireshark extcap list them.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace drivetap {

struct SerialPortEntry {
  std::string name;                // ttyUSB0
  std::string path;                // /dev/ttyUSB0 (as a user names it, whatever the root)
  std::vector<std::string> by_id;  // its /dev/serial/by-id names, sorted
};

// Where /dev and /sys are: DRIVETAP_DEVICE_ROOT when set (tests give a fake tree), else "/".
std::filesystem::path device_root();

// The serial ports under device_root(), in natural order (ttyUSB2 before ttyUSB10).
std::vector<SerialPortEntry> find_serial_ports();

}  // namespace drivetap
