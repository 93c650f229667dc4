// Logic-analyser capture as level runs per channel: the contract between the sampled-capture
// readers (sigrok session .sr, VCD) and what decodes them (src/sources/logic/logic_source.hpp,
// src/sources/logic/detect.hpp). Issue 6 / docs/protocols.md §1 (the line under the bytes).
//
// A reader hands out the capture block by block. Every block covers the same samples
// [begin, end) for each selected channel, as run-length levels:
//
//   block n:   ch0  ‾‾‾‾‾‾‾‾\____/‾‾‾‾|      runs {1,8} {0,5} {1,4}
//              ch1  ‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾|      runs {1,17}
//   block n+1: ch0  ‾‾‾‾\__ ...             the first run may continue the level of the last
//
// so a consumer holds at most one block, whatever the length of the capture.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sources/logic/uart_decoder.hpp"

namespace drivetap {

struct RunBlock {
  std::uint64_t begin = 0;  // sample number of the first sample in the block
  std::uint64_t end = 0;    // one past the last
  // runs[k]: the k-th selected channel; lengths sum to end - begin; no run is empty.
  std::vector<std::vector<phy::LevelRun>> runs;
};

class LogicCapture {
 public:
  virtual ~LogicCapture() = default;

  // Samples per second (a VCD: one sample per timescale unit, see its reader).
  [[nodiscard]] virtual std::uint64_t sample_rate() const = 0;
  // Channel names, index = what `select` takes.
  [[nodiscard]] virtual const std::vector<std::string>& channels() const = 0;

  // (Re)starts at sample 0, reading these channels (indices into channels(), in this order).
  // False with *error ("FILE: why") when the capture cannot be read again.
  virtual bool select(const std::vector<std::size_t>& channels, std::string* error) = 0;
  // The next block. False at the end of the capture (error untouched) or when the capture is
  // damaged (*error = "FILE: where: why"; the blocks before it stand).
  virtual bool next_block(RunBlock& block, std::string* error) = 0;
};

}  // namespace drivetap
