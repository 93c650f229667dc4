// Byte log reader (format: docs/formats.md "The byte log"; hand-written, see docs/design.md).
#include "sources/file/byte_log.hpp"

#include <fmt/format.h>

#include <cstdlib>
#include <cstring>

#include "core/read_block.hpp"

namespace drivetap {
namespace {

constexpr std::size_t kMaxLineLength = 16u << 20;  // bound on one line: hostile input

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

}  // namespace

ByteLogReader::ByteLogReader(std::FILE* in, std::string name, ChannelTable& channels)
    : in_(in), name_(std::move(name)), channels_(channels) {}

ByteLogReader::~ByteLogReader() = default;

bool ByteLogReader::fail(std::size_t column, const std::string& reason) {
  // Bytes already parsed from the failing line are not delivered: the line is rejected whole.
  queue_.clear();
  queue_pos_ = 0;
  error_ = fmt::format("{}:{}:{}: {}", name_, line_number_, column + 1, reason);
  return false;
}

bool ByteLogReader::read_line() {
  // One read block a read: straight into the buffer, past stdio's (core/read_block.hpp).
  constexpr std::size_t kReadBytes = kReadBlockBytes;
  std::size_t scanned = 0;  // bytes of this line already searched for '\n'
  // Each pass finds the line's end or reads more (or ends): the buffer only fills up.
  while (true) {
    const char* start = buffer_.data() + buffer_pos_;
    const std::size_t have = buffer_end_ - buffer_pos_;
    // (memchr is never given the empty buffer's null pointer, even for 0 bytes.)
    const auto* newline =
        have > scanned
            ? static_cast<const char*>(std::memchr(start + scanned, '\n', have - scanned))
            : nullptr;
    const std::size_t length = newline ? static_cast<std::size_t>(newline - start) + 1 : have;
    if (length > kMaxLineLength) {
      ++line_number_;
      fail(0, fmt::format("line longer than {} bytes", kMaxLineLength));
      return false;
    }
    if (newline || (at_eof_ && have > 0)) {
      ++line_number_;
      line_ = std::string_view(start, length);
      buffer_pos_ += length;
      break;
    }
    if (at_eof_) return false;
    scanned = have;
    // Keep the partial line, make room for one more block, read it.
    if (buffer_pos_ > 0) {
      std::memmove(buffer_.data(), start, have);
      buffer_pos_ = 0;
      buffer_end_ = have;
    }
    if (buffer_.size() < buffer_end_ + kReadBytes) buffer_.resize(buffer_end_ + kReadBytes);
    const std::size_t got = std::fread(buffer_.data() + buffer_end_, 1, kReadBytes, in_);
    buffer_end_ += got;
    if (got < kReadBytes) {
      if (std::ferror(in_)) {
        error_ = fmt::format("{}: read error after line {}: {}", name_, line_number_,
                             std::strerror(errno));
        return false;
      }
      if (std::feof(in_)) at_eof_ = true;
    }
  }
  line_ended_ = line_.ends_with('\n');
  while (!line_.empty() && (line_.back() == '\n' || line_.back() == '\r')) line_.remove_suffix(1);
  return true;
}

bool ByteLogReader::read_header() {
  while (read_line()) {
    std::size_t i = 0;
    while (i < line_.size() && is_space(line_[i])) ++i;
    const std::string_view rest = line_.substr(i);
    if (rest.empty()) continue;
    if (rest.starts_with("#!")) {
      std::string_view directive = rest.substr(2);
      while (!directive.empty() && is_space(directive.front())) directive.remove_prefix(1);
      if (directive.starts_with("serial")) {
        std::string err;
        auto cfg = SerialConfig::parse(directive.substr(6), &err);
        if (!cfg) return fail(i, err);
        header_serial_ = cfg;
      } else {
        // Unknown directives are kept for forward compatibility: newer writers may add some.
      }
      continue;
    }
    if (rest.front() == '#') continue;
    have_pending_line_ = true;
    return true;
  }
  return error_.empty();
}

bool ByteLogReader::parse_data_line() {
  queue_.clear();
  queue_pos_ = 0;
  const std::string_view line = line_;
  std::size_t i = 0;
  auto skip_space = [&] {
    while (i < line.size() && is_space(line[i])) ++i;
  };
  skip_space();
  if (i >= line.size()) return true;
  if (line[i] == '#') {
    if (line.substr(i).starts_with("#!")) {
      std::string_view directive = line.substr(i + 2);
      while (!directive.empty() && is_space(directive.front())) directive.remove_prefix(1);
      if (directive.starts_with("serial"))
        return fail(i, "'#! serial' after the first byte: line settings must come first");
    }
    return true;
  }
  // Time: seconds[.fraction], parsed exactly into nanoseconds.
  const std::size_t time_col = i;
  TimeNs seconds = 0;
  std::size_t digits = 0;
  while (i < line.size() && line[i] >= '0' && line[i] <= '9') {
    constexpr TimeNs kMaxSeconds = kTimeLimit / kNsPerSecond - 1;
    seconds = seconds * 10 + (line[i] - '0');
    if (seconds > kMaxSeconds)
      return fail(time_col, fmt::format("time too large (limit {} s)", kMaxSeconds));
    ++i;
    ++digits;
  }
  TimeNs fraction = 0;
  int fraction_digits = 0;
  if (i < line.size() && line[i] == '.') {
    ++i;
    while (i < line.size() && line[i] >= '0' && line[i] <= '9') {
      if (fraction_digits < 9) {
        fraction = fraction * 10 + (line[i] - '0');
        ++fraction_digits;
      }
      ++i;
      ++digits;
    }
  }
  if (digits == 0 || (i < line.size() && !is_space(line[i])))
    return fail(time_col, "expected a time in seconds (e.g. 0.012345) at the start of the line");
  for (int d = fraction_digits; d < 9; ++d) fraction *= 10;
  const TimeNs line_time = seconds * kNsPerSecond + fraction;

  skip_space();
  const std::size_t channel_col = i;
  while (i < line.size() && !is_space(line[i])) ++i;
  const std::string_view channel_name = line.substr(channel_col, i - channel_col);
  if (channel_name.empty() || channel_name.front() == '#')
    return fail(channel_col, "expected a channel name after the time (e.g. bus, m, s)");
  const ChannelId channel = channels_.intern(channel_name);
  if (channel == kNoChannel)
    return fail(channel_col, fmt::format("more than {} channels (the most drivetap keeps apart)",
                                         ChannelTable::kMaxChannels));
  if (last_line_time_.size() <= channel) last_line_time_.resize(channel + 1u, -1);
  if (last_line_time_[channel] > line_time) {
    findings_.push_back(
        {AnomalyKind::time_reversed, line_time, channel, 0,
         fmt::format("{}:{}: time {} s is earlier than the previous line's on channel {}", name_,
                     line_number_, static_cast<double>(line_time) / kNsPerSecond, channel_name)});
  }
  last_line_time_[channel] = line_time;

  TimeNs t = line_time;
  const std::size_t queued_before = queue_.size();
  while (true) {
    skip_space();
    if (i >= line.size() || line[i] == '#') break;
    const std::size_t token_col = i;
    std::size_t end = i;
    while (end < line.size() && !is_space(line[end])) ++end;
    const std::string_view token = line.substr(i, end - i);
    const std::size_t bang = token.find('!');
    const std::string_view hex = token.substr(0, bang);
    if (hex.empty() || hex.size() % 2 != 0)
      return fail(token_col, fmt::format("bad byte '{}': expected pairs of hex digits", token));
    std::uint8_t flags = 0;
    if (bang != std::string_view::npos) {
      if (hex.size() != 2)
        return fail(token_col, fmt::format("UART marks '!..' belong to one byte, not '{}'", hex));
      for (const char f : token.substr(bang + 1)) {
        switch (f) {
          case 'f':
            flags |= kUartFramingError;
            break;
          case 'p':
            flags |= kUartParityError;
            break;
          case 'b':
            flags |= kUartBreak;
            break;
          case 'o':
            flags |= kUartOverrun;
            break;
          default:
            return fail(token_col,
                        fmt::format("unknown UART mark '{}' in '{}' (use f, p, b, o)", f, token));
        }
      }
    }
    for (std::size_t k = 0; k < hex.size(); k += 2) {
      const int hi = hex_value(hex[k]);
      const int lo = hex_value(hex[k + 1]);
      if (hi < 0 || lo < 0)
        return fail(token_col + k + (hi < 0 ? 0 : 1), fmt::format("bad hex digit in '{}'", token));
      if (!time_in_range(t))
        return fail(token_col, fmt::format("byte time beyond {} s", kTimeLimit / kNsPerSecond));
      ByteEvent e;
      e.time = t;
      e.byte = static_cast<std::uint8_t>((hi << 4) | lo);
      e.flags = flags;
      e.channel = channel;
      queue_.push_back(e);
      t += character_time_;
    }
    i = end;
  }
  // A file cut off inside its last line ("0.1 b"): the time and channel are there, the bytes
  // and the end of line are not. (A line cut right after a whole byte cannot be told apart.)
  if (queue_.size() == queued_before && !line_ended_)
    return fail(channel_col, "last line cut short: no bytes and no end of line (file truncated?)");
  return true;
}

bool ByteLogReader::next(ByteEvent& out) {
  // Each pass consumes one queued byte or one line.
  while (queue_pos_ >= queue_.size()) {
    if (!error_.empty()) return false;
    if (have_pending_line_) {
      have_pending_line_ = false;
    } else if (!read_line()) {
      return false;
    }
    if (!parse_data_line()) return false;
  }
  out = queue_[queue_pos_++];
  return true;
}

std::vector<Anomaly> ByteLogReader::take_findings() {
  std::vector<Anomaly> out;
  out.swap(findings_);
  return out;
}

bool ByteLogReader::sniff(std::string_view head) {
  std::size_t i = 0;
  while (i < head.size()) {
    while (i < head.size() && is_space(head[i])) ++i;
    if (i >= head.size()) return true;
    if (head[i] == '#') {
      while (i < head.size() && head[i] != '\n') ++i;
      continue;
    }
    return head[i] >= '0' && head[i] <= '9';
  }
  return true;
}

}  // namespace drivetap
