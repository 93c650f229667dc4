// Fuzzes ByteLogReader (byte-log text, docs/formats.md "The byte log") feeding the whole Pipeline.
#include <cstdint>
#include <cstdio>
#include <vector>

#include "fuzz/fuzz_common.hpp"
#include "sources/file/byte_log.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;  // the CLI stops at an empty file before choosing a reader
  std::vector<std::uint8_t> copy(data, data + size);
  std::FILE* f = fmemopen(copy.data(), copy.size(), "rb");
  if (!f) return 0;
  {
    drivetap::ChannelTable channels;
    drivetap::ByteLogReader reader(f, "fuzz.log", channels);
    drivetap::fuzz::run_source(reader, channels);
  }
  std::fclose(f);  // the byte-log reader leaves the FILE to its caller
  return 0;
}
