// Fuzzes SigrokFile (sigrok session .sr, src/sources/logic/sigrok_file.hpp) and the logic path behind
// it. Inputs with an even first byte are written as the file itself (a zip, damaged or not);
// with an odd one they are a recipe the target zips with libzip, so that mutations reach the
// reader's own parsing instead of dying in zip's checks:
//
//   byte 0: bit 1 -> chunks named "logic-1" (old files) instead of "logic-1-N";
//           bit 2 -> "analog-1-1-N" chunks
//   then    the `metadata` INI text up to the first NUL, then the sample bytes, cut into up to
//           three chunks at 0xA5 0x5A markers.
//
// Every channel is selected and every block read, with the block contract of
// src/sources/logic/logic_capture.hpp checked (fuzz_logic.hpp); errors must name the file.
#include <zip.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz/fuzz_logic.hpp"
#include "fuzz/structured_mutators.hpp"
#include "sources/logic/sigrok_file.hpp"

namespace {

using drivetap::fuzz::contract_broken;

const std::string& input_path() {
  return drivetap::fuzz::temp_input_path("sr");
}

void add_entry(zip_t* archive, const std::string& name, std::string_view content) {
  // libzip copies nothing until zip_close: the buffer must live until then (it does: the
  // fuzzer's input).
  zip_source_t* source = zip_source_buffer(archive, content.data(), content.size(), 0);
  if (!source) contract_broken("zip_source_buffer failed");
  if (zip_file_add(archive, name.c_str(), source, ZIP_FL_OVERWRITE) < 0) {
    zip_source_free(source);
    contract_broken("zip_file_add failed");
  }
}

void write_recipe(const std::uint8_t* data, std::size_t size) {
  const std::string_view all(reinterpret_cast<const char*>(data), size);
  const unsigned mode = size > 0 ? data[0] : 0;
  std::string_view rest = all.substr(size > 0 ? 1 : 0);
  const std::size_t nul = rest.find('\0');
  const std::string_view metadata = rest.substr(0, nul);
  std::string_view samples =
      nul == std::string_view::npos ? std::string_view() : rest.substr(nul + 1);
  std::vector<std::string_view> chunks;
  while (chunks.size() < 2) {
    const std::size_t cut = samples.find("\xA5\x5A");
    if (cut == std::string_view::npos) break;
    chunks.push_back(samples.substr(0, cut));
    samples = samples.substr(cut + 2);
  }
  chunks.push_back(samples);

  int code = 0;
  zip_t* archive = zip_open(input_path().c_str(), ZIP_CREATE | ZIP_TRUNCATE, &code);
  if (!archive) contract_broken("zip_open for writing failed");
  add_entry(archive, "version", "2");
  add_entry(archive, "metadata", metadata);
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    std::string name;
    if (mode & 4)
      name = "analog-1-1-" + std::to_string(i + 1);
    else if ((mode & 2) && i == 0)
      name = "logic-1";
    else
      name = "logic-1-" + std::to_string(i + 1);
    add_entry(archive, name, chunks[i]);
  }
  if (zip_close(archive) != 0) {
    zip_discard(archive);
    contract_broken("zip_close failed");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = input_path();
  if (size > 0 && (data[0] & 1))
    write_recipe(data, size);
  else
    drivetap::fuzz::write_file(path, data, size);

  std::string error;
  auto file = drivetap::SigrokFile::open(path, &error);
  if (!file) {
    if (error.rfind(path + ": ", 0) != 0) contract_broken("open() failed without 'FILE: '");
    return 0;
  }
  if (file->channels().empty()) contract_broken("a session opened with no channel");
  if (file->sample_rate() == 0) contract_broken("a session opened with no sample rate");
  std::vector<std::size_t> all(file->channels().size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  if (!file->select(all, &error)) {
    if (error.rfind(path + ": ", 0) != 0) contract_broken("select() failed without 'FILE: '");
    return 0;
  }
  drivetap::RunBlock block;
  std::uint64_t at = 0;
  while (file->next_block(block, &error)) {
    drivetap::fuzz::check_block(block, at, all.size(),
                                [](std::size_t, const drivetap::phy::LevelRun&) {});
    at = block.end;
  }
  if (!error.empty() && error.rfind(path + ": ", 0) != 0)
    contract_broken("a read error without 'FILE: '");

  // The whole logic path: channel choice, line detection, UART decoding, the time-ordered merge.
  file = drivetap::SigrokFile::open(path, &error);
  if (!file) contract_broken("a session that opened once does not open again");
  drivetap::fuzz::run_logic_path(std::move(file), path);
  return 0;
}

// Half the mutations of a recipe (odd first byte) rewrite its metadata with extreme or duplicate
// keys (fuzz/structured_mutators.hpp); the rest, and every raw zip, are libFuzzer's.
extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size,
                                               std::size_t max_size, unsigned seed) {
  std::mt19937 rng(seed);
  if (size > 0 && (data[0] & 1) && rng() % 2 == 0) {
    const std::string all(reinterpret_cast<const char*>(data), size);
    const std::size_t nul = all.find('\0', 1);
    const std::string metadata =
        all.substr(1, nul == std::string::npos ? std::string::npos : nul - 1);
    const std::string rest = nul == std::string::npos ? std::string() : all.substr(nul);
    const std::string mutated =
        all.substr(0, 1) + drivetap::fuzz::mutate_sigrok_metadata(metadata, rng) + rest;
    if (const std::size_t used = drivetap::fuzz::store(mutated, data, max_size)) return used;
  }
  return LLVMFuzzerMutate(data, size, max_size);
}
