// Byte log writer (format: docs/formats.md "The byte log"; reader: sources/file/byte_log.cpp).
#include "generate/byte_log_writer.hpp"

#include "core/byte_event.hpp"

namespace drivetap {

namespace {
constexpr std::size_t kSpillAt = 1 << 20;
constexpr char kHex[] = "0123456789ABCDEF";
}  // namespace

void ByteLogWriter::comment(std::string_view text) {
  while (true) {
    const std::size_t nl = text.find('\n');
    buffer_ += "# ";
    buffer_ += text.substr(0, nl);
    buffer_ += '\n';
    if (nl == std::string_view::npos) break;
    text.remove_prefix(nl + 1);
  }
  spill();
}

void ByteLogWriter::header(const SerialConfig& serial) {
  buffer_ += "#! serial ";
  buffer_ += serial.to_string();
  buffer_ += '\n';
  spill();
}

void ByteLogWriter::line(TimeNs time, std::string_view channel, std::span<const std::uint8_t> bytes,
                         std::span<const std::uint8_t> flags, std::string_view note) {
  // Seconds with nine decimals, read back exactly.
  char digits[32];
  std::uint64_t t = time < 0 ? 0 : static_cast<std::uint64_t>(time);
  std::uint64_t whole = t / kNsPerSecond;
  std::uint64_t fraction = t % kNsPerSecond;
  int n = 0;
  do {
    digits[n++] = static_cast<char>('0' + whole % 10);
    whole /= 10;
  } while (whole != 0);
  while (n > 0) buffer_ += digits[--n];
  buffer_ += '.';
  char frac[9];
  for (int i = 8; i >= 0; --i) {
    frac[i] = static_cast<char>('0' + fraction % 10);
    fraction /= 10;
  }
  buffer_.append(frac, 9);
  buffer_ += ' ';
  buffer_ += channel;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    buffer_ += ' ';
    buffer_ += kHex[bytes[i] >> 4];
    buffer_ += kHex[bytes[i] & 0xF];
    const std::uint8_t f = i < flags.size() ? flags[i] : 0;
    if (f != 0) {
      buffer_ += '!';
      if (f & kUartFramingError) buffer_ += 'f';
      if (f & kUartParityError) buffer_ += 'p';
      if (f & kUartBreak) buffer_ += 'b';
      if (f & kUartOverrun) buffer_ += 'o';
    }
  }
  if (!note.empty()) {
    buffer_ += "  # ";
    buffer_ += note;
  }
  buffer_ += '\n';
  if (buffer_.size() >= kSpillAt) spill();
}

void ByteLogWriter::spill() {
  if (buffer_.empty()) return;
  if (!failed_ && std::fwrite(buffer_.data(), 1, buffer_.size(), out_) != buffer_.size())
    failed_ = true;
  buffer_.clear();
}

bool ByteLogWriter::flush() {
  spill();
  if (!failed_ && std::fflush(out_) != 0) failed_ = true;
  return !failed_;
}

}  // namespace drivetap
