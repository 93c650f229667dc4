// sigrok session file (.sr) reader: a zip (Debian's libzip) holding `metadata` (INI: sample rate,
// channel names, bytes per sample) and the samples in order, `logic-1-1`, `logic-1-2`, ... (or
// one `logic-1` in old files), or `analog-1-<ch>-<n>` float32 chunks for an oscilloscope trace.
//
//   logic sample = unitsize bytes, little-endian; bit i = channel probe(i+1)
//
// The reader hands out level runs block by block (src/sources/logic/logic_capture.hpp); it never holds
// the whole capture in memory. An analog channel is turned into levels by a Schmitt trigger
// around the middle of its range (a first pass finds the range).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sources/logic/logic_capture.hpp"

namespace drivetap {

class SigrokFile final : public LogicCapture {
 public:
  // nullptr with *error = "FILE: reason" when the file is no sigrok session this reader knows.
  static std::unique_ptr<SigrokFile> open(const std::string& path, std::string* error);
  ~SigrokFile() override;
  SigrokFile(const SigrokFile&) = delete;
  SigrokFile& operator=(const SigrokFile&) = delete;

  [[nodiscard]] std::uint64_t sample_rate() const override { return sample_rate_; }
  // Channel names in bit order (logic) or the one analog channel.
  [[nodiscard]] const std::vector<std::string>& channels() const override { return channels_; }
  [[nodiscard]] bool analog() const { return analog_; }
  // The most sample data one pass decompresses (0: no limit). Deflate packs an idle line a
  // thousandfold, so a few MB of zip can hold gigabytes: past the limit reading stops with an
  // error, the blocks before it standing.
  static constexpr std::uint64_t kDefaultMaxSampleBytes = std::uint64_t{1} << 30;
  void set_max_sample_bytes(std::uint64_t bytes) { max_sample_bytes_ = bytes; }

  bool select(const std::vector<std::size_t>& channels, std::string* error) override;
  bool next_block(RunBlock& block, std::string* error) override;

 private:
  SigrokFile() = default;
  struct Zip;
  std::unique_ptr<Zip> zip_;
  std::string path_;
  struct Entry;
  bool open_next_entry(std::string* error);
  bool rewind(std::string* error);
  bool read_piece(std::size_t* samples, std::string* error);
  bool find_analog_range(std::string* error);
  void scan_logic(const std::uint8_t* bytes, std::size_t samples, RunBlock& block);
  void scan_analog(const std::uint8_t* bytes, std::size_t samples, RunBlock& block);

  std::uint64_t sample_rate_ = 0;
  std::vector<std::string> channels_;
  bool analog_ = false;
  int unit_size_ = 1;
  std::vector<std::string> chunks_;  // zip entry names in sample order

  // Reading position.
  std::vector<std::size_t> selected_;
  std::unique_ptr<Entry> entry_;  // the open sample chunk
  std::size_t next_chunk_ = 0;
  std::vector<std::uint8_t> raw_;  // the piece read last: whole samples, then part of one
  std::size_t filled_ = 0;         // bytes in raw_
  std::size_t used_ = 0;           // bytes of whole samples handed out from raw_
  std::uint64_t entry_offset_ = 0;
  std::uint64_t pass_bytes_ = 0;  // sample bytes decompressed since the last rewind
  std::uint64_t max_sample_bytes_ = kDefaultMaxSampleBytes;
  std::uint64_t sample_ = 0;  // samples handed out so far
  bool have_level_ = false;
  std::uint64_t last_word_ = 0;             // previous sample (selected bits only)
  std::vector<std::uint64_t> run_start_;    // per selected channel: where its run began
  std::vector<bool> level_;                 // per selected channel: its current level
  float analog_low_ = 0, analog_high_ = 0;  // Schmitt trigger thresholds
  bool analog_range_known_ = false;
};

// "1 MHz", "500 kHz", "8000000" -> samples per second; 0 when not a rate.
double parse_sample_rate(const std::string& text);

}  // namespace drivetap
