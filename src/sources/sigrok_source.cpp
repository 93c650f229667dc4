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
  const std::uint64_t rate = file_->sample_rate();
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
  RunBlock block;
  if (bits.empty()) {
    std::vector<std::size_t> all(names.size());
    for (std::size_t b = 0; b < all.size(); ++b) all[b] = b;
    if (!file_->select(all, &error_)) return false;
    std::vector<std::uint64_t> edges(names.size(), 0);
    std::vector<int> last(names.size(), -1);
    while (file_->next_block(block, &error_))
      for (std::size_t b = 0; b < all.size(); ++b)
        for (const phy::LevelRun& r : block.runs[b]) {
          if (last[b] >= 0 && last[b] != static_cast<int>(r.level)) ++edges[b];
          last[b] = r.level;
        }
    if (!error_.empty()) return false;
    for (std::size_t b = 0; b < names.size(); ++b)
      if (edges[b] >= 4) bits.push_back(static_cast<int>(b));
    if (bits.empty()) {
      error_ = fmt::format("{}: no channel carries traffic (no line changes level)", name_);
      return false;
    }
  }
  // One decoder per channel.
  std::vector<phy::UartDecoder> decoders;
  std::vector<ChannelId> ids;
  std::vector<std::size_t> selected;
  for (int b : bits) {
    decoders.emplace_back(options_.uart, rate);
    selected.push_back(static_cast<std::size_t>(b));
    // All channels of one analyser watch one link: on a 4-wire link RX and TX are its two
    // directions, and content and order tell requests from replies (as on a shared pair).
    ids.push_back(channels_.intern(names[static_cast<std::size_t>(b)], "", ChannelRole::bus));
  }
  std::vector<std::vector<phy::UartCharacter>> out(bits.size());
  if (!file_->select(selected, &error_)) return false;
  while (file_->next_block(block, &error_))
    for (std::size_t k = 0; k < bits.size(); ++k) decoders[k].push_runs(block.runs[k], out[k]);
  if (!error_.empty()) return false;
  const phy::SampleClock clock{rate, 0};
  for (std::size_t k = 0; k < bits.size(); ++k) {
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
