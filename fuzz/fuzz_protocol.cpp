// Fuzzes one protocol's decoder (built three times: Modbus ASCII, Danfoss FC, Easydrive, chosen
// by DRIVETAP_FUZZ_PROTOCOL): the data as one frame through the dissector in every direction and
// the decoder's direction/pairing helpers; then as a byte stream through the pipeline with that
// protocol fixed (its framer, pairing), checking the byte accounting and field spans.
#include <cstdint>
#include <span>
#include <vector>

#include "core/protocol.hpp"
#include "fuzz/fuzz_common.hpp"

namespace {

using namespace drivetap;

// The protocol by its --protocol name ("modbus-ascii"), from the registry.
const Protocol kProtocol = protocol_from_option(DRIVETAP_FUZZ_PROTOCOL);
constexpr Direction kDirections[] = {Direction::unknown, Direction::request, Direction::response};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  const ProtocolDecoder& decoder = *decoder_for(kProtocol);
  SerialConfig serial;
  const FramingTiming timing = FramingTiming::from(serial);

  (void)decoder.direction_fit(bytes);
  (void)decoder.always_response(bytes);
  (void)decoder.recognisable(bytes);
  (void)decoder.pairing_keys(bytes);
  for (Direction dir : kDirections) {
    Frame f;
    TimeNs t = 0;
    for (std::uint8_t b : bytes) f.events.push_back({t += timing.character_time, b, 0, 0, 0});
    const Message m = decoder.dissect(std::move(f), dir, timing);
    fuzz::check_field_spans(m);
    for (const FieldNode& n : m.fields)
      (void)format_field_value(m.fields, n, m.bytes, m.text_encoded);
  }

  // As a stream: a byte 0xFE followed by another byte b means "b x 1 ms of silence".
  ChannelTable channels;
  channels.intern("bus");
  PipelineOptions options;
  options.protocol = kProtocol;
  options.timing = timing;
  options.auto_candidates = fuzz::builtin_candidates();
  fuzz::CheckedRun run(options, channels);
  TimeNs t = 0;
  for (std::size_t i = 0; i < size; ++i) {
    if (bytes[i] == 0xFE && i + 1 < size) {
      t += static_cast<TimeNs>(bytes[++i]) * kNsPerMs;
      continue;
    }
    run.push({t, bytes[i], 0, 0, 0});
    t += timing.character_time;
  }
  run.finish();
  return 0;
}
