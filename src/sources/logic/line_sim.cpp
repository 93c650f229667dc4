// RS-485 line simulator and VCD writer (docs/protocols.md §1; IEEE 1364 §18; see line_sim.hpp).
#include "sources/logic/line_sim.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace drivetap::phy {
namespace {

std::uint64_t whole_samples(double time) {
  return time <= 0 ? 0 : static_cast<std::uint64_t>(std::ceil(time));
}

}  // namespace

LineSimulator::LineSimulator(const LineSimSettings& settings)
    : settings_(settings), rng_(settings.seed) {
  // The receiver's minimum of samples per bit applies to the transmitter too: fewer, and the
  // waveform itself is too coarse to mean anything.
  if (std::string problem = settings.uart.validate(settings.sample_rate_hz); !problem.empty())
    throw std::invalid_argument(problem);
  if (!(settings.baud_error_percent > -50 && settings.baud_error_percent < 100))
    throw std::invalid_argument(
        fmt::format("baud error {}% is outside -50..100%", settings.baud_error_percent));
  if (!(settings.edge_jitter_bits >= 0 && settings.edge_jitter_bits < 0.5))
    throw std::invalid_argument(
        fmt::format("edge jitter {} bit times is outside 0..0.5 (edges would swap places)",
                    settings.edge_jitter_bits));
  const double actual_baud = settings.uart.baud * (1 + settings.baud_error_percent / 100);
  samples_per_bit_ = static_cast<double>(settings.sample_rate_hz) / actual_baud;
}

double LineSimulator::uniform01() {
  // By hand rather than std::uniform_real_distribution, whose output the standard leaves to
  // each library: the same seed must give the same line everywhere.
  return static_cast<double>(rng_()) / 4294967296.0;
}

void LineSimulator::toggle_at(double time) {
  if (settings_.edge_jitter_bits > 0)
    time += (2 * uniform01() - 1) * settings_.edge_jitter_bits * samples_per_bit_;
  toggle_times_.push_back(std::max(time, 0.0));
}

void LineSimulator::idle(double bit_times) {
  if (bit_times > 0) now_ += bit_times * samples_per_bit_;
}

void LineSimulator::send(std::uint16_t value) {
  const UartSettings& uart = settings_.uart;
  const double start = now_;
  auto set_level = [&](bool mark, double bit_time) {
    if (mark == line_mark_) return;
    toggle_at(start + bit_time * samples_per_bit_);
    line_mark_ = mark;
  };
  set_level(false, 0);  // the line is always idle between calls: the start edge is a toggle
  const double start_edge = toggle_times_.back();
  for (unsigned i = 0; i < uart.data_bits; ++i) set_level(((value >> i) & 1u) != 0, 1.0 + i);
  const auto data_mask = static_cast<std::uint16_t>((1u << uart.data_bits) - 1);
  const auto data = static_cast<std::uint16_t>(value & data_mask);
  const double after_data = 1.0 + uart.data_bits;
  if (uart.parity != UartParity::none) set_level(parity_bit(uart.parity, data), after_data);
  set_level(true, after_data + (uart.parity == UartParity::none ? 0.0 : 1.0));
  now_ = start + uart.frame_bits() * samples_per_bit_;
  characters_.push_back({data, start_edge, now_});
}

void LineSimulator::send(std::span<const std::uint8_t> bytes, double gap_bit_times) {
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i > 0) idle(gap_bit_times);
    send(std::uint16_t{bytes[i]});
  }
}

void LineSimulator::send_break(double bit_times) {
  if (bit_times <= 0) return;
  toggle_at(now_);
  const double begins = toggle_times_.back();
  toggle_at(now_ + bit_times * samples_per_bit_);
  // A jittered end may fall after the nominal one: the line must reach it to come back to idle.
  now_ = std::max(now_ + bit_times * samples_per_bit_, toggle_times_.back());
  breaks_.push_back({begins, toggle_times_.back()});
}

void LineSimulator::add_glitch(std::uint64_t at_sample, std::uint64_t width_samples) {
  if (width_samples == 0) return;
  glitch_toggles_.push_back(at_sample);
  glitch_toggles_.push_back(at_sample + width_samples);
}

void LineSimulator::add_random_glitches(double glitches_per_second, std::uint64_t width_samples) {
  const std::uint64_t length = whole_samples(now_);
  if (!(glitches_per_second > 0) || width_samples == 0 || length <= width_samples) return;
  const double seconds = now_ / static_cast<double>(settings_.sample_rate_hz);
  const auto count = static_cast<std::uint64_t>(std::llround(glitches_per_second * seconds));
  const auto places = static_cast<double>(length - width_samples);
  for (std::uint64_t i = 0; i < count; ++i)
    add_glitch(static_cast<std::uint64_t>(uniform01() * places), width_samples);
}

