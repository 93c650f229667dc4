// Value Change Dump (.vcd) reader, IEEE 1364-2005 §18.2 (four-state VCD): what sigrok-cli and
// PulseView export (`sigrok-cli -i X.sr -O vcd`), what logic-analyser software such as Saleae's
// writes, and what HDL simulators (Icarus, GHDL, Verilator, SystemC) dump.
//
//   $timescale 1 us $end                      one sample per timescale unit (but see below)
//   $scope module libsigrok $end
//   $var wire 1 ! TX $end                     1-bit variable: a channel; wider ones are skipped
//   $upscope $end
//   $enddefinitions $end
//   #0 1!                                     time, then the values that change at it
//   #300 0!
//   #6937                                     the last time stamp is the end of the capture
//
// Sample rate and sample numbers:
//   - Normally one sample per timescale unit: 1 us -> 1 MHz, 100 ns -> 10 MHz.
//   - A timescale finer than 1 ns (simulators: 1 ps, 1 fs) would give sample rates a UART never
//     needs and the pipeline's clock arithmetic does not take: times are divided down to 1 GHz
//     (rounded down), so pulses shorter than 1 ns may vanish.
//   - sigrok picks a decade timescale at or above its sample rate (2 MHz -> 100 ns; up to 100
//     times finer when that makes its sample times whole, else it rounds them: 24 MHz -> 100 ps)
//     and states the real rate in a header comment ("Acquisition with 8/8 channels at 2 MHz").
//     That rate is used when it is at most the timescale's: times are divided by the ratio, or
//     rounded to the nearest sample when sigrok rounded them, so the VCD gives the very samples
//     of the .sr it came from.
//   - The capture ends at its last time stamp (sigrok writes one with no values: the sample
//     count). Values that change at that last time stamp therefore last no sample.
//   - Times are unsigned 64-bit and must not go backwards; a time beyond the pipeline's time
//     limit (2^62 ns, src/core/time.hpp) is refused.
//
// Values: 0/1 (and the weak L/H) are levels. x, z, u, w and - keep the level the channel had:
// the runs have no unknown level, and the last one seen invents no edge (a simulator's x is
// mostly an undriven wire before reset or a dump switched off). A channel's first level also
// covers the time before it (sample 0 onwards), so a signal dumped late or first as x does not
// start with an invented edge; a channel that never gets a level reads as 1 (an idle UART line)
// throughout. A `b` value given to a 1-bit variable counts with its last bit; vector, real and
// string values of other variables are skipped. $dumpvars, $dumpall, $dumpon and $dumpoff are
// read as the value changes they contain; $comment may appear anywhere.
//
// Channel names: the variable's reference name (a bit-select "[3]" is appended, other extra
// words joined with a space: "Channel 0"), prefixed by the scopes below the ones that all
// channels share, joined with '.': sigrok's single "libsigrok" scope gives plain names ("TX"),
// a simulator's top.tb.{tx, dut.rx} gives "tx" and "dut.rx". Aliases (one identifier declared
// under several names) are one channel each, with the same levels.
//
// Bounds against hostile files: at most 4096 variables and 4096 scopes, 32 scopes deep, tokens
// (identifiers, values, words) of at most 64 KiB, identifiers of at most 256 bytes, names of at
// most 1024. The file is read in pieces of up to 1 MiB and never held whole; a block holds at most
// one run per selected channel and distinct sample in about 64 K tokens of the file.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "sources/logic/logic_capture.hpp"

namespace drivetap {

class VcdFile final : public LogicCapture {
 public:
  // nullptr with *error = "FILE: line N: reason" (or "FILE: reason" when it cannot be opened)
  // when the header cannot be read or declares no 1-bit variable. `read_bytes`: bytes per read,
  // 0 for 1 MiB (less for a smaller file); tests and the fuzz target give a few, so that words
  // run across reads everywhere.
  static std::unique_ptr<VcdFile> open(const std::string& path, std::string* error,
                                       std::size_t read_bytes = 0);
  ~VcdFile() override;
  VcdFile(const VcdFile&) = delete;
  VcdFile& operator=(const VcdFile&) = delete;

