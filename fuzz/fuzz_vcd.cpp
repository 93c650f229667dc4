// Fuzzes VcdFile (Value Change Dump, src/sources/logic/vcd_file.hpp). The reader takes a path, so the
// input goes to a temporary file first. Every channel is selected and every block read, with the
// block contract of src/sources/logic/logic_capture.hpp checked; a second select() of the first channel
// alone, in blocks of a few tokens, must give that channel's levels again (select() starts over,
// channels are independent, where blocks end changes nothing).
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz/fuzz_logic.hpp"
#include "fuzz/structured_mutators.hpp"
#include "sources/logic/vcd_file.hpp"

namespace {

const std::string& input_path() {
  return drivetap::fuzz::temp_input_path("vcd");
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
    drivetap::fuzz::check_block(block, at, selected.size(),
                                [&](std::size_t k, const drivetap::phy::LevelRun& run) {
                                  if (k == 0) append(first, run);
                                });
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
  drivetap::fuzz::write_file(path, data, size);

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
  drivetap::fuzz::run_logic_path(std::move(file), path);
  return 0;
}

// Half the mutations rewrite the header (fuzz/structured_mutators.hpp), half are libFuzzer's.
extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size,
                                               std::size_t max_size, unsigned seed) {
  std::mt19937 rng(seed);
  if (rng() % 2 == 0) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    if (const std::size_t used =
            drivetap::fuzz::store(drivetap::fuzz::mutate_vcd_header(text, rng), data, max_size))
      return used;
  }
  return LLVMFuzzerMutate(data, size, max_size);
}
