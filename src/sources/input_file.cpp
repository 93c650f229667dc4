// Input opening and format recognition by content (magic numbers; a byte log is text).
#include "sources/input_file.hpp"

#include <fmt/format.h>
#include <stdio_ext.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <iterator>

#include "core/enum_text.hpp"
#include "core/read_block.hpp"

namespace drivetap {
namespace {

// A FILE that first yields the sniffed prefix, then the rest of the underlying stream: lets a
// pipe be sniffed and still read from its first byte by any reader (ours or libpcap's).
struct Prefixed {
  std::FILE* under;
  unsigned char prefix[4];
  std::size_t size;
  std::size_t pos;
};

ssize_t prefixed_read(void* cookie, char* buf, size_t n) {
  auto* p = static_cast<Prefixed*>(cookie);
  std::size_t done = 0;
  while (done < n && p->pos < p->size) buf[done++] = static_cast<char>(p->prefix[p->pos++]);
  if (done < n) {
    const std::size_t got = std::fread(buf + done, 1, n - done, p->under);
    if (got == 0 && std::ferror(p->under) && done == 0) return -1;
    done += got;
  }
  return static_cast<ssize_t>(done);
}

int prefixed_close(void* cookie) {
  auto* p = static_cast<Prefixed*>(cookie);
  const int rc = p->under == stdin ? 0 : std::fclose(p->under);
  delete p;
  return rc;
}

InputFormat recognise(const unsigned char* h, std::size_t n) {
  if (n == 0) return InputFormat::empty;
  if (n >= 4) {
    const std::uint32_t be = (std::uint32_t{h[0]} << 24) | (std::uint32_t{h[1]} << 16) |
                             (std::uint32_t{h[2]} << 8) | h[3];
    if (be == 0x0A0D0D0A) return InputFormat::pcapng;
    if (be == 0x504B0304) return InputFormat::sigrok;  // a zip: sigrok session file
    if (be == 0xA1B2C3D4 || be == 0xD4C3B2A1 || be == 0xA1B23C4D || be == 0x4D3CB2A1)
      return InputFormat::pcap;
  }
  // A Value Change Dump opens with a $keyword ($date, $version, $timescale...), maybe after
  // blank lines, maybe after a UTF-8 byte order mark (an editor's; the VCD reader skips it).
  const std::size_t bom = n >= 3 && h[0] == 0xEF && h[1] == 0xBB && h[2] == 0xBF ? 3 : 0;
  for (std::size_t i = bom; i < n; ++i) {
    if (h[i] == '$') return InputFormat::vcd;
    if (h[i] != ' ' && h[i] != '\t' && h[i] != '\n' && h[i] != '\r') break;
  }
  const unsigned char c = h[0];
  if (c == '#' || (c >= '0' && c <= '9') || c == ' ' || c == '\t' || c == '\n' || c == '\r')
    return InputFormat::byte_log;
  return InputFormat::unknown;
}

}  // namespace

const char* input_format_name(InputFormat f) {
  static constexpr const char* kInputFormatNames[] = {
      "byte log", "pcap", "pcapng", "sigrok session", "VCD", "unknown", "empty"};
  static_assert(std::size(kInputFormatNames) == static_cast<std::size_t>(InputFormat::empty) + 1);
  return enum_text(f, kInputFormatNames, static_cast<const char*>("unknown"));
}

namespace {
// Before the first read of `f`: a stdio buffer of kReadBlockBytes (a file of many small pcapng
// blocks is otherwise read 4 KiB per system call; larger reads of whole blocks bypass it).
void use_large_buffer(std::FILE* f, InputFile* in) {
  if (in->buffer) return;  // one per input: a replay cookie keeps the file's buffer too
  in->buffer = new char[kReadBlockBytes];
  if (std::setvbuf(f, in->buffer, _IOFBF, kReadBlockBytes) != 0) {
    delete[] in->buffer;  // not taken: stdio keeps its own
    in->buffer = nullptr;
  }
}
}  // namespace

bool open_input(const std::string& path, InputFile* out, std::string* error) {
  out->name = path == "-" ? "<stdin>" : path;
  std::FILE* f = stdin;
  if (path != "-") {
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
      *error = fmt::format("{}: is a directory, not a capture file", path);
      return false;
    }
    f = std::fopen(path.c_str(), "rb");
    if (!f) {
      *error = fmt::format("{}: cannot open: {}", path, std::strerror(errno));
      return false;
    }
  }
  if (f != stdin) use_large_buffer(f, out);
  out->head_size = std::fread(out->head, 1, sizeof out->head, f);
  if (out->head_size < sizeof out->head && std::ferror(f)) {
    *error = fmt::format("{}: read error: {}", out->name, std::strerror(errno));
    if (f != stdin) std::fclose(f);
    return false;
  }
  out->format = recognise(out->head, out->head_size);
  if (f != stdin && std::fseek(f, 0, SEEK_SET) == 0) {
    // One thread reads an input at a time (the read-ahead thread, or the caller's): stdio need
    // not lock the stream around each of the three reads of every pcapng block.
    __fsetlocking(f, FSETLOCKING_BYCALLER);
    out->file = f;
    return true;
  }
  // A pipe: replay the sniffed bytes in front of the stream.
  auto* cookie = new Prefixed{f, {}, out->head_size, 0};
  std::memcpy(cookie->prefix, out->head, out->head_size);
  cookie_io_functions_t io{prefixed_read, nullptr, nullptr, prefixed_close};
  out->file = fopencookie(cookie, "rb", io);
  if (!out->file) {
    delete cookie;
    *error = fmt::format("{}: cannot set up reading", out->name);
    return false;
  }
  use_large_buffer(out->file, out);
  return true;
}

void close_input(InputFile& in) {
  if (in.file && in.file != stdin) std::fclose(in.file);
  in.file = nullptr;
  delete[] in.buffer;
  in.buffer = nullptr;
}

}  // namespace drivetap
