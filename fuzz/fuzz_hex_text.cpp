// Fuzzes the text `drivetap decode` reads (src/sources/file/hex_text.hpp, docs/formats.md "Hex
// text"): each line of the input is hex bytes ("01 03 00 00 | 01 83 02") or one ':' / '~' text
// frame with escapes, parsed by the functions decode uses (decode_text_kind, parse_decode_text); a
// refused line must say why; the frames are laid out on a synthetic time line (times must not go
// back) and decoded by a pipeline with detection.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz/fuzz_common.hpp"
#include "sources/file/hex_text.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace drivetap;
  const std::string_view all(reinterpret_cast<const char*>(data), size);
  ChannelTable channels;
  channels.intern("bus");
  PipelineOptions options;
  options.timing = FramingTiming::from(options.serial);
  fuzz::CheckedRun run(options, channels);
  const TimeNs gap = std::max<TimeNs>(options.timing.t35 * 4, 20 * kNsPerMs);
  TimeNs clock = 0;
  std::vector<ByteEvent> events;
  // Each pass takes one line (up to '\n' or the end) and moves past it.
  for (std::size_t at = 0; at < all.size();) {
    const std::size_t newline = all.find('\n', at);
    const std::size_t end = newline == std::string_view::npos ? all.size() : newline;
    const std::string_view line = all.substr(at, end - at);
    at = end + 1;
    const char kind = decode_text_kind(line);
    if (kind == 0) continue;
    std::string error;
    const auto frames = parse_decode_text(line, kind, &error);
    if (!frames) {
      if (error.empty()) fuzz::contract_broken("a refused line without a reason");
      continue;
    }
    events.clear();
    const TimeNs before = clock;
    synthesize_events(*frames, 0, options.timing.character_time, gap, &clock, events);
    TimeNs last = before;
    for (const ByteEvent& e : events) {
      if (e.time < last) fuzz::contract_broken("synthesized times go back");
      last = e.time;
      run.push(e);
    }
  }
  run.finish();
  return 0;
}
