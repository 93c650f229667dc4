// Ring of capture files (src/sinks/ring_capture_sink.hpp).
#include "sinks/ring_capture_sink.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <ctime>

namespace drivetap {

std::string parse_ring_option(const std::string& text, RingOptions& ring) {
  const std::size_t colon = text.find(':');
  const std::string key = text.substr(0, colon);
  const std::string value = colon == std::string::npos ? "" : text.substr(colon + 1);
  std::uint64_t number = 0;
  std::size_t used = 0;
  try {
    number = std::stoull(value, &used);
  } catch (...) {
    used = 0;
  }
  if (used == 0 || used != value.size() || number == 0 || value[0] == '-')
    return fmt::format(
        "-b {}: expected filesize:MB, duration:S or files:N with a positive whole "
        "number",
        text);
  if (key == "filesize") {
    if (number > (std::uint64_t{1} << 40) / 1'000'000)
      return fmt::format("-b {}: file size too large", text);
    ring.max_bytes = number * 1'000'000;
  } else if (key == "duration") {
    if (number > 100ull * 365 * 86400) return fmt::format("-b {}: duration too long", text);
    ring.max_duration = static_cast<TimeNs>(number) * kNsPerSecond;
  } else if (key == "files") {
    ring.max_files = number;
  } else {
    return fmt::format("-b {}: unknown key '{}' (filesize, duration, files)", text, key);
  }
  return {};
}

RingCaptureSink::RingCaptureSink(std::string path, const ChannelTable& channels,
                                 CaptureSinkOptions capture, RingOptions ring)
    : path_(std::move(path)),
      channels_(channels),
      capture_options_(std::move(capture)),
      ring_(ring) {}

RingCaptureSink::~RingCaptureSink() {
  close();
}

bool RingCaptureSink::open(std::string* error) {
  if (!open_next(-1)) {
    *error = error_;
    return false;
  }
  return true;
}

// dumpcap's naming: the -w name's stem, a five-digit sequence number and the local start time.
bool RingCaptureSink::open_next(TimeNs packet_time) {
  ++sequence_;
  const std::size_t slash = path_.rfind('/');
  const std::size_t dot = path_.rfind('.');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash);
  const std::string stem = has_ext ? path_.substr(0, dot) : path_;
  const std::string ext = has_ext ? path_.substr(dot) : ".pcapng";
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d%H%M%S", &local);
  current_name_ = fmt::format("{}_{:05}_{}{}", stem, sequence_, stamp, ext);
  file_ = open_output_file(current_name_);
  if (!file_) {
    error_ = fmt::format("-w {}: cannot create: {}", current_name_, std::strerror(errno));
    failed_ = true;
    return false;
  }
  sink_ = std::make_unique<CaptureSink>(file_, channels_, capture_options_);
  file_start_ = packet_time;
  good_size_ = 0;
  written_.push_back(current_name_);
  while (ring_.max_files > 0 && written_.size() > ring_.max_files) {
    std::remove(written_.front().c_str());
    written_.pop_front();
  }
  return true;
}

bool RingCaptureSink::close() {
  if (!sink_) return !failed_;
  const bool ok = !failed_ && sink_->flush();
  if (!ok) cut_back_to(file_, good_size_, capture_options_.format);
  sink_.reset();
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if ((!ok || !closed) && error_.empty()) {
    error_ = fmt::format("-w {}: write failed: {}", current_name_, std::strerror(errno));
    failed_ = true;
  }
  return ok && closed && !failed_;
}

bool RingCaptureSink::rotate_if_due(TimeNs packet_time) {
  if (!sink_) return false;
  if (file_start_ < 0) file_start_ = packet_time;
  bool due = false;
  if (ring_.max_bytes > 0 && sink_->packets() > 0) {
    // The logical position counts what stdio still buffers: no flush needed to know the size.
    const long size = std::ftell(file_);
    due = size >= 0 && static_cast<std::uint64_t>(size) >= ring_.max_bytes;
  }
  if (ring_.max_duration > 0 && sink_->packets() > 0 &&
      packet_time - file_start_ >= ring_.max_duration)
    due = true;
  if (!due) return true;
  if (!close()) return false;
  return open_next(packet_time);
}

void RingCaptureSink::on_frame(const Message& message) {
  if (!rotate_if_due(message.frame.start())) return;
  sink_->on_frame(message);
  ++packets_;
}

void RingCaptureSink::on_noise(const Frame& noise) {
  if (!rotate_if_due(noise.start())) return;
  sink_->on_noise(noise);
  ++packets_;
}

void RingCaptureSink::on_anomaly(const Anomaly& anomaly) {
  if (sink_) sink_->on_anomaly(anomaly);
}

bool RingCaptureSink::flush() {
  if (!sink_) return !failed_;
  if (sink_->flush()) {
    good_size_ = std::ftell(file_);
  } else {
    cut_back_to(file_, good_size_, capture_options_.format);
    if (error_.empty())
      error_ = fmt::format("-w {}: write failed: {}", current_name_, std::strerror(errno));
    failed_ = true;
  }
  return !failed_;
}

}  // namespace drivetap
