// Fuzzes the pcapng reader via CaptureReader(pcapng=true) feeding the whole Pipeline.
#include <cstdint>
#include <cstdio>
#include <vector>

#include "fuzz/fuzz_common.hpp"
#include "sources/file/capture_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;  // the CLI stops at an empty file before choosing a reader
  std::vector<std::uint8_t> copy(data, data + size);
  std::FILE* f = fmemopen(copy.data(), copy.size(), "rb");
  if (!f) return 0;
  {
    drivetap::ChannelTable channels;
    drivetap::CaptureReader reader(f, "fuzz.pcapng", /*pcapng=*/true, channels);
    drivetap::fuzz::run_source(reader, channels);
  }
  std::fclose(f);  // for pcapng the FILE stays the caller's
  return 0;
}
