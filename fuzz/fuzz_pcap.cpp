// Fuzzes classic pcap input (libpcap) via CaptureReader(pcapng=false) feeding the whole Pipeline.
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
  // CaptureReader owns `f` for classic pcap: libpcap (or the reader, on a bad header) closes it.
  drivetap::ChannelTable channels;
  drivetap::CaptureReader reader(f, "fuzz.pcap", /*pcapng=*/false, channels);
  drivetap::fuzz::run_source(reader, channels);
  return 0;
}
