// UART decoder over sampled logic levels (docs/protocols.md §1 line settings; see
// uart_decoder.hpp).
#include "sources/logic/uart_decoder.hpp"

#include <fmt/format.h>

#include <bit>
#include <cmath>
#include <stdexcept>

namespace drivetap::phy {
namespace {

// Fewer samples per bit leave no room between the start edge's one-sample uncertainty and a bit
// boundary. At 2 the centre is still the sample after the edge's (sigrok decodes such captures
// too); detection gives such a line low confidence.
constexpr double kMinSamplesPerBit = 2.0;
// Above this, SampleClock::to_ns's integer arithmetic could overflow.
constexpr std::uint64_t kMaxSampleRateHz = 10'000'000'000;

double stop_bit_count(StopBits stop_bits) {
  switch (stop_bits) {
    case StopBits::one:
      return 1.0;
    case StopBits::one_and_half:
      return 1.5;
    case StopBits::two:
      return 2.0;
  }
  return 1.0;
}

std::uint64_t default_glitch_filter(double samples_per_bit) {
  const auto eighth_bit = static_cast<std::uint64_t>(std::llround(samples_per_bit / 8.0));
  return eighth_bit < 1 ? 1 : eighth_bit;
}

}  // namespace

bool parity_bit(UartParity parity, std::uint16_t value) {
  switch (parity) {
    case UartParity::even:
    case UartParity::odd:  // the bit that makes the count of ones even, or odd
      return ((std::popcount(value) & 1) != 0) != (parity == UartParity::odd);
    case UartParity::mark:
      return true;
    case UartParity::none:
    case UartParity::space:
      return false;
  }
  return false;
}

UartSettings UartSettings::from(const SerialConfig& serial) {
  UartSettings s;
  s.baud = serial.baud;
  s.data_bits = serial.data_bits;
  switch (serial.parity) {
    case Parity::none:
      s.parity = UartParity::none;
      break;
    case Parity::even:
      s.parity = UartParity::even;
      break;
    case Parity::odd:
      s.parity = UartParity::odd;
      break;
  }
  s.stop_bits = serial.stop_bits == 2 ? StopBits::two : StopBits::one;
  return s;
}

SerialConfig UartSettings::serial_config() const {
  SerialConfig serial;
  serial.baud = static_cast<std::uint32_t>(baud + 0.5);
  serial.data_bits = data_bits;
  serial.parity = parity == UartParity::even  ? Parity::even
                  : parity == UartParity::odd ? Parity::odd
                                              : Parity::none;
  serial.stop_bits = stop_bits == StopBits::two ? 2 : 1;
  return serial;
}

double UartSettings::frame_bits() const {
  return 1.0 + data_bits + (parity == UartParity::none ? 0.0 : 1.0) + stop_bit_count(stop_bits);
}

std::string UartSettings::validate(std::uint64_t sample_rate_hz) const {
  if (!std::isfinite(baud) || baud < kMinBaud || baud > kMaxBaud)
    return fmt::format("{:g} baud is outside the UART range {:.0f}..{:.0f} baud", baud, kMinBaud,
                       kMaxBaud);
  if (data_bits < 5 || data_bits > 9)
    return fmt::format("{} data bits: a UART character has 5 to 9", data_bits);
  if (sample_rate_hz == 0 || sample_rate_hz > kMaxSampleRateHz)
    return fmt::format("sample rate {} Hz is outside 1 Hz..10 GHz", sample_rate_hz);
  const double per_bit = samples_per_bit(sample_rate_hz);
  if (per_bit < kMinSamplesPerBit)
    return fmt::format("{:g} samples per bit at {} Hz and {:g} baud: need at least {:g}", per_bit,
                       sample_rate_hz, baud, kMinSamplesPerBit);
  if (glitch_filter_samples && static_cast<double>(*glitch_filter_samples) * 2 > per_bit)
    return fmt::format(
        "a glitch filter of {} samples would remove real bits (a bit is {:g} samples; keep the "
        "filter under half a bit)",
        *glitch_filter_samples, per_bit);
  return {};
}

UartDecoder::UartDecoder(const UartSettings& settings, std::uint64_t sample_rate_hz)
    : data_bits_(settings.data_bits), parity_(settings.parity), inverted_(settings.inverted) {
  if (std::string problem = settings.validate(sample_rate_hz); !problem.empty())
    throw std::invalid_argument(problem);
  const double per_bit = settings.samples_per_bit(sample_rate_hz);
  glitch_filter_ = settings.glitch_filter_samples.value_or(default_glitch_filter(per_bit));
  if (glitch_filter_ < 1) glitch_filter_ = 1;

  // The start edge is seen at the first low sample; the line really fell up to one sample
  // earlier, half a sample on average. Centres are placed from that average, so a bit centre
  // `b` bit times after the edge is the sample nearest to b * per_bit - 0.5.
  auto add_point = [&](double bit_time) {
    point_offsets_[point_count_++] =
        static_cast<std::uint64_t>(std::llround(bit_time * per_bit - 0.5));
  };
  add_point(0.5);  // start bit: still low at its centre, or it was a spike (false start)
  for (unsigned i = 0; i < data_bits_; ++i) add_point(1.5 + i);
  const double after_data = 1.0 + data_bits_;
  parity_point_ = point_count_;
  double stop_begins = after_data;
  if (parity_ != UartParity::none) {
    add_point(after_data + 0.5);
    stop_begins += 1.0;
  }
  // Every stop bit is sampled, but only the first decides a framing error, as on a 16550 (and in
  // sigrok's decoder): a transmitter set to 2 stop bits that sometimes sends 1.2 is read without
  // error by every receiver on the bus. A low later stop bit is counted (short_stop_bits), for
  // line detection and diagnosis. A start edge after the first stop bit's centre re-synchronises
  // (commit_edge).
  first_stop_point_ = point_count_;
  add_point(stop_begins + 0.5);
  if (settings.stop_bits == StopBits::one_and_half) add_point(stop_begins + 1.25);
  if (settings.stop_bits == StopBits::two) add_point(stop_begins + 1.5);
  frame_samples_ = static_cast<std::uint64_t>(std::llround(settings.frame_bits() * per_bit));
  rest_samples_ = kRestCharacters * frame_samples_;
}

void UartDecoder::push_runs(std::span<const LevelRun> runs, std::vector<UartCharacter>& out) {
  for (const LevelRun& run : runs) push_run(run.level, run.length, out);
}

void UartDecoder::push_run(bool level, std::uint64_t samples, std::vector<UartCharacter>& out) {
  if (samples == 0) return;
  const bool mark = level != inverted_;
  if (!level_known_) {
    // No edge seen yet: a capture that starts low may start inside a character, so its first
    // low stretch is not taken for a start bit.
    level_known_ = true;
    mark_ = mark;
    now_ += samples;
    return;
  }
  if (mark == mark_) {
    if (edge_pending_) {
      // The opposite level did not last the filter's length: a glitch, as if it never happened.
      edge_pending_ = false;
      ++glitches_since_report_;
      ++stats_.glitches;
    }
  } else if (!edge_pending_) {
    edge_pending_ = true;
    pending_start_ = now_;
  }
  now_ += samples;
  if (edge_pending_ && now_ - pending_start_ >= glitch_filter_) {
    edge_pending_ = false;
    commit_edge(pending_start_, mark, out);
  }
  // The filtered line is known up to a pending edge: it may still turn out to be a glitch.
  sample_until(edge_pending_ ? pending_start_ : now_, out);
}

void UartDecoder::end_of_low(std::uint64_t at, std::vector<UartCharacter>& out) {
  if (!low_after_break_) return;
  low_after_break_ = false;
  if (at - break_start_ >= rest_samples_) {
    ++stats_.rests_at_space;
    return;
  }
  start_ = break_start_;
  report(break_start_ + frame_samples_, true, out);
}

void UartDecoder::commit_edge(std::uint64_t at, bool mark, std::vector<UartCharacter>& out) {
  sample_until(at, out);  // sample points before the edge see the old level
  mark_ = mark;
  if (mark) end_of_low(at, out);
  if (in_character_ && !mark && next_point_ > first_stop_point_) {
    // A start bit after the first stop bit's centre, inside the second stop bit (or the half
    // one): the character ends here, and the receiver re-synchronises on this edge, as a UART
    // that checks only the first stop bit does.
    report(at, false, out);
  }
  if (in_character_) {
    if (mark) rose_since_start_ = true;
  } else if (!mark) {
    // A falling edge while hunting: a start bit. Any other edge while hunting is the line
    // returning to idle after a framing error or a break, which is all a hunt needs to wait for.
    in_character_ = true;
    rose_since_start_ = false;
    start_ = at;
    next_point_ = 0;
    sampled_levels_ = 0;
  }
}

void UartDecoder::sample_until(std::uint64_t limit, std::vector<UartCharacter>& out) {
  if (low_after_break_ && limit - break_start_ >= rest_samples_) {
    low_after_break_ = false;  // low this long: the line at rest, known without waiting for it
    ++stats_.rests_at_space;
  }
  while (in_character_) {
    if (next_point_ < point_count_) {
      if (start_ + point_offsets_[next_point_] >= limit) return;
      if (next_point_ == 0 && mark_) {
        // The start bit is gone at its centre: a pulse that passed the glitch filter but is
        // shorter than half a bit. A UART drops it (false start rejection); so does this one.
        in_character_ = false;
        ++stats_.false_starts;
        return;
      }
      sampled_levels_ |= std::uint32_t{mark_} << next_point_;
      ++next_point_;
    } else if (rose_since_start_) {
      report(start_ + frame_samples_, false, out);
    } else if (start_ + frame_samples_ <= limit) {
      // Low from the start edge to the end of the stop bits: not a character but a break, or the
      // line at rest; the rise (or how long it stays low) tells which.
      in_character_ = false;
      low_after_break_ = true;
      break_start_ = start_;
      if (limit - break_start_ >= rest_samples_) {
        low_after_break_ = false;
        ++stats_.rests_at_space;
      }
    } else {
      return;  // all low so far: a break if the line stays low to the end of the stop bits
    }
  }
}

void UartDecoder::report(std::uint64_t end_sample, bool is_break, std::vector<UartCharacter>& out) {
  UartCharacter c;
  c.start_sample = start_;
  c.end_sample = end_sample;
  c.glitches = glitches_since_report_;
  glitches_since_report_ = 0;
  if (is_break) {
    // One flag, not framing + break: a break is a framing violation by definition, and the
    // pipeline makes one finding per flag.
    c.flags = kUartBreak;
    ++stats_.breaks;
  } else {
    c.value = static_cast<std::uint16_t>((sampled_levels_ >> 1) & ((1u << data_bits_) - 1));
    const bool parity_seen = next_point_ > parity_point_;
    if (parity_ != UartParity::none && parity_seen &&
        parity_bit(parity_, c.value) != (((sampled_levels_ >> parity_point_) & 1) != 0)) {
      c.flags |= kUartParityError;
      ++stats_.parity_errors;
    }
    // The first stop bit decides. A later one that read low, or was never sampled because the
    // next start bit came first, is a short stop: no error, but evidence about the format.
    if (((sampled_levels_ >> first_stop_point_) & 1) == 0) {
      c.flags |= kUartFramingError;
      ++stats_.framing_errors;
    } else {
      const std::uint32_t stop_mask = ((1u << (point_count_ - first_stop_point_)) - 1)
                                      << first_stop_point_;
      if ((sampled_levels_ & stop_mask) != stop_mask) ++stats_.short_stop_bits;
    }
  }
  ++stats_.characters;
  in_character_ = false;
  out.push_back(c);
}

void UartDecoder::finish(std::vector<UartCharacter>& out) {
  if (edge_pending_) {
    // The capture ended inside a pulse still shorter than the filter: counted as the noise it
    // looks like.
    edge_pending_ = false;
    ++glitches_since_report_;
    ++stats_.glitches;
  }
  sample_until(now_, out);
  end_of_low(now_, out);  // the capture ends inside a break: reported as the break it was so far
  // A character whose stop bit the capture does not reach was cut by the end of the recording,
  // not damaged on the line: not reported, counted.
  if (in_character_ && next_point_ > 0 && next_point_ <= first_stop_point_) ++stats_.cut_by_end;
  in_character_ = false;
  level_known_ = false;
}

std::vector<UartCharacter> decode_runs(std::span<const LevelRun> runs, const UartSettings& settings,
                                       std::uint64_t sample_rate_hz) {
  UartDecoder decoder(settings, sample_rate_hz);
  std::vector<UartCharacter> out;
  decoder.push_runs(runs, out);
  decoder.finish(out);
  return out;
}

TimeNs SampleClock::to_ns(std::uint64_t sample) const {
  // Whole seconds and the remainder apart, so that nothing overflows 64 bits before the division.
  const auto ns_per_second = static_cast<std::uint64_t>(kNsPerSecond);
  const std::uint64_t whole_seconds = sample / sample_rate_hz;
  const std::uint64_t rest = sample % sample_rate_hz;
  const std::uint64_t ns =
      whole_seconds * ns_per_second + (rest * ns_per_second + sample_rate_hz / 2) / sample_rate_hz;
  return origin + static_cast<TimeNs>(ns);
}

ByteEvent to_byte_event(const UartCharacter& c, const SampleClock& clock, ChannelId channel) {
  ByteEvent e;
  e.time = clock.to_ns(c.start_sample);
  e.byte = static_cast<std::uint8_t>(c.value & 0xFF);
  e.flags = c.flags;
  if (c.value & 0x100) e.flags |= kUartNinthBit;
  e.channel = channel;
  return e;
}

}  // namespace drivetap::phy
