// The read block of capture files: the stdio buffer of every input and the unit of large reads.
#pragma once

#include <cstddef>

namespace drivetap {

// open_input() gives each file a stdio buffer of this size, and readers that read large pieces
// (pcapng::Reader from a regular file, ByteLogReader) ask for whole multiples of it: glibc's
// fread() hands a request of whole buffers straight to read(2), where a smaller one is read into
// the buffer and copied out, a copy that showed in `read` on a plain pcapng.
inline constexpr std::size_t kReadBlockBytes = 64 * 1024;

}  // namespace drivetap