  [[nodiscard]] std::uint64_t sample_rate() const override { return sample_rate_; }
  // 1-bit variables in declaration order.
  [[nodiscard]] const std::vector<std::string>& channels() const override { return channels_; }
  // Variables wider than one bit, reals, events and strings: declared, not channels.
  [[nodiscard]] std::size_t skipped_variables() const { return skipped_variables_; }
  // The file's time units per second (10 MHz for 100 ns); a multiple of sample_rate() unless
  // sigrok had to round its times (24 MHz on 100 ps).
  [[nodiscard]] std::uint64_t timescale_rate() const { return timescale_rate_; }

  // About how many tokens of the file, and values they set, a block covers (default 65536; at
  // least 1): tests and the fuzz target make blocks small to put their ends everywhere. Takes
  // effect at once.
  void set_block_tokens(std::size_t tokens) {
    block_tokens_ = std::clamp<std::size_t>(tokens, 1, std::size_t{1} << 40);
  }

  bool select(const std::vector<std::size_t>& channels, std::string* error) override;
  bool next_block(RunBlock& block, std::string* error) override;

 private:
  VcdFile() = default;
  class Tokens;
  struct Slot;
  bool read_header(std::string* error);
  [[nodiscard]] std::string where() const;
  int slot_of(std::string_view id) const;
  int add_slot(std::string_view id);
  // The body from the current position: value changes applied, runs appended to `block` (null:
  // the first pass of select(), which only learns each selected channel's first level). Returns
  // 1 at a block boundary, 0 at the end of the file, -1 on an error (*error set).
  int scan(RunBlock* block, std::string* error);
  [[nodiscard]] std::uint64_t to_sample(std::uint64_t time) const;
  bool rewind_body(std::string* error);
  void commit(std::uint64_t at, RunBlock& block);

  std::string path_;
  std::unique_ptr<Tokens> tokens_;
  std::uint64_t sample_rate_ = 0;
  std::uint64_t timescale_rate_ = 0;
  std::uint64_t divider_ = 1;  // time units per sample; 0: rounded, see to_sample()
  std::vector<std::string> channels_;
  std::vector<int> channel_slot_;  // per channel: its identifier's slot
  std::size_t skipped_variables_ = 0;
  std::size_t block_tokens_ = std::size_t{1} << 16;

  // Identifiers: one slot each. One- and two-byte identifiers (nearly all of them) index tables.
  std::vector<std::int32_t> slot_by_byte_;  // 256 entries, -1 = none
  std::vector<std::int32_t> slot_by_pair_;  // 65536 entries when a 2-byte identifier exists
  std::vector<std::string> long_ids_;       // sorted, with long_slots_ alongside
  std::vector<std::int32_t> long_slots_;
  std::vector<bool> slot_is_channel_;  // declared 1 bit wide at least once

  std::uint64_t body_offset_ = 0;  // file offset just after `$enddefinitions $end`
  std::uint64_t body_line_ = 1;

  // Reading position.
  std::vector<std::size_t> selected_;
  std::vector<std::int32_t> first_selected_;  // per slot: first selected index on it, -1
  std::vector<std::int32_t> next_selected_;   // per selected index: the next one on its slot
  std::vector<std::uint8_t> level_;           // per selected index: level since run_start_
  std::vector<std::uint8_t> value_;           // per selected index: latest value at now_
  std::vector<std::uint8_t> known_;           // first pass: level seen yet
  std::vector<std::uint8_t> touched_;         // per selected index: changed at now_
  std::vector<std::int32_t> touched_list_;
  std::vector<std::uint64_t> run_start_;
  bool have_time_ = false;
  std::uint64_t time_ = 0;     // last time stamp, in file units
  std::uint64_t now_ = 0;      // its sample
  std::uint64_t emitted_ = 0;  // samples handed out
  std::size_t unknown_ = 0;    // first pass: selected channels without a level yet
  bool done_ = true;
};

}  // namespace drivetap
