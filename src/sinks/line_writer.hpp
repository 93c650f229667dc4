// LineWriter: the text and JSON sinks' output — lines gathered in one buffer and written to the
// file in blocks (to a terminal, line by line), with the first failed write's errno kept; and
// LineFormattingSink, their common base, whose formatting contract is the writer's.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdio>
#include <string_view>

#include "core/line_buffer.hpp"
#include "sinks/sink.hpp"

namespace drivetap {

class LineWriter {
 public:
  // With no file (nullptr), the lines are gathered in memory until their owner takes them
  // (gathered()): a sink formatting batches of records for another one (ThreadedSink helpers).
  explicit LineWriter(std::FILE* out)
      : out_(out), to_terminal_(out != nullptr && ::isatty(::fileno(out)) == 1) {}

  // The buffer: a line may be built at its end in place, then ended with end_line().
  LineBuffer& buffer() { return buffer_; }
  // Appends `line` (built elsewhere) and a newline.
  void write(std::string_view line) {
    buffer_ += line;
    end_line();
  }
  // Ends the line built at the end of the buffer; writes the buffer out once it holds kBlockBytes
  // (one fwrite per some 600 frame lines, not one or two per line).
  void end_line() {
    buffer_ += '\n';
    if (buffer_.size() >= kBlockBytes || to_terminal_) write_out();
  }
  // Whole lines made by another writer (its gathered() text), written as if ended here: with
  // nothing buffered, straight to the file (no copy).
  void write_lines(std::string_view lines) {
    if (status_.failed()) return;  // a failed output stays failed: no write may block again
    if (buffer_.empty() && out_) {
      if (std::fwrite(lines.data(), 1, lines.size(), out_) != lines.size()) status_.note_failure();
      return;
    }
    buffer_ += lines;
    if (buffer_.size() >= kBlockBytes || to_terminal_) write_out();
  }
  // Without a file: the lines gathered so far (the owner writes them elsewhere and clears them);
  // nullptr for a writer with a file.
  LineBuffer* gathered() { return out_ ? nullptr : &buffer_; }
  // Writes what is buffered and flushes the file: true when every write went through (else
  // errno is the first failure's). Without a file: true, the lines stay gathered.
  bool flush() {
    if (!out_) return true;
    write_out();
    return status_.flush(out_);
  }

 private:
  // Once per block: kept out of the path every line takes.
  [[gnu::noinline]] void write_out() {
    if (buffer_.empty() || !out_) return;
    if (status_.failed()) {  // a failed output (a closed pipe) stays failed: nothing more to it
      buffer_.clear();
      return;
    }
    if (std::fwrite(buffer_.data(), 1, buffer_.size(), out_) != buffer_.size())
      status_.note_failure();
    buffer_.clear();
  }

  static constexpr std::size_t kBlockBytes = 64 * 1024;
  std::FILE* out_;
  // A terminal gets each line as it is made (someone is watching); files and pipes get blocks.
  bool to_terminal_;
  WriteStatus status_;
  LineBuffer buffer_;  // whole lines not written yet, and the line being built
};

// A FormattingSink (sink.hpp) writing lines through a LineWriter: made with no file (nullptr), it
// writes into memory, for a ThreadedSink's helpers; formatted(), write_formatted() and flush() are
// the writer's.
class LineFormattingSink : public FormattingSink {
 public:
  explicit LineFormattingSink(std::FILE* out) : lines_(out) {}
  LineBuffer* formatted() final { return lines_.gathered(); }
  void write_formatted(std::string_view text) final { lines_.write_lines(text); }
  bool flush() final { return lines_.flush(); }

 protected:
  LineWriter lines_;  // lines not written yet; a record's line is built at its end
};

}  // namespace drivetap