std::vector<LevelRun> LineSimulator::runs() const {
  const std::uint64_t length = whole_samples(now_);
  std::vector<std::uint64_t> toggles;
  toggles.reserve(toggle_times_.size() + glitch_toggles_.size());
  for (double t : toggle_times_) toggles.push_back(whole_samples(t));
  for (std::uint64_t g : glitch_toggles_) toggles.push_back(std::min(g, length));
  std::sort(toggles.begin(), toggles.end());

  std::vector<LevelRun> runs;
  bool level = !settings_.uart.inverted;  // idle line
  std::uint64_t pos = 0;
  for (std::size_t i = 0; i < toggles.size();) {
    std::size_t same = i;
    while (same < toggles.size() && toggles[same] == toggles[i]) ++same;
    // Toggles landing on one sample cancel in pairs (a glitch ending on an edge, two edges closer
    // than a sample): what the analyser sees is whether the level changed there.
    const bool changes = (same - i) % 2 == 1;
    const std::uint64_t at = toggles[i];
    i = same;
    if (!changes || at >= length) continue;
    if (at > pos) runs.push_back({level, at - pos});
    pos = at;
    level = !level;
  }
  if (length > pos) runs.push_back({level, length - pos});
  return runs;
}

std::vector<LevelRun> simulate_uart(std::span<const std::uint8_t> bytes,
                                    const LineSimSettings& settings, double gap_bit_times) {
  LineSimulator sim(settings);
  sim.idle(10);
  sim.send(bytes, gap_bit_times);
  sim.idle(10);
  return sim.runs();
}

std::vector<bool> expand_to_samples(std::span<const LevelRun> runs) {
  std::uint64_t total = 0;
  for (const LevelRun& r : runs) total += r.length;
  std::vector<bool> samples;
  samples.reserve(total);
  for (const LevelRun& r : runs) samples.insert(samples.end(), r.length, r.level);
  return samples;
}

std::vector<LevelRun> runs_from_samples(const std::vector<bool>& samples) {
  std::vector<LevelRun> runs;
  for (bool s : samples) {
    if (runs.empty() || runs.back().level != s) runs.push_back({s, 0});
    ++runs.back().length;
  }
  return runs;
}

namespace {

// sigrok's choice (libsigrok src/output/vcd.c): VCD allows 1, 10 or 100 of s..fs per tick.
std::uint64_t vcd_ticks_per_second(std::uint64_t sample_rate_hz) {
  std::uint64_t ticks = 1;
  while (ticks < sample_rate_hz) ticks *= 10;
  for (int finer = 0; finer < 2 && ticks % sample_rate_hz != 0; ++finer) ticks *= 10;
  return ticks;
}

std::string vcd_timescale(std::uint64_t ticks_per_second) {
  int decades = 0;
  for (std::uint64_t t = ticks_per_second; t >= 10; t /= 10) ++decades;
  static constexpr const char* kUnits[] = {"s", "ms", "us", "ns", "ps", "fs"};
  const int unit = (decades + 2) / 3;
  int magnitude = 1;
  for (int i = decades; i < unit * 3; ++i) magnitude *= 10;
  return fmt::format("{} {}", magnitude, kUnits[unit]);
}

std::string rate_text(std::uint64_t hz) {
  if (hz % 1'000'000'000 == 0) return fmt::format("{} GHz", hz / 1'000'000'000);
  if (hz % 1'000'000 == 0) return fmt::format("{} MHz", hz / 1'000'000);
  if (hz % 1'000 == 0) return fmt::format("{} kHz", hz / 1'000);
  return fmt::format("{} Hz", hz);
}

}  // namespace

void write_vcd(std::ostream& out, std::span<const LevelRun> runs, std::uint64_t sample_rate_hz,
               std::string_view signal_name) {
  if (sample_rate_hz == 0 || sample_rate_hz > 10'000'000'000)
    throw std::invalid_argument(
        fmt::format("sample rate {} Hz is outside 1 Hz..10 GHz", sample_rate_hz));
  const std::uint64_t ticks_per_second = vcd_ticks_per_second(sample_rate_hz);
  const bool exact = ticks_per_second % sample_rate_hz == 0;
  auto tick_of = [&](std::uint64_t sample) -> std::uint64_t {
    if (exact) return sample * (ticks_per_second / sample_rate_hz);
    return static_cast<std::uint64_t>(
        std::llround(static_cast<long double>(sample) * ticks_per_second / sample_rate_hz));
  };
  // A VCD reference is one token: whitespace in a channel name would end it early.
  std::string name(signal_name.empty() ? "RX" : signal_name);
  std::replace_if(
      name.begin(), name.end(), [](char c) { return c == ' ' || c == '\t'; }, '_');

  // No $date: the same line must give the same file.
  out << "$version drivetap line simulator $end\n"
      << "$comment\n  Acquisition with 1/1 channels at " << rate_text(sample_rate_hz) << "\n$end\n"
      << "$timescale " << vcd_timescale(ticks_per_second) << " $end\n"
      << "$scope module drivetap $end\n"
      << "$var wire 1 ! " << name << " $end\n"
      << "$upscope $end\n$enddefinitions $end\n";
  std::uint64_t pos = 0;
  bool first = true;
  bool level = false;
  for (const LevelRun& r : runs) {
    if (r.length == 0) continue;
    if (first || r.level != level)
      out << '#' << tick_of(pos) << ' ' << (r.level ? '1' : '0') << "!\n";
    first = false;
    level = r.level;
    pos += r.length;
  }
  out << '#' << tick_of(pos) << '\n';
}

}  // namespace drivetap::phy
