// drivetap command line: the progress line of a long offline run on stderr (frames, % of the file,
// rate), only when stderr is a terminal, never with -q or --no-progress; cleared at the end.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include "app/common.hpp"

namespace drivetap::app {

class Progress {
 public:
  // `fd`: the input's file descriptor, -1 when the input is not read through one (a logic capture
  // read by name): its position against its size gives the percentage.
  Progress(const CommonOptions& o, const std::string& name, int fd);
  ~Progress() { clear(); }
  // Called often (after each batch): redraws the line at most every kInterval.
  void update(std::uint64_t frames) {
    if (!shown_wanted_) return;
    const auto now = std::chrono::steady_clock::now();
    if (now < next_) return;
    next_ = now + interval_;
    draw(frames, now);
  }
  // Erases the line, if one was drawn.
  void clear();

  // The first line after this, then one per this at most: a short run shows nothing.
  static constexpr std::chrono::milliseconds kInterval{500};

 private:
  void draw(std::uint64_t frames, std::chrono::steady_clock::time_point now);

  bool shown_wanted_ = false;
  bool drawn_ = false;
  std::string name_;
  int fd_ = -1;
  std::int64_t size_ = 0;  // 0: unknown (not a regular file)
  std::chrono::milliseconds interval_ = kInterval;
  std::chrono::steady_clock::time_point start_, next_;
};

}  // namespace drivetap::app
