// Fuzzes drive profiles (TOML, src/drive/profile.hpp, docs/reference.md "Drive profiles"): the
// input up to its first NUL is a profile file; a profile that loads is then the only `--drive auto`
// candidate of a pipeline fed the rest of the input as bus bytes (0xFE b = b ms of silence), with
// its protocol fixed, so that its registers, enums, scales and timing rules meet hostile frames.
// A profile that does not load must say why in "FILE:LINE: ..." form.
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "dissectors/modbus/modbus_protocol.hpp"
#include "drive/profile.hpp"
#include "fuzz/fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace drivetap;
  const std::string_view all(reinterpret_cast<const char*>(data), size);
  const std::size_t nul = all.find('\0');
  const std::string_view text = all.substr(0, nul);
  ProfileError error;
  const auto profile = parse_profile(text, "fuzz.toml", &error);
  if (!profile) {
    if (error.text().rfind("fuzz.toml", 0) != 0) fuzz::contract_broken("error without the file");
    return 0;
  }
  // The lookups sinks make, on addresses taken from the input.
  for (std::size_t i = 0; i + 1 < text.size() && i < 64; i += 2) {
    const std::uint32_t address = static_cast<std::uint32_t>(data[i] << 8 | data[i + 1]);
    std::string label;
    (void)profile->find_holding(address, &label);
    (void)profile->parameter_of_register(address);
    (void)profile->parameter_label(address);
  }
  if (nul == std::string_view::npos) return 0;

  const std::span<const std::uint8_t> stream(data + nul + 1, size - nul - 1);
  ChannelTable channels;
  channels.intern("bus");
  PipelineOptions options;
  options.protocol = profile->protocols.empty() ? protocols::modbus_rtu : profile->protocols[0];
  options.timing = FramingTiming::from(options.serial);
  options.auto_candidates = {&*profile};
  fuzz::CheckedRun run(options, channels);
  TimeNs t = 0;
  for (std::size_t i = 0; i < stream.size(); ++i) {
    if (stream[i] == 0xFE && i + 1 < stream.size()) {
      t += TimeNs{stream[++i]} * kNsPerMs;
      continue;
    }
    run.push({t, stream[i], 0, 0, 0});
    t += options.timing.character_time;
  }
  run.finish();
  return 0;
}
