// Logic-analyser captures as a byte source: any LogicCapture (sigrok .sr, VCD;
// src/sources/logic/logic_capture.hpp) decoded by drivetap's own UART decoder (src/sources/logic/uart_decoder.hpp),
// one decoder per chosen channel, the characters of all channels merged in time order (channel =
// direction on a 4-wire link). Byte times are the start bits' first samples; UART errors ride on
// the events. Line settings not given are detected from the first runs of each channel on its own
// (src/sources/logic/detect.hpp): the two sides of a converter differ in polarity, a clock or enable line
// beside the data is no UART at all.
//
// Streaming: the capture is decoded block by block; a character is handed out once no channel
// can still produce an earlier one (two character times behind the block end), so memory holds
// about one block whatever the length of the capture.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sources/logic/detect.hpp"
#include "sources/logic/uart_decoder.hpp"
#include "sources/logic/logic_capture.hpp"
#include "sources/source.hpp"

namespace drivetap {

struct LogicSourceOptions {
  // Given line settings (`-s`, `--invert`); unset: detected.
  std::optional<phy::UartSettings> uart;
  // Channel names or indices (`--channels RX,TX`); empty: every channel whose line moves.
  std::vector<std::string> channels;
  // Runs per channel read ahead for channel choice and detection.
  std::size_t detection_runs = 40'000;
};

class LogicSource final : public ByteSource {
 public:
  LogicSource(std::unique_ptr<LogicCapture> capture, std::string name, ChannelTable& channels,
              LogicSourceOptions options);
  bool read_header() override;  // chooses the channels, detects the line, starts decoding
  [[nodiscard]] RunSettings settings() const override;
  void set_character_time(TimeNs) override {}
  bool next(ByteEvent& out) override;
  [[nodiscard]] const std::string& error() const override { return error_; }
  [[nodiscard]] std::vector<std::string> notes() const override;

  // What read_header() found, per decoded channel (in the order of decoder_stats()).
  struct ChannelLine {
    std::string name;
    phy::UartSettings uart;                       // decoded with
    std::optional<phy::LineDetection> detection;  // what its own samples show
    // With settings given (-s): how they decode the first runs; unset when they were detected.
    std::optional<phy::FormatTrial> given_trial;
    std::vector<phy::LevelRun> head_runs;  // the first runs (what detection read)
  };
  [[nodiscard]] const std::vector<ChannelLine>& lines() const { return lines_; }
  // The settings of the busiest channel: the pipeline's character time follows them.
  [[nodiscard]] const phy::UartSettings& uart() const { return lines_.at(main_line_).uart; }
  [[nodiscard]] const std::optional<phy::LineDetection>& detection() const {
    return lines_.at(main_line_).detection;
  }
  // Channels whose detection failed while others' succeeded: not decoded, one note each.
  [[nodiscard]] const std::vector<std::string>& dropped() const { return dropped_; }
  [[nodiscard]] std::uint64_t sample_rate() const { return capture_->sample_rate(); }
  // Per decoded channel, the decoder's totals so far (final once next() returned false).
  [[nodiscard]] std::vector<phy::UartDecoderStats> decoder_stats() const;

 private:
  bool choose_channels();
  bool fill();  // decodes the next block into pending_; false at the end or on error

  std::unique_ptr<LogicCapture> capture_;
  std::string name_;
  ChannelTable& channels_;
  LogicSourceOptions options_;

  std::vector<ChannelLine> lines_;
  std::size_t main_line_ = 0;
  std::vector<std::string> dropped_;
  std::vector<std::size_t> chosen_;
  std::vector<std::string> chosen_names_;
  std::vector<std::vector<phy::LevelRun>> head_runs_;
  std::vector<ChannelId> ids_;
  std::vector<phy::UartDecoder> decoders_;
  phy::SampleClock clock_;
  std::uint64_t hold_back_ = 0;  // samples behind the block end that may still produce a character

  RunBlock block_;
  std::vector<phy::UartCharacter> decoded_;
  std::vector<ByteEvent> pending_;  // sorted by time; handed out from next_pending_
  std::size_t next_pending_ = 0;
  std::uint64_t releasable_before_ = 0;  // sample: events starting before it are final
  bool at_end_ = false;
  std::string error_;
  std::vector<std::string> extra_notes_;
};

}  // namespace drivetap
