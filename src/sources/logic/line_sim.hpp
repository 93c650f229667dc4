// RS-485 line simulator: UART characters -> the level runs a logic analyser would record, with
// the faults a real bus shows (docs/protocols.md §1: swapped A/B, clock error, noise, breaks), and
// a VCD writer for looking at the result in PulseView or GTKWave.
//
// Time runs in samples as a real number; an edge at time t shows from the first sample at or
// after t (sample i is the level at time i), so a sampled edge is up to one sample late, as on a
// real analyser. Everything random comes from one seeded std::mt19937 drawn in call order, so a
// simulation is the same on every run and every standard library.
#pragma once

#include <cstdint>
#include <ostream>
#include <random>
#include <span>
#include <string_view>
#include <vector>

#include "sources/logic/uart_decoder.hpp"

namespace drivetap::phy {

struct LineSimSettings {
  std::uint64_t sample_rate_hz = 1'000'000;
  // The transmitter's baud rate, format and polarity (inverted: A and B swapped at the tap).
  // The glitch filter is the receiver's business and is not used here.
  UartSettings uart;
  // The transmitter's clock is off by this much: +2 sends 2 % faster than uart.baud says.
  double baud_error_percent = 0;
  // Every edge moves by a uniform random amount in [-edge_jitter_bits, +edge_jitter_bits] bit
  // times. Below 0.5 (checked), so that edges never swap places.
  double edge_jitter_bits = 0;
  std::uint32_t seed = 1;
};

// A character as sent, for comparing with what a decoder makes of it.
struct SimulatedCharacter {
  std::uint16_t value = 0;
  double start_time = 0;  // the start bit's falling edge, in samples (before sampling)
  double end_time = 0;    // end of the last stop bit, in samples
};

struct SimulatedBreak {
  double start_time = 0;
  double end_time = 0;
};

class LineSimulator {
 public:
  // Throws std::invalid_argument when the settings cannot be simulated (the UART settings'
  // validate() reason, or a jitter or baud error out of range). The line starts idle.
  explicit LineSimulator(const LineSimSettings& settings);

  // The line idle (mark) for this many of the transmitter's bit times.
  void idle(double bit_times);
  // One character: start bit, data bits LSB first, parity, stop bits; ends at the end of the
  // stop bits. Bits above data_bits are ignored.
  void send(std::uint16_t value);
  // Characters with `gap_bit_times` of idle line between them (not before the first or after
  // the last).
  void send(std::span<const std::uint8_t> bytes, double gap_bit_times = 0);
  // The line held at space for this many bit times, then back to mark.
  void send_break(double bit_times);

  // A pulse of the opposite level over samples [at_sample, at_sample + width_samples), laid over
  // the line when runs() is taken: noise flips the line wherever it is. Pulses past the end of
  // the line are cut there.
  void add_glitch(std::uint64_t at_sample, std::uint64_t width_samples);
  // round(glitches_per_second x the line's duration so far) pulses at uniformly random places.
  void add_random_glitches(double glitches_per_second, std::uint64_t width_samples);

  // The line as an analyser records it: physical levels (inverted when uart.inverted), the runs
  // of the same level merged, total length = the line's duration rounded up to whole samples.
  [[nodiscard]] std::vector<LevelRun> runs() const;

  [[nodiscard]] const std::vector<SimulatedCharacter>& characters() const { return characters_; }
  [[nodiscard]] const std::vector<SimulatedBreak>& breaks() const { return breaks_; }
  // One bit time of the transmitter (baud error included), in samples.
  [[nodiscard]] double samples_per_bit() const { return samples_per_bit_; }
  [[nodiscard]] double now() const { return now_; }  // end of the line so far, in samples

 private:
  void toggle_at(double time);
  [[nodiscard]] double uniform01();

  LineSimSettings settings_;
  double samples_per_bit_;
  double now_ = 0;
  bool line_mark_ = true;  // logical level at now_
  std::vector<double> toggle_times_;
  std::vector<std::uint64_t> glitch_toggles_;
  std::vector<SimulatedCharacter> characters_;
  std::vector<SimulatedBreak> breaks_;
  std::mt19937 rng_;
};

// Bytes with `gap_bit_times` between them, 10 idle bit times before and after: a whole line.
std::vector<LevelRun> simulate_uart(std::span<const std::uint8_t> bytes,
                                    const LineSimSettings& settings, double gap_bit_times = 0);

// One bool per sample, for tests and for feeding anything that reads samples.
std::vector<bool> expand_to_samples(std::span<const LevelRun> runs);
// The inverse: consecutive equal samples as one run.
std::vector<LevelRun> runs_from_samples(const std::vector<bool>& samples);

// Value Change Dump (IEEE 1364 §18) of one wire, laid out as sigrok's VCD export writes it:
// header with $timescale and `$var wire 1 ! <name> $end`, then one "#<time> <level>!" line per
// change (the first at #0) and the end of the capture as a last "#<time>". The timescale is the
// first power of ten at or above the sample rate, up to 100 times finer when that makes every
// sample time a whole number (2 MHz -> 100 ns, 8 MHz -> 1 ns), as sigrok chooses it.
void write_vcd(std::ostream& out, std::span<const LevelRun> runs, std::uint64_t sample_rate_hz,
               std::string_view signal_name = "RX");

}  // namespace drivetap::phy
