// Fuzzes SigrokFile (sigrok session .sr, src/sources/sigrok_file.hpp) and the logic path behind
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
// src/sources/logic_capture.hpp checked; errors must name the file.
#include <unistd.h>
#include <zip.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz/fuzz_common.hpp"
#include "sources/logic_source.hpp"
#include "sources/sigrok_file.hpp"

namespace {

using drivetap::fuzz::contract_broken;

const std::string& input_path() {
  static const std::string path = [] {
    // tmpfs when there is one (see fuzz_vcd.cpp).
    std::string name = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    name += "/drivetap-fuzz-sr-XXXXXX";
    const int fd = mkstemp(name.data());
    if (fd < 0) contract_broken("cannot create a temporary file");
    close(fd);
    static std::string kept = name;
    std::atexit([] { unlink(kept.c_str()); });
    return kept;
  }();
  return path;
}

void write_raw(const std::uint8_t* data, std::size_t size) {
  std::FILE* out = std::fopen(input_path().c_str(), "wb");
  if (!out) contract_broken("cannot write the temporary file");
  if (size > 0 && std::fwrite(data, 1, size, out) != size) contract_broken("short write");
  std::fclose(out);
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
  if (size > 0 && (data[0] & 1))
    write_recipe(data, size);
  else
    write_raw(data, size);
  const std::string& path = input_path();

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
    if (block.begin != at) contract_broken("a block does not begin where the last one ended");
    if (block.end <= block.begin) contract_broken("an empty block");
    if (block.runs.size() != all.size()) contract_broken("runs not one per selected channel");
    for (const auto& runs : block.runs) {
      std::uint64_t covered = 0;
      for (const drivetap::phy::LevelRun& run : runs) {
        if (run.length == 0) contract_broken("an empty run");
        covered += run.length;
      }
      if (covered != block.end - block.begin) contract_broken("runs do not cover the block");
    }
    at = block.end;
  }
  if (!error.empty() && error.rfind(path + ": ", 0) != 0)
    contract_broken("a read error without 'FILE: '");

  // The whole logic path: channel choice, line detection, UART decoding, the time-ordered merge.
  file = drivetap::SigrokFile::open(path, &error);
  if (!file) contract_broken("a session that opened once does not open again");
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
