// Line diagnosis (docs/protocols.md §1 line settings, §2 Modbus RTU timing): evidence
// gathered from a capture -> verdicts a field engineer can act on, each with its evidence and fix.
//
//   logic capture:  detection + decoder totals ─┐
//   any capture:    UART flags, frames, anomalies ┴─> LineEvidence ─> diagnose() ─> Verdicts
//
// The same verdict logic runs on sampled captures (where polarity and baud can be measured) and
// on byte-level captures (byte logs, pcapng, live), where only the UART flags and the byte
// patterns are known; a verdict says which kind of evidence it rests on.
#pragma once

#include <array>
#include <bit>
#include <csignal>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/protocol.hpp"
#include "core/stats.hpp"
#include "pipeline/options.hpp"
#include "sinks/sink.hpp"
#include "sources/logic/detect.hpp"
#include "sources/source.hpp"

namespace drivetap {

// The UART level (UartCounts): every character received.
struct LineEvidence : UartCounts {
  std::string settings;  // the line settings decoded with ("19200 8E1, inverted")
  // Byte-level captures: where they came from (SettingsProvenance::text(): "as given", "from the
  // capture", "default", or per part).
  std::string settings_source = "from the capture";

  // Byte-level captures: characters by the parity of their number of one bits, and of those the
  // ones with a framing error. Read without parity, a line whose format carries one has its
  // parity bit where the stop bit is looked for: a framing error exactly where that bit is 0
  // (even parity: on bytes with an even number of ones).
  std::array<std::uint64_t, 2> by_ones{}, framed_badly_by_ones{};  // [popcount & 1]
  void count_byte(std::uint8_t value, std::uint8_t flags) {
    count_character(flags);
    const int odd = std::popcount(value) & 1;
    ++by_ones[odd];
    framed_badly_by_ones[odd] += (flags & kUartFramingError) != 0;
  }

  // Sampled captures: per decoded channel, what detection measured on it and how the settings
  // given with -s (if any) decode it. Verdicts about the line are per channel; one about the
  // file only where the channels agree.
  bool from_samples = false;
  struct Channel {
    std::string name;
    std::string settings;  // decoded with
    std::optional<phy::LineDetection> detection;
    std::optional<phy::FormatTrial> given_trial;  // the given settings on the detection sample
    phy::UartDecoderStats decoded;                // the whole capture
  };
  std::vector<Channel> channels;
  std::vector<std::string> dropped_channels;  // not decoded: why, one line each
  std::optional<phy::UartSettings> given;

  // Frame level (from the pipeline).
  std::uint64_t frames = 0;
  std::uint64_t frames_checksum_ok = 0;
  std::uint64_t frames_checksum_bad = 0;
  // Frames whose checksum fails only because of a last 0x00/0xFF or flagged byte: the line
  // floating when the driver lets go.
  std::uint64_t release_artefacts = 0;
  // Bytes with a UART error inside frames whose checksum is good otherwise... and in bad frames.
  std::uint64_t flagged_bytes_in_bad_frames = 0;
  std::uint64_t noise_bytes = 0;
  std::uint64_t intra_frame_gaps = 0;            // t1.5 broken
  std::uint64_t short_interframe_gaps = 0;       // t3.5 broken
  std::string first_intra_gap, first_short_gap;  // an example of each

