// `capture --scan`'s judgement (docs/reference.md "Live capture"): which of the line settings
// tried gave the largest share of frames with a good checksum, then the smallest share of bytes
// with a UART mark, and, when several are alike (shares within 5 %, at least half the good frames
// of the best), what could not be told apart and why. Pure: the listening is src/app/capture.cpp's.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/serial_config.hpp"

namespace drivetap {

// One setting tried: what listening a while at `serial` gave.
struct ScanResult {
  SerialConfig serial;
  std::uint64_t bytes = 0, uart_errors = 0, frames = 0, frames_ok = 0;
  std::string error;
};

// The settings tried, in order: each standard rate with 8N1, 8E1, 8O1, 7E1, 7O1, 7N2 (Modbus
// RTU's and Modbus ASCII's formats; 8N2 reads as 8N1).
std::vector<SerialConfig> scan_settings();

struct ScanVerdict {
  // The best setting alone, or the settings alike with it in the order tried; empty when none
  // gave a frame with a good checksum.
  std::vector<ScanResult> best;
  // With several best: what could not be told apart and why, one sentence; empty otherwise.
  std::string untold;
};
ScanVerdict judge_scan(const std::vector<ScanResult>& tried);

}  // namespace drivetap
