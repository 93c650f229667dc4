// drivetap command line: the progress line of a long offline run (src/app/progress.hpp).
#include "app/progress.hpp"

#include <fmt/format.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>

#include "core/printable.hpp"

namespace drivetap::app {

Progress::Progress(const CommonOptions& o, const std::string& name, int fd)
    : name_(printable(name, false)), fd_(fd) {
  shown_wanted_ = !o.quiet && !o.no_progress && ::isatty(STDERR_FILENO) == 1;
  struct stat st {};
  if (fd_ >= 0 && ::fstat(fd_, &st) == 0 && S_ISREG(st.st_mode)) size_ = st.st_size;
  // DRIVETAP_PROGRESS_MS: the delay and interval in ms instead (tests: 0 draws at every update).
  if (const char* ms = std::getenv("DRIVETAP_PROGRESS_MS"); ms && *ms)
    interval_ = std::chrono::milliseconds(std::strtol(ms, nullptr, 10));
  start_ = std::chrono::steady_clock::now();
  next_ = start_ + interval_;
}

void Progress::draw(std::uint64_t frames, std::chrono::steady_clock::time_point now) {
  const double seconds = std::chrono::duration<double>(now - start_).count();
  std::string line = fmt::format("drivetap: {}: {} frames", name_, frames);
  if (size_ > 0) {
    // The kernel's position: ahead of what was decoded by at most the read buffers.
    const off_t at = ::lseek(fd_, 0, SEEK_CUR);
    if (at >= 0) line += fmt::format(", {:.0f} %", 100.0 * static_cast<double>(at) / size_);
  }
  if (seconds > 0) line += fmt::format(", {:.0f} frames/s", static_cast<double>(frames) / seconds);
  // Back to the line's start, the text, the rest of the old line erased.
  std::fprintf(stderr, "\r%s\x1b[K", line.c_str());
  std::fflush(stderr);
  drawn_ = true;
}

void Progress::clear() {
  if (!drawn_) return;
  std::fputs("\r\x1b[K", stderr);
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace drivetap::app
