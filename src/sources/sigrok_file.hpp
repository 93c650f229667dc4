// sigrok session file (.sr) reader: a zip (Debian's libzip) holding `metadata` (INI: sample rate,
// channel names, bytes per sample) and the samples in order, `logic-1-1`, `logic-1-2`, ... (or
// one `logic-1` in old files), or `analog-1-<ch>-<n>` float32 chunks for an oscilloscope trace.
//
//   logic sample = unitsize bytes, little-endian; bit i = channel probe(i+1)
//
// The reader hands out the samples chunk by chunk; it never holds the whole capture in memory.
// An analog channel is thresholded halfway between its lowest and highest value.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace drivetap {

class SigrokFile {
 public:
  // nullptr with *error = "FILE: reason" when the file is no sigrok session this reader knows.
  static std::unique_ptr<SigrokFile> open(const std::string& path, std::string* error);
  ~SigrokFile();
  SigrokFile(const SigrokFile&) = delete;
  SigrokFile& operator=(const SigrokFile&) = delete;

  [[nodiscard]] double sample_rate() const { return sample_rate_; }
  // Channel names in bit order (logic) or the one analog channel.
  [[nodiscard]] const std::vector<std::string>& channels() const { return channels_; }
  [[nodiscard]] bool analog() const { return analog_; }

  // Calls `chunk` with consecutive blocks of samples; each sample is one 64-bit word whose bit i
  // is channel i (analog: bit 0 = above the threshold). Returns false with *error on a damaged
  // file ("FILE: logic-1-3: ...").
  bool read(const std::function<void(std::span<const std::uint64_t>)>& chunk, std::string* error);

 private:
  SigrokFile() = default;
  struct Zip;
  std::unique_ptr<Zip> zip_;
  std::string path_;
  double sample_rate_ = 0;
  std::vector<std::string> channels_;
  bool analog_ = false;
  int unit_size_ = 1;
  std::vector<std::string> chunks_;  // zip entry names in sample order
};

// "1 MHz", "500 kHz", "8000000" -> samples per second; 0 when not a rate.
double parse_sample_rate(const std::string& text);

}  // namespace drivetap
