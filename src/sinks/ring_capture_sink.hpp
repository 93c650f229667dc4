// Ring of capture files for long unattended runs (dumpcap's -b): the CaptureSink
// (src/sinks/capture_sink.hpp) writes into the current file; at a frame boundary the file is
// closed, valid, and the next one begun when it has grown past filesize or lasted duration;
// with files:N only the newest N are kept.
//
//   -w bus.pcapng -b filesize:100 -b files:5  ->  bus_00001_20261121145801.pcapng
//                                                 bus_00002_20261121151233.pcapng ...
#pragma once

#include <cstdint>
#include <cstdio>
#include <deque>
#include <memory>
#include <string>

#include "sinks/capture_sink.hpp"

namespace drivetap {

struct RingOptions {
  std::uint64_t max_bytes = 0;  // 0: no size limit
  TimeNs max_duration = 0;      // 0: no time limit (capture time, from the first packet)
  std::size_t max_files = 0;    // 0: keep every file
};

// Parses one `-b` value ("filesize:MB", "duration:S", "files:N") into `ring`; "" or an error.
std::string parse_ring_option(const std::string& text, RingOptions& ring);

class RingCaptureSink final : public PacketSink {
 public:
  // `path`: the -w name; the files are named from it (prefix_NNNNN_YYYYMMDDHHMMSS.ext).
  RingCaptureSink(std::string path, const ChannelTable& channels, CaptureSinkOptions capture,
                  RingOptions ring);
  ~RingCaptureSink() override;
  // False with error() when the first file cannot be created.
  bool open(std::string* error);
  void on_frame(const Message& message) override;
  void on_noise(const Frame& noise) override;
  void on_anomaly(const Anomaly& anomaly) override;
  void on_event(const BusEvent& event) override {
    if (sink_) sink_->on_event(event);
  }
  bool flush() override;
  [[nodiscard]] SinkNeeds needs() const override {  // as each file's CaptureSink
    SinkNeeds n = PacketSink::needs();
    n.fields = !capture_options_.plain;
    return n;
  }
  // Flushes and closes the current file; false when a write failed (disk full).
  bool close();
  [[nodiscard]] const std::string& error() const { return error_; }
  [[nodiscard]] std::string refusal() const { return sink_ ? sink_->refusal() : std::string(); }
  [[nodiscard]] std::uint64_t packets() const { return packets_; }
  [[nodiscard]] const std::string& current_file() const { return current_name_; }

 private:
  bool rotate_if_due(TimeNs packet_time);
  bool open_next(TimeNs packet_time);

  std::string path_;
  const ChannelTable& channels_;
  CaptureSinkOptions capture_options_;
  RingOptions ring_;
  std::FILE* file_ = nullptr;
  std::unique_ptr<CaptureSink> sink_;
  std::string current_name_;
  std::deque<std::string> written_;  // oldest first
  std::uint64_t sequence_ = 0;
  TimeNs file_start_ = -1;
  long good_size_ = 0;  // the current file up to its last packet flushed whole
  std::uint64_t packets_ = 0;
  bool failed_ = false;
  std::string error_;
};

}  // namespace drivetap
