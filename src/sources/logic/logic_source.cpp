// Logic-analyser captures as a byte source (src/sources/logic/logic_source.hpp).
#include "sources/logic/logic_source.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "core/printable.hpp"

namespace drivetap {
namespace {

// Level runs held for channel choice and detection, over all channels (16 bytes each: 64 MiB),
// and the fewest kept for each channel however many there are.
constexpr std::size_t kDetectionRunBudget = std::size_t{4} << 20;
constexpr std::size_t kMinDetectionRuns = 1000;

}  // namespace

LogicSource::LogicSource(std::unique_ptr<LogicCapture> capture, std::string name,
                         ChannelTable& channels, LogicSourceOptions options)
    : capture_(std::move(capture)),
      name_(std::move(name)),
      channels_(channels),
      options_(std::move(options)) {}

// The named channels, else every channel whose line moves. Either way the first runs of each are
// kept for detection; reading stops once every moving channel has enough of them (a channel
// that starts moving only after that is not found: name it with --channels).
bool LogicSource::choose_channels() {
  const std::vector<std::string>& names = capture_->channels();
  std::vector<std::size_t> reading;
  for (const std::string& wanted : options_.channels) {
    std::optional<std::size_t> found;
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == wanted) found = i;
    if (!found && !wanted.empty() && wanted.size() < 4 &&
        std::all_of(wanted.begin(), wanted.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
        std::stoul(wanted) < names.size())
      found = std::stoul(wanted);
    if (!found) {
      std::vector<std::string> shown;
      for (const std::string& n : names)
        shown.push_back(printable_bounded(n, ChannelTable::kMaxNameBytes));
      error_ = fmt::format("--channels: {}: no channel '{}' (channels: {})", name_,
                           printable(wanted), fmt::join(shown, ", "));
      return false;
    }
    if (std::find(reading.begin(), reading.end(), *found) != reading.end()) {
      error_ = fmt::format("--channels: {}: channel '{}' is named twice (as '{}')", name_,
                           printable_bounded(names[*found], ChannelTable::kMaxNameBytes),
                           printable(wanted));
      return false;
    }
    reading.push_back(*found);
  }
  const bool named = !reading.empty();
  if (!named)
    for (std::size_t i = 0; i < names.size(); ++i) reading.push_back(i);
  if (!capture_->select(reading, &error_)) return false;
  // The runs held for detection are bounded in all, not only per channel: a capture of thousands
  // of channels gets fewer runs for each.
  const std::size_t per_channel = std::max<std::size_t>(
      kMinDetectionRuns, std::min(options_.detection_runs, kDetectionRunBudget / reading.size()));
  std::vector<std::vector<phy::LevelRun>> runs(reading.size());
  std::vector<std::uint64_t> edges(reading.size(), 0);
  std::size_t moving = 0;  // channels with 4 edges or more
  auto enough = [&] {
    bool any_full = false;
    for (std::size_t k = 0; k < reading.size(); ++k) {
      const bool full = runs[k].size() >= per_channel;
      if (edges[k] >= 4 && !full) return false;
      any_full = any_full || full;
    }
    return any_full;
  };
  while (!enough() && !stop_requested() && capture_->next_block(block_, &error_)) {
    for (std::size_t k = 0; k < reading.size(); ++k)
      for (const phy::LevelRun& r : block_.runs[k]) {
        if (runs[k].size() >= per_channel) break;
        if (!runs[k].empty() && runs[k].back().level != r.level && ++edges[k] == 4) ++moving;
        runs[k].push_back(r);
      }
    // More moving channels than can be kept apart: say so now, before detecting any of them.
    if (!named && moving > ChannelTable::kMaxChannels) {
      error_ = fmt::format(
          "{}: more than {} channels change level; drivetap keeps at most {} apart (choose with "
          "--channels)",
          name_, ChannelTable::kMaxChannels, ChannelTable::kMaxChannels);
      return false;
    }
  }
  // Damage (or the decompression limit) met while reading ahead is met again, at the same place,
  // when decoding: detect from what came before it, decode up to it, then report it.
  if (!error_.empty() &&
      std::all_of(runs.begin(), runs.end(), [](const auto& r) { return r.empty(); }))
    return false;
  error_.clear();
  for (std::size_t k = 0; k < reading.size(); ++k) {
    if (!named && edges[k] < 4) continue;
    chosen_.push_back(reading[k]);
    chosen_names_.push_back(names[reading[k]]);
    head_runs_.push_back(std::move(runs[k]));
  }
  if (chosen_.empty()) {
    error_ = fmt::format("{}: no channel carries traffic (no line changes level)", name_);
    return false;
  }
  return true;
}

bool LogicSource::read_header() {
  const std::uint64_t rate = capture_->sample_rate();
  if (options_.uart) {
    if (const std::string why = options_.uart->validate(rate); !why.empty()) {
      error_ = fmt::format("{}: line settings at {} samples/s: {}", name_, rate, why);
      return false;
    }
  }
  if (!choose_channels()) return false;
  // Each channel on its own: settings, polarity and verdicts of one never decide another's.
  std::vector<std::size_t> kept;
  std::string first_failure;
  for (std::size_t k = 0; k < chosen_.size(); ++k) {
    ChannelLine line;
    line.name = chosen_names_[k];
    line.head_runs = std::move(head_runs_[k]);
    const std::span<const std::vector<phy::LevelRun>> one(&line.head_runs, 1);
    phy::LineDetection found = phy::detect_line(one, rate);
    const std::string shown = printable_bounded(line.name, ChannelTable::kMaxNameBytes);
    if (options_.uart) {
      line.uart = *options_.uart;
      // Given settings are used as given; when they decode badly and others decode clean, say so.
      line.given_trial = phy::trial_decode(one, rate, line.uart);
      const phy::FormatTrial& given = *line.given_trial;
      if (found.found && given.error_rate() > 0.05 && found.best().error_rate() < 0.01)
        extra_notes_.push_back(fmt::format(
            "{}: channel {}: {} of {} characters have errors with the given settings ({}); the "
            "line looks like {} (detected) — see `drivetap diagnose`",
            name_, shown, given.errors(), given.stats.characters, phy::settings_text(line.uart),
            phy::settings_text(found.settings)));
    } else if (!found.found) {
      if (first_failure.empty())
        first_failure = chosen_.size() == 1 ? found.why_not
                                            : fmt::format("channel {}: {}", shown, found.why_not);
      dropped_.push_back(
          fmt::format("{}: channel {}: not decoded: cannot detect its line "
                      "settings: {}",
                      name_, shown, found.why_not));
      continue;
    } else {
      line.uart = found.settings;
    }
    line.detection = std::move(found);
    kept.push_back(k);
    lines_.push_back(std::move(line));
  }
  head_runs_.clear();
  if (lines_.empty()) {
    error_ = fmt::format(
        "{}: cannot detect the line settings: {}; give them with -s (and "
        "--invert if the line idles low)",
        name_, first_failure);
    return false;
  }
  std::vector<std::size_t> decoded;
  for (std::size_t k : kept) decoded.push_back(chosen_[k]);
  if (decoded.size() != chosen_.size()) {
    std::vector<std::string> names;
    for (std::size_t k : kept) names.push_back(chosen_names_[k]);
    chosen_ = decoded;
    chosen_names_ = names;
  }
  // The busiest channel sets the pipeline's character time.
  auto characters = [](const ChannelLine& l) {
    return l.detection && l.detection->found ? l.detection->best().stats.characters : 0;
  };
  for (std::size_t k = 1; k < lines_.size(); ++k)
    if (characters(lines_[k]) > characters(lines_[main_line_])) main_line_ = k;
  if (!capture_->select(chosen_, &error_)) return false;
  for (std::size_t k = 0; k < chosen_.size(); ++k) {
    decoders_.emplace_back(lines_[k].uart, rate);
    // All channels of one analyser watch one link: on a 4-wire link RX and TX are its two
    // directions, and content and order tell requests from replies (as on a shared pair).
    ids_.push_back(channels_.intern(chosen_names_[k], "", ChannelRole::bus));
    if (ids_.back() == kNoChannel) {
      error_ = fmt::format(
          "{}: {} channels chosen; drivetap keeps at most {} apart (choose with "
          "--channels)",
          name_, chosen_.size(), ChannelTable::kMaxChannels);
      return false;
    }
  }
  clock_ = phy::SampleClock{rate, 0};
  // A character still to come began at most one character (plus a filtered edge) before the end
  // of what was pushed, a break up to kRestCharacters before it (reported when the line rises);
  // two characters of margin.
  constexpr double kHeldCharacters = phy::UartDecoder::kRestCharacters + 2;
  for (std::size_t k = 0; k < lines_.size(); ++k)
    hold_back_ = std::max<std::uint64_t>(
        hold_back_, static_cast<std::uint64_t>(kHeldCharacters * lines_[k].uart.frame_bits() *
                                               lines_[k].uart.samples_per_bit(rate)) +
                        decoders_[k].glitch_filter_samples() + 2);
  return true;
}

RunSettings LogicSource::settings() const {
  // The pipeline's timing (t1.5, t3.5, character time) follows the line found or given.
  RunSettings s;
  s.serial = uart().serial_config();
  return s;
}

bool LogicSource::fill() {
  if (at_end_) return false;
  // Drop what was handed out; keep what is not final yet.
  pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(next_pending_));
  next_pending_ = 0;
  const bool more = capture_->next_block(block_, &error_);
  if (!error_.empty()) return false;
  const std::size_t before = pending_.size();
  for (std::size_t k = 0; k < decoders_.size(); ++k) {
    decoded_.clear();
    if (more)
      decoders_[k].push_runs(block_.runs[k], decoded_);
    else
      decoders_[k].finish(decoded_);
    for (const phy::UartCharacter& c : decoded_)
      pending_.push_back(phy::to_byte_event(c, clock_, ids_[k]));
  }
  // Each channel's characters are in order, the channels not: sort the new ones, then merge them
  // with what is held.
  const auto fresh = pending_.begin() + static_cast<std::ptrdiff_t>(before);
  auto by_time = [](const ByteEvent& a, const ByteEvent& b) { return a.time < b.time; };
  std::stable_sort(fresh, pending_.end(), by_time);
  std::inplace_merge(pending_.begin(), fresh, pending_.end(), by_time);
  if (more) {
    releasable_before_ = block_.end > hold_back_ ? block_.end - hold_back_ : 0;
  } else {
    at_end_ = true;
    releasable_before_ = UINT64_MAX;
  }
  return true;
}

