// Opens a capture path (or "-" for stdin) and recognises its format from the first bytes,
// without consuming them: the returned FILE* starts at offset 0 even when it is a pipe.
#pragma once

#include <cstdio>
#include <string>

namespace drivetap {

enum class InputFormat { byte_log, pcap, pcapng, sigrok, vcd, unknown, empty };

struct InputFile {
  std::FILE* file = nullptr;  // owned: close with close_input()
  std::string name;           // for messages ("<stdin>" for "-")
  InputFormat format = InputFormat::unknown;
  unsigned char head[4] = {0, 0, 0, 0};
  std::size_t head_size = 0;
  // stdio buffer of `file` (kReadBlockBytes, larger than the default 4 KiB); freed by close_input
  // after the file is closed, never before.
  char* buffer = nullptr;
};

// Returns false with *error set (one line naming the path) when the path cannot be read.
bool open_input(const std::string& path, InputFile* out, std::string* error);
void close_input(InputFile& in);
const char* input_format_name(InputFormat f);

}  // namespace drivetap
