// Shared by the logic-capture fuzz targets (fuzz_vcd, fuzz_sigrok): the temporary file their
// path-taking readers open, the block contract of src/sources/logic/logic_capture.hpp, and the whole
// logic path (LogicSource: channel choice, line detection, UART decoding, time-ordered merge).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <string_view>

#include "fuzz/fuzz_common.hpp"
#include "sources/logic/logic_capture.hpp"
#include "sources/logic/logic_source.hpp"

namespace drivetap::fuzz {

// One temporary file per process, removed at exit: /dev/shm when there is one (ext4 flushes a
// file rewritten after truncation on every close, which makes each run wait for the disk).
inline const std::string& temp_input_path(std::string_view tag) {
  static const std::string path = [tag] {
    std::string name = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    name += "/drivetap-fuzz-";
    name += tag;
    name += "-XXXXXX";
    const int fd = mkstemp(name.data());
    if (fd < 0) contract_broken("cannot create a temporary file");
    close(fd);
    static std::string kept = name;
    std::atexit([] { unlink(kept.c_str()); });
    return kept;
  }();
  return path;
}

inline void write_file(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::FILE* out = std::fopen(path.c_str(), "wb");
  if (!out) contract_broken("cannot write the temporary file");
  if (size > 0 && std::fwrite(data, 1, size, out) != size) contract_broken("short write");
  std::fclose(out);
}

// A block read at sample `at` with `channels` selected keeps the contract: it begins where the
// last one ended, is not empty, has one run list per channel, and each list covers it with
// non-empty runs. `each_run(k, run)` sees channel k's runs in order.
template <class EachRun>
void check_block(const RunBlock& block, std::uint64_t at, std::size_t channels,
                 EachRun&& each_run) {
  if (block.begin != at) contract_broken("a block does not begin where the last one ended");
  if (block.end <= block.begin) contract_broken("an empty block");
  if (block.runs.size() != channels) contract_broken("runs not one per selected channel");
  for (std::size_t k = 0; k < block.runs.size(); ++k) {
    std::uint64_t covered = 0;
    for (const phy::LevelRun& run : block.runs[k]) {
      if (run.length == 0) contract_broken("an empty run");
      if (covered + run.length < covered) contract_broken("run lengths overflow");
      covered += run.length;
      each_run(k, run);
    }
    if (covered != block.end - block.begin) contract_broken("runs do not cover the block");
  }
}

// The whole logic path over a freshly opened capture; events must come in time order, and a
// header that fails must say why.
inline void run_logic_path(std::unique_ptr<LogicCapture> capture, const std::string& path) {
  ChannelTable channels;
  LogicSourceOptions options;
  options.detection_runs = 2'000;
  LogicSource source(std::move(capture), path, channels, options);
  if (!source.read_header()) {
    if (source.error().empty()) contract_broken("read_header() failed without an error");
    return;
  }
  ByteEvent e;
  TimeNs last = 0;
  while (source.next(e)) {
    if (e.time < last) contract_broken("logic source events out of time order");
    last = e.time;
  }
}

}  // namespace drivetap::fuzz
