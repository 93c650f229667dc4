// The floor of a `read --stats` pass (docs/performance.md "The targets of issue 8"): a
// capture read by drivetap's own reader into the runs `read` decodes (CaptureReader::append_runs,
// on one thread), each run's Modbus RTU CRC checked and counted (docs/protocols.md §2); no framer,
// direction, pairing, findings or anomalies.
//
//   drivetap_floor FILE.pcapng
//
// What no decode of that file by drivetap can undercut on one core: bench/end_to_end.sh times it
// beside `read --stats`, whose work it is a part of. On a capture whose packets are each one frame
// (`generate --plain`, as another capture tool writes them), its counts are the checksum verdicts
// of `read --stats`'s summary, and its packets under 4 bytes its noise records.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "core/byte_event.hpp"
#include "core/byte_events.hpp"
#include "core/checksum.hpp"
#include "core/serial_config.hpp"
#include "sources/file/capture_reader.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: drivetap_floor FILE.pcapng\n");
    return 2;
  }
  const std::string name = argv[1];
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> in(std::fopen(name.c_str(), "rb"),
                                                           &std::fclose);
  if (!in) {
    std::perror(("drivetap_floor: " + name).c_str());
    return 2;
  }
  drivetap::ChannelTable channels;
  drivetap::CaptureReader reader(in.get(), name, true, channels);
  if (!reader.read_header()) {
    std::fprintf(stderr, "drivetap_floor: %s\n", reader.error().c_str());
    return 1;
  }
  // (The character time places the bytes in time, which the floor does not look at: `read`'s.)
  reader.set_character_time(
      reader.settings().serial.value_or(drivetap::SerialConfig{}).character_time());
  std::uint64_t runs = 0, short_runs = 0, good = 0, swapped = 0, bad = 0;
  drivetap::RunBatch batch;
  // Each pass reads one batch of runs and counts them, or ends.
  while (true) {
    batch.clear();
    if (!reader.append_runs(batch)) break;
    for (std::size_t k = 0; k < batch.size(); ++k) {
      const drivetap::ByteRun run = batch[k];
      ++runs;
      if (run.size() < 4) {
        ++short_runs;
        continue;
      }
      switch (drivetap::check_rtu_crc(run.bytes).verdict) {
        case drivetap::ChecksumVerdict::good:
          ++good;
          break;
        case drivetap::ChecksumVerdict::swapped:
          ++swapped;
          break;
        default:
          ++bad;
          break;
      }
    }
  }
  if (!reader.error().empty()) {
    std::fprintf(stderr, "drivetap_floor: %s\n", reader.error().c_str());
    return 1;
  }
  std::printf("runs %llu: crc ok %llu, swapped %llu, bad %llu; shorter than 4 bytes %llu\n",
              static_cast<unsigned long long>(runs), static_cast<unsigned long long>(good),
              static_cast<unsigned long long>(swapped), static_cast<unsigned long long>(bad),
              static_cast<unsigned long long>(short_runs));
  return 0;
}
