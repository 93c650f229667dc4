// `capture --scan`'s judgement (src/sources/live/line_scan.hpp).
#include "sources/live/line_scan.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <set>

namespace drivetap {

std::vector<SerialConfig> scan_settings() {
  struct Format {
    std::uint8_t data_bits;
    Parity parity;
    std::uint8_t stop_bits;
  };
  constexpr Format kFormats[] = {{8, Parity::none, 1}, {8, Parity::even, 1}, {8, Parity::odd, 1},
                                 {7, Parity::even, 1}, {7, Parity::odd, 1},  {7, Parity::none, 2}};
  std::vector<SerialConfig> out;
  for (const std::uint32_t baud : {9600u, 19200u, 38400u, 57600u, 115200u, 4800u, 2400u, 1200u})
    for (const Format& f : kFormats) {
      SerialConfig s;
      s.baud = baud;
      s.data_bits = f.data_bits;
      s.parity = f.parity;
      s.stop_bits = f.stop_bits;
      out.push_back(s);
    }
  return out;
}

ScanVerdict judge_scan(const std::vector<ScanResult>& tried) {
  ScanVerdict v;
  // A setting is judged by the share of its frames that are good and the share of its bytes with
  // a UART mark, not by counts: each listened for a while of its own, and caught what traffic
  // came then. The most good frames break what shares leave equal.
  // (The listening's start and end may each cut a frame: two bad frames are forgiven.)
  const auto good_share = [](const ScanResult& r) {
    const std::uint64_t bad = r.frames - std::min(r.frames, r.frames_ok);
    const std::uint64_t judged = r.frames_ok + (bad > 2 ? bad - 2 : 0);
    return judged ? static_cast<double>(r.frames_ok) / static_cast<double>(judged) : 0.0;
  };
  const auto mark_share = [](const ScanResult& r) {
    return r.bytes ? static_cast<double>(r.uart_errors) / static_cast<double>(r.bytes) : 0.0;
  };
  const auto better = [&](const ScanResult& a, const ScanResult& b) {
    if (good_share(a) != good_share(b)) return good_share(a) > good_share(b);
    if (mark_share(a) != mark_share(b)) return mark_share(a) < mark_share(b);
    return a.frames_ok > b.frames_ok;
  };
  const ScanResult* top = nullptr;
  for (const ScanResult& r : tried)
    if (r.frames_ok > 0 && (!top || better(r, *top))) top = &r;
  if (!top) return v;
  // Alike: shares within what a few frames more or less move, on comparable evidence.
  constexpr double kShareTolerance = 0.05;
  for (const ScanResult& r : tried)
    if (r.frames_ok > 0 && 2 * r.frames_ok >= top->frames_ok &&
        good_share(r) >= good_share(*top) - kShareTolerance &&
        mark_share(r) <= mark_share(*top) + kShareTolerance / 5)
      v.best.push_back(r);
  if (v.best.size() < 2) {
    v.best = {*top};
    return v;
  }

  std::set<std::uint32_t> rates;
  std::set<std::string> formats;
  for (const ScanResult& r : v.best) {
    rates.insert(r.serial.baud);
    const std::string text = r.serial.to_string();
    formats.insert(text.substr(text.find(' ') + 1));
  }
  std::vector<std::string> why;
  if (rates.size() > 1)
    why.push_back(fmt::format(
        "{} rates gave the same frames: the port applies no baud rate of its own (a pty, a "
        "network port, a converter set apart from the bus), so the line's rate cannot be told "
        "here",
        rates.size()));
  if (formats.size() > 1) {
    std::string list;
    for (const std::string& f : formats) list += (list.empty() ? "" : ", ") + f;
    why.push_back(fmt::format(
        "{} alike: the port reported no parity or framing mark under any of them (a pty or a "
        "network port checks none; on a real UART a parity bit the setting does not expect shows "
        "as framing errors, and one it expects but misses as parity errors)",
        list));
  }
  v.untold = fmt::format("not told apart: {}", fmt::join(why, "; "));
  return v;
}

}  // namespace drivetap
