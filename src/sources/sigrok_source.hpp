// Logic-analyser captures as a byte source: a sigrok session file (src/sources/sigrok_file.hpp)
// decoded by drivetap's own UART decoder (src/phy/uart_decoder.hpp), one decoder per chosen
// channel, the characters of all channels merged in time order (channel = direction on a
// 4-wire link). Byte times are the start bits' first samples; UART errors ride on the events.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "phy/uart_decoder.hpp"
#include "sources/sigrok_file.hpp"
#include "sources/source.hpp"

namespace drivetap {

struct SigrokSourceOptions {
  phy::UartSettings uart;
  // Channel names or indices (`--channels RX,TX`); empty: every channel whose line moves.
  std::vector<std::string> channels;
};

class SigrokSource final : public ByteSource {
 public:
  SigrokSource(std::unique_ptr<SigrokFile> file, std::string name, ChannelTable& channels,
               SigrokSourceOptions options);
  bool read_header() override;  // chooses the channels and decodes them
  [[nodiscard]] RunSettings settings() const override { return {}; }
  void set_character_time(TimeNs) override {}
  bool next(ByteEvent& out) override;
  [[nodiscard]] const std::string& error() const override { return error_; }
  [[nodiscard]] std::vector<std::string> notes() const override { return notes_; }

 private:
  std::unique_ptr<SigrokFile> file_;
  std::string name_;
  ChannelTable& channels_;
  SigrokSourceOptions options_;
  std::vector<ByteEvent> events_;  // decoded, time-ordered
  std::size_t next_ = 0;
  std::string error_;
  std::vector<std::string> notes_;
};

}  // namespace drivetap
