// Logic-analyser captures as a byte source (src/sources/sigrok_source.hpp).
#include "sources/sigrok_source.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace drivetap {

SigrokSource::SigrokSource(std::unique_ptr<SigrokFile> file, std::string name,
                           ChannelTable& channels, SigrokSourceOptions options)
    : file_(std::move(file)),
      name_(std::move(name)),
      channels_(channels),
      options_(std::move(options)) {}

bool SigrokSource::read_header() {
  const std::vector<std::string>& names = file_->channels();
  const auto rate = static_cast<std::uint64_t>(file_->sample_rate());
  if (const std::string why = options_.uart.validate(rate); !why.empty()) {
    error_ = fmt::format("{}: {} at {} samples/s: {}", name_, "line settings", rate, why);
    return false;
  }
  // Which bits to decode: the named ones, else every line that moves (a first pass counts edges).
  std::vector<int> bits;
  for (const std::string& wanted : options_.channels) {
    int found = -1;
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == wanted) found = static_cast<int>(i);
    if (found < 0 && !wanted.empty() &&
        std::all_of(wanted.begin(), wanted.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
        std::stoul(wanted) < names.size())
      found = static_cast<int>(std::stoul(wanted));
    if (found < 0) {
      error_ = fmt::format("--channels: {}: no channel '{}' (channels: {})", name_, wanted,
                           fmt::join(names, ", "));
      return false;
    }
    bits.push_back(found);
  }
  if (bits.empty()) {
    std::vector<std::uint64_t> edges(names.size(), 0);
    bool have = false;
    std::uint64_t prev = 0;
    if (!file_->read(
            [&](std::span<const std::uint64_t> chunk) {
              for (std::uint64_t s : chunk) {
                const std::uint64_t changed = have ? (s ^ prev) : 0;
                have = true;
                prev = s;
                if (changed)
                  for (std::size_t b = 0; b < names.size(); ++b) edges[b] += (changed >> b) & 1;
              }
            },
            &error_))
      return false;
    for (std::size_t b = 0; b < names.size(); ++b)
      if (edges[b] >= 4) bits.push_back(static_cast<int>(b));
    if (bits.empty()) {
      error_ = fmt::format("{}: no channel carries traffic (no line changes level)", name_);
      return false;
    }
  }
  // One decoder per channel; each chunk is turned into level runs per channel.
  std::vector<phy::UartDecoder> decoders;
  std::vector<ChannelId> ids;
  for (int b : bits) {
    decoders.emplace_back(options_.uart, rate);
    // All channels of one analyser watch one link: on a 4-wire link RX and TX are its two
    // directions, and content and order tell requests from replies (as on a shared pair).
    ids.push_back(channels_.intern(names[static_cast<std::size_t>(b)], "", ChannelRole::bus));
  }
  std::vector<std::vector<phy::UartCharacter>> out(bits.size());
  std::vector<bool> level(bits.size(), true);
  std::vector<std::uint64_t> run(bits.size(), 0);
  bool started = false;
  if (!file_->read(
          [&](std::span<const std::uint64_t> chunk) {
            for (std::size_t k = 0; k < bits.size(); ++k) {
              const int b = bits[k];
              bool lv = level[k];
              std::uint64_t length = run[k];
              std::size_t i = 0;
              if (!started && !chunk.empty()) lv = (chunk[0] >> b) & 1;
              for (; i < chunk.size(); ++i) {
                const bool s = (chunk[i] >> b) & 1;
                if (s != lv) {
                  decoders[k].push_run(lv, length, out[k]);
                  lv = s;
                  length = 0;
                }
                ++length;
              }
              level[k] = lv;
              run[k] = length;
            }
            started = true;
          },
          &error_))
    return false;
  const phy::SampleClock clock{rate, 0};
  for (std::size_t k = 0; k < bits.size(); ++k) {
    if (run[k]) decoders[k].push_run(level[k], run[k], out[k]);
    decoders[k].finish(out[k]);
    for (const phy::UartCharacter& c : out[k])
      events_.push_back(phy::to_byte_event(c, clock, ids[k]));
    const phy::UartDecoderStats& st = decoders[k].stats();
    notes_.push_back(
        fmt::format("{}: channel {}: {} characters ({} parity errors, {} framing errors, {} "
                    "breaks, {} glitches "
                    "filtered)",
                    name_, names[static_cast<std::size_t>(bits[k])], st.characters,
                    st.parity_errors, st.framing_errors, st.breaks, st.glitches));
  }
  std::stable_sort(events_.begin(), events_.end(),
                   [](const ByteEvent& a, const ByteEvent& b) { return a.time < b.time; });
  return true;
}

bool SigrokSource::next(ByteEvent& out) {
  if (next_ >= events_.size()) return false;
  out = events_[next_++];
  return true;
}

}  // namespace drivetap
