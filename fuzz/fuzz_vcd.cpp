// Fuzzes VcdFile (Value Change Dump, src/sources/vcd_file.hpp). The reader takes a path, so the
// input goes to a temporary file first. Every channel is selected and every block read, with the
// block contract of src/sources/logic_capture.hpp checked; a second select() of the first channel
// alone, in blocks of a few tokens, must give that channel's levels again (select() starts over,
// channels are independent, where blocks end changes nothing).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz/fuzz_common.hpp"
#include "sources/logic_source.hpp"
#include "sources/vcd_file.hpp"

namespace {

const std::string& input_path() {
  static const std::string path = [] {
    // tmpfs when there is one: ext4 flushes a file rewritten after truncation on every close,
    // which makes each run wait for the disk.
    std::string name = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    name += "/drivetap-fuzz-vcd-XXXXXX";
    const int fd = mkstemp(name.data());
    if (fd < 0) drivetap::fuzz::contract_broken("cannot create a temporary file");
    close(fd);
    static std::string kept = name;
    std::atexit([] { unlink(kept.c_str()); });
    return kept;
  }();
  return path;
}

// One channel's levels as (level, length) with equal neighbours merged: blocks may split a run.
using Levels = std::vector<drivetap::phy::LevelRun>;

void append(Levels& to, const drivetap::phy::LevelRun& run) {
  if (!to.empty() && to.back().level == run.level)
    to.back().length += run.length;
  else
    to.push_back(run);
}

// Reads every block of `selected`, checking the contract; the first channel's levels in `first`.
// False when reading stopped at an error.
bool read_checked(drivetap::VcdFile& file, const std::vector<std::size_t>& selected,
                  Levels& first) {
  using drivetap::fuzz::contract_broken;
  std::string error;
  if (!file.select(selected, &error)) contract_broken("select() of valid channels failed");
  drivetap::RunBlock block;
  std::uint64_t at = 0;
  while (file.next_block(block, &error)) {
    if (block.begin != at) contract_broken("a block does not begin where the last one ended");
    if (block.end <= block.begin) contract_broken("an empty block");
    if (block.runs.size() != selected.size()) contract_broken("runs not one per selected channel");
    for (std::size_t k = 0; k < block.runs.size(); ++k) {
      std::uint64_t covered = 0;
      for (const drivetap::phy::LevelRun& run : block.runs[k]) {
        if (run.length == 0) contract_broken("an empty run");
        if (covered + run.length < covered) contract_broken("run lengths overflow");
        covered += run.length;
        if (k == 0) append(first, run);
      }
      if (covered != block.end - block.begin) contract_broken("runs do not cover the block");
    }
    at = block.end;
  }
  if (file.next_block(block, &error)) contract_broken("a block after the end");
  if (!error.empty() && error.rfind(input_path() + ": line ", 0) != 0)
    contract_broken("an error without 'FILE: line N: '");
  return error.empty();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using drivetap::fuzz::contract_broken;
  const std::string& path = input_path();
  std::FILE* out = std::fopen(path.c_str(), "wb");
  if (!out) contract_broken("cannot write the temporary file");
  if (size > 0 && std::fwrite(data, 1, size, out) != size) contract_broken("short write");
  std::fclose(out);

  std::string error;
  // Every other input is read a few bytes at a time, so that words run across reads.
  const std::size_t read_bytes = size % 2 == 0 ? 0 : 1 + size % 37;
  auto file = drivetap::VcdFile::open(path, &error, read_bytes);
  if (!file) {
    if (error.rfind(path + ": line ", 0) != 0)
      contract_broken("open() failed without 'FILE: line N: '");
    return 0;
  }
  if (file->channels().empty()) contract_broken("a VCD opened with no channel");
  if (file->sample_rate() == 0 || file->sample_rate() > 1'000'000'000)
    contract_broken("sample rate outside 1 Hz..1 GHz");
  std::vector<std::size_t> all(file->channels().size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  Levels first_of_all, first_alone;
  const bool complete = read_checked(*file, all, first_of_all);
  file->set_block_tokens(1 + size % 13);
  const bool complete_alone = read_checked(*file, {0}, first_alone);
  // With no error the channel's levels must be the same however it was read. (An error ends
  // each read at the end of the block before it, which depends on where blocks end.)
  if (complete && complete_alone && first_of_all != first_alone)
    contract_broken("a channel's levels depend on the channels selected or the block size");

  // The whole logic path on it: channel choice, line detection, decoding, the time-ordered merge.
  file = drivetap::VcdFile::open(path, &error, read_bytes);
  if (!file) contract_broken("a VCD that opened once does not open again");
  drivetap::ChannelTable channels;
  drivetap::LogicSourceOptions options;
  options.detection_runs = 2'000;
  drivetap::LogicSource source(std::move(file), path, channels, options);
  if (!source.read_header()) {
    if (source.error().empty()) contract_broken("read_header() failed without an error");
    return 0;
  }
  drivetap::ByteEvent e;
  drivetap::TimeNs last = 0;
  while (source.next(e)) {
    if (e.time < last) contract_broken("logic source events out of time order");
    last = e.time;
  }
  return 0;
}