bool LogicSource::next(ByteEvent& out) {
  for (;;) {
    if (next_pending_ < pending_.size() &&
        (releasable_before_ == UINT64_MAX ||
         pending_[next_pending_].time < clock_.to_ns(releasable_before_))) {
      out = pending_[next_pending_++];
      return true;
    }
    if (stop_requested() || !fill()) return false;
  }
}

std::vector<phy::UartDecoderStats> LogicSource::decoder_stats() const {
  std::vector<phy::UartDecoderStats> stats;
  for (const phy::UartDecoder& d : decoders_) stats.push_back(d.stats());
  return stats;
}

std::vector<std::string> LogicSource::notes() const {
  std::vector<std::string> notes;
  for (const ChannelLine& line : lines_) {
    if (!line.detection || options_.uart) continue;
    const phy::LineDetection& d = *line.detection;
    notes.push_back(fmt::format(
        "{}: channel {}: line detected: {} (baud {} measured {:.0f}, {}; polarity {}; format {}: "
        "{})",
        name_, printable_bounded(line.name, ChannelTable::kMaxNameBytes),
        phy::settings_text(line.uart), d.baud_standard ? "standard," : "non-standard,",
        d.measured_baud, phy::confidence_name(d.baud_confidence),
        phy::confidence_name(d.polarity_confidence), phy::confidence_name(d.format_confidence),
        d.format_reason));
  }
  notes.insert(notes.end(), dropped_.begin(), dropped_.end());
  notes.insert(notes.end(), extra_notes_.begin(), extra_notes_.end());
  for (std::size_t k = 0; k < decoders_.size(); ++k) {
    const phy::UartDecoderStats& st = decoders_[k].stats();
    notes.push_back(fmt::format(
        "{}: channel {}: {} characters ({} parity errors, {} framing errors, {} breaks, {} "
        "glitches filtered, {} false starts)",
        name_, channels_.at(ids_[k]).name, st.characters, st.parity_errors, st.framing_errors,
        st.breaks, st.glitches, st.false_starts));
  }
  return notes;
}

}  // namespace drivetap
