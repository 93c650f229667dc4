// TelegramPrecheck: what a protocol decoder works out of a run's bytes alone, made ahead of the
// pipeline by the read-ahead thread (ReadAhead::precheck_with, ProtocolDecoder::precheck), kept
// beside the run in its chunk (RunBatch::precheck) and handed to the framer's fast take
// (Framer::take_whole) and the dissection to the head (ProtocolDecoder::dissect,
// DissectDepth::head), which use it instead of working it out again.
//
// Contract: every member is a function of the run's bytes alone (no time, no state), so a
// precheck gives exactly what the framer and the decoder would compute; the pipeline hands a run
// its precheck only when `decoder` is the decoder of the run's channel, whose framer takes it.
#pragma once

#include <cstddef>
#include <cstdint>

namespace drivetap {

class ProtocolDecoder;

// Which directions a frame's layout agrees with (ProtocolDecoder::direction_fit).
struct DirectionFit {
  bool request = false;
  bool response = false;
};

struct TelegramPrecheck {
  const ProtocolDecoder* decoder = nullptr;  // who made it; nullptr: none was made
  // The framer's check of the run taken as one telegram (Framer::take_whole): exactly a frame
  // of a predicted length with a good checksum, and that checksum as computed.
  bool whole_frame = false;
  std::uint32_t checksum = 0;
  // The rest is made for a whole frame only (the framer takes no other run at once).
  DirectionFit fit;              // ProtocolDecoder::direction_fit()
  bool always_response = false;  // ProtocolDecoder::always_response()
  // What the dissection to the head finds in the telegram read as a request [0] and as a reply
  // [1] (ProtocolDecoder::dissect): its exception code (-1: none) and malformed findings.
  int exception_code[2] = {-1, -1};
  std::size_t malformed[2] = {0, 0};
};

}  // namespace drivetap