  // Every finding the pipeline reported, by kind: each leads to a verdict or is named benign.
  AnomalyCounts findings{};
  // What each station (address; -1 for none) sent and what went wrong with it.
  struct Station {
    std::uint64_t requests = 0;  // transactions it was asked for
    std::uint64_t timeouts = 0;
    std::uint64_t unsolicited = 0;
    std::uint64_t frames = 0;
    std::uint64_t bad_checksum = 0;  // without a UART error or a floating-line artefact
    std::uint64_t swapped_checksum = 0;
    std::uint64_t malformed = 0;
    std::map<std::pair<int, int>, std::uint64_t> exceptions;  // (function, code) -> replies
  };
  std::map<int, Station> stations;
  std::uint64_t noise_records = 0;
  std::uint64_t flagged_noise_records = 0;  // holding a byte with a UART error
  std::uint64_t release_noise_records = 0;  // a clean stray 0x00/0xFF right after a frame
  // Timing-rule breaks by rule, as the pipeline states it (the drive, its rule and the manual's
  // section), per station: count and first example. (A station whose binding is let go takes
  // its own along: DiagnosisSink::on_event.)
  struct RuleBreaks {
    struct AtStation {
      std::uint64_t count = 0;
      std::uint64_t first_frame = 0;
      std::string first;  // "frame 7: request 171.0 ms after ..."
    };
    TimingRule rule = TimingRule::none;
    std::map<int, AtStation> stations;
    [[nodiscard]] std::uint64_t count() const;
    [[nodiscard]] const std::string& first() const;  // the earliest frame's
  };
  std::map<std::string, RuleBreaks> timing_rules;
  // Channels where detection found no drive protocol: name and what the line carries instead
  // ("56 bytes of printable ASCII text"); their noise records are that line, not stray bytes.
  std::vector<std::pair<std::string, std::string>> foreign_lines;
  std::uint64_t foreign_noise_records = 0;
};

struct Verdict {
  std::string id;     // stable: inverted-line, baud-mismatch, parity-mismatch, settings-mismatch,
                      // non-standard-baud, noise, unbiased-bus, timing-t15, timing-t35,
                      // timing-rule, timeouts, swapped-crc, bad-checksum, unsolicited-replies,
                      // malformed-frames, stray-bytes, exception-replies, tap-overrun; benign:
                      // capture-packets, capture-clock
  std::string title;  // one line
  std::string evidence;  // what was seen, with figures
  std::string fix;       // what to do about it ("" for a benign note)
  bool benign = false;   // a finding that is no fault of the bus (named, not a verdict)
};

// Which verdict each kind of finding leads to (or the benign note that names it), declared as
// data: a new kind of finding cannot be added without deciding what diagnose says about it.
struct FindingCoverage {
  AnomalyKind kind;
  const char* verdict;  // the id of the verdict or benign note that covers it
};
extern const std::array<FindingCoverage, kAnomalyKindCount> kFindingCoverage;

std::vector<Verdict> diagnose(const LineEvidence& evidence);

// Collects the frame-level evidence while the pipeline runs (it prints nothing).
class DiagnosisSink final : public Sink {
 public:
  DiagnosisSink(LineEvidence& evidence, const FramingTiming& timing)
      : evidence_(evidence), timing_(timing) {}
  void on_frame(const Message& message) override;
  void on_noise(const Frame& noise) override;
  void on_anomaly(const Anomaly& anomaly) override;
  void on_transaction(const Transaction& transaction) override;
  void on_summary(const Stats& stats) override { stats_ = stats; }
  void on_event(const BusEvent& event) override;
  bool flush() override { return true; }
  [[nodiscard]] const Stats& stats() const { return stats_; }
  // Channels whose (last) detection found no drive protocol, and what they carry.
  [[nodiscard]] const std::map<ChannelId, std::string>& foreign() const { return foreign_; }

 private:
  LineEvidence& evidence_;
  FramingTiming timing_;
  Stats stats_;
  // The frame the anomalies that follow belong to ("anomalies of a frame arrive right after it").
  std::uint64_t last_frame_ = 0;
  int last_address_ = -1;
  bool last_clean_ = true;  // no byte of it with a UART error
  std::map<ChannelId, std::string> foreign_;
};

// What a capture adds to `evidence` beyond its records, once its pipeline has finished: the lines
// detection found no drive protocol on, the line settings, a logic capture's sample evidence
// (diagnose_capture() calls it; `drivetap report` once per capture).
void add_capture_evidence(LineEvidence& evidence, const ByteSource& source,
                          const PipelineOptions& options, const ChannelTable& channels,
                          const DiagnosisSink& sink);

// A whole diagnosis: the source (read_header() done) through the pipeline, nothing printed.
struct Diagnosis {
  LineEvidence evidence;
  std::vector<Verdict> verdicts;
  Stats stats;
  std::string error;  // the source's, when it failed part way (the evidence so far stands)
  bool interrupted = false;
};
Diagnosis diagnose_capture(ByteSource& source, const PipelineOptions& options,
                           ChannelTable& channels,
                           const volatile std::sig_atomic_t* stop = nullptr);

}  // namespace drivetap
