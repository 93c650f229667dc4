// The serial ports that exist (src/sources/live/port_list.hpp; docs/protocols.md §1).
#include "sources/live/port_list.hpp"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>
#include <system_error>
#include <utility>

namespace drivetap {

namespace fs = std::filesystem;

namespace {

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

fs::path device_root() {
  const char* root = std::getenv("DRIVETAP_DEVICE_ROOT");
  return root && *root ? fs::path(root) : fs::path("/");
}

std::vector<SerialPortEntry> find_serial_ports() {
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
  std::vector<std::string> names;
  for (fs::directory_iterator it(root / "dev", ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.starts_with("ttyUSB") || name.starts_with("ttyACM") ||
        (name.starts_with("ttyS") && has_uart(root, name)))
      names.push_back(name);
  }
  std::sort(names.begin(), names.end(), port_before);
  std::vector<SerialPortEntry> ports;
  for (const std::string& name : names) {
    SerialPortEntry entry{name, "/dev/" + name, {}};
    if (const auto found = by_id.find(name); found != by_id.end()) {
      entry.by_id = found->second;
      std::sort(entry.by_id.begin(), entry.by_id.end());
    }
    ports.push_back(std::move(entry));
  }
  return ports;
}

}  // namespace drivetap
